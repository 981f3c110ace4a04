//! `lucid convert`: formats, exposure and tone curves, and bad input.

use lucid_image::color::srgb_encode;
use lucid_image::{Image, read_image, write_image};
use lucid_tests::{files_under, lucid_in, temp_dir};

#[test]
fn hdr_to_ldr_applies_exposure_and_tone_curve() {
    let dir = temp_dir();
    let hdr = Image::from_fn(4, 2, |x, _| [0.25 * x as f32, 2.0, 0.1, 1.0]);
    write_image(dir.path().join("in.exr"), &hdr).unwrap();
    lucid_in(dir.path(), &["convert", "in.exr", "out.png", "--exposure", "1", "--tone-curve", "reinhard"]).success();
    let out = read_image(dir.path().join("out.png")).unwrap();
    // Pixel (2,0): 0.5 linear, +1 stop = 1.0, Reinhard → 0.5, stored as sRGB(0.5) in 8 bits.
    let stored = srgb_encode(out.get(2, 0)[0]);
    assert!((stored - srgb_encode(0.5)).abs() <= 0.5 / 255.0 + 1e-6, "{stored}");
    // Green 2.0 → 4.0 → 0.8.
    assert!((srgb_encode(out.get(0, 0)[1]) - srgb_encode(0.8)).abs() <= 0.5 / 255.0 + 1e-6);
}

#[test]
fn every_format_converts_to_every_other() {
    let dir = temp_dir();
    let img = Image::from_fn(9, 7, |x, y| [x as f32 / 9.0, y as f32 / 7.0, 0.5, 1.0]);
    write_image(dir.path().join("a.exr"), &img).unwrap();
    let chain = ["a.exr", "b.pfm", "c.hdr", "d.png", "e.exr", "f.jpg", "g.pfm"];
    for pair in chain.windows(2) {
        lucid_in(dir.path(), &["convert", pair[0], pair[1]]).success();
    }
    let back = read_image(dir.path().join("g.pfm")).unwrap();
    assert_eq!(back.dimensions(), (9, 7));
    // Through 8-bit PNG and JPEG the values survive to within a few sRGB steps.
    for (a, b) in img.pixels().iter().zip(back.pixels()) {
        for c in 0..3 {
            assert!((srgb_encode(a[c]) - srgb_encode(b[c])).abs() < 0.05, "{a:?} vs {b:?}");
        }
    }
    lucid_in(dir.path(), &["convert", "a.exr", "h.exr", "--half"]).success();
    lucid_in(dir.path(), &["convert", "a.exr", "i.png", "--png16"]).success();
}

#[test]
fn bad_input_fails_with_the_file_named_and_writes_nothing() {
    let dir = temp_dir();
    write_image(dir.path().join("ok.exr"), &Image::black(4, 4)).unwrap();
    std::fs::write(dir.path().join("bad.exr"), b"not an exr").unwrap();
    let before = files_under(dir.path());

    lucid_in(dir.path(), &["convert", "missing.exr", "out.png"]).failure(&["missing.exr", "no such file"]);
    lucid_in(dir.path(), &["convert", "bad.exr", "out.png"]).failure(&["bad.exr", "malformed OpenEXR"]);
    lucid_in(dir.path(), &["convert", "ok.exr", "out.tga"]).failure(&["out.tga", "unsupported image format"]);
    lucid_in(dir.path(), &["convert", "ok.txt", "out.png"]).failure(&["ok.txt", "unsupported image format"]);
    lucid_in(dir.path(), &["convert", "ok.exr", "nodir/out.png"]).failure(&["out.png"]);
    lucid_in(dir.path(), &["convert", "ok.exr", "out.png", "--exposure", "NaN"]).usage_error(&["--exposure", "finite"]);
    assert_eq!(files_under(dir.path()), before, "a failed conversion left files behind");
}
