//! A smooth dielectric interface (glass, water): Fresnel-weighted mirror reflection and
//! Snell refraction, both Dirac deltas.

use glam::{Vec2, Vec3};

use super::fresnel::fresnel_dielectric;
use super::{Bsdf, BsdfSample, reflect_z};

/// Smooth dielectric with relative index `eta` (inside over outside, e.g. 1.5 for glass in air).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothDielectric {
    /// Relative index of refraction.
    pub eta: f32,
    /// Tint of transmitted light (1 for clear glass).
    pub transmittance: Vec3,
}

impl Bsdf for SmoothDielectric {
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    fn sample(&self, wo: Vec3, _u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = fresnel_dielectric(wo.z, self.eta);
        if uc < r {
            let wi = reflect_z(wo);
            return Some(BsdfSample {
                wi,
                f: Vec3::splat(r / wi.z.abs()),
                pdf: r,
                specular: true,
                transmission: false,
            });
        }
        // Refraction: η is the ratio across the side wo is on.
        let (eta, cos_o) = if wo.z > 0.0 { (self.eta, wo.z) } else { (1.0 / self.eta, -wo.z) };
        let sin2_t = (1.0 - cos_o * cos_o).max(0.0) / (eta * eta);
        if sin2_t >= 1.0 {
            return None; // total internal reflection, handled by r = 1 above
        }
        let cos_t = (1.0 - sin2_t).sqrt();
        let wi = Vec3::new(-wo.x / eta, -wo.y / eta, if wo.z > 0.0 { -cos_t } else { cos_t });
        // Radiance is scaled by 1/η² when crossing into a denser medium.
        let t = (1.0 - r) / (eta * eta);
        Some(BsdfSample { wi, f: self.transmittance * t / cos_t, pdf: 1.0 - r, specular: true, transmission: true })
    }

    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    fn is_specular(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refraction_obeys_snell_and_energy_splits_by_fresnel() {
        let glass = SmoothDielectric { eta: 1.5, transmittance: Vec3::ONE };
        let theta: f32 = 0.6;
        let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
        let r = fresnel_dielectric(wo.z, 1.5);
        let refl = glass.sample(wo, Vec2::ZERO, 0.0).unwrap();
        assert!(!refl.transmission && (refl.wi - reflect_z(wo)).length() < 1e-6);
        let refr = glass.sample(wo, Vec2::ZERO, 0.999).unwrap();
        assert!(refr.transmission && refr.wi.z < 0.0);
        // sin θt = sin θi / η, and the refracted ray leaves on the far side of the normal.
        let sin_t = (refr.wi.x * refr.wi.x + refr.wi.y * refr.wi.y).sqrt();
        assert!((sin_t - theta.sin() / 1.5).abs() < 1e-6 && refr.wi.x < 0.0);
        // Weights: reflection R, transmission (1−R)/η² (radiance compression).
        assert!((refl.f.x * refl.wi.z.abs() / refl.pdf - 1.0).abs() < 1e-6);
        let t_weight = refr.f.x * refr.wi.z.abs() / refr.pdf;
        assert!((t_weight - 1.0 / 2.25).abs() < 1e-5);
        assert!((refl.pdf + refr.pdf - 1.0).abs() < 1e-6 && (refl.pdf - r).abs() < 1e-6);
        // From inside, beyond the critical angle, everything reflects.
        let inside = Vec3::new(0.9, 0.0, -(1.0f32 - 0.81).sqrt());
        let s = glass.sample(inside, Vec2::ZERO, 0.999).unwrap();
        assert!(!s.transmission && s.wi.z < 0.0);
    }

    #[test]
    fn a_round_trip_through_the_interface_restores_radiance() {
        // In then out along the reversed path (the viewer inside looks along into.wi): the
        // 1/η² and η² factors cancel and the ray leaves parallel to where it came from.
        let glass = SmoothDielectric { eta: 1.5, transmittance: Vec3::ONE };
        let wo = Vec3::new(0.3, 0.4, (1.0f32 - 0.25).sqrt());
        let into = glass.sample(wo, Vec2::ZERO, 0.9999).unwrap();
        let back = glass.sample(into.wi, Vec2::ZERO, 0.9999).unwrap();
        let w_in = into.f.x * into.wi.z.abs() / into.pdf;
        let w_out = back.f.x * back.wi.z.abs() / back.pdf;
        assert!((w_in * w_out - 1.0).abs() < 1e-5, "{}", w_in * w_out);
        assert!((back.wi - wo).length() < 1e-5, "{} vs {wo}", back.wi);
    }
}
