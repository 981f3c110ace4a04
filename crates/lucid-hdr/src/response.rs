//! The camera response: for each 8-bit code `z`, the log exposure `g(z) = ln(E·Δt)` that
//! produced it, per channel.
//!
//! Recovered from an [`ExposureStack`] by Debevec and Malik's least squares (SIGGRAPH 1997)
//! or by Robertson et al.'s iteration (1999), or given in closed form ([`ResponseCurve::srgb`])
//! when the camera is known. A recovered curve is known only up to scale (one exposure unit
//! is fixed by `g(128) = 0`).

use nalgebra::{DMatrix, DVector};

use crate::HdrError;
use crate::stack::{CODES, ExposureStack, hat_weight};

/// `g(z)` per channel: the natural log of the exposure that gives code `z`.
#[derive(Clone, Debug, PartialEq)]
pub struct ResponseCurve {
    /// `log_exposure[c][z]`.
    pub log_exposure: [[f32; CODES]; 3],
}

/// Settings of the Debevec–Malik solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DebevecSettings {
    /// Weight λ of the smoothness term `Σ (w(z) g''(z))²` against the data term.
    pub smoothness: f32,
    /// Pixels sampled per channel (the system has `samples + 256` unknowns).
    pub samples: usize,
}

impl Default for DebevecSettings {
    fn default() -> Self {
        // λ = 50 is a common choice for 8-bit data (as in OpenCV's calibrateDebevec); 200
        // samples over-determine the 256 codes several times for 3+ exposures.
        Self { smoothness: 50.0, samples: 200 }
    }
}

/// Settings of Robertson's iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobertsonSettings {
    /// Iterations (each re-estimates the radiances, then the curve).
    pub iterations: usize,
    /// Pixels sampled per channel (0: every pixel).
    pub samples: usize,
}

impl Default for RobertsonSettings {
    fn default() -> Self {
        Self { iterations: 30, samples: 5000 }
    }
}

impl ResponseCurve {
    /// The sRGB transfer function with exposure 1 at code 255: the curve of a camera that
    /// stores linear sensor values through the standard encoding.
    pub fn srgb() -> Self {
        Self::from_inverse(lucid_image::color::srgb_decode)
    }

    /// The curve of a known inverse response `f⁻¹: [0,1] → [0,1]` (code `z` ↦ exposure
    /// `f⁻¹(z/255)`); code 0 takes the exposure of half a code, so that `ln` stays finite.
    pub fn from_inverse(inverse: impl Fn(f32) -> f32) -> Self {
        let mut g = [0.0f32; CODES];
        for (z, v) in g.iter_mut().enumerate() {
            let y = (z as f32).max(0.5) / 255.0;
            *v = inverse(y).max(1e-8).ln();
        }
        Self { log_exposure: [g; 3] }
    }

    /// Exposure (`E·Δt`, in the curve's units) of code `z` in channel `c`.
    pub fn exposure(&self, c: usize, z: u8) -> f32 {
        self.log_exposure[c][z as usize].exp()
    }

    /// The curve shifted so that `g(128) = 0` in every channel (the scale a recovered curve
    /// is known up to), for comparing curves.
    pub fn normalised(&self) -> Self {
        let mut out = self.clone();
        for g in &mut out.log_exposure {
            let offset = g[128];
            for v in g.iter_mut() {
                *v -= offset;
            }
        }
        out
    }

    /// CSV text: `code,red,green,blue` with `g(z)` per channel.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("code,log_exposure_red,log_exposure_green,log_exposure_blue\n");
        for z in 0..CODES {
            let g = |c: usize| self.log_exposure[c][z];
            s.push_str(&format!("{z},{},{},{}\n", g(0), g(1), g(2)));
        }
        s
    }
}

/// Most pixels a Debevec–Malik recovery samples per channel: its normal equations are
/// `(256 + N)²` doubles per channel, 150 MB at this bound.
pub const MAX_DEBEVEC_SAMPLES: usize = 4096;

/// Response recovery compares the codes one radiance gives at different exposures; with
/// every exposure alike there is nothing to compare and the solution is arbitrary.
fn require_distinct_times(stack: &ExposureStack) -> Result<(), HdrError> {
    let t = stack.times();
    if t.iter().all(|&x| x == t[0]) {
        return Err(HdrError::Stack(format!(
            "every frame has exposure time {}: response recovery needs exposures that differ (or use --method mertens, which needs no times)",
            t[0]
        )));
    }
    Ok(())
}

