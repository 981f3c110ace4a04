//! The Lafortune model (Lafortune et al. 1997): generalised cosine lobes
//! `ρj·[Cx·wi.x·wo.x + Cy·wi.y·wo.y + Cz·wi.z·wo.z]^nj` added to a diffuse term. With
//! `Cx = Cy = −Cz` a lobe is Phong around the mirror direction; `Cx = Cy > 0` gives
//! retro-reflection, `Cx ≠ Cy` anisotropy and `|Cz| < |Cx|` off-specular peaks. The
//! coefficients carry the normalisation, as in fitted data; each lobe is sampled as a cosine
//! power around its axis `(Cx·wo.x, Cy·wo.y, Cz·wo.z)`.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use super::lobe::{Lobe, cosine_power_pdf, sample_cosine_power};

/// One generalised cosine lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LafortuneTerm {
    /// `(Cx, Cy, Cz)`.
    pub c: Vec3,
    /// Exponent `n`.
    pub exponent: f32,
    /// Colour of the lobe `ρj`.
    pub albedo: Vec3,
}

/// Up to four lobes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LafortuneLobes {
    terms: [Option<LafortuneTerm>; 4],
}

impl LafortuneLobes {
    /// The lobes (at most four; more are ignored by the caller's validation).
    pub fn new(terms: &[LafortuneTerm]) -> Self {
        let mut t = [None; 4];
        for (slot, term) in t.iter_mut().zip(terms) {
            *slot = Some(*term);
        }
        Self { terms: t }
    }

    fn terms(&self) -> impl Iterator<Item = &LafortuneTerm> {
        self.terms.iter().flatten()
    }

    /// Upper bound of a lobe's albedo from `wo`: `ρ·|u|^n·2π/(n+1)`.
    fn term_weight(t: &LafortuneTerm, wo: Vec3) -> f32 {
        let u = t.c * wo;
        t.albedo.max_element() * u.length().powf(t.exponent) * 2.0 * PI / (t.exponent + 1.0)
    }
}

impl Lobe for LafortuneLobes {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.terms()
            .map(|t| {
                let d = (t.c * wo).dot(wi);
                if d > 0.0 { t.albedo * d.powf(t.exponent) } else { Vec3::ZERO }
            })
            .sum()
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let weights: Vec<(f32, &LafortuneTerm)> = self.terms().map(|t| (Self::term_weight(t, wo), t)).collect();
        let total: f32 = weights.iter().map(|w| w.0).sum();
        if total <= 0.0 {
            return None;
        }
        // Pick a lobe with u.x, then rescale u.x within it for the direction.
        let mut target = u.x * total;
        let mut chosen = weights.len() - 1;
        for (j, (w, _)) in weights.iter().enumerate() {
            if target < *w {
                chosen = j;
                break;
            }
            target -= w;
        }
        let (w, t) = weights[chosen];
        let axis = (t.c * wo).normalize_or_zero();
        if axis == Vec3::ZERO || w <= 0.0 {
            return None;
        }
        let ux = (target / w).clamp(0.0, 0.999_999);
        let wi = sample_cosine_power(axis, t.exponent, Vec2::new(ux, u.y));
        (wi.z > 0.0).then_some(wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let total: f32 = self.terms().map(|t| Self::term_weight(t, wo)).sum();
        if total <= 0.0 {
            return 0.0;
        }
        self.terms()
            .map(|t| {
                let axis = (t.c * wo).normalize_or_zero();
                Self::term_weight(t, wo) / total * cosine_power_pdf(axis, t.exponent, wi)
            })
            .sum()
    }

    fn weight(&self) -> f32 {
        self.terms().map(|t| Self::term_weight(t, Vec3::Z)).sum::<f32>().min(1.0)
    }
}
