//! Every format written and read back, and every reader fed bad input.

use std::path::Path;

use lucid_image::color::srgb_encode;
use lucid_image::io::{PfmEndianness, read_pfm, write_pfm};
use lucid_image::{
    ExrPrecision, Image, ImageError, PngBitDepth, WriteOptions, image_dimensions, read_image, write_image,
    write_image_with,
};

/// An HDR test image with a gradient, values above 1, tiny values and partial alpha, and
/// no symmetry, so that flipped rows or swapped channels show.
fn hdr_test_image(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let u = x as f32 / w as f32;
        let v = y as f32 / h as f32;
        [u * 4.0 + 0.001, v * v * 100.0 + 0.01, (u * 7.0 + v * 3.0).sin().abs() * 0.5 + 1e-3, 0.25 + 0.75 * u]
    })
}

fn ldr_test_image(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let u = x as f32 / (w - 1) as f32;
        let v = y as f32 / (h - 1) as f32;
        [u, v, 1.0 - u * v, if x % 3 == 0 { 1.0 } else { 0.5 * v }]
    })
}

fn assert_close(a: &Image, b: &Image, channels: usize, tol: impl Fn(f32) -> f32) {
    assert_eq!(a.dimensions(), b.dimensions());
    for (i, (pa, pb)) in a.pixels().iter().zip(b.pixels()).enumerate() {
        for c in 0..channels {
            let t = tol(pa[c]);
            assert!((pa[c] - pb[c]).abs() <= t, "pixel {i} channel {c}: {} vs {} (tolerance {t})", pa[c], pb[c]);
        }
    }
}

#[test]
fn exr_float_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let img = hdr_test_image(37, 23);
    write_image(&path, &img).unwrap();
    assert_eq!(read_image(&path).unwrap(), img);
    assert_eq!(image_dimensions(&path).unwrap(), (37, 23));
}

#[test]
fn exr_half_round_trip_within_half_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let img = hdr_test_image(16, 9);
    let options = WriteOptions { exr_precision: ExrPrecision::Half, ..Default::default() };
    write_image_with(&path, &img, options).unwrap();
    // Half floats keep 11 significant bits: relative error ≤ 2^-11 (normal range).
    assert_close(&read_image(&path).unwrap(), &img, 4, |v| v.abs() * 2f32.powi(-11) + 1e-7);
    // Half is smaller on disk than float.
    let float_path = dir.path().join("b.exr");
    write_image(&float_path, &img).unwrap();
    assert!(std::fs::metadata(&path).unwrap().len() < std::fs::metadata(&float_path).unwrap().len());
}

#[test]
fn exr_without_alpha_reads_opaque_and_single_channel_reads_grey() {
    let dir = tempfile::tempdir().unwrap();
    let opaque = hdr_test_image(8, 8).map(|p| [p[0], p[1], p[2], 1.0]);
    let path = dir.path().join("rgb.exr");
    write_image(&path, &opaque).unwrap();
    assert_eq!(read_image(&path).unwrap(), opaque);

    let depth = Image::from_fn(5, 4, |x, y| [(x + 10 * y) as f32, 0.0, 0.0, 1.0]);
    let path = dir.path().join("depth.exr");
    write_image_with(&path, &depth, WriteOptions { single_channel: true, ..Default::default() }).unwrap();
    let back = read_image(&path).unwrap();
    assert_eq!(back.get(3, 2), [23.0, 23.0, 23.0, 1.0]);
}

#[test]
fn pfm_round_trips_in_both_byte_orders_and_both_channel_counts() {
    let dir = tempfile::tempdir().unwrap();
    let img = hdr_test_image(11, 7).map(|p| [p[0], p[1], p[2], 1.0]);
    for endianness in [PfmEndianness::Little, PfmEndianness::Big] {
        let path = dir.path().join(format!("c_{endianness:?}.pfm"));
        write_pfm(&path, &img, false, endianness).unwrap();
        assert_eq!(read_image(&path).unwrap(), img);

        let path = dir.path().join(format!("g_{endianness:?}.pfm"));
        write_pfm(&path, &img, true, endianness).unwrap();
        let grey = img.map(|p| [p[0], p[0], p[0], 1.0]);
        assert_eq!(read_pfm(&path).unwrap(), grey);
    }
}

#[test]
fn pfm_rows_are_bottom_to_top_as_the_format_says() {
    // A hand-made 1x2 grey big-endian file: the first stored row is the bottom of the image.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rows.pfm");
    let mut bytes = b"Pf\n1 2\n1.0\n".to_vec();
    bytes.extend_from_slice(&1.5f32.to_be_bytes());
    bytes.extend_from_slice(&7.0f32.to_be_bytes());
    std::fs::write(&path, bytes).unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!(img.get(0, 0)[0], 7.0, "top row is the last one in the file");
    assert_eq!(img.get(0, 1)[0], 1.5);
    assert_eq!(image_dimensions(&path).unwrap(), (1, 2));
}

