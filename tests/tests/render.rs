//! `lucid render` end to end: outputs, determinism across thread counts, bad scene files.

use std::path::PathBuf;
use std::process::Command;

use lucid_image::read_image;
use lucid_tests::{files_under, lucid_bin, lucid_in, temp_dir};

fn cornell() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../configs/scenes/cornell.toml").display().to_string()
}

#[test]
fn render_writes_exr_png_and_buffers_identically_for_any_thread_count() {
    let dir = temp_dir();
    let args = |out: &str| {
        vec![
            "render".to_string(),
            cornell(),
            "-o".into(),
            out.into(),
            "--spp".into(),
            "4".into(),
            "--width".into(),
            "40".into(),
            "--height".into(),
            "40".into(),
        ]
    };
    let run = |threads: &str, out: &str| {
        let status = Command::new(lucid_bin())
            .args(args(out))
            .current_dir(dir.path())
            .env("RAYON_NUM_THREADS", threads)
            .env("LUCID_LOG", "warn")
            .output()
            .unwrap();
        assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
        String::from_utf8_lossy(&status.stdout).into_owned()
    };
    let stdout = run("1", "one.exr");
    assert!(stdout.contains("image mean"), "{stdout}");
    run("2", "two.exr");
    assert_eq!(
        files_under(dir.path()),
        [
            "one.exr",
            "one.png",
            "one_albedo.exr",
            "one_depth.exr",
            "one_normal.exr",
            "two.exr",
            "two.png",
            "two_albedo.exr",
            "two_depth.exr",
            "two_normal.exr"
        ]
    );
    let a = read_image(dir.path().join("one.exr")).unwrap();
    assert_eq!(a, read_image(dir.path().join("two.exr")).unwrap(), "same seed, different thread count, same image");
    assert_eq!(a.dimensions(), (40, 40));
    // The depth buffer sees the back wall at z-distance 3.9 + 1 in the image centre region
    // or a box in front of it: always between the open front (2.9) and the back wall (4.9).
    let d = read_image(dir.path().join("one_depth.exr")).unwrap().get(20, 8)[0];
    assert!((2.9..=4.91).contains(&d), "{d}");
}

#[test]
fn bad_scene_files_fail_with_file_and_key_and_write_nothing() {
    let dir = temp_dir();
    std::fs::write(
        dir.path().join("bad.toml"),
        "[camera]\nposition = [0.0, 0.0, 1.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = -3.0\nwidth = 8\nheight = 8\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("typo.toml"), "[camra]\n").unwrap();
    let before = files_under(dir.path());
    lucid_in(dir.path(), &["render", "bad.toml", "-o", "out.exr"]).failure(&["bad.toml", "camera.fov"]);
    lucid_in(dir.path(), &["render", "typo.toml", "-o", "out.exr"]).failure(&["typo.toml", "camra"]);
    lucid_in(dir.path(), &["render", "missing.toml", "-o", "out.exr"]).failure(&["missing.toml"]);
    lucid_in(dir.path(), &["render", &cornell(), "-o", "out.jpg"]).failure(&["out.jpg"]);
    lucid_in(dir.path(), &["render", &cornell(), "-o", "out.exr", "--spp", "0"]).failure(&["--spp"]);
    // A usage error (clap's exit code 2) that lists the integrators.
    let unknown = lucid_in(dir.path(), &["render", &cornell(), "-o", "out.exr", "--integrator", "mlt"]);
    assert!(unknown.code == Some(2) && unknown.stderr.contains("\"mlt\"") && unknown.stderr.contains("bdpt"));
    let media = cornell().replace("cornell.toml", "media.toml");
    lucid_in(dir.path(), &["render", &media, "-o", "out.exr", "--integrator", "bdpt"])
        .failure(&["media.toml", "media"]);
    assert_eq!(files_under(dir.path()), before);
}

#[test]
fn render_takes_the_integrator_from_the_command_line() {
    let dir = temp_dir();
    let size = ["--spp", "4", "--width", "24", "--height", "24"];
    let scene = cornell();
    let mut means = Vec::new();
    for integrator in ["path", "bdpt", "light-tracing"] {
        let out = format!("{integrator}.exr");
        let mut args = vec!["render", &scene, "-o", &out, "--integrator", integrator];
        args.extend(size);
        let run = lucid_in(dir.path(), &args).success();
        assert!(run.stdout.contains(&format!("({integrator})")), "{}", run.stdout);
        means.push(read_image(dir.path().join(&out)).unwrap().mean()[0]);
    }
    // Different algorithms, different noise: the command line reached the renderer.
    assert!(means[0] != means[1] && means[1] != means[2], "{means:?}");
}

#[test]
fn bench_trace_quick_prints_a_table_and_writes_json() {
    let dir = temp_dir();
    let run = lucid_in(dir.path(), &["bench", "trace", "--quick", "--json", "bench.json"]).success();
    for row in ["wall time (s)", "paths/s (M)", "rays/s (M)", "image mean", "reference mean"] {
        assert!(run.stdout.contains(row), "{}", run.stdout);
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("bench.json")).unwrap()).unwrap();
    assert_eq!((json["width"].as_u64(), json["spp"].as_u64()), (Some(64), Some(16)));
    assert!(json["rays"].as_u64().unwrap() >= json["paths"].as_u64().unwrap());
    // A 64x64, 16 spp render of the reference scene lands near its mean (loose: ~2% noise).
    let mean = json["image_mean"].as_f64().unwrap();
    assert!((mean - 0.1470).abs() < 0.006, "{mean}");
}
