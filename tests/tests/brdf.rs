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
    for m in ["lambert", "phong", "ward"] {
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
        &["brdf", "pca", "lambert.binary", "phong.binary", "-k", "1", "--fit", "ward.binary", "-o", "fit.binary"],
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

    // Refusals: an existing output, an unknown material, too many components.
    let before = files_under(dir.path());
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "ward", "-o", "ward.binary"])
        .failure(&["ward.binary", "already exists"]);
    lucid_in(dir.path(), &["brdf", "tabulate", &materials(), "--material", "velvet", "-o", "v.binary"])
        .failure(&["velvet", "materials.toml"]);
    lucid_in(dir.path(), &["brdf", "pca", "lambert.binary", "phong.binary", "-k", "2"]).failure(&["2 components"]);
    std::fs::write(dir.path().join("bad.binary"), b"not a table").unwrap();
    lucid_in(dir.path(), &["brdf", "pca", "lambert.binary", "bad.binary", "-k", "1"]).failure(&["bad.binary", "MERL"]);
    let mut after = files_under(dir.path());
    after.retain(|f| f != "bad.binary");
    assert_eq!(before, after, "nothing written by refused commands");
}
