//! The GGX (Trowbridge–Reitz) microfacet distribution with Smith masking and visible-normal
//! sampling (Heitz 2018), and the rough conductor built on it.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use super::fresnel::fresnel_conductor;
use super::{Bsdf, BsdfSample, reflect, reflect_z, same_hemisphere};

/// Roughness below which surfaces are treated as perfectly smooth (a delta).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// GGX normal distribution, anisotropic in the local x and y axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxDistribution {
    /// Roughness along x.
    pub alpha_x: f32,
    /// Roughness along y.
    pub alpha_y: f32,
}

impl GgxDistribution {
    /// Isotropic GGX with `α = roughness²` (the perceptual mapping of Burley).
    pub fn from_roughness(roughness: f32) -> Self {
        let a = (roughness * roughness).max(1e-4);
        Self { alpha_x: a, alpha_y: a }
    }

    /// Too smooth to sample as a distribution.
    pub fn is_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// `D(ωm)`: density of micro-normals per unit projected area.
    pub fn d(&self, wm: Vec3) -> f32 {
        let cos2 = wm.z * wm.z;
        if cos2 <= 0.0 {
            return 0.0;
        }
        let e = (wm.x / self.alpha_x).powi(2) + (wm.y / self.alpha_y).powi(2) + cos2;
        1.0 / (PI * self.alpha_x * self.alpha_y * e * e)
    }

    /// Smith's auxiliary function `Λ(ω)`.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        let alpha2_tan2 = ((w.x * self.alpha_x).powi(2) + (w.y * self.alpha_y).powi(2)) / cos2;
        0.5 * ((1.0 + alpha2_tan2).sqrt() - 1.0)
    }

    /// Masking `G1(ω) = 1/(1 + Λ(ω))`.
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing `G(ωo, ωi) = 1/(1 + Λ(ωo) + Λ(ωi))`.
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals from `w`: `G1(w)·max(0, w·ωm)·D(ωm)/|cos θ_w|`.
    pub fn visible_d(&self, w: Vec3, wm: Vec3) -> f32 {
        self.g1(w) / w.z.abs() * self.d(wm) * w.dot(wm).abs()
    }

    /// Samples a micro-normal visible from `w` (Heitz 2018), for `w` above the surface.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let flip = w.z < 0.0;
        let w = if flip { -w } else { w };
        let wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        let t1 = if wh.z < 0.999_99 { Vec3::Z.cross(wh).normalize() } else { Vec3::X };
        let t2 = wh.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let (p1, mut p2) = (r * phi.cos(), r * phi.sin());
        let s = 0.5 * (1.0 + wh.z);
        p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * wh;
        let wm = Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize();
        if flip { -wm } else { wm }
    }
}

/// A conductor: GGX microfacets with the complex Fresnel term, or a perfect mirror when smooth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetConductor {
    /// Micro-normal distribution.
    pub distribution: GgxDistribution,
    /// Real part of the index of refraction, per channel.
    pub eta: Vec3,
    /// Absorption coefficient (imaginary part of the index), per channel.
    pub k: Vec3,
}

