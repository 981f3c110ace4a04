//! The one training loop as a user meets it: what the budget flags mean, runs killed at a
//! random moment that resume and finish, folders that hold a run, and a second writer.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lucid_tests::{files_under, lucid_bin, lucid_in, temp_dir};

fn tiny_dataset(d: &Path, name: &str) {
    lucid_in(d, &["gen", "object", "-o", name, "--views", "4,0,1", "--res", "16", "--spp", "2", "-q"]).success();
}

/// The step column of a log, and how many header lines it has.
fn log_steps(path: &Path) -> (usize, Vec<usize>) {
    let text = std::fs::read_to_string(path).unwrap();
    let headers = text.lines().filter(|l| l.starts_with("step,")).count();
    (headers, text.lines().filter_map(|l| l.split(',').next()?.parse().ok()).collect())
}

/// Starts `lucid args` in `d` and waits (up to a minute) until `file` exists; returns the
/// process and when it started.
fn spawn_until(d: &Path, args: &[&str], file: &Path) -> (std::process::Child, Instant) {
    let child = Command::new(lucid_bin())
        .args(args)
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !file.is_file() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    (child, start)
}

fn budget(d: &Path, out: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(d.join(out).join("run.json")).unwrap()).unwrap()
}

#[test]
fn the_budget_flags_mean_the_same_for_every_trainer() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    // --time-limit alone: trains for the seconds, past the configuration's step count.
    let t = ["--no-eval", "--set", "train.steps=3", "--set", "train.log_every=1", "--time-limit", "1.5"];
    for (model, out) in [("splat", "s"), ("nerf", "n")] {
        let mut args = vec!["train", model, "ds", "-o", out];
        args.extend_from_slice(&t);
        if model == "nerf" {
            args.extend(["--set", "field.grid.log2_table_size=12", "--set", "train.batch_samples=4096"]);
        }
        lucid_in(d, &args).success();
        assert_eq!(budget(d, out)["budget"], serde_json::json!({"mode": "seconds", "seconds": 1.5}));
        let (_, steps) = log_steps(&d.join(out).join("train_log.csv"));
        assert!(*steps.last().unwrap() > 3, "{model}: a time budget ignores train.steps ({steps:?})");
    }
    // --steps alone: exactly that many, whatever the configuration's time limit.
    let s = ["--no-eval", "--set", "train.time_limit=0.001", "--set", "train.log_every=1", "--steps", "7"];
    lucid_in(d, &[&["train", "splat", "ds", "-o", "a"][..], &s[..]].concat()).success();
    assert_eq!(log_steps(&d.join("a/train_log.csv")).1.last(), Some(&7));
    // Both: whichever ends first (here the steps).
    let b = ["--no-eval", "--steps", "5", "--time-limit", "600", "--set", "train.log_every=1"];
    lucid_in(d, &[&["train", "splat", "ds", "-o", "b"][..], &b[..]].concat()).success();
    assert_eq!(budget(d, "b")["budget"], serde_json::json!({"mode": "first", "steps": 5, "seconds": 600.0}));
    assert_eq!(log_steps(&d.join("b/train_log.csv")).1.last(), Some(&5));
}

/// A time-limited run killed at a moment after its first checkpoint (by time) resumes and
/// finishes, with one header and strictly increasing steps in its log.
#[test]
fn a_time_limited_run_killed_after_its_first_checkpoint_resumes_and_finishes() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    let args = ["train", "splat", "ds", "-o", "t", "--time-limit", "8", "--checkpoint-seconds", "1", "--no-eval"];
    let ckpt = d.join("t/checkpoint.lucid");
    let (mut child, start) = spawn_until(d, &args, &ckpt);
    assert!(ckpt.is_file(), "a checkpoint by time within a minute");
    // A moment after it that varies from run to run, well before the budget ends.
    let jitter = Instant::now().duration_since(start).subsec_millis() as u64 % 1500;
    std::thread::sleep(Duration::from_millis(200 + jitter));
    assert!(child.try_wait().unwrap().is_none(), "still training when killed");
    child.kill().unwrap();
    child.wait().unwrap();
    let (_, before) = log_steps(&d.join("t/train_log.csv"));

    let out = lucid_in(d, &["train", "splat", "ds", "-o", "t", "--resume", "--no-eval"]).success();
    assert!(out.stdout.contains("trained"), "{}", out.stdout);
    let (headers, steps) = log_steps(&d.join("t/train_log.csv"));
    assert_eq!(headers, 1);
    assert!(steps.windows(2).all(|w| w[0] < w[1]), "{steps:?}");
    assert!(steps.last() > before.last(), "the resumed run went on");
    let info = lucid_in(d, &["info", "t/checkpoint.lucid", "--json"]).success();
    let header: serde_json::Value = serde_json::from_str(&info.stdout).expect("info --json prints JSON");
    assert!(header["elapsed"].as_f64().unwrap() >= 8.0, "finished its budget: {header}");
}

