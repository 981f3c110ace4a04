//! Hair scattering after Marschner et al. (2003) in the energy-conserving form of d'Eon et al.
//! (2011) and Chiang et al. (2016), as pbrt-v3 builds it: light leaves a fibre after p internal
//! paths (R: p = 0, TT: 1, TRT: 2, and the rest summed as one isotropic-in-azimuth term), each
//! the product of a longitudinal lobe `Mp(θi, θo)` (d'Eon's normalised von Mises–Fisher form,
//! the cuticle scales tilting it by 2α, −α, −4α), an attenuation `Ap` (Fresnel at the
//! fibre's surface and absorption `σa` along the refracted path) and an azimuthal lobe
//! `Np(φ)` (a logistic around the exit angle `Φ = 2pγt − 2γo + pπ` of a smooth cylinder).
//!
//! Frames: local x is the fibre's axis (θ is measured from the plane normal to it, sin θ =
//! w.x); y and z span the normal plane, z the shading normal, and φ = atan2(z, y). The offset
//! across the fibre `h = sin γo` is where the ray met the cylinder; on a round fibre it is the
//! sine of the angle from the normal to `ωo` in the normal plane, so [`HairSurface`] reads it
//! from `ωo` itself. The scattering function `S = Σ Mp Ap Np` is divided by |cos θi| of the
//! shading frame, which the integrators multiply back.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

use super::fresnel::fresnel_dielectric;
use super::{Bsdf, BsdfSample};

/// Internal paths given their own lobes (R, TT, TRT); the rest are summed.
const P_MAX: usize = 3;

/// A fibre's material, with everything that does not depend on where the ray hit worked out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairModel {
    /// Absorption per unit of fibre radius.
    pub sigma_a: Vec3,
    /// Index of refraction of the fibre.
    pub eta: f32,
    v: [f32; P_MAX + 1],
    s: f32,
    sin_2k_alpha: [f32; 3],
    cos_2k_alpha: [f32; 3],
}

impl HairModel {
    /// Absorption `sigma_a`, longitudinal and azimuthal roughness `beta_m`, `beta_n` (0..1),
    /// cuticle tilt `alpha` (radians) and index `eta`.
    pub fn new(sigma_a: Vec3, beta_m: f32, beta_n: f32, alpha: f32, eta: f32) -> Self {
        // Chiang et al.'s fits from roughness to the lobes' variances and logistic scale.
        let v0 = (0.726 * beta_m + 0.812 * beta_m.powi(2) + 3.7 * beta_m.powi(20)).powi(2);
        let v = [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0];
        let s = (PI / 8.0).sqrt() * (0.265 * beta_n + 1.194 * beta_n.powi(2) + 5.372 * beta_n.powi(22));
        let mut sin_2k_alpha = [alpha.sin(), 0.0, 0.0];
        let mut cos_2k_alpha = [(1.0 - sin_2k_alpha[0].powi(2)).max(0.0).sqrt(), 0.0, 0.0];
        for k in 1..3 {
            sin_2k_alpha[k] = 2.0 * cos_2k_alpha[k - 1] * sin_2k_alpha[k - 1];
            cos_2k_alpha[k] = cos_2k_alpha[k - 1].powi(2) - sin_2k_alpha[k - 1].powi(2);
        }
        Self { sigma_a, eta, v, s, sin_2k_alpha, cos_2k_alpha }
    }

    /// The absorption that gives a fibre of azimuthal roughness `beta_n` the multiply
    /// scattered colour `colour` (Chiang et al. 2016).
    pub fn sigma_a_from_colour(colour: Vec3, beta_n: f32) -> Vec3 {
        let denominator = chiang_denominator(beta_n);
        colour.clamp(Vec3::splat(1e-4), Vec3::ONE).to_array().map(|c| (c.ln() / denominator).powi(2)).into()
    }