impl Bsdf for MicrofacetConductor {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !same_hemisphere(wo, wi) || self.distribution.is_smooth() {
            return Vec3::ZERO;
        }
        let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
        if cos_o == 0.0 || cos_i == 0.0 {
            return Vec3::ZERO;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return Vec3::ZERO;
        }
        let wm = wm.normalize();
        let f = fresnel_conductor(wo.dot(wm).abs(), self.eta, self.k);
        f * self.distribution.d(wm) * self.distribution.g(wo, wi) / (4.0 * cos_o * cos_i)
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        if self.distribution.is_smooth() {
            let wi = reflect_z(wo);
            let f = fresnel_conductor(wo.z.abs(), self.eta, self.k) / wi.z.abs();
            return Some(BsdfSample { wi, f, pdf: 1.0, specular: true, transmission: false });
        }
        let wm = self.distribution.sample_visible(wo, u);
        let wi = reflect(wo, wm);
        if !same_hemisphere(wo, wi) {
            return None;
        }
        let pdf = self.distribution.visible_d(wo, wm) / (4.0 * wo.dot(wm).abs());
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.eval(wo, wi), pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere(wo, wi) || self.distribution.is_smooth() {
            return 0.0;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return 0.0;
        }
        let mut wm = wm.normalize();
        if wm.z < 0.0 {
            wm = -wm;
        }
        self.distribution.visible_d(wo, wm) / (4.0 * wo.dot(wm).abs())
    }

    fn is_specular(&self) -> bool {
        self.distribution.is_smooth()
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;
    use crate::sampling::{Rng, uniform_sphere};

    #[test]
    fn ggx_normals_project_to_unit_area() {
        // ∫ D(ωm) cos θm dωm = 1 for any roughness.
        for (ax, ay) in [(0.1, 0.1), (0.5, 0.5), (0.2, 0.7)] {
            let d = GgxDistribution { alpha_x: ax, alpha_y: ay };
            let mut rng = Rng::new(1, 0);
            let n = 2_000_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let mut w = uniform_sphere(rng.uniform2());
                w.z = w.z.abs();
                sum += (d.d(w) * w.z) as f64 * 2.0 * std::f64::consts::PI;
            }
            let integral = sum / n as f64;
            assert!((integral - 1.0).abs() < 0.02, "α = ({ax}, {ay}): {integral}");
        }
    }

    #[test]
    fn white_conductor_conserves_energy_and_sampling_is_consistent() {
        // η = 0, k = ∞-like gives F ≈ 1: the only loss is single-scattering masking.
        let white = |a: f32| MicrofacetConductor {
            distribution: GgxDistribution { alpha_x: a, alpha_y: a },
            eta: Vec3::splat(0.0),
            k: Vec3::splat(1e4),
        };
        for alpha in [0.05f32, 0.3, 0.8] {
            let bsdf = white(alpha);
            for wo in outgoing_directions() {
                let sampled = albedo_by_sampling(&bsdf, wo, 200_000).x;
                let uniform = albedo_by_uniform(&bsdf, wo, 1_000_000).x;
                assert!(sampled <= 1.0 + 1e-3, "α {alpha}: albedo {sampled} exceeds 1");
                // Smooth surfaces at moderate angles lose little energy to masking.
                if alpha <= 0.05 && wo.z >= 0.3 {
                    assert!(sampled > 0.95, "α {alpha}, cos {}: albedo {sampled}", wo.z);
                }
                if alpha >= 0.3 {
                    assert!((sampled - uniform).abs() < 0.03, "α {alpha}: {sampled} vs {uniform}");
                    // Reflected visible normals that point below the horizon are lost: ≤ 1.
                    assert!(pdf_integral(&bsdf, wo, 1_000_000) <= 1.02);
                }
                sample_matches_eval(&bsdf, wo, 2000);
            }
            reciprocal(&bsdf, 2000);
        }
    }

    #[test]
    fn furnace_at_unit_roughness_matches_the_closed_form() {
        // α = 1 makes D = 1/π; seen from the normal, G = 2μ/(1+μ) and the single-scattering
        // albedo is ∫ G/(4π) dω = 1 − ln 2.
        let bsdf = MicrofacetConductor {
            distribution: GgxDistribution { alpha_x: 1.0, alpha_y: 1.0 },
            eta: Vec3::ZERO,
            k: Vec3::splat(1e4),
        };
        let albedo = albedo_by_sampling(&bsdf, Vec3::Z, 1_000_000).x;
        let exact = 1.0 - std::f32::consts::LN_2;
        assert!((albedo - exact).abs() < 3e-3, "{albedo} vs {exact}");
    }

    #[test]
    fn smooth_conductor_is_a_fresnel_mirror() {
        let mirror = MicrofacetConductor {
            distribution: GgxDistribution { alpha_x: 0.0, alpha_y: 0.0 },
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        };
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let s = mirror.sample(wo, Vec2::splat(0.5), 0.5).unwrap();
        assert!(s.specular && (s.wi - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
        let expected = fresnel_conductor(0.8, Vec3::splat(0.2), Vec3::splat(3.0));
        assert!((s.f * s.wi.z / s.pdf - expected).length() < 1e-5);
        assert_eq!(mirror.eval(wo, s.wi), Vec3::ZERO);
    }
}
