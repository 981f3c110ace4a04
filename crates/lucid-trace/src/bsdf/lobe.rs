//! Glossy lobes and the diffuse-plus-lobe mixture that the classic analytic BRDFs share:
//! each model supplies its lobe (value, sampling, density) and [`DiffuseAndLobe`] adds a
//! Lambertian term and samples one or the other in proportion to their albedos.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

use super::{Bsdf, BsdfSample, same_hemisphere, to_upper};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf, orthonormal_basis};

/// A reflection lobe in the local shading frame (both directions above the surface).
pub trait Lobe {
    /// Lobe value `f(wo, wi)` (no cosine).
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;
    /// A direction drawn from the lobe's sampling density, or `None` if it fell below the horizon.
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3>;
    /// Density of [`Lobe::sample`] in solid angle.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// Upper bound of the lobe's reflectance, used to pick it against the diffuse term.
    fn weight(&self) -> f32;
}

/// `kd/π + lobe`, sampled as a mixture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseAndLobe<L> {
    /// Diffuse albedo.
    pub diffuse: Vec3,
    /// The glossy lobe.
    pub lobe: L,
}

impl<L: Lobe> DiffuseAndLobe<L> {
    fn lobe_probability(&self) -> f32 {
        let (d, s) = (self.diffuse.max_element(), self.lobe.weight());
        if d + s <= 0.0 { 1.0 } else { s / (d + s) }
    }
}

impl<L: Lobe> Bsdf for DiffuseAndLobe<L> {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !same_hemisphere(wo, wi) {
            return Vec3::ZERO;
        }
        let (wo, wi) = to_upper(wo, wi);
        self.diffuse * FRAC_1_PI + self.lobe.eval(wo, wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let wo_up = if flip { -wo } else { wo };
        let mut wi = if uc < self.lobe_probability() { self.lobe.sample(wo_up, u)? } else { cosine_hemisphere(u) };
        if wi.z <= 0.0 {
            return None;
        }
        if flip {
            wi = -wi;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.eval(wo, wi), pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere(wo, wi) {
            return 0.0;
        }
        let (wo, wi) = to_upper(wo, wi);
        let p = self.lobe_probability();
        p * self.lobe.pdf(wo, wi) + (1.0 - p) * cosine_hemisphere_pdf(wi.z)
    }
}

/// A direction around unit `axis` with density `(n+1)/2π · cos^n` of the angle to it.
pub fn sample_cosine_power(axis: Vec3, n: f32, u: Vec2) -> Vec3 {
    let cos = (1.0 - u.x).powf(1.0 / (n + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let (t, b) = orthonormal_basis(axis);
    (sin * phi.cos()) * t + (sin * phi.sin()) * b + cos * axis
}

/// Density of [`sample_cosine_power`].
pub fn cosine_power_pdf(axis: Vec3, n: f32, w: Vec3) -> f32 {
    let c = axis.dot(w);
    if c <= 0.0 { 0.0 } else { (n + 1.0) / (2.0 * PI) * c.powf(n) }
}