/// Debevec and Malik's recovery: per channel, the least-squares solution of
/// `w(Z_ij)·(g(Z_ij) − ln E_i) = w(Z_ij)·ln Δt_j` over sampled pixels `i` and frames `j`,
/// plus `λ·w(z)·g''(z) = 0` and `g(128) = 0`, solved through its normal equations by Cholesky
/// (SVD if they are singular).
pub fn debevec_malik(stack: &ExposureStack, settings: DebevecSettings) -> Result<ResponseCurve, HdrError> {
    if stack.len() < 2 {
        return Err(HdrError::Stack("response recovery needs at least two exposures".into()));
    }
    if !(settings.smoothness.is_finite() && settings.smoothness >= 0.0) {
        return Err(HdrError::Parameter(format!("smoothness λ must be finite and ≥ 0, got {}", settings.smoothness)));
    }
    require_distinct_times(stack)?;
    // Debevec and Malik's condition: N·(P − 1) ≥ Z_max − Z_min observations fix the curve's
    // 256 values; with fewer, the smoothness term alone extrapolates it to overflow.
    let needed = 255usize.div_ceil(stack.len() - 1);
    if settings.samples < needed || settings.samples > MAX_DEBEVEC_SAMPLES {
        return Err(HdrError::Parameter(format!(
            "{} samples per channel with {} exposures: need {needed}..={MAX_DEBEVEC_SAMPLES} (N·(P−1) ≥ 255 observations fix the 256 codes; the normal equations grow with N²)",
            settings.samples,
            stack.len()
        )));
    }
    let mut curve = ResponseCurve { log_exposure: [[0.0; CODES]; 3] };
    let channels: Vec<Result<[f32; CODES], HdrError>> = {
        use rayon::prelude::*;
        (0..3).into_par_iter().map(|c| debevec_channel(stack, c, settings)).collect()
    };
    for (c, g) in channels.into_iter().enumerate() {
        curve.log_exposure[c] = g?;
    }
    Ok(curve)
}

fn debevec_channel(stack: &ExposureStack, c: usize, settings: DebevecSettings) -> Result<[f32; CODES], HdrError> {
    // Pixels clipped or black in every frame say nothing (and would leave their unknown
    // unconstrained, the normal equations singular).
    let pixels: Vec<usize> = stack
        .sample_pixels(c, settings.samples.max(2))
        .into_iter()
        .filter(|&px| (0..stack.len()).any(|j| hat_weight(stack.code(j, px, c)) > 0.0))
        .collect();
    let (n, p) = (pixels.len(), stack.len());
    let cols = CODES + n;
    // The system's rows, each with at most three non-zeros: (entries, right-hand side).
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::with_capacity(n * p + CODES);
    for (i, &px) in pixels.iter().enumerate() {
        for j in 0..p {
            let z = stack.code(j, px, c);
            let w = hat_weight(z) as f64;
            rows.push((vec![(z as usize, w), (CODES + i, -w)], w * (stack.times()[j] as f64).ln()));
        }
    }
    // Fix the scale: g(128) = 0.
    rows.push((vec![(128, 1.0)], 0.0));
    let lambda = settings.smoothness as f64;
    for z in 1..CODES - 1 {
        let w = lambda * hat_weight(z as u8) as f64;
        rows.push((vec![(z - 1, w), (z, -2.0 * w), (z + 1, w)], 0.0));
    }
    // The normal equations are small (256 + samples unknowns) and, with the smoothness rows
    // and the fixed g(128), positive definite: assembled from the sparse rows and solved by
    // Cholesky in milliseconds, where an SVD of the tall dense system takes a third of a
    // second per channel. SVD remains the fallback if they are singular.
    let mut ata = DMatrix::<f64>::zeros(cols, cols);
    let mut atb = DVector::<f64>::zeros(cols);
    for (entries, rhs) in &rows {
        for &(ka, va) in entries {
            atb[ka] += va * rhs;
            for &(kb, vb) in entries {
                ata[(ka, kb)] += va * vb;
            }
        }
    }
    let x = match ata.cholesky() {
        Some(chol) => chol.solve(&atb),
        None => {
            let mut a = DMatrix::<f64>::zeros(rows.len(), cols);
            let mut b = DVector::<f64>::zeros(rows.len());
            for (r, (entries, rhs)) in rows.iter().enumerate() {
                for &(k, v) in entries {
                    a[(r, k)] = v;
                }
                b[r] = *rhs;
            }
            a.svd(true, true).solve(&b, 1e-10).map_err(|e| HdrError::Solve(e.to_string()))?
        }
    };
    let mut g = [0.0f32; CODES];
    for (z, v) in g.iter_mut().enumerate() {
        *v = x[z] as f32;
    }
    Ok(g)
}