    /// The colour whose [`HairModel::sigma_a_from_colour`] is `sigma_a` (its inverse).
    pub fn colour_of(sigma_a: Vec3, beta_n: f32) -> Vec3 {
        let denominator = chiang_denominator(beta_n);
        sigma_a.max(Vec3::ZERO).to_array().map(|s| (-s.sqrt() * denominator).exp()).into()
    }

    /// The absorption of eumelanin and pheomelanin concentrations (d'Eon et al. 2011).
    pub fn sigma_a_from_melanin(eumelanin: f32, pheomelanin: f32) -> Vec3 {
        eumelanin * Vec3::new(0.419, 0.697, 1.37) + pheomelanin * Vec3::new(0.187, 0.4, 1.05)
    }

    /// `sin θo, cos θo` tilted by the cuticle scales for lobe `p`.
    fn tilted(&self, p: usize, sin_o: f32, cos_o: f32) -> (f32, f32) {
        let (s, c) = (&self.sin_2k_alpha, &self.cos_2k_alpha);
        let (sin, cos) = match p {
            0 => (sin_o * c[1] - cos_o * s[1], cos_o * c[1] + sin_o * s[1]),
            1 => (sin_o * c[0] + cos_o * s[0], cos_o * c[0] - sin_o * s[0]),
            2 => (sin_o * c[2] + cos_o * s[2], cos_o * c[2] - sin_o * s[2]),
            _ => (sin_o, cos_o),
        };
        (sin, cos.abs())
    }
}

/// Chiang et al.'s polynomial in the azimuthal roughness relating colour and absorption:
/// `σa = (ln c / P(βn))²`.
fn chiang_denominator(b: f32) -> f32 {
    5.969 - 0.215 * b + 2.532 * b.powi(2) - 10.73 * b.powi(3) + 5.574 * b.powi(4) + 0.245 * b.powi(5)
}

/// What one evaluation needs about `ωo` and the hit offset.
struct Outgoing {
    sin_o: f32,
    cos_o: f32,
    phi_o: f32,
    gamma_o: f32,
    gamma_t: f32,
    attenuation: [Vec3; P_MAX + 1],
}

/// The fibre hit at offset `h ∈ [−1, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairBsdf {
    /// The material.
    pub model: HairModel,
    /// Offset across the fibre.
    pub h: f32,
}

impl HairBsdf {
    fn outgoing(&self, wo: Vec3) -> Outgoing {
        let m = &self.model;
        let sin_o = wo.x.clamp(-1.0, 1.0);
        let cos_o = (1.0 - sin_o * sin_o).max(0.0).sqrt();
        let phi_o = wo.z.atan2(wo.y);
        let h = self.h.clamp(-1.0, 1.0);
        let gamma_o = h.asin();
        // The refracted ray: its longitudinal angle, and its azimuthal offset through the
        // modified index η′ of the normal plane (Bravais).
        let sin_t = sin_o / m.eta;
        let cos_t = (1.0 - sin_t * sin_t).max(1e-8).sqrt();
        let eta_p = (m.eta * m.eta - sin_o * sin_o).max(0.0).sqrt() / cos_o.max(1e-6);
        let sin_gamma_t = (h / eta_p).clamp(-1.0, 1.0);
        let cos_gamma_t = (1.0 - sin_gamma_t * sin_gamma_t).max(0.0).sqrt();
        let transmittance = (-m.sigma_a * (2.0 * cos_gamma_t / cos_t)).exp();
        let cos_gamma_o = (1.0 - h * h).max(0.0).sqrt();
        let f = fresnel_dielectric(cos_o * cos_gamma_o, m.eta);
        let mut a = [Vec3::ZERO; P_MAX + 1];
        a[0] = Vec3::splat(f);
        a[1] = (1.0 - f) * (1.0 - f) * transmittance;
        a[2] = a[1] * transmittance * f;
        a[3] = a[2] * transmittance * f / (Vec3::ONE - transmittance * f).max(Vec3::splat(1e-6));
        Outgoing { sin_o, cos_o, phi_o, gamma_o, gamma_t: sin_gamma_t.asin(), attenuation: a }
    }

