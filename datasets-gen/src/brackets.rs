//! Exposure brackets: turning one HDR render into the LDR frames a camera would record at
//! several exposure times, through a camera response curve, with sensor noise and clipping.
//!
//! The sensor model: the irradiance-proportional signal `L·t` (relative to the full well, 1)
//! gets photon shot noise (Gaussian, variance `L·t / full_well_electrons`) and read noise
//! (Gaussian, σ in full-well units), is clipped to `[0, 1]`, mapped by the response curve and
//! quantised to 8 bits.

use lucid_image::Image;

/// A camera response curve `f: [0,1] → [0,1]`, monotone, with its inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraResponse {
    /// The sRGB transfer function.
    Srgb,
    /// A smooth S-curve `x^p / (x^p + (1−x)^p)`: darker shadows and softer highlights than
    /// linear, like film and many camera picture profiles.
    SCurve {
        /// Contrast exponent `p > 0` (1 is the identity).
        contrast: f32,
    },
}

impl CameraResponse {
    /// `f(x)` for exposure `x ∈ [0,1]`.
    pub fn apply(&self, x: f32) -> f32 {
        let x = x.clamp(0.0, 1.0);
        match *self {
            CameraResponse::Srgb => lucid_image::color::srgb_encode(x),
            CameraResponse::SCurve { contrast: p } => {
                let (a, b) = (x.powf(p), (1.0 - x).powf(p));
                if a + b == 0.0 { 0.0 } else { a / (a + b) }
            }
        }
    }

    /// `f⁻¹(y)`: the exposure that gives pixel value `y`.
    pub fn invert(&self, y: f32) -> f32 {
        let y = y.clamp(0.0, 1.0);
        match *self {
            CameraResponse::Srgb => lucid_image::color::srgb_decode(y),
            CameraResponse::SCurve { contrast: p } => {
                // y/(1−y) = (x/(1−x))^p, so x/(1−x) = (y/(1−y))^(1/p).
                if y >= 1.0 {
                    return 1.0;
                }
                let r = (y / (1.0 - y)).powf(1.0 / p);
                r / (1.0 + r)
            }
        }
    }
}

/// Sensor noise parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorNoise {
    /// Electrons at full well: shot noise has variance `signal / full_well_electrons`
    /// (`f32::INFINITY` for none).
    pub full_well_electrons: f32,
    /// Read noise standard deviation, in full-well units.
    pub read_noise: f32,
}

impl SensorNoise {
    /// No noise at all.
    pub const NONE: SensorNoise = SensorNoise { full_well_electrons: f32::INFINITY, read_noise: 0.0 };
}

/// How brackets are made.
#[derive(Clone, Debug, PartialEq)]
pub struct BracketSpec {
    /// Exposure times in seconds (relative: radiance 1 for 1 s fills the well).
    pub exposure_times: Vec<f32>,
    /// Response curve.
    pub response: CameraResponse,
    /// Sensor noise.
    pub noise: SensorNoise,
}

