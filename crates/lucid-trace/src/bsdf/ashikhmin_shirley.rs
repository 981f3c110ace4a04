//! The Ashikhmin–Shirley anisotropic Phong BRDF (2000): a Fresnel-weighted anisotropic
//! half-vector lobe
//! `√((nu+1)(nv+1))/8π · (n·h)^(nu cos²φh + nv sin²φh) / ((wi·h)·max(cos θi, cos θo)) · F(wi·h)`
//! (Schlick's F with normal reflectance Rs) over a diffuse term that takes the energy the
//! coating does not reflect,
//! `28 Rd/23π · (1 − Rs) · (1 − (1 − cos θi/2)⁵) · (1 − (1 − cos θo/2)⁵)`.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

use super::{Bsdf, BsdfSample, reflect, same_hemisphere};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Ashikhmin–Shirley BRDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AshikhminShirley {
    /// Diffuse reflectance `Rd`.
    pub rd: Vec3,
    /// Specular reflectance at normal incidence `Rs`.
    pub rs: Vec3,
    /// Exponent along the local x axis.
    pub nu: f32,
    /// Exponent along the local y axis.
    pub nv: f32,
}

impl AshikhminShirley {
    fn exponent(&self, h: Vec3) -> f32 {
        let s2 = (1.0 - h.z * h.z).max(1e-12);
        (self.nu * h.x * h.x + self.nv * h.y * h.y) / s2
    }

    /// Density of the half-vector sampler: `√((nu+1)(nv+1))/2π · (n·h)^e(h)`.
    fn half_vector_pdf(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        ((self.nu + 1.0) * (self.nv + 1.0)).sqrt() / (2.0 * PI) * h.z.powf(self.exponent(h))
    }

    fn sample_half_vector(&self, u: Vec2) -> Vec3 {
        // φ in the first quadrant by the paper's formula, then mirrored to the quadrant u.x picks.
        let q = (u.x * 4.0).floor().min(3.0);
        let uq = u.x * 4.0 - q;
        let ratio = ((self.nu + 1.0) / (self.nv + 1.0)).sqrt();
        let mut phi = (ratio * (FRAC_PI_2 * uq).tan()).atan();
        phi = match q as u32 {
            0 => phi,
            1 => PI - phi,
            2 => PI + phi,
            _ => 2.0 * PI - phi,
        };
        let (s, c) = phi.sin_cos();
        let e = self.nu * c * c + self.nv * s * s;
        let cos_t = (1.0 - u.y).powf(1.0 / (e + 1.0));
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        Vec3::new(sin_t * c, sin_t * s, cos_t)
    }

    fn specular_probability(&self) -> f32 {
        let (s, d) = (self.rs.max_element(), self.rd.max_element());
        if s + d <= 0.0 { 1.0 } else { s / (s + d) }
    }
}

fn pow5(x: f32) -> f32 {
    let x2 = x * x;
    x2 * x2 * x
}

impl Bsdf for AshikhminShirley {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !same_hemisphere(wo, wi) {
            return Vec3::ZERO;
        }
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let diffuse = self.rd
            * (Vec3::ONE - self.rs)
            * (28.0 / (23.0 * PI))
            * (1.0 - pow5(1.0 - 0.5 * wi.z))
            * (1.0 - pow5(1.0 - 0.5 * wo.z));
        let h = (wo + wi).normalize();
        let ih = wi.dot(h);
        let fresnel = self.rs + (Vec3::ONE - self.rs) * pow5(1.0 - ih);
        let specular = ((self.nu + 1.0) * (self.nv + 1.0)).sqrt() / (8.0 * PI) * h.z.powf(self.exponent(h))
            / (ih * wi.z.max(wo.z));
        diffuse + fresnel * specular
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let wo_up = if flip { -wo } else { wo };
        let mut wi = if uc < self.specular_probability() {
            reflect(wo_up, self.sample_half_vector(u))
        } else {
            cosine_hemisphere(u)
        };
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
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let h = (wo + wi).normalize();
        let p = self.specular_probability();
        p * self.half_vector_pdf(h) / (4.0 * wo.dot(h)) + (1.0 - p) * cosine_hemisphere_pdf(wi.z)
    }
}
