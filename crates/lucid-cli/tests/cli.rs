//! The binary's contract with the shell: version, help, and exit codes. (Having an
//! integration test here also makes `cargo test` build the `lucid` binary that the
//! end-to-end tests in `tests/` run.)

use std::process::Command;

fn lucid(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lucid")).args(args).output().expect("lucid runs")
}

#[test]
fn version_and_help() {
    let out = lucid(&["--version"]);
    assert!(out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), format!("lucid {}", env!("CARGO_PKG_VERSION")));
    let help = String::from_utf8_lossy(&lucid(&["--help"]).stdout).into_owned();
    for sub in ["demo", "convert", "metrics", "info"] {
        assert!(help.contains(sub), "help lacks {sub}");
    }
}

#[test]
fn errors_are_one_line_with_exit_code_one() {
    let out = lucid(&["info", "/definitely/not/here"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: ") && stderr.contains("/definitely/not/here"), "{stderr}");
}
