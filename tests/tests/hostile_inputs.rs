//! Numbers and files a careless or hostile user gives: each once crashed, allocated without
//! bound, or exited 0 with a meaningless result; now each is refused where it is parsed (a
//! usage error naming the flag, exit code 2) or read as the user meant it.

use std::path::Path;

use lucid_tests::{lucid_in, lucid_with_memory, temp_dir};

fn tiny_dataset(d: &Path, name: &str, res: &str) {
    lucid_in(d, &["gen", "object", "-o", name, "--views", "4,0,1", "--res", res, "--spp", "2", "-q"]).success();
}

#[test]
fn numbers_out_of_range_are_refused_where_they_are_parsed() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds", "16");
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "10", "--no-eval"]).success();
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "run/checkpoint.lucid", "-o", "frames", "--frames", "1"];
        args.extend_from_slice(extra);
        lucid_in(d, &args)
    };
    render(&["--lens-rays", "0", "--aperture", "0.1", "--focus", "3"]).usage_error(&["--lens-rays"]);
    render(&["--elevation", "NaN"]).usage_error(&["--elevation"]);
    render(&["--width", "0"]).usage_error(&["--width"]);
    render(&["--frames", "100000000000"]).usage_error(&["--frames"]);
    render(&["--focus", "-1", "--aperture", "0.1"]).usage_error(&["--focus"]);
    // Negative values where they make sense, in both spellings.
    render(&["--elevation", "-10"]).success();
    lucid_in(d, &["render", "run/checkpoint.lucid", "-o", "low", "--frames", "1", "--elevation=-10"]).success();
    lucid_in(d, &["eval", "run/checkpoint.lucid", "ds", "--limit", "0"]).usage_error(&["--limit"]);
    lucid_in(d, &["convert", "ds/test/r_0.exr", "x.exr", "--exposure", "1000"]).usage_error(&["--exposure"]);
    lucid_in(d, &["convert", "ds/test/r_0.exr", "x.exr", "--exposure", "30", "--half"]).failure(&["half"]);
    lucid_in(d, &["convert", "ds/test/r_0.exr", "dark.exr", "--exposure", "-2"]).success();
    // Never over its own input, under any name.
    let before = std::fs::read(d.join("dark.exr")).unwrap();
    lucid_in(d, &["convert", "dark.exr", "./dark.exr", "--exposure", "1"]).failure(&["dark.exr", "input"]);
    assert_eq!(std::fs::read(d.join("dark.exr")).unwrap(), before);
    lucid_in(d, &["envmap", "to-mirror-ball", "ds/test/r_0.exr", "-o", "b.exr", "--size", "0"])
        .usage_error(&["--size"]);
    lucid_in(d, &["envmap", "voronoi", ""]).failure(&["no directions"]);
    // A size within the flag's range that does not fit in memory is refused before any work.
    lucid_with_memory(
        d,
        "1G",
        &["render", "run/checkpoint.lucid", "-o", "big", "--width", "16384", "--height", "16384"],
    )
    .failure(&["16384x16384", "GiB is available"]);
    assert!(!d.join("big").exists());
    lucid_with_memory(d, "1G", &["gen", "object", "-o", "huge", "--res", "8192", "--views", "1,0,0"])
        .failure(&["8192x8192", "--res"]);
    // The generator writes only what its readers accept.
    lucid_in(d, &["gen", "object", "-o", "far", "--radius", "1e8", "--views", "1,0,0", "--res", "8"])
        .failure(&["--radius"]);
    lucid_in(d, &["gen", "object", "-o", "many", "--views", "100000000000000000,0,0", "--res", "8"])
        .failure(&["--views"]);
}

/// A light probe holding a NaN gave NaN coefficients, lights and relit images with exit 0.
#[test]
fn maps_that_are_not_finite_are_refused_naming_the_pixel() {
    let dir = temp_dir();
    let d = dir.path();
    let mut pixels = vec![[0.5f32, 0.5, 0.5, 1.0]; 32 * 16];
    pixels[3 * 32 + 7] = [f32::NAN, 0.5, 0.5, 1.0];
    lucid_image::write_image(d.join("env.exr"), &lucid_image::Image::from_pixels(32, 16, pixels)).unwrap();
    for command in ["sh", "median-cut"] {
        lucid_in(d, &["envmap", command, "env.exr"]).failure(&["env.exr", "(7, 3)", "not finite"]);
    }
}

