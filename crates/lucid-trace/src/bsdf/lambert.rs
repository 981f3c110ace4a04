//! The Lambertian (ideal diffuse) BRDF `ρ/π`.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::{Bsdf, BsdfSample, same_hemisphere};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Ideal diffuse reflection with albedo `ρ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambertian {
    /// Diffuse reflectance in `[0,1]` per channel.
    pub albedo: Vec3,
}

impl Bsdf for Lambertian {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if same_hemisphere(wo, wi) { self.albedo * FRAC_1_PI } else { Vec3::ZERO }
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        let mut wi = cosine_hemisphere(u);
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let pdf = cosine_hemisphere_pdf(wi.z.abs());
        (pdf > 0.0).then_some(BsdfSample { wi, f: self.albedo * FRAC_1_PI, pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if same_hemisphere(wo, wi) { cosine_hemisphere_pdf(wi.z.abs()) } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;

    #[test]
    fn white_lambertian_reflects_everything() {
        let white = Lambertian { albedo: Vec3::ONE };
        for wo in outgoing_directions() {
            // Cosine sampling makes f·cos/pdf = ρ exactly per sample.
            assert!((albedo_by_sampling(&white, wo, 1000) - Vec3::ONE).abs().max_element() < 1e-5);
            assert!((albedo_by_uniform(&white, wo, 400_000) - Vec3::ONE).abs().max_element() < 0.01);
            assert!((pdf_integral(&white, wo, 400_000) - 1.0).abs() < 0.01);
            sample_matches_eval(&white, wo, 1000);
        }
        reciprocal(&white, 1000);
    }
}