#[test]
fn rgbe_round_trip_within_shared_exponent_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.hdr");
    let img = hdr_test_image(40, 12).map(|p| [p[0], p[1], p[2], 1.0]);
    write_image(&path, &img).unwrap();
    let back = read_image(&path).unwrap();
    // Each channel is an 8-bit mantissa of the pixel's largest component: the absolute
    // error is at most one step of that mantissa, max·2^-8 (truncation, not rounding).
    for (pa, pb) in img.pixels().iter().zip(back.pixels()) {
        let max = pa[0].max(pa[1]).max(pa[2]);
        for c in 0..3 {
            assert!((pa[c] - pb[c]).abs() <= max * 2f32.powi(-7), "{pa:?} vs {pb:?}");
        }
    }
}

#[test]
fn png_8_and_16_bit_round_trip_in_srgb_space() {
    let dir = tempfile::tempdir().unwrap();
    let img = ldr_test_image(19, 13);
    for (depth, step) in [(PngBitDepth::Eight, 255.0f32), (PngBitDepth::Sixteen, 65535.0)] {
        let path = dir.path().join(format!("a_{depth:?}.png"));
        write_image_with(&path, &img, WriteOptions { png_bit_depth: depth, ..Default::default() }).unwrap();
        let back = read_image(&path).unwrap();
        for (pa, pb) in img.pixels().iter().zip(back.pixels()) {
            for c in 0..3 {
                let err = (srgb_encode(pa[c]) - srgb_encode(pb[c])).abs();
                assert!(err <= 0.5 / step + 1e-5, "{depth:?}: {pa:?} vs {pb:?}");
            }
            assert!((pa[3] - pb[3]).abs() <= 0.5 / step + 1e-6, "alpha is stored linearly");
        }
    }
}

#[test]
fn png_stores_srgb_encoded_values() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey.png");
    write_image(&path, &Image::filled(2, 2, [0.18, 0.18, 0.18, 1.0])).unwrap();
    // Decode the raw bytes with the image crate, bypassing our sRGB decode.
    let raw = image::open(&path).unwrap().to_rgb8();
    assert_eq!(raw.get_pixel(0, 0)[0], 118, "0.18 linear is 118/255 in sRGB");
}

fn assert_error_names_file(result: Result<Image, ImageError>, path: &Path, needle: &str) {
    let err = result.expect_err("bad input must be an error");
    let msg = err.to_string();
    assert!(msg.contains(&*path.file_name().unwrap().to_string_lossy()), "message {msg:?} does not name the file");
    assert!(msg.to_lowercase().contains(needle), "message {msg:?} does not say {needle:?}");
}

#[test]
fn bad_input_gives_errors_that_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    assert_error_names_file(read_image(d.join("missing.exr")), &d.join("missing.exr"), "no such file");
    assert_error_names_file(read_image(d.join("x.tiff")), &d.join("x.tiff"), "unsupported image format");

    for (name, bytes, needle) in [
        ("garbage.exr", b"definitely not an exr".to_vec(), "malformed openexr"),
        ("garbage.png", b"\x89PNG\r\n\x1a\n garbage".to_vec(), "malformed png"),
        ("garbage.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\nbogus dims\n".to_vec(), "malformed radiance"),
        ("garbage.pfm", b"P6\n1 1\n255\n".to_vec(), "malformed pfm"),
        ("short.pfm", b"PF\n4 4\n-1.0\n\x00\x00\x00\x00".to_vec(), "truncated"),
        ("badscale.pfm", b"PF\n1 1\nzero\n\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00".to_vec(), "scale"),
        ("empty.jpg", Vec::new(), "malformed jpeg"),
    ] {
        let path = d.join(name);
        std::fs::write(&path, bytes).unwrap();
        assert_error_names_file(read_image(&path), &path, needle);
    }

    // Truncated copies of valid files.
    let img = hdr_test_image(32, 32);
    for name in ["t.exr", "t.png", "t.hdr"] {
        let path = d.join(name);
        write_image(&path, &img).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let err = read_image(&path).expect_err("truncated file must fail").to_string();
        assert!(err.contains(name), "{err}");
    }
}

#[test]
fn failed_writes_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let img = ldr_test_image(4, 4);
    // A missing parent directory.
    let path = dir.path().join("no/such/dir/a.png");
    let err = write_image(&path, &img).unwrap_err().to_string();
    assert!(err.contains("a.png"), "{err}");
    // An empty image cannot be encoded; the directory must stay empty.
    let path = dir.path().join("empty.exr");
    assert!(write_image(&path, &Image::black(0, 0)).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "failed writes left files behind");
    // A successful write leaves exactly the target, no temporary file.
    let path = dir.path().join("ok.exr");
    write_image(&path, &img).unwrap();
    let names: Vec<String> =
        std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn unknown_output_extension_is_rejected_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.bmp");
    let err = write_image(&path, &ldr_test_image(4, 4)).unwrap_err();
    assert!(matches!(err, ImageError::UnsupportedFormat { .. }));
    assert!(!path.exists());
}

#[test]
fn the_same_image_always_gives_the_same_bytes() {
    // Parallel EXR compression must not reorder blocks: datasets are compared byte for byte.
    let dir = tempfile::tempdir().unwrap();
    let img = hdr_test_image(300, 200);
    for name in ["a.exr", "b.exr", "c.exr"] {
        write_image(dir.path().join(name), &img).unwrap();
    }
    let a = std::fs::read(dir.path().join("a.exr")).unwrap();
    for name in ["b.exr", "c.exr"] {
        assert!(a == std::fs::read(dir.path().join(name)).unwrap(), "{name} differs from a.exr");
    }
}
