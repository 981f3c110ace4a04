//! PSNR and SSIM against scikit-image on a committed fixture (see
//! `fixtures/metrics/make_reference.py`, which wrote the PNGs and the expected values).

use std::path::PathBuf;

use lucid_image::metrics::{psnr, ssim};
use lucid_image::read_image;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/metrics").join(name)
}

#[test]
fn psnr_and_ssim_match_scikit_image() {
    let a = read_image(fixture("reference.png")).unwrap();
    let b = read_image(fixture("distorted.png")).unwrap();
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("expected.json")).unwrap()).unwrap();
    let value = |k: &str| expected[k].as_f64().unwrap();

    let left_half: Vec<f32> =
        (0..a.height()).flat_map(|_| (0..a.width()).map(|x| if 2 * x < a.width() { 1.0 } else { 0.0 })).collect();

    // skimage works in float64 on the same float32-decoded values: only summation order differs.
    let checks = [
        ("psnr", psnr(&a, &b, None).unwrap(), 1e-6),
        ("ssim", ssim(&a, &b, None).unwrap(), 1e-6),
        ("psnr_masked_left_half", psnr(&a, &b, Some(&left_half)).unwrap(), 1e-6),
        ("ssim_masked_left_half", ssim(&a, &b, Some(&left_half)).unwrap(), 1e-6),
    ];
    for (key, got, tol) in checks {
        assert!((got - value(key)).abs() < tol, "{key}: ours {got}, scikit-image {}", value(key));
    }
}
