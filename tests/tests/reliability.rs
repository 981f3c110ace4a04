//! Adversarial inputs that once slipped through: each exits with code 1 and one `error:` line
//! naming the file and the problem, and leaves other tools' data untouched.

use std::collections::BTreeMap;
use std::path::Path;

use lucid_tests::{files_under, lucid_in, lucid_with_memory, temp_dir};

fn tiny_dataset(d: &Path, name: &str) {
    lucid_in(d, &["gen", "object", "-o", name, "--views", "4,0,1", "--res", "16", "--spp", "2", "-q"]).success();
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    files_under(dir).into_iter().map(|f| (f.clone(), std::fs::read(dir.join(&f)).unwrap())).collect()
}

/// A dataset another tool wrote (transforms files and images, no `dataset.toml`) is never
/// rewritten by `gen`, nor is a folder holding anything else.
#[test]
fn gen_refuses_a_folder_it_did_not_write() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "blender");
    std::fs::remove_file(d.join("blender/dataset.toml")).unwrap();
    let before = snapshot(&d.join("blender"));
    let args = ["gen", "object", "-o", "blender", "--views", "2,0,1", "--res", "8", "--spp", "1"];
    lucid_in(d, &args).failure(&["blender", "did not write", "transforms_test.json", "dataset.toml"]);
    assert_eq!(snapshot(&d.join("blender")), before, "the foreign dataset is byte-identical");

    std::fs::create_dir(d.join("notes")).unwrap();
    std::fs::write(d.join("notes/readme.txt"), "mine").unwrap();
    lucid_in(d, &["gen", "object", "-o", "notes", "--views", "1,0,0", "--res", "8"]).failure(&["readme.txt"]);
    assert_eq!(files_under(&d.join("notes")), ["readme.txt"]);

    // An empty folder (made by the user) is fine, and so is the folder of an earlier gen.
    std::fs::create_dir(d.join("empty")).unwrap();
    lucid_in(d, &["gen", "object", "-o", "empty", "--views", "1,0,0", "--res", "8", "--spp", "1", "-q"]).success();
    lucid_in(d, &["gen", "object", "-o", "empty", "--views", "1,0,0", "--res", "8", "--spp", "1", "-q"]).success();
}

/// Settings within their ranges that need more memory than there is are refused before
/// anything is allocated or written, naming the keys that drive the need; unbounded counts
/// have bounds.
#[test]
fn configurations_that_cannot_fit_in_memory_are_refused_naming_their_keys() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    let nerf = ["train", "nerf", "ds", "-o", "n", "--steps", "1", "--set", "field.grid.log2_table_size=26"];
    lucid_with_memory(d, "4G", &nerf).failure(&["field.grid.log2_table_size = 26", "GiB is available"]);
    let batch = [
        "train",
        "nerf",
        "ds",
        "-o",
        "n",
        "--steps",
        "1",
        "--set",
        "train.batch_samples=4194304",
        "--set",
        "train.initial_rays=1048576",
    ];
    lucid_with_memory(d, "1G", &batch).failure(&["train.batch_samples = 4194304"]);
    let splat = ["train", "splat", "ds", "-o", "s", "--steps", "1", "--set", "densify.max_gaussians=20000000"];
    lucid_with_memory(d, "2G", &splat).failure(&["densify.max_gaussians = 20000000"]);
    lucid_in(d, &["train", "splat", "ds", "-o", "s", "--set", "init.random_points=1000000000"])
        .failure(&["init.random_points", "1..=20000000"]);
    assert!(!d.join("n").exists() && !d.join("s").exists(), "nothing was created");
    // The defaults fit in a modest machine: 1 GiB for NeRF, 3 GiB for splats (a cloud may grow
    // to a million Gaussians).
    lucid_with_memory(d, "1G", &["train", "nerf", "ds", "-o", "n", "--steps", "2", "--no-eval"]).success();
    lucid_with_memory(d, "3G", &["train", "splat", "ds", "-o", "s", "--steps", "2", "--no-eval"]).success();
    lucid_with_memory(d, "lots", &["train", "nerf", "ds", "-o", "x", "--steps", "1"]).failure(&["LUCID_MEMORY_LIMIT"]);
}

