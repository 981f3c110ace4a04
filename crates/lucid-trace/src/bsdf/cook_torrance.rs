//! Cook–Torrance / Torrance–Sparrow: `D·G·F / (4 cos θi cos θo)` with the Beckmann
//! distribution `D = exp(−tan²θh/m²)/(π m² cos⁴θh)`, the V-cavity masking
//! `G = min(1, 2(n·h)(n·wo)/(wo·h), 2(n·h)(n·wi)/(wo·h))` and the dielectric Fresnel term.
//! Half vectors are sampled from `D·cos θh` (`tan²θh = −m² ln(1−u₁)`).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use super::fresnel::fresnel_dielectric;
use super::lobe::Lobe;
use super::reflect;

/// The Beckmann microfacet lobe of Cook–Torrance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CookTorranceLobe {
    /// Colour of the specular reflection.
    pub ks: Vec3,
    /// RMS slope `m` of the Beckmann distribution.
    pub m: f32,
    /// Index of refraction for the Fresnel term.
    pub eta: f32,
}

impl CookTorranceLobe {
    /// Beckmann `D(h)`.
    pub fn beckmann(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let cos2 = h.z * h.z;
        let tan2 = (1.0 - cos2) / cos2;
        (-tan2 / (self.m * self.m)).exp() / (PI * self.m * self.m * cos2 * cos2)
    }
}

impl Lobe for CookTorranceLobe {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let oh = wo.dot(h);
        let g = (2.0 * h.z * wo.z / oh).min(2.0 * h.z * wi.z / oh).min(1.0);
        let f = fresnel_dielectric(oh, self.eta);
        self.ks * (self.beckmann(h) * g * f / (4.0 * wo.z * wi.z))
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let tan2 = -self.m * self.m * (1.0 - u.x).ln();
        let cos_t = 1.0 / (1.0 + tan2).sqrt();
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let h = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
        let wi = reflect(wo, h);
        (wi.z > 0.0).then_some(wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize_or_zero();
        let d = wo.dot(h);
        if d <= 0.0 { 0.0 } else { self.beckmann(h) * h.z / (4.0 * d) }
    }

    fn weight(&self) -> f32 {
        self.ks.max_element()
    }
}