/// Images a few pixels wide: the generator's point cloud keeps points (it once wrote none,
/// which training then refused) and both trainers run.
#[test]
fn datasets_of_tiny_images_train() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds", "4");
    lucid_in(d, &["train", "splat", "ds", "-o", "splat", "--steps", "5"]).success();
    lucid_in(d, &["train", "nerf", "ds", "-o", "nerf", "--steps", "5"]).success();
}

/// Files saved by Windows editors start with a UTF-8 byte-order mark.
#[test]
fn files_with_a_byte_order_mark_are_read() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds", "16");
    for split in ["train", "val", "test"] {
        let path = d.join(format!("ds/transforms_{split}.json"));
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, format!("\u{feff}{text}")).unwrap();
    }
    lucid_in(d, &["info", "ds"]).success();
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "5", "--no-eval"]).success();
    lucid_in(d, &["render", "run/checkpoint.lucid", "-o", "orbit", "--frames", "2"]).success();
    let path = std::fs::read_to_string(d.join("orbit/camera_path.json")).unwrap();
    std::fs::write(d.join("path.json"), format!("\u{feff}{path}")).unwrap();
    lucid_in(d, &["render", "run/checkpoint.lucid", "--camera-path", "path.json", "-o", "again"]).success();
    std::fs::write(d.join("config.toml"), "\u{feff}[train]\nsteps = 3\n").unwrap();
    lucid_in(d, &["train", "splat", "ds", "-o", "configured", "--config", "config.toml", "--no-eval"]).success();
}

/// `--resume` on another dataset, or with settings that a run cannot change once begun, went
/// on without a word.
#[test]
fn a_resumed_run_refuses_other_data_and_new_settings() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds", "16");
    lucid_in(
        d,
        &["gen", "object", "-o", "other", "--views", "4,0,1", "--res", "16", "--spp", "2", "--seed", "7", "-q"],
    )
    .success();
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "10", "--until", "5", "--no-eval"]).success();
    lucid_in(d, &["train", "splat", "other", "-o", "run", "--resume", "--no-eval"]).failure(&["run", "other data"]);
    std::fs::write(d.join("x.toml"), "[train]\nseed = 4\n").unwrap();
    for changed in [&["--set", "train.seed=3"][..], &["--seed", "3"], &["--config", "x.toml"]] {
        let mut args = vec!["train", "splat", "ds", "-o", "run", "--resume", "--no-eval"];
        args.extend_from_slice(changed);
        lucid_in(d, &args).failure(&["--resume", "train.seed = "]);
    }
    // The settings it began with may be repeated, and the budget may change.
    let args = ["train", "splat", "ds", "-o", "run", "--resume", "--no-eval", "--seed", "0", "--steps", "12"];
    lucid_in(d, &args).success();
}

/// A mirrored or sheared rotation trained as a mirrored or distorted scene; a scaled one (a
/// Blender camera with an object scale) is the same camera without its scale.
#[test]
fn camera_poses_must_be_rigid_and_right_handed() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds", "16");
    let path = d.join("ds/transforms_train.json");
    let original = std::fs::read_to_string(&path).unwrap();
    let with_pose = |change: &dyn Fn(&mut Vec<Vec<f64>>)| {
        let mut json: serde_json::Value = serde_json::from_str(&original).unwrap();
        let mut m: Vec<Vec<f64>> = serde_json::from_value(json["frames"][0]["transform_matrix"].clone()).unwrap();
        change(&mut m);
        json["frames"][0]["transform_matrix"] = serde_json::json!(m);
        std::fs::write(&path, json.to_string()).unwrap();
    };
    with_pose(&|m| (0..3).for_each(|r| m[r][0] = -m[r][0]));
    lucid_in(d, &["info", "ds"]).failure(&["frames[0].transform_matrix", "mirrored"]);
    with_pose(&|m| (0..3).for_each(|r| m[r][0] += 0.3 * m[r][1]));
    lucid_in(d, &["info", "ds"]).failure(&["frames[0].transform_matrix", "not orthogonal"]);
    with_pose(&|m| (0..3).for_each(|r| (0..3).for_each(|c| m[r][c] *= 2.0)));
    lucid_in(d, &["info", "ds"]).success();
}
