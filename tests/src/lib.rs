//! Helpers for the end-to-end tests in `tests/tests/`: they run the real `lucid` binary as a
//! user would and check exit codes, messages and files.
//!
//! `cargo test --workspace --release` builds the binary before any test runs (the
//! `lucid-cli` package has integration tests, which makes cargo build its binary). To run
//! these tests alone, build it first or point `LUCID_BIN` at one.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `lucid` binary of the profile these tests were built with.
pub fn lucid_bin() -> PathBuf {
    if let Some(path) = std::env::var_os("LUCID_BIN") {
        return PathBuf::from(path);
    }
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> → target/<profile>/lucid
    let profile_dir = exe.parent().and_then(Path::parent).expect("test executable lives in target/<profile>/deps");
    let bin = profile_dir.join(format!("lucid{}", std::env::consts::EXE_SUFFIX));
    assert!(
        bin.is_file(),
        "{} not found: run `cargo test --workspace --release`, or build it with `cargo build --release -p lucid-cli`",
        bin.display()
    );
    bin
}

/// The result of one run of `lucid`.
#[derive(Debug)]
pub struct Run {
    /// Exit code (`None` if killed by a signal).
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

impl Run {
    /// Panics unless the run succeeded.
    pub fn success(self) -> Self {
        assert_eq!(self.code, Some(0), "lucid failed:\nstdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
        self
    }

    /// Panics unless the run failed with exit code 1 and a one-line `error:` message that
    /// contains every needle; returns the message.
    pub fn failure(self, needles: &[&str]) -> String {
        assert_eq!(self.code, Some(1), "expected exit code 1:\nstdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
        let errors: Vec<&str> = self.stderr.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(errors.len(), 1, "expected one error line, stderr:\n{}", self.stderr);
        for needle in needles {
            assert!(errors[0].contains(needle), "error line {:?} lacks {needle:?}", errors[0]);
        }
        errors[0].to_string()
    }

    /// Panics unless the arguments were refused as they were parsed (exit code 2) with a
    /// message that contains every needle (the flag's name, its range).
    pub fn usage_error(self, needles: &[&str]) {
        assert_eq!(self.code, Some(2), "expected a usage error:\nstdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
        for needle in needles {
            assert!(self.stderr.contains(needle), "the usage error lacks {needle:?}:\n{}", self.stderr);
        }
    }

    /// Parses stdout as JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_str(&self.stdout).unwrap_or_else(|e| panic!("stdout is not JSON ({e}):\n{}", self.stdout))
    }
}

/// Runs `lucid` with `args` in `dir`.
pub fn lucid_in(dir: &Path, args: &[&str]) -> Run {
    lucid_with_env(dir, &[], args)
}

/// Runs `lucid` in `dir` with `LUCID_MEMORY_LIMIT` set, so that a memory check does not
/// depend on the machine.
pub fn lucid_with_memory(dir: &Path, limit: &str, args: &[&str]) -> Run {
    lucid_with_env(dir, &[("LUCID_MEMORY_LIMIT", limit)], args)
}

/// Runs `lucid` with `args` in `dir` and the environment variables `vars` set.
pub fn lucid_with_env(dir: &Path, vars: &[(&str, &str)], args: &[&str]) -> Run {
    let out: Output = Command::new(lucid_bin())
        .args(args)
        .current_dir(dir)
        .env("LUCID_LOG", "warn")
        .envs(vars.iter().copied())
        .output()
        .expect("lucid binary runs");
    Run {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Every file under `dir`, relative, sorted: for checking that nothing half-written remains.
pub fn files_under(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let p = entry.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap_or(&p).display().to_string());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// A fresh temporary folder.
pub fn temp_dir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary folder")
}

/// The given columns of every data row of a CSV file, joined by commas (for comparing the
/// deterministic part of training logs; times and rates vary between runs).
pub fn csv_columns(path: &Path, columns: &[usize]) -> Vec<String> {
    let csv = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    csv.lines()
        .skip(1)
        .map(|l| {
            l.split(',').enumerate().filter(|(i, _)| columns.contains(i)).map(|(_, v)| v).collect::<Vec<_>>().join(",")
        })
        .collect()
}

/// Renders a small light field into `dir/lf` (a 5×5 camera grid, 40 px, and thin-lens test
/// views with `aperture_radius` 0.5 focused at 3.5), trains `model` (`nerf` or `splat`) on it
/// into `dir/m` for 300 steps with `train_args`, and returns the held-out PSNR rendered
/// through each view's lens and through a pinhole.
pub fn light_field_lens_and_pinhole_psnr(dir: &Path, model: &str, train_args: &[&str]) -> (f64, f64) {
    let generate = [
        "gen",
        "object",
        "--rig",
        "lightfield",
        "-o",
        "lf",
        "--res",
        "40",
        "--spp",
        "8",
        "--grid",
        "5,5",
        "--spacing",
        "0.25",
        "--focus",
        "3.5",
        "--apertures",
        "0.5",
    ];
    lucid_in(dir, &generate).success();
    let mut args = vec!["train", model, "lf", "-o", "m", "--steps", "300", "--no-eval"];
    args.extend_from_slice(train_args);
    lucid_in(dir, &args).success();
    let psnr = |extra: &[&str]| {
        let mut a = vec!["eval", "m/checkpoint.lucid", "lf", "--json", "-o", "e"];
        a.extend_from_slice(extra);
        lucid_in(dir, &a).success().json()["summary"]["psnr"].as_f64().expect("a PSNR")
    };
    (psnr(&[]), psnr(&["--pinhole"]))
}
