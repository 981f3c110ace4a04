//! Homogeneous participating media: Beer–Lambert transmittance, free-flight distance
//! sampling and the Henyey–Greenstein phase function.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use crate::sampling::{UniformSource, orthonormal_basis};

/// The Henyey–Greenstein phase function with asymmetry `g ∈ (−1, 1)` (positive: forward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine of the scattering angle.
    pub g: f32,
}

impl HenyeyGreenstein {
    /// Density of scattering by the angle whose cosine is `cos` (between the direction of
    /// travel before and after), per steradian: `(1−g²) / (4π (1 + g² − 2g cos)^{3/2})`.
    pub fn p(&self, cos: f32) -> f32 {
        let g = self.g;
        let denom = 1.0 + g * g - 2.0 * g * cos;
        (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
    }

    /// Value (= density) for `wo` (towards the eye, where the light goes next) and `wi`
    /// (towards where the light comes from); both point away from the scattering point.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        // Light travels along −wi before and along wo after the event.
        self.p((-wi).dot(wo))
    }

    /// Samples `wi` given `wo`, returning it with its density (equal to the value).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> (Vec3, f32) {
        let g = self.g;
        // Invert the HG cumulative distribution of the scattering angle's cosine.
        let cos = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.x
        } else {
            let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
            ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        // −wi (the light's direction of travel before the event) makes the angle θ with wo.
        let (t, b) = orthonormal_basis(wo);
        let wi = -(sin * phi.cos() * t + sin * phi.sin() * b + cos * wo);
        (wi, self.p(cos))
    }
}

/// A medium with constant absorption and scattering coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousMedium {
    /// Absorption coefficient σa (per unit length).
    pub sigma_a: Vec3,
    /// Scattering coefficient σs (per unit length).
    pub sigma_s: Vec3,
    /// Phase function.
    pub phase: HenyeyGreenstein,
}

/// The outcome of sampling a free-flight distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediumSample {
    /// Distance to a scattering event, or `None` if the flight reached `t_max`.
    pub scatter_at: Option<f32>,
    /// Throughput weight of the sampled segment (transmittance × σs over the density).
    pub weight: Vec3,
}

impl HomogeneousMedium {
    /// Extinction σt = σa + σs.
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_a + self.sigma_s
    }

    /// Beer–Lambert transmittance over a distance.
    pub fn transmittance(&self, distance: f32) -> Vec3 {
        if distance.is_infinite() {
            return Vec3::select(self.sigma_t().cmpgt(Vec3::ZERO), Vec3::ZERO, Vec3::ONE);
        }
        (-self.sigma_t() * distance).exp()
    }

    /// Samples where along `(0, t_max)` the ray first scatters. A colour channel is chosen
    /// uniformly and the distance drawn from its exponential; the density is the average over
    /// channels (single-sample MIS over channels, as pbrt does), so the weight is unbiased.
    pub fn sample_distance(&self, t_max: f32, rng: &mut impl UniformSource) -> MediumSample {
        let sigma_t = self.sigma_t();
        let channel = ((rng.uniform() * 3.0) as usize).min(2);
        let s = sigma_t[channel];
        let t = if s > 0.0 { -(1.0 - rng.uniform()).ln() / s } else { f32::INFINITY };
        if t < t_max {
            let tr = (-sigma_t * t).exp();
            let density = (sigma_t * tr).dot(Vec3::splat(1.0 / 3.0));
            if density <= 0.0 {
                return MediumSample { scatter_at: None, weight: Vec3::ZERO };
            }
            MediumSample { scatter_at: Some(t), weight: tr * self.sigma_s / density }
        } else {
            let tr = self.transmittance(t_max);
            let probability = tr.dot(Vec3::splat(1.0 / 3.0));
            let weight = if probability > 0.0 { tr / probability } else { Vec3::ZERO };
            MediumSample { scatter_at: None, weight }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, UNIFORM_SPHERE_PDF, uniform_sphere};

    #[test]
    fn hg_is_normalised_and_its_mean_cosine_is_g() {
        for g in [-0.7f32, 0.0, 0.3, 0.9] {
            let hg = HenyeyGreenstein { g };
            let wo = Vec3::new(0.3, -0.4, 0.866).normalize();
            let mut rng = Rng::new(1, 0);
            let n = 400_000;
            let (mut integral, mut mean_cos) = (0.0f64, 0.0f64);
            for _ in 0..n {
                integral += (hg.eval(wo, uniform_sphere(rng.uniform2())) / UNIFORM_SPHERE_PDF) as f64;
                let (wi, pdf) = hg.sample(wo, rng.uniform2());
                assert!((pdf - hg.eval(wo, wi)).abs() < 1e-3 * pdf.max(1.0), "g {g}");
                // Cosine between the travel directions before (−wi) and after (wo).
                mean_cos += (-wi).dot(wo) as f64;
            }
            let tolerance = if g.abs() > 0.8 { 0.05 } else { 0.01 };
            assert!((integral / n as f64 - 1.0).abs() < tolerance, "g {g}: ∫p = {}", integral / n as f64);
            assert!((mean_cos / n as f64 - g as f64).abs() < 0.01, "g {g}: mean cos {}", mean_cos / n as f64);
        }
    }

    #[test]
    fn distance_sampling_is_unbiased_for_transmittance_and_collision_density() {
        // E[weight · 1{no scatter}] = T(t_max), and E[weight/σs · 1{scatter before d}] is
        // ∫₀^d T(t) dt = (1 − e^{−σt d})/σt per channel.
        let m = HomogeneousMedium {
            sigma_a: Vec3::new(0.2, 0.5, 1.0),
            sigma_s: Vec3::new(0.6, 0.3, 0.1),
            phase: HenyeyGreenstein { g: 0.0 },
        };
        let (t_max, d) = (2.0f32, 0.7f32);
        let mut rng = Rng::new(2, 0);
        let n = 1_000_000;
        let (mut tr, mut collision) = (Vec3::ZERO, Vec3::ZERO);
        for _ in 0..n {
            let s = m.sample_distance(t_max, &mut rng);
            match s.scatter_at {
                None => tr += s.weight,
                Some(t) if t < d => collision += s.weight / m.sigma_s,
                Some(_) => {}
            }
        }
        let (tr, collision) = (tr / n as f32, collision / n as f32);
        let expected_tr = m.transmittance(t_max);
        let st = m.sigma_t();
        let expected_collision = (Vec3::ONE - (-st * d).exp()) / st;
        assert!(((tr - expected_tr) / expected_tr).abs().max_element() < 0.01, "{tr} vs {expected_tr}");
        assert!(
            ((collision - expected_collision) / expected_collision).abs().max_element() < 0.01,
            "{collision} vs {expected_collision}"
        );
    }
}
