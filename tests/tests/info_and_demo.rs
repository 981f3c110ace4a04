//! `lucid info` on generated and broken datasets, and `lucid demo` end to end.

use lucid_tests::{lucid_in, temp_dir};

#[test]
fn demo_generates_a_dataset_that_info_reads() {
    let dir = temp_dir();
    let args =
        ["demo", "--out", "demo", "--size", "32", "--views", "6,2,3", "--nerf-steps", "80", "--splat-steps", "300"];
    let run = lucid_in(dir.path(), &args).success();
    assert!(run.stdout.contains("nearest training view"), "{}", run.stdout);
    assert!(run.stdout.contains("NeRF (80 steps"), "{}", run.stdout);
    assert!(dir.path().join("demo/nerf/checkpoint.lucid").is_file());
    assert!(
        dir.path().join("demo/splat/checkpoint.lucid").is_file() && dir.path().join("demo/splat/splats.ply").is_file()
    );

    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("demo/metrics.json")).unwrap()).unwrap();
    let quant = metrics["metrics"]["ldr_vs_hdr_truth"]["psnr"].as_f64().unwrap();
    let nearest = metrics["metrics"]["nearest_train_view"]["psnr"].as_f64().unwrap();
    // 8-bit quantisation alone costs at most 20·log10(255·2) ≈ 54 dB (worst case, every
    // value half a step off); the nearest other view is far worse than that.
    assert!(quant > 54.0, "quantisation PSNR {quant}");
    assert!(nearest < 35.0 && nearest > 5.0, "nearest-view PSNR {nearest}");
    let nerf = &metrics["metrics"]["nerf"];
    assert_eq!(nerf["count"], 3);
    // Measured 20.53 dB after 80 steps of the default batch (16.98 after 40 of the earlier
    // 2^15-sample one); an untrained field (1 step) scores 8.39.
    assert!(nerf["psnr"].as_f64().unwrap() > 19.5, "{nerf}");
    let splat = &metrics["metrics"]["splat"];
    assert_eq!(splat["count"], 3);
    // Measured 27.32 dB after 300 steps against 22.54 dB for the nearest training view.
    assert!(splat["psnr"].as_f64().unwrap() > 26.5, "{splat} vs nearest {nearest}");

    // The report: both models' numbers, a curve plot, and every image it shows on disk.
    let html = std::fs::read_to_string(dir.path().join("demo/report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    for needle in ["NeRF", "3DGS", "<svg", "Held-out PSNR", "nearest training view", "Machine"] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    assert!(html.contains(&format!("{:.2}", splat["psnr"].as_f64().unwrap())), "the table shows the splat PSNR");
    let images: Vec<&str> = html.split("<img src=\"").skip(1).map(|s| s.split('"').next().unwrap()).collect();
    // Per model: 3 test views × (truth, prediction, error), 6 orbit frames, 1 refocused view.
    assert_eq!(images.len(), 2 * (9 + 7), "{images:?}");
    for src in images {
        assert!(dir.path().join("demo").join(src).is_file(), "{src} missing");
    }

    let info = lucid_in(dir.path(), &["info", "demo/dataset", "--json"]).success().json();
    let splits = info["splits"].as_array().unwrap();
    let counts: Vec<u64> = splits.iter().map(|s| s["frames"].as_u64().unwrap()).collect();
    assert_eq!(counts, [6, 2, 3]);
    assert_eq!(splits[0]["resolutions"][0], "32x32");
    assert!((splits[0]["intrinsics"]["fov_x_degrees"].as_f64().unwrap() - 40.0).abs() < 1e-3);
    assert_eq!(splits[2]["extras"]["depth"], 3);
    let text = lucid_in(dir.path(), &["info", "demo/dataset"]).success().stdout;
    assert!(text.contains("train    6 frames"), "{text}");
}

#[test]
fn info_reports_broken_datasets() {
    let dir = temp_dir();
    lucid_in(dir.path(), &["info", "nowhere"]).failure(&["nowhere", "no such directory"]);
    lucid_in(dir.path(), &["info", "."]).failure(&["not a dataset"]);
    std::fs::write(dir.path().join("transforms_train.json"), "{\"frames\": [}").unwrap();
    lucid_in(dir.path(), &["info", "."]).failure(&["transforms_train.json", "malformed JSON"]);
}

#[test]
fn bad_arguments_are_usage_errors() {
    let dir = temp_dir();
    let run = lucid_in(dir.path(), &["demo", "--size", "4"]);
    assert_eq!(run.code, Some(1));
    assert!(run.stderr.contains("--size 4 is too small"));
    let run = lucid_in(dir.path(), &["no-such-command"]);
    assert_eq!(run.code, Some(2), "clap reports usage errors with exit code 2");
}