/// A pose 1e30 away is refused at load, naming the file and frame; it used to train into a
/// cloud of NaN with exit code 0.
#[test]
fn absurd_poses_are_refused_when_the_dataset_is_read() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    let path = d.join("ds/transforms_train.json");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["frames"][2]["transform_matrix"][0][3] = serde_json::json!(1e30);
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    lucid_in(d, &["train", "splat", "ds", "-o", "s", "--steps", "5"]).failure(&[
        "transforms_train.json",
        "frames[2].transform_matrix",
        "beyond",
    ]);
    assert!(!d.join("s").exists());
}

/// A missing PNG is reported as missing; the EXR of the same stem is not read in its place.
#[test]
fn a_missing_image_is_not_replaced_by_another_file_of_its_stem() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    std::fs::remove_file(d.join("ds/train/r_1.png")).unwrap();
    assert!(d.join("ds/train/r_1.exr").is_file());
    lucid_in(d, &["train", "nerf", "ds", "-o", "a", "--steps", "1"]).failure(&["frames[1].file_path", "r_1.png"]);
    lucid_in(d, &["info", "ds"]).failure(&["r_1.png", "not found"]);
}

fn write_png_ramp(path: &Path, gain: f32) {
    let image = lucid_image::Image::from_fn(32, 24, |x, y| {
        let v = (gain * (0.02 + 0.03 * x as f32 + 0.01 * y as f32)).min(1.0);
        [v, 0.8 * v, 0.6 * v, 1.0]
    });
    lucid_image::write_image(path, &image).unwrap();
}

/// Degenerate inputs to `hdr merge`, `convert` and `metrics` are errors, not garbage files
/// with exit code 0; an infinite PSNR is written so that a JSON reader tells it from an error.
#[test]
fn degenerate_inputs_are_errors_and_infinite_psnr_is_spelled_out() {
    let dir = temp_dir();
    let d = dir.path();
    for (k, gain) in [0.25f32, 1.0, 4.0].iter().enumerate() {
        write_png_ramp(&d.join(format!("b{k}.png")), *gain);
    }
    let merge = |extra: &[&str]| {
        let mut args = vec!["hdr", "merge", "b0.png", "b1.png", "b2.png", "-o", "out.exr"];
        args.extend_from_slice(extra);
        lucid_in(d, &args)
    };
    merge(&["--times", "1,1,1"]).failure(&["exposure time 1", "differ"]);
    merge(&["--times", "0.25,1,4", "--samples", "0"]).failure(&["0 samples", "need 128..=4096"]);
    assert!(!d.join("out.exr").exists());
    merge(&["--times", "0.25,1,4"]).success();

    let nan = lucid_image::Image::from_fn(16, 16, |x, _| if x == 3 { [f32::NAN, 0.0, 0.0, 1.0] } else { [0.5; 4] });
    lucid_image::write_image(d.join("nan.exr"), &nan).unwrap();
    lucid_in(d, &["convert", "nan.exr", "nan.png"]).failure(&["nan.exr", "16 values are NaN", "PNG"]);
    assert!(!d.join("nan.png").exists());
    lucid_in(d, &["convert", "nan.exr", "nan.pfm"]).success();
    lucid_in(d, &["metrics", "nan.exr", "out.exr", "--json"]).failure(&["nan.exr", "NaN"]);

    let same = lucid_in(d, &["metrics", "b1.png", "b1.png", "--json"]).success().json();
    assert_eq!(same["images"][0]["psnr"], "inf");
    assert_eq!(same["mean"]["psnr"], "inf");
    assert_eq!(same["images"][0]["ssim"], 1.0);
    let differ = lucid_in(d, &["metrics", "b0.png", "b1.png", "--json"]).success().json();
    assert!(differ["images"][0]["psnr"].as_f64().is_some_and(|p| p > 5.0 && p < 40.0), "{differ}");
}

