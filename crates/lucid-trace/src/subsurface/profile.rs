//! The radial reflectance profile of a semi-infinite scattering slab under a pencil beam:
//! Jensen et al.'s dipole (2001) for multiple scattering, as the reference notes give it, plus
//! single scattering along the refracted beam. Both are per unit area of the exit point (their
//! integral over the plane is the slab's diffuse reflectance), per colour channel, and are
//! tabulated once per material so that exit radii can be sampled by inverting their
//! cumulative distribution.

use glam::Vec3;
use std::f32::consts::PI;

use crate::bsdf::fresnel::fresnel_dielectric;

/// Cells of the tabulated profile.
const CELLS: usize = 512;
/// Depth steps of the single-scattering integral.
const DEPTH_STEPS: usize = 64;

/// One channel's scattering coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// Absorption σa (per unit length).
    pub sigma_a: f32,
    /// Reduced scattering σs′ = σs (1 − g) (per unit length).
    pub sigma_s: f32,
}

impl Coefficients {
    fn sigma_t(&self) -> f32 {
        self.sigma_a + self.sigma_s
    }
}

/// The dipole's boundary term `A = (1 + Fdr)/(1 − Fdr)`, from the internal diffuse Fresnel
/// reflectance `Fdr` (Egan and Hilgeman's fit).
fn boundary_mismatch(eta: f32) -> f32 {
    let fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    (1.0 + fdr) / (1.0 - fdr)
}

/// The dipole's diffuse reflectance at distance `r` from the entry point (Jensen et al. 2001):
/// a real source at depth `z_r = 1/σt′` and its mirror image at `z_v = z_r + 4AD` above the
/// extrapolated boundary, `A = (1 + Fdr)/(1 − Fdr)` from the internal diffuse Fresnel
/// reflectance, `D = 1/(3σt′)`, `σtr = √(3 σa σt′)`.
pub fn dipole(c: Coefficients, eta: f32, r: f32) -> f32 {
    let sigma_t = c.sigma_t();
    if sigma_t <= 0.0 {
        return 0.0;
    }
    let albedo = c.sigma_s / sigma_t;
    let sigma_tr = (3.0 * c.sigma_a * sigma_t).sqrt();
    let a = boundary_mismatch(eta);
    let z_r = 1.0 / sigma_t;
    let z_v = z_r + 4.0 * a / (3.0 * sigma_t);
    let d_r = (r * r + z_r * z_r).sqrt();
    let d_v = (r * r + z_v * z_v).sqrt();
    let term = |z: f32, d: f32| z * (sigma_tr * d + 1.0) * (-sigma_tr * d).exp() / (d * d * d);
    albedo / (4.0 * PI) * (term(z_r, d_r) + term(z_v, d_v))
}

/// The dipole's total diffuse reflectance `∫ Rd(r) 2πr dr` in closed form.
pub fn dipole_total(c: Coefficients, eta: f32) -> f32 {
    let sigma_t = c.sigma_t();
    if sigma_t <= 0.0 {
        return 0.0;
    }
    let albedo = c.sigma_s / sigma_t;
    let a = boundary_mismatch(eta);
    let s = (3.0 * (1.0 - albedo)).sqrt();
    0.5 * albedo * (1.0 + (-4.0 / 3.0 * a * s).exp()) * (-s).exp()
}

/// Light scattered once (isotropically) by a beam entering along the normal, leaving at
/// distance `r`: `∫ σs e^{−σt t} (1/4π) e^{−σt d} cos θ/d² (1 − F(cos θ)) dt` over the depth `t`
/// of the scattering, `d = √(r² + t²)`, `cos θ = t/d` the exit angle inside (F from inside:
/// total internal reflection beyond the critical angle). Depths are importance sampled by
/// `e^{−σt t}` at fixed quantiles.
pub fn single_scattering(c: Coefficients, eta: f32, r: f32) -> f32 {
    let sigma_t = c.sigma_t();
    if sigma_t <= 0.0 || c.sigma_s <= 0.0 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..DEPTH_STEPS {
        let t = -(1.0 - (i as f32 + 0.5) / DEPTH_STEPS as f32).ln() / sigma_t;
        let d = (r * r + t * t).sqrt();
        let cos = t / d;
        let transmit = 1.0 - fresnel_dielectric(-cos, eta);
        sum += (-sigma_t * d).exp() * cos / (d * d) * transmit;
    }
    c.sigma_s / sigma_t / (4.0 * PI) * sum / DEPTH_STEPS as f32
}

