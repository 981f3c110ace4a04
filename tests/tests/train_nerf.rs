//! `lucid train nerf` and `lucid eval` end to end on a tiny generated scene: training beats
//! a floor on held-out views, runs are reproducible, a resumed run equals an uninterrupted
//! one, and broken checkpoints are clear errors.

use std::path::Path;

use lucid_tests::{lucid_in, temp_dir};

/// A small, fast configuration: coarse grid, small batches.
const TINY: [&str; 8] = [
    "--set",
    "field.grid.log2_table_size=14",
    "--set",
    "train.batch_samples=16384",
    "--set",
    "occupancy.warmup_steps=64",
    "--set",
    "train.log_every=10",
];

fn dataset(dir: &Path) {
    lucid_in(dir, &["gen", "object", "-o", "ds", "--views", "24,1,3", "--res", "32", "--spp", "8", "--seed", "3"])
        .success();
}

fn train(dir: &Path, out: &str, steps: &str, extra: &[&str]) -> lucid_tests::Run {
    let mut args = vec!["train", "nerf", "ds", "-o", out, "--steps", steps];
    args.extend_from_slice(&TINY);
    args.extend_from_slice(extra);
    lucid_in(dir, &args)
}

fn metrics(dir: &Path, out: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join(out).join("eval_test/metrics.json")).unwrap()).unwrap()
}

/// Loss per logged step, the deterministic part of the CSV (time and rates vary).
fn losses(dir: &Path, out: &str) -> Vec<String> {
    lucid_tests::csv_columns(&dir.join(out).join("train_log.csv"), &[0, 2, 3, 4, 5])
}

#[test]
fn training_beats_the_floor_is_reproducible_and_resumes_exactly() {
    let dir = temp_dir();
    let d = dir.path();
    dataset(d);
    train(d, "a", "300", &[]).success();
    let m = metrics(d, "a");
    let psnr = m["summary"]["psnr"].as_f64().unwrap();
    let views = m["views"].as_array().unwrap();
    assert_eq!(views.len(), 3);
    for f in ["r_0.png", "r_0_depth.exr", "r_0_error.png"] {
        assert!(d.join("a/eval_test").join(f).is_file(), "{f} written");
    }
    // Measured 25.12 dB here after 300 steps, views marched at half the training steps (25.10
    // at the training steps; before, 25.03 with three colour layers, 24.91 with two, rendered
    // from the parameters' running average; 24.92 from the last parameters; 8 levels of 4
    // features; 23.9 with 16 of 2); the untrained model scores 8.9 dB on these views.
    assert!(psnr > 24.8, "held-out PSNR {psnr}");

    // Same seed, same numbers.
    train(d, "b", "300", &["--no-eval"]).success();
    assert_eq!(losses(d, "a"), losses(d, "b"));

    // Stopped at step 250, where the parameters' average has begun, then resumed to 300: the
    // same losses as the straight run, and the same average, so the same evaluation.
    train(d, "c", "300", &["--no-eval", "--until", "250"]).success();
    lucid_in(d, &["train", "nerf", "ds", "-o", "c", "--resume", "--no-eval"]).success();
    assert_eq!(losses(d, "a"), losses(d, "c"));
    let resumed = lucid_in(d, &["eval", "c/checkpoint.lucid", "ds", "--json", "-o", "ec"]).success();
    assert_eq!(resumed.json()["summary"]["psnr"], m["summary"]["psnr"]);

    // eval on the checkpoint reproduces the closing evaluation.
    let out = lucid_in(d, &["eval", "a/checkpoint.lucid", "ds", "--json", "-o", "e"]).success();
    let again: serde_json::Value = out.json();
    assert_eq!(again["summary"]["psnr"], m["summary"]["psnr"]);

    // Four rays over each pixel's area render another image of the same quality.
    let out = lucid_in(d, &["eval", "a/checkpoint.lucid", "ds", "--json", "-o", "e4", "--pixel-rays", "4"]).success();
    let four = out.json()["summary"]["psnr"].as_f64().unwrap();
    assert!(four != psnr && (four - psnr).abs() < 1.5, "{four} dB with 4 rays per pixel against {psnr} dB");
    lucid_in(d, &["eval", "a/checkpoint.lucid", "ds", "-o", "e0", "--pixel-rays", "0"]).failure(&["--pixel-rays"]);

    // Rays marched at the training steps (the default renders at half of them) give another
    // image; a scale outside (0, 1] is refused.
    let out = lucid_in(d, &["eval", "a/checkpoint.lucid", "ds", "--json", "-o", "es", "--step-scale", "1"]).success();
    let coarse = out.json()["summary"]["psnr"].as_f64().unwrap();
    assert!(coarse != psnr && (coarse - psnr).abs() < 1.5, "{coarse} dB at the training steps against {psnr} dB");
    lucid_in(d, &["eval", "a/checkpoint.lucid", "ds", "-o", "e2", "--step-scale", "2"]).failure(&["--step-scale"]);

    // Trained on the mean of four rays per pixel: as good where it is evaluated so (measured
    // 25.29 dB with 4 rays per pixel, views at half the training steps; before, at the
    // training steps, 24.45 dB with three colour layers, 24.69 with two, 24.79 without the
    // average; the model above 25.03 with one and 25.31 with four).
    train(d, "p", "300", &["--set", "train.pixel_rays=4", "--set", "train.eval_pixel_rays=4"]).success();
    let p = metrics(d, "p")["summary"]["psnr"].as_f64().unwrap();
    assert!(p > 24.9, "held-out PSNR {p} trained and evaluated with 4 rays per pixel");
}