/// Converting an image with transparent pixels to a format without alpha composites it
/// (over black unless `--background` says otherwise) and says so; it used to keep the straight
/// colour, brightening every anti-aliased edge.
#[test]
fn alpha_is_composited_when_the_output_cannot_store_it() {
    let dir = temp_dir();
    let d = dir.path();
    let image = lucid_image::Image::from_fn(4, 4, |x, _| [0.8, 0.4, 0.2, if x < 2 { 1.0 } else { 0.25 }]);
    lucid_image::write_image(d.join("a.exr"), &image).unwrap();
    let run = lucid_in(d, &["convert", "a.exr", "black.pfm"]).success();
    assert!(run.stderr.contains("composited over black"), "{}", run.stderr);
    lucid_in(d, &["convert", "a.exr", "white.hdr", "--background", "white"]).success();
    let black = lucid_image::read_image(d.join("black.pfm")).unwrap();
    let white = lucid_image::read_image(d.join("white.hdr")).unwrap();
    let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol;
    assert!(close(black.get(3, 0)[0], 0.2, 1e-6) && close(black.get(0, 0)[0], 0.8, 1e-6));
    // 0.8·0.25 + 1·0.75, within RGBE's 8-bit mantissa.
    assert!(close(white.get(3, 0)[0], 0.95, 0.01) && close(white.get(3, 0)[2], 0.8, 0.01), "{:?}", white.get(3, 0));
    // PNG and EXR keep alpha: nothing to composite, nothing said.
    let kept = lucid_in(d, &["convert", "a.exr", "kept.png"]).success();
    assert!(!kept.stderr.contains("composited"), "{}", kept.stderr);
}

/// A checkpoint with a flipped byte or bytes appended is refused as damaged; a failing run
/// leaves no empty folder; `splats.ply` has the permissions of the run's other files; an
/// RGBE file whose header says 0×0 is an error naming that file.
#[test]
fn damaged_files_are_named_and_outputs_are_consistent() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    lucid_in(d, &["train", "splat", "ds", "-o", "s", "--steps", "3", "--no-eval"]).success();
    let ckpt = std::fs::read(d.join("s/checkpoint.lucid")).unwrap();
    let mut flipped = ckpt.clone();
    let middle = flipped.len() / 2;
    flipped[middle] ^= 0x10;
    std::fs::write(d.join("flipped.lucid"), &flipped).unwrap();
    lucid_in(d, &["eval", "flipped.lucid", "ds", "-o", "e1"]).failure(&["flipped.lucid", "damaged"]);
    let mut appended = ckpt.clone();
    appended.extend_from_slice(b"trailing garbage\n");
    std::fs::write(d.join("appended.lucid"), &appended).unwrap();
    let err = lucid_in(d, &["eval", "appended.lucid", "ds", "-o", "e2"]).failure(&["appended.lucid", "damaged"]);
    assert!(!err.contains("7450474826515505511"), "{err}");

    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = |f: &str| std::fs::metadata(d.join(f)).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode("s/splats.ply"), mode("s/config.toml"), "splats.ply is written like the other outputs");
    }

    // The run fails after its folder would have been made (the point cloud is unreadable).
    std::fs::write(d.join("ds/points3d.ply"), "ply\nformat ascii 1.0\nelement vertex 9\nend_header\n1 2\n").unwrap();
    lucid_in(d, &["train", "splat", "ds", "-o", "never", "--steps", "1"]).failure(&["points3d.ply"]);
    assert!(!d.join("never").exists(), "no empty folder is left behind");

    std::fs::write(d.join("empty.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n").unwrap();
    lucid_in(d, &["convert", "empty.hdr", "out.png"]).failure(&["empty.hdr", "0x0"]);
}