/// The 8-bit pixel values (in `[0,1]`, as stored in the file) of `hdr` exposed for `time`
/// seconds. `seed` makes the noise reproducible.
pub fn expose(hdr: &Image, time: f32, response: CameraResponse, noise: SensorNoise, seed: u64) -> Image {
    let mut rng = lucid_trace::sampling::Rng::new(seed, 0x005e_150e);
    let mut gaussian = move || {
        // Box–Muller.
        let (u1, u2) = (1.0 - rng.uniform(), rng.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    };
    hdr.map(|p| {
        let mut out = [0.0f32; 4];
        for c in 0..3 {
            let signal = (p[c].max(0.0) * time).min(4.0);
            let shot =
                if noise.full_well_electrons.is_finite() { (signal / noise.full_well_electrons).sqrt() } else { 0.0 };
            let sigma = (shot * shot + noise.read_noise * noise.read_noise).sqrt();
            let measured = if sigma > 0.0 { signal + sigma * gaussian() } else { signal };
            out[c] = (response.apply(measured.clamp(0.0, 1.0)) * 255.0).round() / 255.0;
        }
        out[3] = p[3];
        out
    })
}

/// Linearises stored pixel values and divides by the exposure time: the radiance estimate
/// of one bracket (meaningful where the pixel is neither clipped nor black).
pub fn radiance_from_bracket(ldr: &Image, time: f32, response: CameraResponse) -> Image {
    ldr.map(|p| [response.invert(p[0]) / time, response.invert(p[1]) / time, response.invert(p[2]) / time, p[3]])
}

/// The largest radiance error (× exposure time) that rounding to the 8-bit code `y` can cause:
/// half a code on the steeper side of the inverse response.
pub fn half_code_error(response: CameraResponse, y: f32) -> f32 {
    let x = response.invert(y);
    (response.invert(y + 0.5 / 255.0) - x).max(x - response.invert(y - 0.5 / 255.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hdr() -> Image {
        // Radiance spanning 1e-3 to 1e2 (17 stops) across the image.
        Image::from_fn(64, 16, |x, y| {
            let l = 10f32.powf(-3.0 + 5.0 * (x as f32 + 0.5) / 64.0);
            [l, l * 0.5, l * (1.0 + y as f32 / 16.0), 1.0]
        })
    }

    #[test]
    fn responses_invert() {
        for r in [CameraResponse::Srgb, CameraResponse::SCurve { contrast: 1.6 }] {
            for i in 0..=100 {
                let x = i as f32 / 100.0;
                assert!((r.invert(r.apply(x)) - x).abs() < 1e-4, "{r:?} at {x}");
                if i > 0 {
                    assert!(r.apply(x) > r.apply(x - 0.01), "{r:?} is monotone");
                }
            }
        }
    }

    #[test]
    fn dividing_linearised_brackets_by_time_recovers_the_hdr_where_unclipped() {
        let truth = hdr();
        for response in [CameraResponse::Srgb, CameraResponse::SCurve { contrast: 1.6 }] {
            let mut checked = 0;
            for (k, time) in [0.01f32, 0.1, 1.0, 10.0].into_iter().enumerate() {
                let ldr = expose(&truth, time, response, SensorNoise::NONE, k as u64);
                let estimate = radiance_from_bracket(&ldr, time, response);
                for (t, (e, v)) in truth.pixels().iter().zip(estimate.pixels().iter().zip(ldr.pixels())) {
                    for c in 0..3 {
                        // Unclipped and above the darkest codes, where 8 bits resolve the value.
                        if v[c] > 0.1 && v[c] < 0.95 {
                            // Half a code of quantisation either side, through the inverse curve (1% for
                            // float rounding of values that sit exactly between two codes).
                            let bound = half_code_error(response, v[c]) / time;
                            assert!(
                                (e[c] - t[c]).abs() <= bound * 1.01 + 1e-6,
                                "{response:?} t={time}: {} vs {}",
                                e[c],
                                t[c]
                            );
                            checked += 1;
                        }
                    }
                }
            }
            assert!(checked > 500, "{checked}");
        }
    }

    #[test]
    fn noise_is_unbiased_and_scales_with_the_signal() {
        // Mid-grey through a linear-ish check: the average of many noisy exposures of a flat
        // field approaches the noiseless value, and shot noise grows with the signal.
        let flat = |l: f32| Image::filled(128, 128, [l, l, l, 1.0]);
        let noise = SensorNoise { full_well_electrons: 2000.0, read_noise: 0.002 };
        let stats = |l: f32| {
            let img = radiance_from_bracket(
                &expose(&flat(l), 1.0, CameraResponse::Srgb, noise, 9),
                1.0,
                CameraResponse::Srgb,
            );
            let v: Vec<f64> = img.pixels().iter().map(|p| p[0] as f64).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64;
            (mean, var.sqrt())
        };
        let (m_low, s_low) = stats(0.05);
        let (m_high, s_high) = stats(0.5);
        assert!((m_low - 0.05).abs() < 0.002 && (m_high - 0.5).abs() < 0.005, "{m_low} {m_high}");
        // σ² = L/2000 + 0.002²: √(0.5/2000) ≈ 0.0158 and √(0.05/2000 + 4e-6) ≈ 0.0054.
        assert!((s_high - 0.0158).abs() < 0.003 && (s_low - 0.0054).abs() < 0.0015, "{s_low} {s_high}");
    }
}
