//! `lucid hdr merge` and `lucid tonemap` on a generated brackets dataset, and bad input.

use lucid_image::read_image;
use lucid_tests::{lucid_in, temp_dir};

/// The brackets rig's frames of one view merge back into its path-traced radiance: with the
/// response recovered by Debevec–Malik (known only up to scale) and with the sRGB response
/// the generator uses. The floor is the sensor model: shot and read noise and 8-bit codes,
/// about 3% per pixel measured here.
#[test]
fn merged_brackets_match_the_rendered_radiance() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(
        d,
        &["gen", "studio", "--rig", "brackets", "--views", "2,0,1", "--res", "64", "--spp", "8", "-o", "br", "-q"],
    )
    .success();
    lucid_in(d, &["hdr", "merge", "br", "-o", "debevec.exr", "--response-out", "curve.csv"]).success();
    lucid_in(d, &["hdr", "merge", "br", "-o", "srgb.exr", "--method", "srgb"]).success();
    lucid_in(d, &["hdr", "merge", "br", "-o", "fused.png", "--method", "mertens"]).success();
    let truth = read_image(d.join("br/train/r_0.exr")).unwrap();
    for (name, scale_free) in [("debevec.exr", true), ("srgb.exr", false)] {
        let merged = read_image(d.join(name)).unwrap();
        let mut ratios: Vec<f32> = Vec::new();
        for (m, t) in merged.pixels().iter().zip(truth.pixels()) {
            for c in 0..3 {
                if t[c] > 1e-2 {
                    ratios.push(m[c] / t[c]);
                }
            }
        }
        ratios.sort_by(f32::total_cmp);
        let scale = ratios[ratios.len() / 2];
        if !scale_free {
            assert!((scale - 1.0).abs() < 0.02, "{name}: radiance scale {scale}");
        }
        let mean = ratios.iter().map(|r| (r / scale - 1.0).abs()).sum::<f32>() / ratios.len() as f32;
        println!("{name}: scale {scale:.3}, mean relative error {mean:.4}");
        assert!(mean < 0.06, "{name}: mean relative error {mean}");
    }
    let csv = std::fs::read_to_string(d.join("curve.csv")).unwrap();
    assert_eq!(csv.lines().count(), 257, "a header and 256 codes");
    for op in ["linear", "reinhard", "drago", "aces", "photographic", "bilateral"] {
        let out = format!("{op}.png");
        lucid_in(d, &["tonemap", "debevec.exr", "-o", &out, "--op", op]).success();
        let img = read_image(d.join(&out)).unwrap();
        assert_eq!(img.dimensions(), truth.dimensions());
        assert!(img.pixels().iter().all(|p| p[..3].iter().all(|v| (0.0..=1.0).contains(v))));
    }
}

#[test]
fn bad_hdr_input_is_refused_clearly() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(
        d,
        &["gen", "studio", "--rig", "brackets", "--views", "1,0,0", "--res", "16", "--spp", "1", "-o", "br", "-q"],
    )
    .success();
    lucid_in(d, &["hdr", "merge", "br", "-o", "out.png"]).failure(&["out.png", "HDR format"]);
    lucid_in(d, &["hdr", "merge", "br/train/r_0_e0.png", "br/train/r_0_e1.png", "-o", "x.exr"])
        .failure(&["2 frames but 0 exposure times"]);
    lucid_in(d, &["hdr", "merge", "br", "--view", "9", "-o", "x.exr"]).failure(&["--view 9"]);
    lucid_in(d, &["hdr", "merge", "missing.png", "br/train/r_0_e1.png", "--times", "1,2", "-o", "x.exr"])
        .failure(&["missing.png"]);
    lucid_in(d, &["hdr", "merge", "br/train/r_0_e0.png", "br/train/r_0_e1.png", "--times", "1,-2", "-o", "x.exr"])
        .failure(&["exposure time"]);
    lucid_in(d, &["tonemap", "missing.exr", "-o", "x.png"]).failure(&["missing.exr"]);
    lucid_in(d, &["tonemap", "br/train/r_0.exr", "-o", "x.png", "--op", "drago", "--bias", "1.5"]).failure(&["bias"]);
    lucid_in(d, &["tonemap", "br/train/r_0.exr", "-o", "x.png", "--key", "nan"]).failure(&["key"]);
    assert!(!d.join("x.exr").exists() && !d.join("x.png").exists(), "nothing half-written");
}