/// One channel's profile, tabulated on radii that crowd near the entry point.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelProfile {
    /// Cell edges, `r_k = r_max (k/n)²`.
    edges: Vec<f32>,
    /// Each cell's share of the total, cumulated.
    cdf: Vec<f32>,
    /// `∫ Sr 2πr dr` over the table: the channel's diffuse reflectance.
    total: f32,
}

impl ChannelProfile {
    /// Tabulates `Sr = dipole + single scattering` out to where the dipole has fallen by
    /// e^{−16} (and at least 32 mean free paths).
    pub fn new(c: Coefficients, eta: f32) -> Self {
        let sigma_t = c.sigma_t().max(1e-6);
        let sigma_tr = (3.0 * c.sigma_a * sigma_t).sqrt();
        let r_max = (16.0 / sigma_tr.max(1e-6)).min(1000.0 / sigma_t).max(32.0 / sigma_t);
        let edges: Vec<f32> = (0..=CELLS).map(|k| r_max * (k as f32 / CELLS as f32).powi(2)).collect();
        // Each cell's mass by the midpoint rule on a 4-point subdivision.
        let mut masses = Vec::with_capacity(CELLS);
        for k in 0..CELLS {
            let (a, b) = (edges[k], edges[k + 1]);
            let mut mass = 0.0;
            for j in 0..4 {
                let r = a + (b - a) * (j as f32 + 0.5) / 4.0;
                mass += (dipole(c, eta, r) + single_scattering(c, eta, r)) * 2.0 * PI * r * (b - a) / 4.0;
            }
            masses.push(mass as f64);
        }
        let total: f64 = masses.iter().sum();
        let mut cdf = Vec::with_capacity(CELLS + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for m in &masses {
            acc += m;
            cdf.push(if total > 0.0 { (acc / total) as f32 } else { 0.0 });
        }
        Self { edges, cdf, total: total as f32 }
    }

    /// `∫ Sr 2πr dr`.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// The largest radius of the table.
    pub fn r_max(&self) -> f32 {
        *self.edges.last().expect("cells")
    }

    fn cell_of(&self, r: f32) -> Option<usize> {
        if !(r >= 0.0 && r < self.r_max()) {
            return None;
        }
        Some((self.edges.partition_point(|&e| e <= r) - 1).min(CELLS - 1))
    }

    /// The profile `Sr(r)` as tabulated: constant `Sr·r` within a cell.
    pub fn value(&self, r: f32) -> f32 {
        self.density(r) * self.total
    }

    /// Density per unit area of the plane of sampling radius `r` (and a uniform angle).
    pub fn density(&self, r: f32) -> f32 {
        let Some(k) = self.cell_of(r) else { return 0.0 };
        let (a, b) = (self.edges[k], self.edges[k + 1]);
        let share = self.cdf[k + 1] - self.cdf[k];
        if share <= 0.0 || r <= 0.0 {
            return 0.0;
        }
        share / (b - a) / (2.0 * PI * r)
    }

    /// A radius with density [`ChannelProfile::density`]·2πr.
    pub fn sample(&self, u: f32) -> f32 {
        let k = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(CELLS - 1);
        let share = self.cdf[k + 1] - self.cdf[k];
        let f = if share > 0.0 { ((u - self.cdf[k]) / share).clamp(0.0, 1.0) } else { 0.5 };
        self.edges[k] + f * (self.edges[k + 1] - self.edges[k])
    }
}

/// The three channels' profiles of a subsurface material.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsurfaceProfile {
    /// Per channel.
    pub channels: [ChannelProfile; 3],
    /// Relative index of refraction of the boundary.
    pub eta: f32,
    /// The direction term at exit points (its normalisation integrates the Fresnel term:
    /// worked out once here rather than at every exit).
    pub exit: super::SubsurfaceExitBsdf,
}

