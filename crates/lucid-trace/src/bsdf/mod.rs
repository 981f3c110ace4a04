//! Scattering functions. Every BSDF works in a local shading frame whose +Z is the shading
//! normal, with `wo` (towards the viewer) and `wi` (towards the light) both pointing away
//! from the surface, and offers three verbs, as in pbrt: [`Bsdf::eval`] the value `f` (no
//! cosine), [`Bsdf::sample`] an importance-sampled direction, and [`Bsdf::pdf`] its density in
//! solid angle.

#[cfg(test)]
mod analytic_tests;
pub mod ashikhmin_shirley;
pub mod blinn_phong;
#[cfg(test)]
mod chi_square;
pub mod cook_torrance;
pub mod dielectric;
pub mod fresnel;
pub mod hair;
pub mod half_vector;
pub mod kubelka_munk;
pub mod lafortune;
pub mod lambert;
pub mod lobe;
pub mod measured;
pub mod measured_pca;
pub mod metallic_roughness;
pub mod microfacet;
pub mod neural;
pub mod phong;
pub mod plastic;
pub mod poulin_fournier;
pub(crate) mod shared_file;
pub mod ward;

use glam::{Vec2, Vec3};

pub use ashikhmin_shirley::AshikhminShirley;
pub use blinn_phong::BlinnPhongLobe;
pub use cook_torrance::CookTorranceLobe;
pub use dielectric::SmoothDielectric;
pub use lafortune::{LafortuneLobes, LafortuneTerm};
pub use lambert::Lambertian;
pub use lobe::DiffuseAndLobe;
pub use microfacet::{GgxDistribution, MicrofacetConductor};
pub use phong::PhongLobe;
pub use plastic::SmoothPlastic;
pub use ward::WardLobe;

/// A sampled direction and what it carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Incident direction (local frame).
    pub wi: Vec3,
    /// BSDF value for `(wo, wi)`; for specular events, the value of the delta's weight.
    pub f: Vec3,
    /// Density of `wi` in solid angle (for specular events, the discrete probability).
    pub pdf: f32,
    /// The sample came from a Dirac delta (mirror or refraction): MIS and light sampling do not apply.
    pub specular: bool,
    /// The sample goes through the surface.
    pub transmission: bool,
}

/// The interface every BSDF implements.
pub trait Bsdf {
    /// `f(wo, wi)`; zero for directions a delta component would need.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;
    /// Samples `wi` given `wo`, with two uniforms `u` and one `uc` for choosing a component.
    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample>;
    /// Density of [`Bsdf::sample`] choosing `wi` (zero for delta components).
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// True when the BSDF is only made of deltas, so that light sampling is pointless.
    fn is_specular(&self) -> bool {
        false
    }
}

/// Whether two local directions are on the same side of the surface.
#[inline]
pub fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Both directions mirrored above the surface when `wo` is below it (two-sided surfaces whose
/// lobes are written for the upper hemisphere).
#[inline]
pub(crate) fn to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) }
}

/// [`to_upper`] of a pair on one side of the surface; `None` for a pair across it.
#[inline]
pub(crate) fn upper_pair(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    same_hemisphere(wo, wi).then(|| to_upper(wo, wi))
}

/// Mirror reflection of `w` about the local normal +Z.
#[inline]
pub fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Mirror reflection of `w` about `n`.
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    -w + 2.0 * w.dot(n) * n
}

#[cfg(test)]
pub(crate) mod testing {
    //! Checks shared by the BSDF tests: energy, pdf normalisation, sampling consistency and
    //! reciprocity, all by Monte Carlo against uniform sphere sampling.
    use super::*;
    use crate::sampling::{Rng, UNIFORM_SPHERE_PDF, uniform_sphere};

    /// ∫ f(wo, wi) |cos θi| dωi estimated by importance sampling the BSDF.
    pub fn albedo_by_sampling(bsdf: &dyn Bsdf, wo: Vec3, n: usize) -> Vec3 {
        let mut rng = Rng::new(11, 0);
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform())
                && s.pdf > 0.0
            {
                sum += s.f * s.wi.z.abs() / s.pdf;
            }
        }
        sum / n as f32
    }

    /// ∫ f(wo, wi) |cos θi| dωi estimated with uniform sphere directions (non-delta part).
    pub fn albedo_by_uniform(bsdf: &dyn Bsdf, wo: Vec3, n: usize) -> Vec3 {
        let mut rng = Rng::new(12, 0);
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let wi = uniform_sphere(rng.uniform2());
            sum += bsdf.eval(wo, wi) * wi.z.abs() / UNIFORM_SPHERE_PDF;
        }
        sum / n as f32
    }

    /// ∫ pdf(wo, wi) dωi over the sphere (1 for a BSDF without deltas).
    pub fn pdf_integral(bsdf: &dyn Bsdf, wo: Vec3, n: usize) -> f32 {
        let mut rng = Rng::new(13, 0);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let wi = uniform_sphere(rng.uniform2());
            sum += (bsdf.pdf(wo, wi) / UNIFORM_SPHERE_PDF) as f64;
        }
        (sum / n as f64) as f32
    }

    /// Sampled `f` and `pdf` agree with `eval` and `pdf` for non-delta samples.
    pub fn sample_matches_eval(bsdf: &dyn Bsdf, wo: Vec3, n: usize) {
        let mut rng = Rng::new(14, 0);
        for _ in 0..n {
            let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { continue };
            if s.specular || s.pdf < 1e-3 {
                continue;
            }
            let f = bsdf.eval(wo, s.wi);
            let pdf = bsdf.pdf(wo, s.wi);
            assert!((f - s.f).abs().max_element() <= 1e-3 * (1.0 + f.max_element()), "{f} vs {}", s.f);
            assert!((pdf - s.pdf).abs() <= 1e-3 * (1.0 + pdf), "{pdf} vs {}", s.pdf);
        }
    }

    /// Helmholtz reciprocity of reflection: f(wo, wi) = f(wi, wo).
    pub fn reciprocal(bsdf: &dyn Bsdf, n: usize) {
        let mut rng = Rng::new(15, 0);
        for _ in 0..n {
            let mut a = uniform_sphere(rng.uniform2());
            let mut b = uniform_sphere(rng.uniform2());
            a.z = a.z.abs();
            b.z = b.z.abs();
            let (fab, fba) = (bsdf.eval(a, b), bsdf.eval(b, a));
            assert!((fab - fba).abs().max_element() <= 1e-4 * (1.0 + fab.max_element()), "{fab} vs {fba}");
        }
    }

    /// Directions from grazing to normal, above the surface.
    pub fn outgoing_directions() -> Vec<Vec3> {
        [0.05f32, 0.3, 0.7, 1.0]
            .iter()
            .map(|&c| Vec3::new((1.0 - c * c).sqrt() * 0.6, (1.0 - c * c).sqrt() * 0.8, c))
            .collect()
    }
}
