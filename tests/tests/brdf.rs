//! `lucid brdf`: tabulating a scene file's material into a MERL table, and the PCA basis of
//! tables with a fit in it.

use std::path::PathBuf;

use lucid_tests::{files_under, lucid_in, temp_dir};
use lucid_trace::bsdf::measured::MerlTable;

fn materials() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../configs/scenes/materials.toml").display().to_string()
}

#[test]
fn tabulate_writes_a_table_that_pca_reconstructs() {
    let dir = temp_dir();
    for m in ["lambert", "phong", "blinn"] {
        lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", m, "-o", &format!("{m}.binary")])
            .success();
    }
    // The Lambertian table holds albedo / π, in MERL's scaled channels.
    let lambert = MerlTable::read(&dir.path().join("lambert.binary")).unwrap();
    let albedo = glam::Vec3::new(0.7, 0.25, 0.2) / std::f32::consts::PI;
    assert!(lambert.values().iter().all(|v| (*v - albedo).abs().max_element() < 1e-5));

    // Two tables are reconstructed exactly by one component (their centred data has rank 1).
    let run = lucid_in(
        dir.path(),
        &["brdf", "pca", "lambert.binary", "phong.binary", "-k", "1", "--fit", "blinn.binary", "-o", "fit.binary"],
    )
    .success();
    let errors: Vec<f64> = run
        .stdout
        .lines()
        .filter(|l| l.contains(".binary") && !l.starts_with("fitted"))
        .map(|l| l.split_whitespace().last().unwrap().parse().unwrap())
        .collect();
    assert_eq!(errors.len(), 2, "{}", run.stdout);
    assert!(errors.iter().all(|&e| e < 1e-3), "{}", run.stdout);
    let fitted = MerlTable::read(&dir.path().join("fit.binary")).unwrap();
    assert!(fitted.values().iter().all(|v| v.min_element() >= 0.0), "a fitted BRDF is non-negative");

    // Refusals: an existing output, an unknown material, materials a table cannot hold (the
    // anisotropic Ward sphere, the plastic's mirror coat), too many components.
    let before = files_under(dir.path());
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "blinn", "-o", "blinn.binary"])
        .failure(&["blinn.binary", "already exists"]);
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "ward", "-o", "ward.binary"])
        .failure(&["ward", "anisotropic"]);
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "plastic", "-o", "plastic.binary"])
        .failure(&["plastic", "mirror-like"]);
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "velvet", "-o", "v.binary"])
        .failure(&["velvet", "materials.toml"]);
    lucid_in(dir.path(), &["brdf", "pca", "lambert.binary", "phong.binary", "-k", "2"]).failure(&["2 components"]);
    std::fs::write(dir.path().join("bad.binary"), b"not a table").unwrap();
    lucid_in(dir.path(), &["brdf", "pca", "lambert.binary", "bad.binary", "-k", "1"]).failure(&["bad.binary", "MERL"]);
    let mut after = files_under(dir.path());
    after.retain(|f| f != "bad.binary");
    assert_eq!(before, after, "nothing written by refused commands");
}

/// A sphere of material `ball` (its lines) on a checkered floor, the measured test's view.
fn sphere_scene(ball: &str) -> String {
    let scene = lucid_trace::sample_scenes::object_on_floor(lucid_trace::sample_scenes::SPHERE, 96, 64, 4);
    format!("{scene}\n[materials.ball]\n{ball}\n")
}

#[test]
fn a_neural_brdf_fitted_to_a_table_renders_the_table_s_image() {
    let dir = temp_dir();
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "phong", "-o", "phong.binary"]).success();
    let run = lucid_in(dir.path(), &["brdf", "fit-neural", "phong.binary", "-o", "phong.json"]).success();
    // "held-out relative RMS error 0.0498, log-cosine RMS 0.0094" when measured.
    let error: f64 = run
        .stdout
        .split("relative RMS error ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no error reported: {}", run.stdout));
    assert!(error < 0.08, "held-out relative RMS error {error}");
    assert!(run.stdout.contains("654 parameters"), "{}", run.stdout);

    // The same sphere rendered with the table and with the network, same seed: measured
    // 43.3 dB between them and means within 0.1 %.
    let render = |ball: &str| {
        let loaded = lucid_trace::parse_scene(&sphere_scene(ball), &dir.path().join("s.toml")).unwrap();
        let settings = lucid_trace::RenderSettings { spp: 256, ..loaded.settings };
        lucid_trace::render(&loaded.scene, &loaded.camera, &settings, &|_| {}).unwrap().colour
    };
    let table = render("type = \"measured\"\nfile = \"phong.binary\"");
    let neural = render("type = \"neural\"\nfile = \"phong.json\"");
    let mse: f64 = table
        .pixels()
        .iter()
        .zip(neural.pixels())
        .map(|(a, b)| (0..3).map(|c| (a[c].clamp(0.0, 1.0) - b[c].clamp(0.0, 1.0)) as f64).map(|d| d * d).sum::<f64>())
        .sum::<f64>()
        / (3 * table.pixels().len()) as f64;
    let psnr = 10.0 * (1.0 / mse).log10();
    let (ma, mb) = (table.mean(), neural.mean());
    assert!(psnr > 40.0, "table vs neural: {psnr:.2} dB");
    assert!((mb[1] / ma[1] - 1.0).abs() < 0.005, "means {ma:?} vs {mb:?}");

    // Refusals: an existing output, a file that is not a table, a bad network in a scene.
    let before = files_under(dir.path());
    lucid_in(dir.path(), &["brdf", "fit-neural", "phong.binary", "-o", "phong.json"])
        .failure(&["phong.json", "already exists"]);
    std::fs::write(dir.path().join("bad.binary"), b"not a table").unwrap();
    lucid_in(dir.path(), &["brdf", "fit-neural", "bad.binary", "-o", "bad.json"]).failure(&["bad.binary", "MERL"]);
    std::fs::write(dir.path().join("bad.json"), b"{\"format\": \"x\"}").unwrap();
    let err =
        lucid_trace::parse_scene(&sphere_scene("type = \"neural\"\nfile = \"bad.json\""), &dir.path().join("s.toml"))
            .unwrap_err()
            .to_string();
    assert!(err.contains("bad.json") && err.contains("materials.ball.file"), "{err}");
    let mut after = files_under(dir.path());
    after.retain(|f| f != "bad.binary" && f != "bad.json");
    assert_eq!(before, after, "nothing written by refused commands");
}
