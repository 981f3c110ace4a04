//! Local operators: the curve adapts to each pixel's surroundings, keeping local contrast
//! that a global curve would flatten.

use rayon::prelude::*;

use super::bilateral::bilateral_grid;
use super::global::log_average;
use crate::blur::{Plane, gaussian_blur};

/// Scales of the centre-surround test: `1.6^i` pixels, `i = 0..8` (Reinhard et al. 2002).
const SCALES: usize = 8;
/// Centre Gaussian width α₁ = 1/(2√2); the surround is 1.6 times wider, so the surround of
/// scale `i` is the centre of scale `i + 1`.
const ALPHA: f32 = 0.353_553_38;

/// Reinhard et al.'s dodge-and-burn: for each pixel the largest scale `s` at which the
/// centre and surround averages of the scaled luminance agree,
/// `|V₁ − V₂| / (2^φ·key/s² + V₁) < ε`, then `L_d = L_m / (1 + V₁(s))`.
pub fn photographic(lum: &Plane, key: f32, sharpening: f32, threshold: f32) -> Plane {
    let scale = key / log_average(lum).max(1e-12);
    let lm = Plane { width: lum.width, height: lum.height, data: lum.data.iter().map(|l| l * scale).collect() };
    // The Gaussian of scale s is exp(−r²/(α s)²): σ = α s / √2.
    let centres: Vec<Plane> = (0..=SCALES)
        .into_par_iter()
        .map(|i| gaussian_blur(&lm, ALPHA * 1.6f32.powi(i as i32) / std::f32::consts::SQRT_2))
        .collect();
    let numerator = sharpening.exp2() * key;
    let data = (0..lm.data.len())
        .into_par_iter()
        .map(|p| {
            let mut chosen = centres[0].data[p];
            for i in 0..SCALES {
                let s = 1.6f32.powi(i as i32);
                let (v1, v2) = (centres[i].data[p], centres[i + 1].data[p]);
                let v = (v1 - v2) / (numerator / (s * s) + v1);
                if v.abs() >= threshold {
                    break;
                }
                chosen = v1;
            }
            (lm.data[p] / (1.0 + chosen)).clamp(0.0, 1.0)
        })
        .collect();
    Plane { width: lum.width, height: lum.height, data }
}

/// Durand and Dorsey's fast bilateral operator: `log₁₀ L = base + detail` with the base a
/// bilateral filter of the log luminance; the base is scaled to span `log₁₀ contrast`
/// (never expanded), the detail is kept, and the result is scaled so that its 99.5th
/// percentile is display white (the brightest details on the brightest base would
/// otherwise clip).
pub fn durand_dorsey(lum: &Plane, contrast: f32, spatial_sigma: f32, range_sigma: f32) -> Plane {
    let log = Plane {
        width: lum.width,
        height: lum.height,
        data: lum.data.par_iter().map(|&l| l.max(1e-6).log10()).collect(),
    };
    let sigma_s = (spatial_sigma * lum.width.max(lum.height) as f32).max(1.0);
    let base = bilateral_grid(&log, sigma_s, range_sigma);
    let (lo, hi) = base.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let range = (hi - lo).max(1e-6);
    let gamma = (contrast.log10() / range).min(1.0);
    let mut data: Vec<f32> =
        log.data.par_iter().zip(&base.data).map(|(&l, &b)| 10f32.powf(gamma * (b - hi) + (l - b))).collect();
    let mut sorted = data.clone();
    let k = ((sorted.len() as f64 * 0.995) as usize).min(sorted.len() - 1);
    let white = *sorted.select_nth_unstable_by(k, f32::total_cmp).1;
    let scale = 1.0 / white.max(1e-12);
    data.par_iter_mut().for_each(|v| *v = (*v * scale).clamp(0.0, 1.0));
    Plane { width: lum.width, height: lum.height, data }
}
