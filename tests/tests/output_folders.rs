//! Commands that write into folders write only into folders Lucid owns (new, empty, or holding
//! its record of what it wrote), never over their own inputs, and remove only what they wrote:
//! each case here once replaced or deleted a user's files.

use std::collections::BTreeMap;
use std::path::Path;

use lucid_tests::{files_under, lucid_in, temp_dir};

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    files_under(dir).into_iter().map(|f| (f.clone(), std::fs::read(dir.join(&f)).unwrap())).collect()
}

/// A dataset and a splat model trained on it for a few steps.
fn dataset_and_model(d: &Path) {
    lucid_in(d, &["gen", "object", "-o", "ds", "--views", "6,1,2", "--res", "16", "--spp", "2", "-q"]).success();
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "30"]).success();
}

#[test]
fn outputs_never_replace_or_remove_what_lucid_did_not_write() {
    let dir = temp_dir();
    let d = dir.path();
    dataset_and_model(d);

    // eval -o at the dataset's own test images.
    let before = snapshot(&d.join("ds"));
    lucid_in(d, &["eval", "run/checkpoint.lucid", "ds", "-o", "ds/test"]).failure(&["ds/test", "did not write"]);
    assert_eq!(snapshot(&d.join("ds")), before, "the dataset is byte-identical");
    // Into a new folder, and again into the same one.
    lucid_in(d, &["eval", "run/checkpoint.lucid", "ds", "-o", "scores"]).success();
    lucid_in(d, &["eval", "run/checkpoint.lucid", "ds", "-o", "scores"]).success();

    // render over the camera path it reads.
    lucid_in(d, &["render", "run/checkpoint.lucid", "-o", "orbit", "--frames", "2", "--width", "16", "--height", "16"])
        .success();
    std::fs::create_dir(d.join("keyframes")).unwrap();
    let path = std::fs::read_to_string(d.join("orbit/camera_path.json")).unwrap();
    let theirs = path.replacen('{', "{\"keyframes\": [1, 2, 3],", 1);
    std::fs::write(d.join("keyframes/camera_path.json"), &theirs).unwrap();
    let args = ["render", "run/checkpoint.lucid", "--camera-path", "keyframes/camera_path.json", "-o", "keyframes"];
    lucid_in(d, &args).failure(&["camera_path.json", "input"]);
    assert_eq!(std::fs::read_to_string(d.join("keyframes/camera_path.json")).unwrap(), theirs);
    // Its own earlier output's path is an input too.
    lucid_in(d, &["render", "run/checkpoint.lucid", "--camera-path", "orbit/camera_path.json", "-o", "orbit"])
        .failure(&["input"]);

    // A second web export keeps what the user added to the folder.
    lucid_in(d, &["export", "web", "run/checkpoint.lucid", "-o", "web"]).success();
    std::fs::write(d.join("web/README.txt"), "my notes").unwrap();
    lucid_in(d, &["export", "web", "run/checkpoint.lucid", "-o", "web"]).success();
    assert_eq!(std::fs::read_to_string(d.join("web/README.txt")).unwrap(), "my notes");
    assert!(d.join("web/splats.bin").is_file());

    // train --overwrite removes the run's evaluation, not the user's notes in it.
    std::fs::write(d.join("run/eval_test/notes.txt"), "mine").unwrap();
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "20", "--no-eval", "--overwrite"]).success();
    assert_eq!(files_under(&d.join("run/eval_test")), ["notes.txt"]);
}

