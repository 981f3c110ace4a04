//! The kernels built twice (baseline x86-64 and AVX2, chosen at run time) give bit-identical
//! results: the path tracer's image and buffers, and a splat model's renders and depths, with
//! `LUCID_SIMD=baseline` forcing the baseline build against the default choice.

use std::path::{Path, PathBuf};
use std::process::Command;

use lucid_tests::{files_under, lucid_bin, lucid_in, temp_dir};

fn run(dir: &Path, simd: Option<&str>, args: &[&str]) {
    let mut command = Command::new(lucid_bin());
    command.args(args).current_dir(dir).env("LUCID_LOG", "warn");
    if let Some(v) = simd {
        command.env("LUCID_SIMD", v);
    }
    let out = command.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

fn same_files(a: &Path, b: &Path) {
    let (fa, fb) = (files_under(a), files_under(b));
    assert_eq!(fa, fb);
    for f in fa.iter().filter(|f| !f.ends_with(".json")) {
        assert!(std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(), "{f} differs");
    }
}

#[test]
fn baseline_and_avx2_builds_give_identical_bits() {
    let dir = temp_dir();
    let d = dir.path();
    let cornell = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../configs/scenes/cornell.toml");
    let cornell = cornell.to_str().unwrap();
    for (sub, simd) in [("base", Some("baseline")), ("auto", None)] {
        std::fs::create_dir(d.join(sub)).unwrap();
        let out = format!("{sub}/cornell.exr");
        run(d, simd, &["render", cornell, "-o", &out, "--spp", "4", "--width", "48", "--height", "40"]);
    }
    same_files(&d.join("base"), &d.join("auto"));

    lucid_in(d, &["gen", "object", "-o", "ds", "--views", "6,0,2", "--res", "32", "--spp", "4", "-q"]).success();
    for (sub, simd) in [("splat_base", Some("baseline")), ("splat_auto", None)] {
        run(d, simd, &["train", "splat", "ds", "-o", sub, "--steps", "60", "--no-eval", "-q"]);
        run(d, simd, &["eval", &format!("{sub}/checkpoint.lucid"), "ds", "-o", &format!("{sub}_eval"), "-q"]);
    }
    assert_eq!(
        std::fs::read(d.join("splat_base/splats.ply")).unwrap(),
        std::fs::read(d.join("splat_auto/splats.ply")).unwrap(),
        "training takes the same path in both builds"
    );
    same_files(&d.join("splat_base_eval"), &d.join("splat_auto_eval"));
}
