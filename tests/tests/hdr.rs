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
    }
}

/// The global operators on a grey ramp over 3.3 decades give the published curves, written
/// out here from the papers (Reinhard et al. 2002 eq. 2 and 4, Drago et al. 2003 eq. 4,
/// Narkowicz's ACES fit), to the PNG's 8-bit precision; the local ones keep the ramp's order within a few codes.
#[test]
fn tone_mapped_ramps_follow_the_published_curves() {
    let dir = temp_dir();
    let d = dir.path();
    let (w, h) = (64usize, 3usize);
    let lum = |x: usize| 0.01f64 * 10f64.powf(3.3 * x as f64 / (w - 1) as f64);
    let ramp = lucid_image::Image::from_fn(w, h, |x, _| {
        let l = lum(x) as f32;
        [l, l, l, 1.0]
    });
    lucid_image::write_image(d.join("ramp.exr"), &ramp).unwrap();
    let log_average = ((0..w).map(|x| (1e-6 + lum(x)).ln()).sum::<f64>() / w as f64).exp();
    let lmax = lum(w - 1);
    let reinhard = |l: f64| {
        let scale = 0.18 / log_average;
        let (lm, white) = (l * scale, lmax * scale);
        lm * (1.0 + lm / (white * white)) / (1.0 + lm)
    };
    let drago = |l: f64| {
        let (lw, lwmax) = (l / log_average, lmax / log_average);
        let exponent = 0.85f64.ln() / 0.5f64.ln();
        (1.0 + lw).ln() / (1.0 + lwmax).log10() / (2.0 + 8.0 * (lw / lwmax).powf(exponent)).ln()
    };
    let aces = |x: f64| (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    let curves: [(&str, &dyn Fn(f64) -> f64); 4] =
        [("linear", &|l: f64| l), ("reinhard", &reinhard), ("drago", &drago), ("aces", &aces)];
    let encode = |v: f64| lucid_image::color::srgb_encode(v.clamp(0.0, 1.0) as f32) as f64;
    for (op, curve) in curves {
        let out = format!("ramp_{op}.png");
        lucid_in(d, &["tonemap", "ramp.exr", "-o", &out, "--op", op]).success();
        let img = read_image(d.join(&out)).unwrap();
        for x in 0..w {
            let got = encode(img.get(x, 1)[0] as f64);
            let want = encode(curve(lum(x)));
            assert!((got - want).abs() <= 0.6 / 255.0, "{op} at L = {:.4}: {got:.4} vs {want:.4}", lum(x));
        }
    }
    for op in ["photographic", "bilateral"] {
        let out = format!("ramp_{op}.png");
        lucid_in(d, &["tonemap", "ramp.exr", "-o", &out, "--op", op]).success();
        let img = read_image(d.join(&out)).unwrap();
        let row: Vec<f64> = (0..w).map(|x| encode(img.get(x, 1)[0] as f64)).collect();
        // Within 4 codes: the photographic operator's scale selection changes along the ramp,
        // a local dip of 3 codes (measured) where it does.
        assert!(row.windows(2).all(|p| p[1] >= p[0] - 4.0 / 255.0), "{op} keeps the ramp's order: {row:?}");
        if op == "photographic" {
            assert!(row[0] < 0.2 && row[w - 1] > 0.8, "{op} spreads the ramp over the display range: {row:?}");
        } else {
            // Durand and Dorsey compress the base layer to the target contrast, 5:1 by default
            // (measured 6.2:1 with the ramp's residual detail).
            let ratio = img.get(w - 1, 1)[0] / img.get(0, 1)[0];
            assert!(row[w - 1] > 0.9 && (4.0..8.0).contains(&ratio), "{op}: end-to-end contrast {ratio}: {row:?}");
        }
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

/// `lucid bench hdr --write-stack` leaves the bracket and a fusion that is the fusion of those
/// very files (what `scripts/compare-opencv-mertens.py` hands to OpenCV), and refuses a folder
/// that exists or a benchmark without a bracket.
#[test]
fn the_hdr_benchmark_writes_its_bracket_for_other_tools() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(d, &["bench", "hdr", "--quick", "--write-stack", "stack"]).success();
    assert_eq!(
        lucid_tests::files_under(&d.join("stack")),
        ["frame_0.png", "frame_1.png", "frame_2.png", "frame_3.png", "frame_4.png", "fused.pfm"]
    );
    let frames: Vec<_> = (0..5).map(|k| read_image(d.join(format!("stack/frame_{k}.png"))).unwrap()).collect();
    let stack = lucid_hdr::stack::ExposureStack::new(&frames, &[1.0 / 16.0, 0.25, 1.0, 4.0, 16.0]).unwrap();
    let fused = lucid_hdr::fusion::mertens(&stack, lucid_hdr::fusion::FusionSettings::default());
    let written = read_image(d.join("stack/fused.pfm")).unwrap();
    let worst = fused
        .pixels()
        .iter()
        .zip(written.pixels())
        .flat_map(|(a, b)| (0..3).map(move |c| (lucid_image::color::srgb_encode(a[c]) - b[c]).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-6, "fused.pfm differs from the fusion of the written frames by {worst}");
    lucid_in(d, &["bench", "hdr", "--quick", "--write-stack", "stack"]).failure(&["stack", "already exists"]);
    lucid_in(d, &["bench", "trace", "--quick", "--write-stack", "other"]).failure(&["only the hdr benchmark"]);
    assert!(!d.join("other").exists());
}