/// Renders of views whose images share a name in two folders are written under two names.
#[test]
fn views_that_share_a_file_name_keep_their_renders_apart() {
    let dir = temp_dir();
    let d = dir.path();
    dataset_and_model(d);
    let mut test: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("ds/transforms_test.json")).unwrap()).unwrap();
    let frames = test["frames"].as_array_mut().unwrap();
    for (k, (frame, folder)) in frames.iter_mut().zip(["left", "right"]).enumerate() {
        std::fs::create_dir_all(d.join("ds").join(folder)).unwrap();
        std::fs::copy(d.join(format!("ds/test/r_{k}.png")), d.join(format!("ds/{folder}/view.png"))).unwrap();
        let pose = frame["transform_matrix"].clone();
        *frame = serde_json::json!({ "file_path": format!("{folder}/view.png"), "transform_matrix": pose });
    }
    std::fs::write(d.join("ds/transforms_test.json"), test.to_string()).unwrap();
    lucid_in(d, &["eval", "run/checkpoint.lucid", "ds", "-o", "scores"]).success();
    let written = files_under(&d.join("scores"));
    for name in ["left_view.png", "right_view.png", "left_view_error.png", "right_view_error.png"] {
        assert!(written.contains(&name.to_string()), "{name} in {written:?}");
    }
}

/// `demo --out` over a folder holding a user's own dataset, and a demo rerun with another
/// seed, which once kept the old images under the new poses.
#[test]
fn a_demo_writes_only_over_an_earlier_demo_of_the_same_settings() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(d, &["gen", "object", "-o", "mine/dataset", "--views", "2,0,1", "--res", "16", "--spp", "1", "-q"])
        .success();
    let before = snapshot(&d.join("mine"));
    let demo = |out: &str, seed: &str| {
        let args = [
            "demo",
            "--out",
            out,
            "--size",
            "16",
            "--views",
            "2,0,1",
            "--spp",
            "1",
            "--nerf-steps",
            "0",
            "--splat-steps",
            "0",
            "--seed",
            seed,
        ];
        lucid_in(d, &args)
    };
    demo("mine", "0").failure(&["mine", "did not write"]);
    assert_eq!(snapshot(&d.join("mine")), before);
    demo("fresh", "0").success();
    demo("fresh", "0").success();
    demo("fresh", "1").failure(&["fresh", "other settings"]);
    // A demo written before folders kept records is taken as the demo it is.
    std::fs::remove_file(d.join("fresh/.lucid-output.json")).unwrap();
    std::fs::remove_file(d.join("fresh/demo.json")).unwrap();
    demo("fresh", "1").failure(&["fresh", "other settings"]);
    demo("fresh", "0").success();
}

/// `train --view` on a port in use fails before the run writes anything, so a rerun is not
/// refused as a folder that "already holds a run".
#[test]
fn a_busy_view_port_leaves_no_run_behind() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(d, &["gen", "object", "-o", "ds", "--views", "4,0,1", "--res", "16", "--spp", "1", "-q"]).success();
    let busy = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = busy.local_addr().unwrap().port().to_string();
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "5", "--view", &port]).failure(&["listen"]);
    assert!(!d.join("run").exists(), "{:?}", files_under(&d.join("run")));
    lucid_in(d, &["train", "splat", "ds", "-o", "run", "--steps", "5", "--no-eval"]).success();
}

/// A render killed part-way leaves a folder its rerun may write into (and finish).
#[test]
fn a_killed_render_can_be_run_again_into_its_folder() {
    let dir = temp_dir();
    let d = dir.path();
    dataset_and_model(d);
    let args =
        ["render", "run/checkpoint.lucid", "-o", "frames", "--frames", "3000", "--width", "64", "--height", "64"];
    let mut child = std::process::Command::new(lucid_tests::lucid_bin())
        .args(args)
        .current_dir(d)
        .env("LUCID_LOG", "warn")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let marker = d.join("frames/frame_0002.png");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while !marker.exists() && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(marker.exists(), "the render wrote frames before it was killed");
    assert!(!d.join("frames/camera_path.json").exists(), "the render finished before it could be killed");
    let args = ["render", "run/checkpoint.lucid", "-o", "frames", "--frames", "3", "--width", "64", "--height", "64"];
    lucid_in(d, &args).success();
    assert!(d.join("frames/camera_path.json").is_file());
}
