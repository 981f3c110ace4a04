//! Inverse tone mapping (LDR → HDR): the soft mask of clipped pixels, the analytic baseline,
//! the blend a learned predictor goes through, and the metrics that score it.
//!
//! An LDR pixel below the clipping point already measures radiance (up to the camera
//! response); only pixels near saturation have lost information. So, as in Eilertsen et al.'s
//! HDR-CNN (2017), a prediction is used only there: with the soft mask
//! `α = max(0, max_c y_c − τ) / (1 − τ)` of the display values `y`,
//! `H = (1 − α)·f⁻¹(y) + α·Ĥ`, and `H = f⁻¹(y)` exactly where `α = 0`.

use lucid_image::Image;
use lucid_image::color::srgb_decode;

/// Display value above which a pixel counts as (partly) clipped: τ = 0.95.
pub const MASK_THRESHOLD: f32 = 0.95;

/// The soft clipping mask of display (file) values `y`: 0 below τ, rising to 1 at 1.
pub fn clip_mask(y: [f32; 3], threshold: f32) -> f32 {
    let m = y[0].max(y[1]).max(y[2]);
    ((m - threshold) / (1.0 - threshold)).clamp(0.0, 1.0)
}

/// `(1 − α)·linear + α·predicted`, per channel.
pub fn blend(linear: [f32; 3], predicted: [f32; 3], alpha: f32) -> [f32; 3] {
    [0, 1, 2].map(|c| (1.0 - alpha) * linear[c] + alpha * predicted[c])
}

/// The analytic baseline: the inverse sRGB response, with highlights expanded where the
/// mask is on by up to `boost_stops` stops, `H = f⁻¹(y)·2^(boost·α²)` (a smooth ramp, so that
/// no edge appears at the threshold). Input: a linearised LDR image as read from a file.
pub fn analytic_itm(ldr: &Image, boost_stops: f32) -> Image {
    ldr.map(|p| {
        let y = [p[0], p[1], p[2]].map(lucid_image::color::srgb_encode);
        let gain = highlight_gain(clip_mask(y, MASK_THRESHOLD), boost_stops);
        [p[0] * gain, p[1] * gain, p[2] * gain, p[3]]
    })
}

/// The analytic baseline's gain on the linearised input at mask value `alpha`:
/// `2^(boost·α²)`.
pub fn highlight_gain(alpha: f32, boost_stops: f32) -> f32 {
    (boost_stops * alpha * alpha).exp2()
}

/// The linearised value of a display value (the inverse of the sRGB response the generator's
/// brackets and most cameras' JPEGs use).
pub fn linearise(y: f32) -> f32 {
    srgb_decode(y)
}

/// Floor of radiance in the log metrics: 10⁻⁴ of the exposure that clips.
pub const LOG_FLOOR: f32 = 1e-4;

/// The `log₁₀` radiance difference the log metrics pool, both values floored at
/// [`LOG_FLOOR`].
pub fn log_difference(prediction: f32, truth: f32) -> f32 {
    prediction.max(LOG_FLOOR).log10() - truth.max(LOG_FLOOR).log10()
}

/// Log-domain PSNR from pooled squared errors, with the peak the dynamic range of the
/// metric: from [`LOG_FLOOR`] to `peak` (the brightest truth value) in decades.
pub fn log_psnr(sum: f64, count: usize, peak: f32) -> f64 {
    let range = (peak.max(1.0) / LOG_FLOOR).log10() as f64;
    if count == 0 {
        return f64::NAN;
    }
    let mse = (sum / count as f64).max(1e-20);
    10.0 * (range * range / mse).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_is_zero_on_well_exposed_pixels_and_one_at_clipping() {
        assert_eq!(clip_mask([0.2, 0.94, 0.5], MASK_THRESHOLD), 0.0);
        assert_eq!(clip_mask([1.0, 0.3, 0.3], MASK_THRESHOLD), 1.0);
        let half = clip_mask([0.975, 0.0, 0.0], MASK_THRESHOLD);
        assert!((half - 0.5).abs() < 1e-5);
        // The blend returns the linearised input where the mask is 0.
        assert_eq!(blend([0.1, 0.2, 0.3], [9.0, 9.0, 9.0], 0.0), [0.1, 0.2, 0.3]);
    }

    #[test]
    fn analytic_baseline_is_the_inverse_response_below_the_threshold() {
        let ldr = Image::from_fn(16, 1, |x, _| {
            let y = x as f32 / 15.0;
            let l = srgb_decode(y);
            [l, l, l, 1.0]
        });
        let out = analytic_itm(&ldr, 3.0);
        for x in 0..16 {
            let (i, o) = (ldr.get(x, 0)[0], out.get(x, 0)[0]);
            if x <= 14 {
                assert!((o - i).abs() < 1e-6, "{x}: {o} vs {i}");
            } else {
                assert!((o - 8.0 * i).abs() < 1e-4, "clipped pixels get the full boost: {o}");
            }
        }
    }
}