#[test]
fn a_folder_holding_a_run_is_refused_and_left_as_it_was() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    lucid_in(d, &["train", "splat", "ds", "-o", "r", "--steps", "3"]).success();
    assert!(d.join("r/splats.ply").is_file() && d.join("r/eval_test/metrics.json").is_file());
    let snapshot = |p: &Path| -> Vec<(String, Vec<u8>)> {
        files_under(p).into_iter().map(|f| (f.clone(), std::fs::read(p.join(&f)).unwrap())).collect()
    };
    let before = snapshot(&d.join("r"));
    lucid_in(d, &["train", "nerf", "ds", "-o", "r", "--steps", "3"]).failure(&["r", "'splat' run", "--overwrite"]);
    lucid_in(d, &["train", "splat", "ds", "-o", "r", "--steps", "3"]).failure(&["--resume"]);
    lucid_in(d, &["train", "nerf", "ds", "-o", "r", "--resume"]).failure(&["'splat' run", "'nerf'"]);
    assert_eq!(snapshot(&d.join("r")), before, "byte-identical");

    // --overwrite replaces it, stale splats.ply and eval_test/ included.
    let tiny = ["--set", "field.grid.log2_table_size=12", "--set", "train.batch_samples=4096", "--no-eval"];
    lucid_in(d, &[&["train", "nerf", "ds", "-o", "r", "--steps", "3", "--overwrite"][..], &tiny[..]].concat())
        .success();
    assert!(!d.join("r/splats.ply").exists() && !d.join("r/eval_test").exists());
    assert_eq!(budget(d, "r")["kind"], "nerf");
}

#[test]
fn a_second_writer_is_refused_naming_the_folder_and_the_holder() {
    let dir = temp_dir();
    let d = dir.path();
    tiny_dataset(d, "ds");
    let args = ["train", "splat", "ds", "-o", "busy", "--time-limit", "30", "--no-eval"];
    let (mut child, _) = spawn_until(d, &args, &d.join("busy/run.json"));
    let pid = child.id().to_string();
    let train = lucid_in(d, &["train", "splat", "ds", "-o", "busy", "--overwrite", "--steps", "2"]);
    // gen never writes into a folder it did not make, busy or not.
    let generate = lucid_in(d, &["gen", "object", "-o", "busy", "--views", "1,0,0", "--res", "8"]);
    child.kill().unwrap();
    child.wait().unwrap();
    train.failure(&["busy", "in use by another lucid process", &pid]);
    generate.failure(&["busy", "did not write"]);
    // Two gens into one folder: the second is told who holds it.
    let args = ["gen", "object", "-o", "g", "--views", "40,0,0", "--res", "64", "--spp", "64", "-q"];
    let (mut first, _) = spawn_until(d, &args, &d.join("g/dataset.toml"));
    let second = lucid_in(d, &args);
    let first_pid = first.id().to_string();
    first.kill().unwrap();
    first.wait().unwrap();
    second.failure(&["g", "in use by another lucid process", &first_pid]);
    // Killed before its first checkpoint: nothing to resume, and the message says what to do.
    lucid_in(d, &["train", "splat", "ds", "-o", "busy", "--resume"])
        .failure(&["before its first checkpoint", "--overwrite"]);
    // Once the holder is gone, the folder is free again.
    lucid_in(d, &["train", "splat", "ds", "-o", "busy", "--overwrite", "--steps", "1", "--no-eval"]).success();
}
