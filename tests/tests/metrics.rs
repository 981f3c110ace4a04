//! `lucid metrics`: single pairs, folders, options and bad input.

use lucid_image::metrics::{MetricSpace, compare, prepare_for_metrics};
use lucid_image::{Image, read_image, write_image};
use lucid_tests::{lucid_in, temp_dir};

fn pattern(seed: u32, w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let v = ((x * 7 + y * 13 + seed as usize * 5) % 17) as f32 / 17.0;
        [v, 1.0 - v, (v * 3.0).fract(), if x < 3 { 0.5 } else { 1.0 }]
    })
}

#[test]
fn pair_metrics_match_the_library_in_srgb_space_over_white() {
    let dir = temp_dir();
    write_image(dir.path().join("a.png"), &pattern(1, 24, 20)).unwrap();
    write_image(dir.path().join("b.png"), &pattern(2, 24, 20)).unwrap();
    let out = lucid_in(dir.path(), &["metrics", "a.png", "b.png", "--json"]).success().json();
    let prep = |p: &str| prepare_for_metrics(&read_image(dir.path().join(p)).unwrap(), [1.0; 3], MetricSpace::Srgb);
    let expected = compare(&prep("a.png"), &prep("b.png"), None).unwrap();
    assert!((out["mean"]["psnr"].as_f64().unwrap() - expected.psnr).abs() < 1e-9);
    assert!((out["mean"]["ssim"].as_f64().unwrap() - expected.ssim).abs() < 1e-9);
    assert_eq!(out["space"], "srgb");

    // A black background changes the half-transparent columns, hence the numbers.
    let black =
        lucid_in(dir.path(), &["metrics", "a.png", "b.png", "--json", "--background", "black"]).success().json();
    assert_ne!(black["mean"]["psnr"], out["mean"]["psnr"]);
    // The text table prints the same mean.
    let text = lucid_in(dir.path(), &["metrics", "a.png", "b.png"]).success().stdout;
    assert!(text.contains(&format!("{:.3}", expected.psnr)), "{text}");
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
