//! Global operators: one curve for the whole image.

use rayon::prelude::*;

use crate::blur::Plane;

fn map(lum: &Plane, f: impl Fn(f32) -> f32 + Sync) -> Plane {
    Plane { width: lum.width, height: lum.height, data: lum.data.par_iter().map(|&l| f(l)).collect() }
}

/// `exp(mean(ln(δ + L)))`: the log-average ("key") luminance, δ = 1e-6 keeping black
/// pixels finite.
pub fn log_average(lum: &Plane) -> f32 {
    if lum.data.is_empty() {
        return 0.0;
    }
    let sum: f64 = lum.data.par_iter().map(|&l| (1e-6 + l.max(0.0) as f64).ln()).sum();
    (sum / lum.data.len() as f64).exp() as f32
}

/// `L·2^exposure`, clipped to `[0,1]`.
pub fn linear(lum: &Plane, exposure: f32) -> Plane {
    let k = exposure.exp2();
    map(lum, |l| (l * k).clamp(0.0, 1.0))
}

/// Reinhard et al.'s global operator with burn-out: `L_m = key·L/L̄`,
/// `L_d = L_m(1 + L_m/L_white²)/(1 + L_m)`.
pub fn reinhard(lum: &Plane, key: f32, white: Option<f32>) -> Plane {
    let scale = key / log_average(lum).max(1e-12);
    let white = white.unwrap_or_else(|| lum.data.iter().fold(0.0f32, |m, &l| m.max(l)) * scale).max(1e-12);
    let w2 = white * white;
    map(lum, |l| {
        let lm = l * scale;
        (lm * (1.0 + lm / w2) / (1.0 + lm)).clamp(0.0, 1.0)
    })
}

/// Drago et al.'s adaptive logarithmic mapping (display maximum 100 cd/m², so the curve's
/// `L_dmax·0.01` factor is 1), on luminance scaled by `2^exposure / L̄`.
pub fn drago(lum: &Plane, bias: f32, exposure: f32) -> Plane {
    let scale = exposure.exp2() / log_average(lum).max(1e-12);
    let lmax = (lum.data.iter().fold(0.0f32, |m, &l| m.max(l)) * scale).max(1e-6);
    let exponent = bias.ln() / 0.5f32.ln();
    let norm = 1.0 / (1.0 + lmax).log10();
    map(lum, |l| {
        let lw = l * scale;
        (norm * (1.0 + lw).ln() / (2.0 + 8.0 * (lw / lmax).powf(exponent)).ln()).clamp(0.0, 1.0)
    })
}

/// Narkowicz's ACES filmic fit on `L·2^exposure`.
pub fn aces(lum: &Plane, exposure: f32) -> Plane {
    let k = exposure.exp2();
    map(lum, |l| lucid_image::tonemap::ToneCurve::Aces.apply(l * k))
}
