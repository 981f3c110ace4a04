//! The metallic–roughness BSDF of spatially varying materials (glTF's and Disney's
//! parameterisation): GGX microfacets with Schlick's Fresnel from `F0 = mix(0.04, base,
//! metallic)`, over a diffuse base `(1 − metallic)·base/π` seen through the coat's Fresnel on
//! both sides, `(1 − F(θi))(1 − F(θo))` with the dielectric's F0 = 0.04 (a smooth-plastic-like
//! coupling that keeps the albedo at most 1 and f reciprocal).
//!
//! A normal map tilts the shading normal: the lobes are evaluated in a frame around `normal`
//! (given in the surface's shading frame), and the value returned is scaled by
//! `cos θi' / cos θi`, so that the integrators' `f |cos θi|` is the lobe's `f' cos θi'` — the
//! tilted normal is the shading normal. Directions below either normal reflect nothing.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::microfacet::GgxDistribution;
use super::{Bsdf, BsdfSample, reflect, upper_pair};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf, orthonormal_basis};

/// Specular reflectance at normal incidence of a dielectric (index 1.5).
const DIELECTRIC_F0: f32 = 0.04;

/// Smallest GGX α: smoother surfaces are not sampled as deltas here, so keep them finite.
const MIN_ALPHA: f32 = 2e-3;

/// Metallic–roughness BSDF at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetallicRoughness {
    /// Base colour (albedo of the diffuse part, F0 of the metal).
    pub base_color: Vec3,
    /// 0: dielectric, 1: metal.
    pub metallic: f32,
    /// GGX α (roughness²).
    pub alpha: f32,
    /// The shading normal after the normal map, in the surface's shading frame (z > 0).
    pub normal: Vec3,
}

fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * m
}

impl MetallicRoughness {
    /// A BSDF with roughness `roughness` (α = roughness², at least 0.002).
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32, normal: Vec3) -> Self {
        let n = normal.normalize_or_zero();
        let normal = if n.z > 1e-3 { n } else { Vec3::Z };
        Self { base_color, metallic, alpha: (roughness * roughness).max(MIN_ALPHA), normal }
    }

    fn ggx(&self) -> GgxDistribution {
        GgxDistribution { alpha_x: self.alpha, alpha_y: self.alpha }
    }

    fn f0(&self) -> Vec3 {
        Vec3::splat(DIELECTRIC_F0).lerp(self.base_color, self.metallic)
    }

    /// Conversions into and out of the tilted frame.
    fn tilted(&self, v: Vec3) -> Vec3 {
        let (t, b) = orthonormal_basis(self.normal);
        Vec3::new(v.dot(t), v.dot(b), v.dot(self.normal))
    }

    fn untilted(&self, v: Vec3) -> Vec3 {
        let (t, b) = orthonormal_basis(self.normal);
        v.x * t + v.y * b + v.z * self.normal
    }

    /// `f'` in the tilted frame, both directions above it.
    fn lobes(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let wm = (wo + wi).normalize_or_zero();
        if wm == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let ggx = self.ggx();
        let specular = schlick(self.f0(), wo.dot(wm)) * (ggx.d(wm) * ggx.g(wo, wi) / (4.0 * wo.z * wi.z));
        let coat = |cos: f32| 1.0 - schlick(Vec3::splat(DIELECTRIC_F0), cos).x;
        let diffuse = self.base_color * ((1.0 - self.metallic) * FRAC_1_PI * coat(wi.z) * coat(wo.z));
        specular + diffuse
    }

    /// Probability of sampling the specular lobe from `wo` (tilted frame): its share of the
    /// Fresnel-weighted energy, kept inside [0.1, 1] where a diffuse part exists.
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let s = schlick(self.f0(), wo.z).element_sum();
        let d = ((1.0 - self.metallic) * self.base_color).element_sum();
        if d <= 0.0 { 1.0 } else { (s / (s + d)).clamp(0.1, 0.9) }
    }

    fn tilted_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability(wo);
        let wm = (wo + wi).normalize_or_zero();
        let specular = if wm == Vec3::ZERO { 0.0 } else { self.ggx().visible_d(wo, wm) / (4.0 * wo.dot(wm).abs()) };
        ps * specular + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }
}

impl Bsdf for MetallicRoughness {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return Vec3::ZERO };
        let (to, ti) = (self.tilted(wo), self.tilted(wi));
        if to.z <= 0.0 || ti.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.lobes(to, ti) * (ti.z / wi.z)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let up = if flip { -wo } else { wo };
        let to = self.tilted(up);
        if to.z <= 0.0 {
            return None;
        }
        let ti = if uc < self.specular_probability(to) {
            reflect(to, self.ggx().sample_visible(to, u))
        } else {
            cosine_hemisphere(u)
        };
        let wi = self.untilted(ti);
        if ti.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        let pdf = self.tilted_pdf(to, ti);
        let f = self.lobes(to, ti) * (ti.z / wi.z);
        let wi = if flip { -wi } else { wi };
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return 0.0 };
        self.tilted_pdf(self.tilted(wo), self.tilted(wi))
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;

    #[test]
    fn metallic_roughness_conserves_energy_is_reciprocal_and_samples_its_density() {
        for (base, metallic, roughness) in
            [(Vec3::ONE, 0.0, 0.5), (Vec3::ONE, 1.0, 0.3), (Vec3::new(0.9, 0.6, 0.2), 0.5, 0.8), (Vec3::ONE, 0.0, 0.05)]
        {
            let bsdf = MetallicRoughness::new(base, metallic, roughness, Vec3::Z);
            for wo in outgoing_directions() {
                sample_matches_eval(&bsdf, wo, 3000);
                let albedo = albedo_by_sampling(&bsdf, wo, 300_000);
                let uniform = albedo_by_uniform(&bsdf, wo, 1_500_000);
                assert!(albedo.max_element() <= 1.01, "{bsdf:?}, cos {}: albedo {albedo}", wo.z);
                if roughness > 0.1 {
                    assert!((albedo.x - uniform.x).abs() < 0.02 + 0.03 * uniform.x, "{albedo} vs {uniform}");
                }
                assert!(pdf_integral(&bsdf, wo, 1_000_000) <= 1.02);
            }
            reciprocal(&bsdf, 3000);
        }
    }

    #[test]
    fn a_tilted_normal_moves_the_highlight_and_keeps_energy() {
        let tilted = Vec3::new(0.4, 0.0, 1.0).normalize();
        let bsdf = MetallicRoughness::new(Vec3::ONE, 1.0, 0.2, tilted);
        let wo = Vec3::new(0.0, 0.0, 1.0);
        // The mirror direction of wo about the tilted normal carries the highlight.
        let mirror = reflect(wo, tilted);
        let flat_mirror = Vec3::Z;
        assert!(bsdf.eval(wo, mirror).x * mirror.z > 10.0 * bsdf.eval(wo, flat_mirror).x * flat_mirror.z);
        for wo in outgoing_directions() {
            sample_matches_eval(&bsdf, wo, 3000);
            let albedo = albedo_by_sampling(&bsdf, wo, 300_000);
            assert!(albedo.max_element() <= 1.01, "cos {}: albedo {albedo}", wo.z);
            let p = pdf_integral(&bsdf, wo, 4_000_000);
            assert!(p <= 1.02, "cos {}: pdf integrates to {p}", wo.z);
        }
    }
}