/// Robertson, Borman and Stevenson's recovery: alternately the maximum-likelihood radiance
/// of every sampled pixel given the curve, `E_i = Σ_j w t_j I(Z_ij) / Σ_j w t_j²`, and the
/// curve given the radiances, `I(m) = mean of t_j E_i over the observations with code m`,
/// normalised to `I(128) = 1`; the weight is a Gaussian bump over the codes. Codes never
/// observed are interpolated from their neighbours. It starts from the sRGB curve and, having
/// no smoothness term, cannot tell the true curve from one distorted periodically in log
/// exposure when the exposure ratios are all powers of one step: Debevec–Malik, whose
/// smoothness term settles that, is the default.
pub fn robertson(stack: &ExposureStack, settings: RobertsonSettings) -> Result<ResponseCurve, HdrError> {
    if stack.len() < 2 {
        return Err(HdrError::Stack("response recovery needs at least two exposures".into()));
    }
    require_distinct_times(stack)?;
    let mut curve = ResponseCurve { log_exposure: [[0.0; CODES]; 3] };
    for c in 0..3 {
        curve.log_exposure[c] = robertson_channel(stack, c, settings);
    }
    Ok(curve)
}

fn robertson_weight(z: u8) -> f64 {
    let d = (z as f64 - 127.5) / 127.5;
    (-4.0 * d * d).exp() - (-4.0f64).exp()
}

fn robertson_channel(stack: &ExposureStack, c: usize, settings: RobertsonSettings) -> [f32; CODES] {
    let all = stack.width() * stack.height();
    let pixels = if settings.samples == 0 || settings.samples >= all {
        (0..all).collect()
    } else {
        stack.sample_pixels(c, settings.samples)
    };
    let times: Vec<f64> = stack.times().iter().map(|&t| t as f64).collect();
    // Start from the sRGB response. With exposure times in a geometric series (the usual
    // ±n EV brackets) the data fix the curve only up to a distortion periodic in log
    // exposure with the series' period, which the iteration never removes; it keeps the part
    // of the starting curve's error that is periodic, and sRGB, which most cameras' curves
    // resemble, leaves much less of it than a linear start.
    let start = ResponseCurve::srgb();
    let mut inv: Vec<f64> = (0..CODES).map(|z| (start.log_exposure[c][z] as f64).exp()).collect();
    let mut radiance = vec![0.0f64; pixels.len()];
    for _ in 0..settings.iterations.max(1) {
        for (e, &px) in radiance.iter_mut().zip(&pixels) {
            let (mut num, mut den) = (0.0, 0.0);
            for (j, &t) in times.iter().enumerate() {
                let z = stack.code(j, px, c);
                let w = robertson_weight(z);
                num += w * t * inv[z as usize];
                den += w * t * t;
            }
            *e = if den > 0.0 { num / den } else { 0.0 };
        }
        let mut sum = [0.0f64; CODES];
        let mut count = [0usize; CODES];
        for (&e, &px) in radiance.iter().zip(&pixels) {
            for (j, &t) in times.iter().enumerate() {
                let z = stack.code(j, px, c) as usize;
                sum[z] += t * e;
                count[z] += 1;
            }
        }
        for z in 0..CODES {
            if count[z] > 0 {
                inv[z] = sum[z] / count[z] as f64;
            }
        }
        fill_unobserved(&mut inv, &count);
        let scale = inv[128];
        if scale > 0.0 {
            for v in &mut inv {
                *v /= scale;
            }
        }
    }
    let mut g = [0.0f32; CODES];
    for z in 0..CODES {
        g[z] = inv[z].max(1e-12).ln() as f32;
    }
    // The inverse response is monotone; noise in rarely observed codes can break that.
    for z in 1..CODES {
        g[z] = g[z].max(g[z - 1]);
    }
    g
}

/// Linear interpolation of `values` over the codes that `count` never saw.
fn fill_unobserved(values: &mut [f64], count: &[usize]) {
    let seen: Vec<usize> = (0..values.len()).filter(|&z| count[z] > 0).collect();
    if seen.is_empty() {
        return;
    }
    for z in 0..values.len() {
        if count[z] > 0 {
            continue;
        }
        let after = seen.partition_point(|&s| s < z);
        values[z] = match (after.checked_sub(1).map(|k| seen[k]), seen.get(after)) {
            (Some(lo), Some(&hi)) => {
                let t = (z - lo) as f64 / (hi - lo) as f64;
                values[lo] * (1.0 - t) + values[hi] * t
            }
            (Some(lo), None) => values[lo] * (z as f64 / lo.max(1) as f64),
            (None, Some(&hi)) => values[hi] * (z as f64).max(0.5) / hi as f64,
            (None, None) => values[z],
        };
    }
}
