//! The modified (energy-conserving) Phong BRDF of Lafortune and Willems (1994):
//! `kd/π + ks·(n+2)/2π·cos^n α`, α the angle between `wi` and the mirror direction of `wo`.
//! With `kd + ks ≤ 1` it never reflects more than it receives.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use super::lobe::{Lobe, cosine_power_pdf, sample_cosine_power};
use super::reflect_z;

/// The specular lobe of the modified Phong model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongLobe {
    /// Specular albedo.
    pub ks: Vec3,
    /// Exponent.
    pub exponent: f32,
}

impl Lobe for PhongLobe {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let c = reflect_z(wo).dot(wi);
        if c <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.ks * ((self.exponent + 2.0) / (2.0 * PI) * c.powf(self.exponent))
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let wi = sample_cosine_power(reflect_z(wo), self.exponent, u);
        (wi.z > 0.0).then_some(wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_power_pdf(reflect_z(wo), self.exponent, wi)
    }

    fn weight(&self) -> f32 {
        self.ks.max_element()
    }
}
