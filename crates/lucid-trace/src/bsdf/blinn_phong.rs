//! Blinn–Phong: `kd/π + ks·c(n)·(n·h)^n`, normalised so that its albedo at normal incidence
//! is exactly `ks`. The usual real-time factor `(n+8)/8π` overshoots by up to 7% (measured);
//! here `c(n)` is the exact inverse of `∫(n·h)^n cos θi dωi` at normal incidence, which with
//! `c = cos(θi/2)` is `8π[2c^(n+4)/(n+4) − c^(n+2)/(n+2)]` from `1/√2` to 1. The albedo falls
//! towards grazing angles, so `kd + ks ≤ 1` conserves energy everywhere.

use glam::{Vec2, Vec3};

use super::lobe::{Lobe, cosine_power_pdf, sample_cosine_power};
use super::reflect;

/// The specular lobe of Blinn–Phong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnPhongLobe {
    /// Specular albedo at normal incidence.
    pub ks: Vec3,
    /// Exponent.
    pub exponent: f32,
    normalisation: f32,
}

impl BlinnPhongLobe {
    /// A lobe with albedo `ks` at normal incidence and exponent `n`.
    pub fn new(ks: Vec3, n: f32) -> Self {
        let n64 = n as f64;
        let antiderivative = |c: f64| 2.0 * c.powf(n64 + 4.0) / (n64 + 4.0) - c.powf(n64 + 2.0) / (n64 + 2.0);
        let integral =
            8.0 * std::f64::consts::PI * (antiderivative(1.0) - antiderivative(std::f64::consts::FRAC_1_SQRT_2));
        Self { ks, exponent: n, normalisation: (1.0 / integral) as f32 }
    }
}

impl Lobe for BlinnPhongLobe {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        self.ks * (self.normalisation * h.z.max(0.0).powf(self.exponent))
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        // Half vectors from (n+1)/2π·cos^n θh, reflected about.
        let h = sample_cosine_power(Vec3::Z, self.exponent, u);
        let wi = reflect(wo, h);
        (wi.z > 0.0).then_some(wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize_or_zero();
        let d = wo.dot(h);
        if d <= 0.0 { 0.0 } else { cosine_power_pdf(Vec3::Z, self.exponent, h) / (4.0 * d) }
    }

    fn weight(&self) -> f32 {
        self.ks.max_element()
    }
}
