//! Importance sampling shared by the data-driven BRDFs (measured tables, the neural BRDF):
//! a quarter of the directions from a cosine lobe, the rest reflected about half vectors drawn
//! from a distribution over θh tabulated in MERL's 90 square-root-spaced bands, each band
//! weighted by the BRDF's mean luminance there.

use std::f32::consts::{FRAC_PI_2, PI};

use glam::{Vec2, Vec3};

use super::reflect;
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Bands in θh (MERL's resolution).
pub const BANDS: usize = 90;
/// Share of samples drawn from the cosine lobe.
const COSINE_SHARE: f32 = 0.25;

/// θh at the lower edge of band `k` (square-root scale).
pub(crate) fn band_edge(k: usize) -> f32 {
    let x = k as f32 / BANDS as f32;
    x * x * FRAC_PI_2
}

/// The band holding `theta_h`.
pub(crate) fn band_of(theta_h: f32) -> usize {
    (((theta_h.max(0.0) / FRAC_PI_2).sqrt() * BANDS as f32) as usize).min(BANDS - 1)
}

/// A tabulated distribution of half vectors, uniform in solid angle within each θh band.
#[derive(Clone, Debug, PartialEq)]
pub struct HalfVectorDistribution {
    /// Cumulative probabilities of the bands (from 0, length BANDS + 1).
    cdf: Vec<f32>,
    /// Density of half vectors per steradian in each band.
    density: Vec<f32>,
}

impl HalfVectorDistribution {
    /// From each band's weight (a mean BRDF value), floored at 10⁻³ of the largest so that
    /// every band can be sampled.
    pub fn from_band_weights(weights: &[f32]) -> Self {
        assert_eq!(weights.len(), BANDS, "one weight per θh band");
        let floor = 1e-3 * weights.iter().cloned().fold(0.0, f32::max).max(1e-6);
        let weights: Vec<f32> = weights.iter().map(|w| w.max(floor)).collect();
        let solid_angle = |k: usize| 2.0 * std::f64::consts::PI * (band_edge(k).cos() - band_edge(k + 1).cos()) as f64;
        let total: f64 = (0..BANDS).map(|k| weights[k] as f64 * solid_angle(k)).sum();
        let mut cdf = vec![0.0f32; BANDS + 1];
        let mut acc = 0.0f64;
        for k in 0..BANDS {
            acc += weights[k] as f64 * solid_angle(k) / total;
            cdf[k + 1] = acc as f32;
        }
        cdf[BANDS] = 1.0;
        let density = weights.iter().map(|&w| (w as f64 / total) as f32).collect();
        Self { cdf, density }
    }

    /// Density per steradian of a half vector at `theta_h`.
    pub fn pdf(&self, theta_h: f32) -> f32 {
        self.density[band_of(theta_h)]
    }

    /// A half vector.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let k = self.cdf.partition_point(|&c| c <= u.x).clamp(1, BANDS) - 1;
        let (lo, hi) = (self.cdf[k], self.cdf[k + 1]);
        let t = if hi > lo { (u.x - lo) / (hi - lo) } else { 0.5 };
        let (c0, c1) = (band_edge(k).cos(), band_edge(k + 1).cos());
        let cos = c0 + (c1 - c0) * t.clamp(0.0, 1.0);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
    }

    /// A direction `wi` for `wo` (both above the surface): cosine lobe or reflected half vector.
    pub fn sample_direction(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<Vec3> {
        let wi = if uc < COSINE_SHARE { cosine_hemisphere(u) } else { reflect(wo, self.sample(u)) };
        (wi.z > 0.0).then_some(wi)
    }

    /// Density of [`HalfVectorDistribution::sample_direction`] (both above the surface).
    pub fn direction_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return COSINE_SHARE * cosine_hemisphere_pdf(wi.z);
        }
        let half = self.pdf(h.z.clamp(-1.0, 1.0).acos()) / (4.0 * wo.dot(h).abs());
        (1.0 - COSINE_SHARE) * half + COSINE_SHARE * cosine_hemisphere_pdf(wi.z)
    }
}

/// `∫ f(n, wi) cos θi dωi`: hemispherical reflectance at normal incidence (stratified cosine
/// directions), for the albedo buffer.
pub fn normal_incidence_albedo(f: impl Fn(Vec3, Vec3) -> Vec3) -> Vec3 {
    const N: usize = 32;
    let mut sum = Vec3::ZERO;
    for a in 0..N {
        for b in 0..N {
            let wi = cosine_hemisphere(Vec2::new((a as f32 + 0.5) / N as f32, (b as f32 + 0.5) / N as f32));
            // Cosine-distributed: f cos / (cos/π) = π f.
            sum += f(Vec3::Z, wi) * PI;
        }
    }
    sum / (N * N) as f32
}
