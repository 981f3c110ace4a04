//! A two-layer "plastic": a diffuse base under a smooth dielectric coating. Light either
//! reflects specularly off the coating (Fresnel `F(θo)`) or enters, scatters diffusely in the
//! base with internal reflections at the coating, and leaves through it.
//!
//! The diffuse lobe is `(1−F(θi))(1−F(θo))·ρ / (π·η²·(1 − ρ·F̄ᵢ))`, where `F̄ᵢ` is the
//! hemispherical average of the internal Fresnel reflectance: the geometric series of light
//! bouncing between base and coating (the model Mitsuba calls `plastic`).

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::fresnel::{average_fresnel_dielectric, fresnel_dielectric};
use super::{Bsdf, BsdfSample, reflect_z, same_hemisphere};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Diffuse base under a smooth dielectric coating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothPlastic {
    /// Base albedo.
    pub albedo: Vec3,
    /// Index of the coating (e.g. 1.5).
    pub eta: f32,
    /// `F̄ᵢ`: average internal reflectance of the coating (from [`SmoothPlastic::new`]).
    internal_reflectance: f32,
}

impl SmoothPlastic {
    /// A plastic with base `albedo` and coating index `eta`.
    pub fn new(albedo: Vec3, eta: f32) -> Self {
        // Internal average from the external one: 1 − F̄ᵢ = (1 − F̄ₑ)/η².
        let internal = 1.0 - (1.0 - average_fresnel_dielectric(eta)) / (eta * eta);
        Self { albedo, eta, internal_reflectance: internal }
    }

    fn diffuse(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let fo = fresnel_dielectric(wo.z.abs(), self.eta);
        let fi = fresnel_dielectric(wi.z.abs(), self.eta);
        let base = self.albedo / (Vec3::ONE - self.albedo * self.internal_reflectance);
        base * ((1.0 - fo) * (1.0 - fi) * FRAC_1_PI / (self.eta * self.eta))
    }

    /// Probability of sampling the specular lobe from `wo`: its share of the energy.
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let f = fresnel_dielectric(wo.z.abs(), self.eta);
        let diffuse_weight = (1.0 - f) * self.albedo.max_element();
        if f + diffuse_weight <= 0.0 { 1.0 } else { f / (f + diffuse_weight) }
    }
}

impl Bsdf for SmoothPlastic {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if same_hemisphere(wo, wi) { self.diffuse(wo, wi) } else { Vec3::ZERO }
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let ps = self.specular_probability(wo);
        if uc < ps {
            let wi = reflect_z(wo);
            let f = fresnel_dielectric(wo.z.abs(), self.eta);
            return Some(BsdfSample {
                wi,
                f: Vec3::splat(f / wi.z.abs()),
                pdf: ps,
                specular: true,
                transmission: false,
            });
        }
        let mut wi = cosine_hemisphere(u);
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let pdf = (1.0 - ps) * cosine_hemisphere_pdf(wi.z.abs());
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.diffuse(wo, wi), pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere(wo, wi) {
            return 0.0;
        }
        (1.0 - self.specular_probability(wo)) * cosine_hemisphere_pdf(wi.z.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;

    #[test]
    fn white_plastic_reflects_at_most_everything_and_sampling_is_consistent() {
        let p = SmoothPlastic::new(Vec3::ONE, 1.5);
        for wo in outgoing_directions() {
            let total = albedo_by_sampling(&p, wo, 400_000).x;
            assert!(total <= 1.0 + 0.01, "cos {}: {total}", wo.z);
            assert!(total > 0.8, "cos {}: {total}", wo.z);
            // The diffuse part alone: importance sampling and uniform sampling agree.
            let diffuse_uniform = albedo_by_uniform(&p, wo, 400_000).x;
            let specular = fresnel_dielectric(wo.z, 1.5);
            assert!((total - specular - diffuse_uniform).abs() < 0.01, "{total} vs {specular} + {diffuse_uniform}");
            sample_matches_eval(&p, wo, 2000);
        }
        reciprocal(&p, 1000);
    }
}