    /// Probabilities of sampling each lobe: their attenuations' channel means, normalised.
    fn lobe_probabilities(o: &Outgoing) -> [f32; P_MAX + 1] {
        let weights = o.attenuation.map(|a| (a.x + a.y + a.z) / 3.0);
        let total: f32 = weights.iter().sum();
        if total <= 0.0 { [0.25; P_MAX + 1] } else { weights.map(|w| w / total) }
    }

    /// `Σ_p Mp·weight_p·Np` at `ωi`, with per-lobe weights (attenuations or probabilities).
    fn lobes<T: Copy + Default + std::ops::Add<Output = T> + std::ops::Mul<f32, Output = T>>(
        &self,
        o: &Outgoing,
        wi: Vec3,
        weights: &[T; P_MAX + 1],
    ) -> T {
        let m = &self.model;
        let sin_i = wi.x.clamp(-1.0, 1.0);
        let cos_i = (1.0 - sin_i * sin_i).max(0.0).sqrt();
        let phi = wi.z.atan2(wi.y) - o.phi_o;
        let mut sum = T::default();
        for (p, &w) in weights.iter().enumerate().take(P_MAX) {
            let (sin_op, cos_op) = m.tilted(p, o.sin_o, o.cos_o);
            let mp = longitudinal(cos_i, cos_op, sin_i, sin_op, m.v[p]);
            sum = sum + w * (mp * azimuthal(phi, p, m.s, o.gamma_o, o.gamma_t));
        }
        let mp = longitudinal(cos_i, o.cos_o, sin_i, o.sin_o, m.v[P_MAX]);
        sum + weights[P_MAX] * (mp / TAU)
    }

    /// The scattering function `S(ωo, ωi)` (the BSDF value times |cos θi|).
    pub fn scattering(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let o = self.outgoing(wo);
        self.lobes(&o, wi, &o.attenuation)
    }

    fn density(&self, wo: Vec3, wi: Vec3) -> f32 {
        let o = self.outgoing(wo);
        self.lobes(&o, wi, &Self::lobe_probabilities(&o))
    }

    /// A direction for `ωo` (the surface's `sample` reuses its own worked-out `ωo`).
    #[cfg(test)]
    fn sample_direction(&self, wo: Vec3, u: Vec2, uc: f32) -> Vec3 {
        let o = self.outgoing(wo);
        self.sample_from(&o, &Self::lobe_probabilities(&o), u, uc)
    }

    /// [`HairBsdf::sample_direction`] for worked-out `ωo` and lobe probabilities.
    fn sample_from(&self, o: &Outgoing, probabilities: &[f32; P_MAX + 1], u: Vec2, uc: f32) -> Vec3 {
        let m = &self.model;
        // Pick the lobe with `uc`, then reuse what is left of it for the azimuth.
        let (mut p, mut start) = (P_MAX, 0.0);
        for (k, &q) in probabilities.iter().enumerate() {
            if uc < start + q || k == P_MAX {
                p = k;
                break;
            }
            start += q;
        }
        let u_phi = ((uc - start) / probabilities[p].max(1e-8)).clamp(0.0, 1.0 - f32::EPSILON);
        let (sin_op, cos_op) = m.tilted(p, o.sin_o, o.cos_o);
        let sin_i = sample_longitudinal(m.v[p], sin_op, cos_op, u);
        let cos_i = (1.0 - sin_i * sin_i).max(0.0).sqrt();
        let dphi = if p < P_MAX {
            exit_azimuth(p, o.gamma_o, o.gamma_t) + sample_trimmed_logistic(u_phi, m.s)
        } else {
            TAU * u_phi
        };
        let phi_i = o.phi_o + dphi;
        Vec3::new(sin_i, cos_i * phi_i.cos(), cos_i * phi_i.sin())
    }
}

