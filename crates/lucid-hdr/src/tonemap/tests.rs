use super::*;
use crate::blur::Plane;

fn all_operators() -> Vec<ToneMapper> {
    ToneMapper::NAMES.iter().map(|n| ToneMapper::by_name(n).expect("known name")).collect()
}

/// A constant image maps to a constant image with the input's hue (saturation 1 keeps the
/// channel ratios), and the global operators give their closed-form value.
#[test]
fn constant_images_map_to_constant_images() {
    let colour = [0.6f32, 0.3, 0.15];
    let image = Image::filled(40, 30, [colour[0], colour[1], colour[2], 1.0]);
    let l = luminance(colour);
    for op in all_operators() {
        let out = tone_map(&image, &op, 1.0).unwrap();
        let first = out.pixels()[0];
        for p in out.pixels() {
            for c in 0..3 {
                assert!((p[c] - first[c]).abs() < 1e-5, "{op:?}: {p:?} vs {first:?}");
            }
        }
        let ld = luminance([first[0], first[1], first[2]]);
        assert!(ld > 0.0 && ld <= 1.0, "{op:?}: display luminance {ld}");
        if first.iter().take(3).all(|&v| v < 1.0) {
            for c in 0..3 {
                assert!((first[c] / ld - colour[c] / l).abs() < 1e-3, "{op:?} keeps the hue");
            }
        }
        // The closed forms, on the luminance plane (the colour above may clip).
        let ld = op.map_luminance(&Plane::filled(4, 4, l)).data[0];
        let expected = match op {
            ToneMapper::Linear { .. } => Some(l),
            // Scaled to the key, and the key is also the maximum (white): 1.
            ToneMapper::Reinhard { .. } => Some(1.0),
            ToneMapper::Aces { .. } => Some(lucid_image::tonemap::ToneCurve::Aces.apply(l)),
            _ => None,
        };
        if let Some(e) = expected {
            assert!((ld - e).abs() < 1e-3, "{op:?}: {ld} vs {e}");
        }
    }
}

/// Along a smooth ramp of luminance, display luminance never decreases: over five decades
/// for the global operators (one curve, so this is the curve's monotonicity), over one decade
/// for the local ones (a local operator may invert a steep gradient where its adaptation
/// scale changes; over gentle gradients it must not).
#[test]
fn operators_are_monotone_in_luminance() {
    let (w, h) = (256, 8);
    let ramp = |decades: f32| {
        Image::from_fn(w, h, move |x, _| {
            let l = 10f32.powf(-1.0 + decades * x as f32 / (w - 1) as f32);
            [l, l, l, 1.0]
        })
    };
    for op in all_operators() {
        let local = matches!(op, ToneMapper::Photographic { .. } | ToneMapper::Bilateral { .. });
        let image = ramp(if local { 1.0 } else { 5.0 });
        let out = tone_map(&image, &op, 1.0).unwrap();
        let row: Vec<f32> = (0..w).map(|x| out.get(x, h / 2)[1]).collect();
        for x in 1..w {
            assert!(row[x] >= row[x - 1] - 1e-6, "{op:?} at {x}: {} after {}", row[x], row[x - 1]);
        }
        assert!(row[w - 1] > row[0], "{op:?} is not flat");
    }
}

#[test]
fn bad_parameters_are_refused() {
    assert!(ToneMapper::by_name("nonsense").is_err());
    let image = Image::filled(2, 2, [1.0; 4]);
    assert!(tone_map(&image, &ToneMapper::Reinhard { key: f32::NAN, white: None }, 1.0).is_err());
    assert!(tone_map(&image, &ToneMapper::Drago { bias: 1.5, exposure: 0.0 }, 1.0).is_err());
    assert!(tone_map(&image, &ToneMapper::Linear { exposure: 0.0 }, -1.0).is_err());
}

/// Local operators keep local contrast that a global compression of the same range would
/// flatten: a 2:1 detail on a dark half and on a half 10⁴ times brighter.
#[test]
fn local_operators_keep_detail_in_both_halves() {
    let (w, h) = (128, 64);
    let image = Image::from_fn(w, h, |x, y| {
        let base = if x < w / 2 { 0.01 } else { 100.0 };
        let detail = if (x % 16 < 2) && (y % 16 < 2) { 2.0 } else { 1.0 };
        let l = base * detail;
        [l, l, l, 1.0]
    });
    let at = |out: &Image, x: usize, y: usize| out.get(x, y)[1];
    // Bilateral: the base (the two halves) is compressed to the 5:1 contrast, the detail ratio
    // of 2 is kept in both.
    let out = tone_map(&image, &ToneMapper::by_name("bilateral").unwrap(), 1.0).unwrap();
    for (x_detail, x_plain) in [(16, 24), (80, 88)] {
        let ratio = at(&out, x_detail, 32) / at(&out, x_plain, 36);
        assert!((ratio - 2.0).abs() < 0.2, "bilateral: detail ratio {ratio} at x = {x_detail}");
    }
    let halves = at(&out, 88, 36) / at(&out, 24, 36);
    assert!(halves < 5.5 && halves > 1.0, "bilateral: the halves differ by {halves}, 10⁴ in the input");
    // Photographic: the detail stays brighter than its surround in both halves.
    let out = tone_map(&image, &ToneMapper::by_name("photographic").unwrap(), 1.0).unwrap();
    for (x_detail, x_plain, min_ratio) in [(16, 24, 1.5), (80, 88, 1.01)] {
        let ratio = at(&out, x_detail, 32) / at(&out, x_plain, 36);
        assert!(ratio > min_ratio, "photographic: detail ratio {ratio} at x = {x_detail}");
    }
}