#[test]
fn broken_checkpoints_and_configs_are_clear_errors() {
    let dir = temp_dir();
    let d = dir.path();
    dataset(d);
    train(d, "a", "5", &["--no-eval"]).success();
    let bytes = std::fs::read(d.join("a/checkpoint.lucid")).unwrap();
    std::fs::write(d.join("cut.lucid"), &bytes[..bytes.len() / 2]).unwrap();
    lucid_in(d, &["eval", "cut.lucid", "ds"]).failure(&["cut.lucid", "truncated"]);
    std::fs::copy(d.join("ds/train/r_0.png"), d.join("image.lucid")).unwrap();
    lucid_in(d, &["eval", "image.lucid", "ds"]).failure(&["image.lucid", "not a Lucid checkpoint"]);
    lucid_in(d, &["eval", "missing.lucid", "ds"]).failure(&["missing.lucid"]);
    std::fs::write(d.join("bad.toml"), "[train]\nlearning_rate = nan\n").unwrap();
    lucid_in(d, &["train", "nerf", "ds", "-o", "x", "--config", "bad.toml"])
        .failure(&["bad.toml", "train.learning_rate"]);
    lucid_in(d, &["train", "nerf", "ds", "-o", "x", "--set", "train.stepz=4"]).failure(&["stepz"]);
    lucid_in(d, &["train", "nerf", "nowhere", "-o", "x"]).failure(&["nowhere"]);
    lucid_in(d, &["train", "nerf", "ds", "-o", "y", "--resume"]).failure(&["checkpoint.lucid"]);
    assert!(!d.join("x/checkpoint.lucid").exists(), "nothing written on a bad config");
}

/// A NeRF trained on a light field's sub-aperture views renders its thin-lens test views
/// (`aperture_radius`, `focus_distance` in the dataset) through the same lens, and matches
/// the path-traced depth-of-field truth better than a pinhole rendering of the same model.
#[test]
fn thin_lens_rendering_from_a_model_matches_the_refocused_truth() {
    let dir = temp_dir();
    let d = dir.path();
    let (lens, pinhole) = lucid_tests::light_field_lens_and_pinhole_psnr(d, "nerf", &TINY);
    // Measured: thin lens 25.76 dB, pinhole 24.49 dB.
    assert!(lens > pinhole + 0.5, "thin lens {lens:.2} dB vs pinhole {pinhole:.2} dB");

    // Novel views along a path, with depth, and with a lens.
    lucid_in(d, &["render", "m/checkpoint.lucid", "-o", "orbit", "--frames", "3", "--width", "24", "--height", "16"])
        .success();
    for k in 0..3 {
        let img = lucid_image::read_image(d.join(format!("orbit/frame_{k:04}.png"))).unwrap();
        assert_eq!(img.dimensions(), (24, 16));
        assert!(d.join(format!("orbit/frame_{k:04}_depth.exr")).is_file());
    }
    lucid_in(d, &["render", "m/checkpoint.lucid", "-o", "x", "--frames", "0"]).usage_error(&["--frames", "1..="]);
}