/// `ln I0(x)`, with the asymptotic form for large arguments.
fn log_i0(x: f32) -> f32 {
    if x > 12.0 { x + 0.5 * (-(TAU.ln()) + (1.0 / x).ln() + 1.0 / (8.0 * x)) } else { i0(x).ln() }
}

/// The modified Bessel function `I0(x)` by its series.
fn i0(x: f32) -> f32 {
    let (mut value, mut term, x2) = (1.0f32, 1.0f32, 0.25 * x * x);
    for i in 1..=10 {
        term *= x2 / (i * i) as f32;
        value += term;
    }
    value
}

/// d'Eon et al.'s longitudinal lobe of variance `v`, normalised so that
/// `∫ Mp cos θi dθi = 1`; the log form for narrow lobes avoids overflow.
fn longitudinal(cos_i: f32, cos_o: f32, sin_i: f32, sin_o: f32, v: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let b = sin_i * sin_o / v;
    if v <= 0.1 {
        (log_i0(a) - b - 1.0 / v + std::f32::consts::LN_2 + (1.0 / (2.0 * v)).ln()).exp()
    } else {
        (-b).exp() * i0(a) / ((1.0 / v).sinh() * 2.0 * v)
    }
}

/// `sin θi` drawn from [`longitudinal`] of variance `v` about the mirror elevation of
/// `(sin θo, cos θo)`, exactly (d'Eon et al.'s sampling of the von Mises–Fisher lobe).
fn sample_longitudinal(v: f32, sin_o: f32, cos_o: f32, u: Vec2) -> f32 {
    let u0 = u.x.max(1e-5);
    let cos_theta = (1.0 + v * (u0 + (1.0 - u0) * (-2.0 / v).exp()).ln()).clamp(-1.0, 1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    (-cos_theta * sin_o + sin_theta * (TAU * u.y).cos() * cos_o).clamp(-1.0, 1.0)
}

/// The azimuth, relative to `ωo`'s, at which path `p` leaves a smooth cylinder.
fn exit_azimuth(p: usize, gamma_o: f32, gamma_t: f32) -> f32 {
    2.0 * p as f32 * gamma_t - 2.0 * gamma_o + p as f32 * PI
}

fn logistic(x: f32, s: f32) -> f32 {
    let e = (-x.abs() / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic of scale `s` restricted to [−π, π] and renormalised.
fn trimmed_logistic(x: f32, s: f32) -> f32 {
    logistic(x, s) / (logistic_cdf(PI, s) - logistic_cdf(-PI, s))
}

fn sample_trimmed_logistic(u: f32, s: f32) -> f32 {
    let k = logistic_cdf(PI, s) - logistic_cdf(-PI, s);
    let x = -s * (1.0 / (u * k + logistic_cdf(-PI, s)) - 1.0).ln();
    x.clamp(-PI, PI)
}

/// The azimuthal lobe of path `p` at relative azimuth `phi`.
fn azimuthal(phi: f32, p: usize, s: f32, gamma_o: f32, gamma_t: f32) -> f32 {
    let mut d = phi - exit_azimuth(p, gamma_o, gamma_t);
    d = (d + PI).rem_euclid(TAU) - PI;
    trimmed_logistic(d, s)
}

/// A fibre's BSDF in the shading frame of a hit on a round fibre (x along the fibre, z the
/// surface normal): the offset is read from `ωo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairSurface {
    /// The material.
    pub model: HairModel,
}

impl HairSurface {
    fn at(&self, wo: Vec3) -> HairBsdf {
        // φ = atan2(z, y): the normal is at π/2, and h = sin(φo − π/2) = −cos φo.
        let r = (wo.y * wo.y + wo.z * wo.z).sqrt();
        let h = if r > 1e-7 { -wo.y / r } else { 0.0 };
        HairBsdf { model: self.model, h }
    }
}

/// `S / |cos θi|` of the shading frame, zero where that cosine vanishes.
fn per_cosine(s: Vec3, wi: Vec3) -> Vec3 {
    if wi.z.abs() < 1e-7 { Vec3::ZERO } else { s / wi.z.abs() }
}

impl Bsdf for HairSurface {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        per_cosine(self.at(wo).scattering(wo, wi), wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        // `ωo`'s angles, attenuations and lobe probabilities serve the direction, its density
        // and its value.
        let fibre = self.at(wo);
        let o = fibre.outgoing(wo);
        let probabilities = HairBsdf::lobe_probabilities(&o);
        let wi = fibre.sample_from(&o, &probabilities, u, uc);
        let pdf = fibre.lobes(&o, wi, &probabilities);
        let f = per_cosine(fibre.lobes(&o, wi, &o.attenuation), wi);
        (pdf > 0.0 && wi.z != 0.0).then_some(BsdfSample {
            wi,
            f,
            pdf,
            specular: false,
            transmission: wi.z * wo.z < 0.0,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.at(wo).density(wo, wi)
    }
}

/// Kajiya and Kay's fibre model (1989): a diffuse term proportional to cos θi (a Lambertian
/// cylinder's light, whatever the azimuth) and a specular cone around the mirror elevation
/// θi = −θo. The cone here is d'Eon's normalised longitudinal lobe with variance `1/exponent`
/// (Kajiya–Kay's `cos^p` as a distribution), spread uniformly in azimuth, so that the albedo
/// is at most `kd + ks`; the diffuse term `kd cos θi / π²` reflects exactly `kd`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KajiyaKay {
    /// Diffuse albedo.
    pub kd: Vec3,
    /// Specular albedo.
    pub ks: Vec3,
    /// Variance of the specular cone (1 / exponent).
    pub v: f32,
}

impl KajiyaKay {
    fn diffuse_probability(&self) -> f32 {
        let (d, s) = (self.kd.max_element(), self.ks.max_element());
        if d + s <= 0.0 { 1.0 } else { d / (d + s) }
    }

    fn angles(w: Vec3) -> (f32, f32) {
        let sin = w.x.clamp(-1.0, 1.0);
        (sin, (1.0 - sin * sin).max(0.0).sqrt())
    }

    /// The scattering function `S(ωo, ωi)`.
    pub fn scattering(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let ((sin_o, cos_o), (sin_i, cos_i)) = (Self::angles(wo), Self::angles(wi));
        self.kd * (cos_i * FRAC_1_PI * FRAC_1_PI) + self.ks * (longitudinal(cos_i, cos_o, sin_i, sin_o, self.v) / TAU)
    }

    fn density(&self, wo: Vec3, wi: Vec3) -> f32 {
        let ((sin_o, cos_o), (sin_i, cos_i)) = (Self::angles(wo), Self::angles(wi));
        let pd = self.diffuse_probability();
        pd * cos_i * FRAC_1_PI * FRAC_1_PI + (1.0 - pd) * longitudinal(cos_i, cos_o, sin_i, sin_o, self.v) / TAU
    }
}

impl Bsdf for KajiyaKay {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        per_cosine(self.scattering(wo, wi), wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        let pd = self.diffuse_probability();
        let (sin_i, phi) = if uc < pd {
            // sin θi as the abscissa of a uniform point of the disc has density ∝ cos θi.
            let d = lucid_scene::sampling::concentric_disk(u);
            (d.x, TAU * (uc / pd).min(1.0 - f32::EPSILON))
        } else {
            let (sin_o, cos_o) = Self::angles(wo);
            (
                sample_longitudinal(self.v, sin_o, cos_o, u),
                TAU * ((uc - pd) / (1.0 - pd)).clamp(0.0, 1.0 - f32::EPSILON),
            )
        };
        let cos_i = (1.0 - sin_i * sin_i).max(0.0).sqrt();
        let wi = Vec3::new(sin_i, cos_i * phi.cos(), cos_i * phi.sin());
        let pdf = self.density(wo, wi);
        (pdf > 0.0 && wi.z != 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
            specular: false,
            transmission: wi.z * wo.z < 0.0,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.density(wo, wi)
    }
}

#[cfg(test)]
mod tests;
