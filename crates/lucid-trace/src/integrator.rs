//! Unidirectional path tracing with next-event estimation, multiple importance sampling
//! (power heuristic) and Russian roulette.
//!
//! Path length follows Mitsuba's convention: `max_depth` counts path segments including the
//! camera ray, so 1 shows only emitters seen directly and 2 is direct illumination.

use glam::Vec3;
use lucid_scene::Ray;

use crate::bsdf::Bsdf;
use crate::geometry::Intersection;
use crate::sampling::{Rng, orthonormal_basis, power_heuristic};
use crate::scene::Scene;

/// Settings of the path tracer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathTracer {
    /// Longest path in segments (camera ray included).
    pub max_depth: u32,
    /// Russian roulette starts once a path has this many segments.
    pub rr_depth: u32,
    /// Do not show emitters (area lights, environment) to camera rays, so that the
    /// background stays transparent; they still light the scene.
    pub hide_emitters: bool,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self { max_depth: 8, rr_depth: 5, hide_emitters: false }
    }
}

/// What one camera path measured: radiance and the auxiliary buffers of its first hit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathSample {
    /// Radiance along the camera ray.
    pub radiance: Vec3,
    /// 1 if the camera ray hit geometry, else 0.
    pub alpha: f32,
    /// Distance along the camera ray to the first hit (0 if none).
    pub distance: f32,
    /// Shading normal at the first hit (world space).
    pub normal: Vec3,
    /// Albedo of the first hit's material.
    pub albedo: Vec3,
}

/// A local shading frame around a normal.
struct Frame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Frame {
    /// The frame around `n` whose x axis is `tangent` made orthogonal to it.
    fn new(n: Vec3, tangent: Vec3) -> Self {
        match (tangent - n * n.dot(tangent)).try_normalize() {
            Some(t) => Self { t, b: n.cross(t), n },
            None => {
                let (t, b) = orthonormal_basis(n);
                Self { t, b, n }
            }
        }
    }
    fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.t + v.y * self.b + v.z * self.n
    }
}

/// Starts a ray just off the surface, on the side `direction` leaves towards, so that it
/// does not hit the surface it starts on.
pub fn spawn(hit: &Intersection, direction: Vec3) -> Ray {
    let offset = 1e-4 * (1.0 + hit.point.abs().max_element());
    let side = if direction.dot(hit.geometric_normal) >= 0.0 { 1.0 } else { -1.0 };
    Ray { origin: hit.point + side * offset * hit.geometric_normal, direction }
}

impl PathTracer {
    /// Traces one camera path.
    pub fn trace(&self, scene: &Scene, camera_ray: Ray, rng: &mut Rng) -> PathSample {
        let mut out = PathSample::default();
        let mut ray = camera_ray;
        let mut beta = Vec3::ONE;
        let light_pick = if scene.lights.is_empty() { 0.0 } else { 1.0 / scene.lights.len() as f32 };
        // The previous vertex's BSDF pdf, for weighting emission found by BSDF sampling;
        // None after a specular bounce or for the camera ray.
        let mut prev_pdf: Option<f32> = None;
        let mut prev_point = ray.origin;
        let mut segments = 1;
        loop {
            let Some(hit) = scene.bvh.intersect(&ray, 0.0, f32::INFINITY) else {
                if let Some(env) = scene.environment
                    && !(segments == 1 && self.hide_emitters)
                    && let Some((radiance, env_pdf)) = scene.lights[env].environment(ray.direction)
                {
                    let weight = match prev_pdf {
                        Some(pdf) => power_heuristic(pdf, light_pick * env_pdf),
                        None => 1.0,
                    };
                    out.radiance += beta * radiance * weight;
                }
                break;
            };
            let primitive = &scene.bvh.primitives()[hit.primitive as usize];
            let material = &scene.materials[primitive.material as usize];
            if segments == 1 {
                out.alpha = 1.0;
                out.distance = hit.t;
                out.normal = hit.shading_normal;
                out.albedo = material.albedo(hit.uv);
            }
            // Emission seen along the path.
            if let Some(l) = primitive.light
                && !(segments == 1 && self.hide_emitters)
            {
                let light = &scene.lights[l as usize];
                let le = light.emitted(hit.geometric_normal, -ray.direction);
                if le != Vec3::ZERO {
                    let weight = match prev_pdf {
                        Some(pdf) => power_heuristic(
                            pdf,
                            light_pick * light.pdf_area(prev_point, hit.point, hit.geometric_normal),
                        ),
                        None => 1.0,
                    };
                    out.radiance += beta * le * weight;
                }
            }
            if segments >= self.max_depth {
                break;
            }
            let bsdf = material.bsdf(hit.uv);
            let frame = Frame::new(hit.shading_normal, hit.tangent);
            let wo = frame.to_local(-ray.direction);

            // Next-event estimation: one light, picked uniformly.
            if !bsdf.is_specular() && !scene.lights.is_empty() {
                let pick = ((rng.uniform() * scene.lights.len() as f32) as usize).min(scene.lights.len() - 1);
                let light = &scene.lights[pick];
                if let Some(ls) = light.sample(hit.point, rng.uniform2(), scene.bvh.primitives()) {
                    let wi = frame.to_local(ls.wi);
                    let f = bsdf.eval(wo, wi);
                    if f != Vec3::ZERO && ls.pdf > 0.0 {
                        let shadow = spawn(&hit, ls.wi);
                        let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-3) } else { f32::INFINITY };
                        if !scene.bvh.occluded(&shadow, 0.0, t_max) {
                            let light_pdf = light_pick * ls.pdf;
                            let weight = if ls.delta { 1.0 } else { power_heuristic(light_pdf, bsdf.pdf(wo, wi)) };
                            out.radiance += beta * f * wi.z.abs() * ls.li * weight / light_pdf;
                        }
                    }
                }
            }

            // Continue the path by sampling the BSDF.
            let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { break };
            if s.pdf <= 0.0 || s.f == Vec3::ZERO {
                break;
            }
            beta *= s.f * s.wi.z.abs() / s.pdf;
            prev_pdf = if s.specular { None } else { Some(s.pdf) };
            prev_point = hit.point;
            let direction = frame.to_world(s.wi).normalize();
            ray = spawn(&hit, direction);
            segments += 1;
            if segments > self.rr_depth {
                let q = beta.max_element().min(0.95);
                if rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
        }
        out
    }
}
