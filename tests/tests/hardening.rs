//! The bad-input table of the README, row by row: each case exits with code 1 and one
//! `error:` line naming the file and the problem, and leaves no partial output; and a killed
//! `gen` or `train` continues where it stopped.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lucid_image::{Image, write_image};
use lucid_tests::{files_under, lucid_bin, lucid_in, temp_dir};

fn tiny_dataset(d: &Path, name: &str) {
    lucid_in(d, &["gen", "object", "-o", name, "--views", "4,0,1", "--res", "16", "--spp", "2", "-q"]).success();
}

#[test]
fn missing_and_wrong_size_images_are_named() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    // Frame paths carry no extension (Blender style) and resolve to any image file of that
    // stem, so all of them go.
    for ext in ["png", "exr"] {
        std::fs::remove_file(d.join(format!("ds/train/r_1.{ext}"))).unwrap();
    }
    lucid_in(d, &["train", "nerf", "ds", "-o", "a", "--steps", "1"]).failure(&["r_1"]);
    tiny_dataset(d, "ds2");
    write_image(d.join("ds2/train/r_2.png"), &Image::filled(8, 8, [0.5; 4])).unwrap();
    lucid_in(d, &["train", "splat", "ds2", "-o", "b", "--steps", "1"]).failure(&["r_2.png", "8x8"]);
    assert!(!d.join("a/checkpoint.lucid").exists() && !d.join("b/checkpoint.lucid").exists());
}

#[test]
fn malformed_dataset_json_is_named_for_training() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    std::fs::write(d.join("ds/transforms_train.json"), "{ \"frames\": [ }").unwrap();
    lucid_in(d, &["train", "nerf", "ds", "-o", "a"]).failure(&["transforms_train.json", "malformed JSON"]);
}

#[test]
fn a_checkpoint_of_another_kind_is_refused() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    lucid_in(d, &["train", "splat", "ds", "-o", "s", "--steps", "2", "--no-eval"]).success();
    lucid_in(d, &["train", "nerf", "ds", "-o", "s", "--resume"]).failure(&["checkpoint.lucid", "splat"]);
    lucid_in(d, &["train", "itm", "ds", "-o", "s", "--resume"]).failure(&["checkpoint.lucid", "splat"]);
}

/// Outputs that cannot be written (a directory under a file; a read-only file system, which
/// even root cannot write: the closest we can get to a full disk in a test): a clear error
/// and no temporary file left behind.
#[test]
fn unwritable_outputs_are_clear_errors_with_nothing_left() {
    let dir = temp_dir();
    let d = dir.path();
    write_image(d.join("ok.exr"), &Image::filled(4, 4, [0.5; 4])).unwrap();
    std::fs::write(d.join("file"), "not a directory").unwrap();
    let before = files_under(d);
    lucid_in(d, &["convert", "ok.exr", "file/out.png"]).failure(&["out.png"]);
    lucid_in(d, &["tonemap", "ok.exr", "-o", "file/out.png"]).failure(&["out.png"]);
    assert_eq!(files_under(d), before, "nothing half-written");
    if Path::new("/proc/self").exists() {
        lucid_in(d, &["convert", "ok.exr", "/proc/lucid-test.png"]).failure(&["lucid-test.png"]);
        lucid_in(d, &["gen", "object", "-o", "/proc/lucid-test", "--views", "1,0,0", "--res", "8"])
            .failure(&["/proc/lucid-test"]);
    }
}

/// Kills `args` once `ready` holds (or after `limit`), and asserts that it was still running
/// when killed: a process that finished first would make a resume test pass untested.
fn kill_when(d: &Path, args: &[&str], ready: impl Fn() -> bool, limit: Duration) {
    let mut child = Command::new(lucid_bin())
        .args(args)
        .current_dir(d)
        .env("LUCID_LOG", "error")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("lucid starts");
    let start = Instant::now();
    while !ready() && start.elapsed() < limit {
        if child.try_wait().expect("waitable").is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(child.try_wait().expect("waitable").is_none(), "{args:?} finished before it could be killed");
    child.kill().expect("killable");
    let status = child.wait().expect("waitable");
    assert!(!status.success(), "{args:?} was killed, not finished: {status}");
}

/// A `gen` killed part-way keeps its finished frames, and running it again completes the set
/// without redoing them.
#[test]
fn killed_generation_resumes() {
    let dir = temp_dir();
    let d = dir.path();
    let args = ["gen", "object", "-o", "ds", "--views", "12,0,4", "--res", "48", "--spp", "64", "-q"];
    let some_done = || std::fs::read_dir(d.join("ds/train")).map(|r| r.count() >= 6).unwrap_or(false);
    kill_when(d, &args, some_done, Duration::from_secs(60));
    assert!(!d.join("ds/transforms_train.json").exists(), "killed before the dataset was complete");
    let run = lucid_in(d, &args[..args.len() - 1]).success();
    assert!(run.stderr.contains("already there") || run.stdout.contains("already there"), "{}", run.stderr);
    assert!(d.join("ds/transforms_train.json").is_file() && d.join("ds/transforms_test.json").is_file());
}

/// A `train` killed after its first checkpoint loses at most the steps since it, and
/// `--resume` finishes the run.
#[test]
fn killed_training_resumes_from_its_checkpoint() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    let args =
        ["train", "splat", "ds", "-o", "t", "--steps", "100000", "--no-eval", "--set", "train.checkpoint_every=20"];
    let ckpt = d.join("t/checkpoint.lucid");
    kill_when(d, &args, || ckpt.is_file(), Duration::from_secs(60));
    assert!(ckpt.is_file(), "a checkpoint was written before the kill");
    // The kill lands at whatever checkpoint the machine reached; `info` says which.
    let info = lucid_in(d, &["info", "t", "--json"]).success();
    let header: serde_json::Value = serde_json::from_str(&info.stdout).expect("info --json prints JSON");
    assert_eq!(header["kind"], "splat");
    let saved = header["step"].as_u64().expect("the header has a step") as usize;
    assert!(saved >= 20 && saved.is_multiple_of(20), "checkpointed every 20 steps: {saved}");
    let end = saved + 40;
    lucid_in(d, &["train", "splat", "ds", "-o", "t", "--resume", "--steps", &end.to_string(), "--no-eval"]).success();
    let log = std::fs::read_to_string(d.join("t/train_log.csv")).unwrap();
    let steps: Vec<usize> = log.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect();
    assert_eq!(steps.last(), Some(&end), "resumed to the end: {steps:?}");
    assert!(steps.windows(2).all(|w| w[0] < w[1]), "no step logged twice: {steps:?}");
}
