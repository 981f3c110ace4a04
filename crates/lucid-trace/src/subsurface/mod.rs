//! Subsurface scattering by a separable BSSRDF (as in pbrt-v3): light refracted into the
//! object at `po` leaves at a point `pi` drawn from the radial profile `Sr(|po − pi|)` of
//! [`profile`], in a direction drawn from the exit term `Sw(ω) = (1 − F(cos θ))/(c π)`
//! (`c` making it reflect all it receives). Exit points are found by probe rays (King et al.
//! 2013): a radius from one channel's profile, a disc around `po` perpendicular to one of
//! the shading frame's axes (the normal half of the time), and the segment through the
//! object at that radius; every crossing of the object's surface is a candidate, one is picked
//! uniformly, and its density sums all axes and channels (multiple importance sampling).

pub mod profile;

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

use crate::bsdf::fresnel::{average_fresnel_dielectric, fresnel_dielectric};
use crate::bsdf::{Bsdf, BsdfSample};
use crate::geometry::Intersection;
use crate::integrator::Frame;
use crate::sampling::{UniformSource, cosine_hemisphere, cosine_hemisphere_pdf};
use crate::scene::Scene;
use lucid_scene::Ray;
pub use profile::SubsurfaceProfile;

/// Crossings of the object a probe ray records at most.
const MAX_CANDIDATES: usize = 32;
/// Probability of probing along the normal; the two tangents share the rest.
const NORMAL_AXIS: f32 = 0.5;

/// Where light left the object, and the weight `Sr/pdf` of that choice.
pub struct SubsurfaceExit {
    /// The exit point.
    pub hit: Intersection,
    /// `Sr(|po − pi|) / pdf(pi)`.
    pub weight: Vec3,
    /// Probe rays traced.
    pub rays: u32,
}

/// The frame's axes in probing order: the normal, then the two tangents.
fn axes(frame: &Frame) -> [(Vec3, Vec3, Vec3, f32); 3] {
    let tangent = 0.5 * (1.0 - NORMAL_AXIS);
    [
        (frame.t, frame.b, frame.n, NORMAL_AXIS),
        (frame.b, frame.n, frame.t, tangent),
        (frame.n, frame.t, frame.b, tangent),
    ]
}

/// Samples the exit point of light that entered at `entry` (material `material` of the scene,
/// with profile `profile`); `None` when the probe found no surface.
pub fn sample_exit(
    scene: &Scene,
    entry: &Intersection,
    material: u32,
    profile: &SubsurfaceProfile,
    rng: &mut impl UniformSource,
) -> Option<SubsurfaceExit> {
    let frame = Frame::new(entry.shading_normal, entry.tangent);
    let u = rng.uniform();
    let (x, y, z, _) = if u < NORMAL_AXIS {
        axes(&frame)[0]
    } else if u < NORMAL_AXIS + 0.5 * (1.0 - NORMAL_AXIS) {
        axes(&frame)[1]
    } else {
        axes(&frame)[2]
    };
    let channel = ((rng.uniform() * 3.0) as usize).min(2);
    let table = &profile.channels[channel];
    let r = table.sample(rng.uniform());
    let r_max = table.r_max();
    if r >= r_max {
        return None;
    }
    let phi = TAU * rng.uniform();
    let half = (r_max * r_max - r * r).sqrt();
    let origin = entry.point + r * (phi.cos() * x + phi.sin() * y) - half * z;
    let probe = Ray { origin, direction: z };
    let mut candidates: Vec<Intersection> = Vec::new();
    let mut t = 0.0;
    let mut rays = 0;
    let epsilon = 1e-5 * (1.0 + entry.point.abs().max_element());
    while candidates.len() < MAX_CANDIDATES {
        rays += 1;
        let Some(hit) = scene.bvh.intersect(&probe, t, 2.0 * half) else { break };
        if scene.bvh.primitives()[hit.primitive as usize].material == material {
            candidates.push(hit);
        }
        t = hit.t + epsilon;
    }
    if candidates.is_empty() {
        return None;
    }
    let k = ((rng.uniform() * candidates.len() as f32) as usize).min(candidates.len() - 1);
    let exit = candidates.swap_remove(k);
    let found = candidates.len() + 1;
    let pdf = exit_density(entry, &frame, &exit, profile) / found as f32;
    if pdf <= 0.0 {
        return None;
    }
    let weight = profile.value((exit.point - entry.point).length()) / pdf;
    Some(SubsurfaceExit { hit: exit, weight, rays })
}

/// Density per unit area of the probe choosing `exit` (before the uniform pick among the
/// crossings): every axis and channel that could have produced it.
fn exit_density(entry: &Intersection, frame: &Frame, exit: &Intersection, profile: &SubsurfaceProfile) -> f32 {
    let d = exit.point - entry.point;
    let mut pdf = 0.0;
    for (_, _, z, p_axis) in axes(frame) {
        let r = (d - d.dot(z) * z).length();
        let cos = exit.geometric_normal.dot(z).abs();
        // A channel's probes reach only the ball of its largest radius around the entry.
        for table in profile.channels.iter().filter(|t| d.length() < t.r_max()) {
            pdf += p_axis / 3.0 * table.density(r) * cos;
        }
    }
    pdf
}

/// The direction term at the exit point, `η² (1 − F(cos θi)) / (c π)` towards the outside
/// (the η² undoes the 1/η² the entering refraction applied to radiance); sampled by the cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubsurfaceExitBsdf {
    eta: f32,
    scale: f32,
}

impl SubsurfaceExitBsdf {
    /// For a boundary of relative index `eta`.
    pub fn new(eta: f32) -> Self {
        let c = 1.0 - average_fresnel_dielectric(eta);
        Self { eta, scale: eta * eta / (c * std::f32::consts::PI) }
    }
}

impl Bsdf for SubsurfaceExitBsdf {
    fn eval(&self, _wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        Vec3::splat(self.scale * (1.0 - fresnel_dielectric(wi.z, self.eta)))
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        let wi = cosine_hemisphere(u);
        let pdf = cosine_hemisphere_pdf(wi.z);
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.eval(wo, wi), pdf, specular: false, transmission: false })
    }

    fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
        if wi.z <= 0.0 { 0.0 } else { wi.z * FRAC_1_PI }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::testing::albedo_by_sampling;

    #[test]
    fn the_exit_term_passes_on_what_the_entry_let_in() {
        // Its albedo is η²: the 1/η² of the entering refraction back.
        for eta in [1.0f32, 1.33, 1.5] {
            let exit = SubsurfaceExitBsdf::new(eta);
            let albedo = albedo_by_sampling(&exit, Vec3::Z, 400_000).x;
            assert!((albedo - eta * eta).abs() < 0.01 * eta * eta, "η {eta}: {albedo}");
        }
    }
}