impl SubsurfaceProfile {
    /// Tabulates the profiles of absorption `sigma_a` and reduced scattering `sigma_s`.
    pub fn new(sigma_a: Vec3, sigma_s: Vec3, eta: f32) -> Self {
        let channel = |i: usize| ChannelProfile::new(Coefficients { sigma_a: sigma_a[i], sigma_s: sigma_s[i] }, eta);
        Self { channels: [channel(0), channel(1), channel(2)], eta, exit: super::SubsurfaceExitBsdf::new(eta) }
    }

    /// `Sr(r)` per channel.
    pub fn value(&self, r: f32) -> Vec3 {
        Vec3::new(self.channels[0].value(r), self.channels[1].value(r), self.channels[2].value(r))
    }

    /// Diffuse reflectance per channel.
    pub fn total(&self) -> Vec3 {
        Vec3::new(self.channels[0].total(), self.channels[1].total(), self.channels[2].total())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dipole_integrates_to_its_closed_form() {
        for (sigma_a, sigma_s, eta) in [(0.1f32, 10.0f32, 1.33f32), (1.0, 5.0, 1.5), (0.01, 2.0, 1.0)] {
            let c = Coefficients { sigma_a, sigma_s };
            // Trapezoid on a fine quadratic grid.
            let r_max = 60.0 / (3.0 * sigma_a * (sigma_a + sigma_s)).sqrt();
            let n = 200_000;
            let mut sum = 0.0f64;
            for k in 0..n {
                let (a, b) = (r_max * (k as f32 / n as f32).powi(2), r_max * ((k + 1) as f32 / n as f32).powi(2));
                let r = 0.5 * (a + b);
                sum += (dipole(c, eta, r) * 2.0 * PI * r * (b - a)) as f64;
            }
            let closed = dipole_total(c, eta) as f64;
            assert!((sum - closed).abs() < 2e-3 * closed, "σa {sigma_a} σs′ {sigma_s} η {eta}: {sum} vs {closed}");
        }
    }

    #[test]
    fn the_table_keeps_the_profile_and_samples_its_density() {
        let c = Coefficients { sigma_a: 0.2, sigma_s: 8.0 };
        let p = ChannelProfile::new(c, 1.33);
        // The total: dipole's closed form plus single scattering.
        let dipole_part = dipole_total(c, 1.33);
        assert!(p.total() > dipole_part && p.total() < dipole_part + 0.1, "{} vs {dipole_part}", p.total());
        // Values follow the formulas away from the entry point (cells are fine there).
        for r in [0.05f32, 0.2, 0.8, 2.0] {
            let exact = dipole(c, 1.33, r) + single_scattering(c, 1.33, r);
            assert!((p.value(r) - exact).abs() < 0.03 * exact, "r {r}: {} vs {exact}", p.value(r));
        }
        // The sampler's histogram of radii matches the density (10 bins of equal probability).
        let mut rng = crate::sampling::Rng::new(3, 0);
        let n = 20_000;
        let mut counts = [0usize; 10];
        for _ in 0..n {
            let r = p.sample(rng.uniform());
            // Probability below r, by integrating the density.
            // On a grid that crowds near 0 as the table's cells do.
            let steps = 2000;
            let mut below = 0.0;
            for k in 0..steps {
                let (a, b) = (r * (k as f32 / steps as f32).powi(2), r * ((k + 1) as f32 / steps as f32).powi(2));
                let x = 0.5 * (a + b);
                below += p.density(x) * 2.0 * PI * x * (b - a);
            }
            counts[((below * 10.0) as usize).min(9)] += 1;
        }
        for c in counts {
            assert!((c as f64 - n as f64 / 10.0).abs() < 0.06 * n as f64 / 10.0, "{counts:?}");
        }
    }

    #[test]
    fn more_absorption_reflects_less_and_nearer() {
        let weak = ChannelProfile::new(Coefficients { sigma_a: 0.05, sigma_s: 10.0 }, 1.33);
        let strong = ChannelProfile::new(Coefficients { sigma_a: 2.0, sigma_s: 10.0 }, 1.33);
        assert!(weak.total() > strong.total());
        let median = |p: &ChannelProfile| p.sample(0.5);
        assert!(median(&weak) > 2.0 * median(&strong), "{} vs {}", median(&weak), median(&strong));
    }
}
