//! `lucid metrics`: single pairs, folders, options and bad input.

use lucid_image::{Image, write_image};
use lucid_tests::{lucid_in, temp_dir};

fn pattern(seed: u32, w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let v = ((x * 7 + y * 13 + seed as usize * 5) % 17) as f32 / 17.0;
        [v, 1.0 - v, (v * 3.0).fract(), if x < 3 { 0.5 } else { 1.0 }]
    })
}

/// An image of one 8-bit sRGB code everywhere.
fn flat(code: u8, alpha: f32) -> Image {
    let v = lucid_image::color::srgb_decode(code as f32 / 255.0);
    Image::filled(24, 20, [v, v, v, alpha])
}

/// Flat images whose codes differ by 10 have, in sRGB space, PSNR 20·log10(255/10) and the
/// SSIM of two constants, (2μₐμᵦ + C₁)/(μₐ² + μᵦ² + C₁) with C₁ = 0.01²: closed forms, not
/// the library the command calls.
#[test]
fn pair_metrics_match_closed_forms_in_srgb_space_over_white() {
    let dir = temp_dir();
    write_image(dir.path().join("a.png"), &flat(100, 1.0)).unwrap();
    write_image(dir.path().join("b.png"), &flat(110, 1.0)).unwrap();
    let out = lucid_in(dir.path(), &["metrics", "a.png", "b.png", "--json"]).success().json();
    let psnr = 20.0 * (255.0f64 / 10.0).log10();
    let (ma, mb, c1) = (100.0 / 255.0, 110.0 / 255.0, 1e-4);
    let ssim = (2.0 * ma * mb + c1) / (ma * ma + mb * mb + c1);
    let got = (out["mean"]["psnr"].as_f64().unwrap(), out["mean"]["ssim"].as_f64().unwrap());
    assert!((got.0 - psnr).abs() < 1e-3, "PSNR {} vs {psnr}", got.0);
    assert!((got.1 - ssim).abs() < 1e-5, "SSIM {} vs {ssim}", got.1);
    assert_eq!(out["space"], "srgb");
    // The text table prints the same mean.
    let text = lucid_in(dir.path(), &["metrics", "a.png", "b.png"]).success().stdout;
    assert!(text.contains(&format!("{psnr:.3}")), "{text}");

    // Half-transparent: as the NeRF literature scores the Blender set, the 8-bit sRGB values
    // are composited, y·α + bg·(1 − α), with α stored as 128/255; over black the difference
    // is the same as over white, and half of the opaque one.
    write_image(dir.path().join("ha.png"), &flat(100, 0.5)).unwrap();
    write_image(dir.path().join("hb.png"), &flat(110, 0.5)).unwrap();
    let alpha = 128.0 / 255.0;
    let over = |bg: f64, code: u8| code as f64 / 255.0 * alpha + bg * (1.0 - alpha);
    for (bg, name) in [(1.0, "white"), (0.0, "black")] {
        let want = -20.0 * (over(bg, 110) - over(bg, 100)).abs().log10();
        let out =
            lucid_in(dir.path(), &["metrics", "ha.png", "hb.png", "--json", "--background", name]).success().json();
        let got = out["mean"]["psnr"].as_f64().unwrap();
        assert!((got - want).abs() < 1e-3, "over {name}: {got} vs {want}");
    }
}

#[test]
fn folders_are_matched_by_stem() {
    let dir = temp_dir();
    for sub in ["pred", "gt"] {
        std::fs::create_dir(dir.path().join(sub)).unwrap();
    }
    for i in 0..3 {
        write_image(dir.path().join(format!("pred/r_{i}.png")), &pattern(i, 16, 16)).unwrap();
        write_image(dir.path().join(format!("gt/r_{i}.exr")), &pattern(i, 16, 16)).unwrap();
    }
    write_image(dir.path().join("gt/r_0.png"), &pattern(9, 16, 16)).unwrap(); // same extension wins
    let out = lucid_in(dir.path(), &["metrics", "pred", "gt", "--json"]).success().json();
    let images = out["images"].as_array().unwrap();
    assert_eq!(images.len(), 3);
    assert!(images[0]["psnr"].as_f64().unwrap() < 40.0, "r_0 must compare with gt/r_0.png");
    // r_1 and r_2 differ only by 8-bit quantisation.
    assert!(images[1]["psnr"].as_f64().unwrap() > 45.0);
}

#[test]
fn mismatched_or_missing_inputs_fail_clearly() {
    let dir = temp_dir();
    write_image(dir.path().join("a.png"), &pattern(1, 24, 20)).unwrap();
    write_image(dir.path().join("small.png"), &pattern(1, 20, 20)).unwrap();
    write_image(dir.path().join("tiny.png"), &pattern(1, 8, 8)).unwrap();
    lucid_in(dir.path(), &["metrics", "a.png", "small.png"]).failure(&["a.png", "small.png", "sizes differ"]);
    lucid_in(dir.path(), &["metrics", "tiny.png", "tiny.png"]).failure(&["tiny.png", "11x11"]);
    lucid_in(dir.path(), &["metrics", "a.png", "nope.png"]).failure(&["nope.png"]);
    lucid_in(dir.path(), &["metrics", "a.png", "a.png", "--background", "purple"]).failure(&["purple"]);
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    lucid_in(dir.path(), &["metrics", "empty", "empty"]).failure(&["no images"]);
}
