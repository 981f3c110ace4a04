//! Colour helpers: the sRGB transfer function, Rec. 709 luminance, exposure and compositing.

/// Rec. 709 / sRGB luminance weights of linear RGB.
pub const REC709_LUMINANCE: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// sRGB opto-electronic transfer function (IEC 61966-2-1): linear `[0,1]` → encoded `[0,1]`.
/// Values outside `[0,1]` are clamped first, as an 8-bit file would.
pub fn srgb_encode(linear: f32) -> f32 {
    let x = linear.clamp(0.0, 1.0);
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// Inverse of [`srgb_encode`]: encoded `[0,1]` → linear `[0,1]`.
pub fn srgb_decode(encoded: f32) -> f32 {
    let x = encoded.clamp(0.0, 1.0);
    if x <= 0.040_45 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) }
}

/// [`srgb_decode`] by linear interpolation in a table of 4097 samples: within 1e-7 of it
/// (the curve's second derivative is below 3.4, so the error is under 3.4·h²/8), at the cost
/// of a multiply-add instead of a `powf`, for whole images of display values.
pub fn srgb_decode_fast(encoded: f32) -> f32 {
    const N: usize = 4096;
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| (0..=N + 1).map(|i| srgb_decode((i as f32 / N as f32).min(1.0))).collect());
    let t = encoded.clamp(0.0, 1.0) * N as f32;
    let i = (t as usize).min(N - 1);
    let f = t - i as f32;
    table[i] + f * (table[i + 1] - table[i])
}

/// Rec. 709 luminance of a linear RGB colour.
pub fn luminance(rgb: [f32; 3]) -> f32 {
    REC709_LUMINANCE[0] * rgb[0] + REC709_LUMINANCE[1] * rgb[1] + REC709_LUMINANCE[2] * rgb[2]
}

/// The factor that an exposure change of `stops` (EV) applies to linear radiance: `2^stops`.
pub fn exposure_factor(stops: f32) -> f32 {
    stops.exp2()
}

/// Scales the colour (not the alpha) of an image by `2^stops`.
pub fn apply_exposure(image: &crate::Image, stops: f32) -> crate::Image {
    let k = exposure_factor(stops);
    image.map(|p| [p[0] * k, p[1] * k, p[2] * k, p[3]])
}

/// Composites a straight-alpha pixel over an opaque background: `c·α + bg·(1−α)`.
pub fn composite_pixel(p: [f32; 4], background: [f32; 3]) -> [f32; 4] {
    let a = p[3].clamp(0.0, 1.0);
    [
        p[0] * a + background[0] * (1.0 - a),
        p[1] * a + background[1] * (1.0 - a),
        p[2] * a + background[2] * (1.0 - a),
        1.0,
    ]
}

/// Composites a whole image over an opaque background colour; the result is opaque.
pub fn composite_over(image: &crate::Image, background: [f32; 3]) -> crate::Image {
    image.map(|p| composite_pixel(p, background))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_decode_is_the_exact_decode() {
        let worst = (0..=1_000_000)
            .map(|i| i as f32 / 1e6)
            .chain([-0.5, 1.5, 0.040_45])
            .map(|x| (srgb_decode_fast(x) - srgb_decode(x)).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn srgb_round_trip_and_known_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        // 18% grey encodes to ~0.4614 (a well-known value).
        assert!((srgb_encode(0.18) - 0.461_356).abs() < 1e-4);
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 2e-6, "{x}");
        }
        // The two pieces meet: the function is continuous at the break point.
        let b = 0.003_130_8f32;
        assert!((12.92 * b - (1.055 * b.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
    }

    #[test]
    fn luminance_weights_sum_to_one() {
        assert!((luminance([1.0, 1.0, 1.0]) - 1.0).abs() < 1e-6);
        assert!((luminance([0.0, 1.0, 0.0]) - 0.7152).abs() < 1e-7);
    }

    #[test]
    fn compositing_and_exposure() {
        assert_eq!(composite_pixel([1.0, 0.0, 0.5, 0.25], [0.0, 1.0, 1.0]), [0.25, 0.75, 0.875, 1.0]);
        let img = crate::Image::filled(2, 1, [0.5, 0.25, 1.0, 0.5]);
        assert_eq!(apply_exposure(&img, 1.0).get(1, 0), [1.0, 0.5, 2.0, 0.5]);
    }
}
