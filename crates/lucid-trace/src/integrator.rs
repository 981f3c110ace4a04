//! Unidirectional path tracing with next-event estimation, multiple importance sampling
//! (power heuristic) and Russian roulette.
//!
//! Participating media are homogeneous: a path flying through one samples a free-flight
//! distance and may scatter (phase-function sampling and next-event estimation with
//! transmittance) before reaching the next surface. Media fill the inside of closed meshes
//! (whose boundary is usually an index-matched `Interface`) or the whole scene.
//!
//! Path length follows Mitsuba's convention: `max_depth` counts path segments including the
//! camera ray, so 1 shows only emitters seen directly and 2 is direct illumination.

use glam::Vec3;
use lucid_scene::Ray;

use crate::bsdf::Bsdf;
use crate::geometry::{Intersection, Primitive};
use crate::light::LightSample;
use crate::material::Material;
use crate::sampling::{UniformSource, orthonormal_basis, power_heuristic};
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
    /// How emitters are found.
    pub strategy: LightStrategy,
}

/// How a path finds light: the three converge to the same image (a test checks it); MIS
/// has the least noise. Only next-event estimation reaches point, spot and directional
/// lights, which BSDF sampling never hits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightStrategy {
    /// Light sampling and BSDF sampling combined by the power heuristic.
    #[default]
    Mis,
    /// Light sampling only (emitters hit by BSDF samples count only after specular bounces).
    NextEventOnly,
    /// BSDF sampling only.
    BsdfOnly,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self { max_depth: 8, rr_depth: 5, hide_emitters: false, strategy: LightStrategy::Mis }
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
    /// Rays traced (closest-hit and shadow), for throughput reports.
    pub rays: u32,
}

/// A local shading frame around a normal.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub(crate) t: Vec3,
    pub(crate) b: Vec3,
    pub(crate) n: Vec3,
}

impl Frame {
    /// The frame around `n` whose x axis is `tangent` made orthogonal to it.
    pub(crate) fn new(n: Vec3, tangent: Vec3) -> Self {
        match (tangent - n * n.dot(tangent)).try_normalize() {
            Some(t) => Self { t, b: n.cross(t), n },
            None => {
                let (t, b) = orthonormal_basis(n);
                Self { t, b, n }
            }
        }
    }
    #[inline(always)]
    pub(crate) fn to_local(self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    #[inline(always)]
    pub(crate) fn to_world(self, v: Vec3) -> Vec3 {
        v.x * self.t + v.y * self.b + v.z * self.n
    }
}

/// Starts a ray just off the surface, on the side `direction` leaves towards, so that it
/// does not hit the surface it starts on.
pub fn spawn(hit: &Intersection, direction: Vec3) -> Ray {
    Ray { origin: spawn_origin(hit.point, hit.geometric_normal, direction), direction }
}

/// Where [`spawn`] starts a ray in `direction` from `point` on a surface with geometric
/// normal `normal`.
#[inline(always)]
pub(crate) fn spawn_origin(point: Vec3, normal: Vec3, direction: Vec3) -> Vec3 {
    let offset = 1e-4 * (1.0 + point.abs().max_element());
    let side = if direction.dot(normal) >= 0.0 { 1.0 } else { -1.0 };
    point + side * offset * normal
}

impl PathTracer {
    /// Traces one camera path.
    pub fn trace(&self, scene: &Scene, camera_ray: Ray, rng: &mut impl UniformSource) -> PathSample {
        let mut out = PathSample::default();
        let mut ray = camera_ray;
        let mut beta = Vec3::ONE;
        let light_pick = light_selection_probability(scene);
        // The previous vertex's BSDF or phase pdf, for weighting emission found by sampling
        // it; None after a specular bounce or for the camera ray.
        let mut prev_pdf: Option<f32> = None;
        let mut prev_point = ray.origin;
        let mut segments = 1;
        let mut medium = scene.global_medium;
        let mut crossings = 0;
        loop {
            let found = scene.bvh.intersect(&ray, 0.0, f32::INFINITY);
            out.rays += 1;

            // Flight through the current medium: maybe a scattering event before the surface.
            if let Some(m) = medium {
                let med = &scene.media[m as usize];
                let sample = med.sample_distance(found.map_or(f32::INFINITY, |h| h.t), rng);
                beta *= sample.weight;
                if beta == Vec3::ZERO {
                    break;
                }
                if let Some(t) = sample.scatter_at {
                    if segments >= self.max_depth {
                        break;
                    }
                    let point = ray.at(t);
                    let wo = -ray.direction;
                    if let Some((light_pdf, ls)) = self.pick_light(scene, point, light_pick, rng) {
                        let f = med.phase.eval(wo, ls.wi);
                        let tr =
                            self.transmittance(scene, Ray { origin: point, direction: ls.wi }, ls.distance, medium);
                        if tr != Vec3::ZERO {
                            let weight = self.light_sample_weight(ls.delta, light_pdf, f);
                            out.radiance += beta * f * tr * ls.li * weight / light_pdf;
                        }
                    }
                    // The phase function is sampled exactly: value/pdf = 1, beta is unchanged.
                    let (wi, pdf) = med.phase.sample(wo, rng.uniform2());
                    prev_pdf = Some(pdf);
                    prev_point = point;
                    ray = Ray { origin: point, direction: wi };
                    segments += 1;
                    if !self.russian_roulette(segments, &mut beta, rng) {
                        break;
                    }
                    continue;
                }
            }

            let Some(hit) = found else {
                if let Some(env) = scene.environment
                    && !(segments == 1 && self.hide_emitters)
                    && let Some((radiance, env_pdf)) = scene.lights[env].environment(ray.direction)
                {
                    let weight = self.emission_weight(prev_pdf, light_pick * env_pdf);
                    out.radiance += beta * radiance * weight;
                }
                break;
            };
            let primitive = &scene.bvh.primitives()[hit.primitive as usize];
            let material = &scene.materials[primitive.material as usize];
            if matches!(material, Material::Interface) {
                // An index-matched boundary of a medium: not a path vertex, only a change of medium.
                medium = medium_across(medium, primitive, ray.direction, &hit);
                ray = spawn(&hit, ray.direction);
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    break;
                }
                continue;
            }
            if segments == 1 && out.alpha == 0.0 {
                out.alpha = 1.0;
                out.distance = (hit.point - camera_ray.origin).dot(camera_ray.direction);
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
                    let weight = self.emission_weight(
                        prev_pdf,
                        light_pick * light.pdf_area(prev_point, hit.point, hit.geometric_normal),
                    );
                    out.radiance += beta * le * weight;
                }
            }
            if segments >= self.max_depth {
                break;
            }
            let bsdf = material.bsdf(hit.uv);
            let frame = Frame::new(hit.shading_normal, hit.tangent);
            let wo = frame.to_local(-ray.direction);

            // Next-event estimation.
            if !bsdf.is_specular() {
                let shadow_medium = |wi| medium_across(medium, primitive, wi, &hit);
                let (light, rays) =
                    self.direct_light(scene, &hit, &bsdf, frame, wo, beta, shadow_medium, light_pick, rng);
                out.radiance += light;
                out.rays += rays;
            }

            // Continue the path by sampling the BSDF.
            let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { break };
            if s.pdf <= 0.0 || s.f == Vec3::ZERO {
                break;
            }
            beta *= s.f * s.wi.z.abs() / s.pdf;
            if s.transmission
                && wo.z > 0.0
                && let Material::Subsurface { profile, .. } = material
            {
                // Refracted into a translucent object: the light comes out elsewhere.
                let Some((next, exit_point, pdf)) = self.leave_subsurface(
                    scene,
                    &hit,
                    primitive.material,
                    profile,
                    light_pick,
                    &mut beta,
                    &mut out,
                    rng,
                ) else {
                    break;
                };
                prev_pdf = Some(pdf);
                prev_point = exit_point;
                ray = next;
                segments += 2;
                if !self.russian_roulette(segments, &mut beta, rng) {
                    break;
                }
                continue;
            }
            prev_pdf = if s.specular { None } else { Some(s.pdf) };
            prev_point = hit.point;
            let direction = frame.to_world(s.wi).normalize();
            if s.transmission {
                medium = medium_across(medium, primitive, direction, &hit);
            }
            ray = spawn(&hit, direction);
            segments += 1;
            if !self.russian_roulette(segments, &mut beta, rng) {
                break;
            }
        }
        out
    }

    /// Next-event estimation at a surface point seen from `wo` (local) by a path of weight
    /// `beta`: one light sampled, its MIS-weighted `β·f·|cos θi|·Tr·Li / pdf` with shadow rays
    /// through `shadow_medium(direction)`, and the shadow rays traced.
    #[allow(clippy::too_many_arguments)]
    fn direct_light(
        &self,
        scene: &Scene,
        hit: &Intersection,
        bsdf: &impl Bsdf,
        frame: Frame,
        wo: Vec3,
        beta: Vec3,
        shadow_medium: impl Fn(Vec3) -> Option<u32>,
        light_pick: f32,
        rng: &mut impl UniformSource,
    ) -> (Vec3, u32) {
        let Some((light_pdf, ls)) = self.pick_light(scene, hit.point, light_pick, rng) else { return (Vec3::ZERO, 0) };
        let wi = frame.to_local(ls.wi);
        let f = bsdf.eval(wo, wi);
        if f == Vec3::ZERO {
            return (Vec3::ZERO, 0);
        }
        let tr = self.transmittance(scene, spawn(hit, ls.wi), ls.distance, shadow_medium(ls.wi));
        if tr == Vec3::ZERO {
            return (Vec3::ZERO, 1);
        }
        let weight = self.light_sample_weight(ls.delta, light_pdf, bsdf.pdf(wo, wi));
        (beta * f * wi.z.abs() * tr * ls.li * weight / light_pdf, 1)
    }

    /// The subsurface step after light refracted into `entry`: samples the exit point (its
    /// weight into `beta`), lights it by next-event estimation into `out`, and samples the
    /// exit direction: the ray to continue with, the exit point and the direction's density.
    #[allow(clippy::too_many_arguments)]
    fn leave_subsurface(
        &self,
        scene: &Scene,
        entry: &crate::geometry::Intersection,
        material: u32,
        profile: &crate::subsurface::SubsurfaceProfile,
        light_pick: f32,
        beta: &mut Vec3,
        out: &mut PathSample,
        rng: &mut impl UniformSource,
    ) -> Option<(Ray, Vec3, f32)> {
        let exit = crate::subsurface::sample_exit(scene, entry, material, profile, rng)?;
        out.rays += exit.rays;
        *beta *= exit.weight;
        if *beta == Vec3::ZERO {
            return None;
        }
        let hit = exit.hit;
        let bsdf = profile.exit;
        let frame = Frame::new(hit.shading_normal, hit.tangent);
        let global = |_| scene.global_medium;
        let (light, rays) = self.direct_light(scene, &hit, &bsdf, frame, Vec3::Z, *beta, global, light_pick, rng);
        out.radiance += light;
        out.rays += rays;
        let s = bsdf.sample(Vec3::Z, rng.uniform2(), rng.uniform())?;
        *beta *= s.f * s.wi.z / s.pdf;
        Some((spawn(&hit, frame.to_world(s.wi).normalize()), hit.point, s.pdf))
    }

    /// MIS weight of emission reached by sampling the previous vertex's BSDF or phase
    /// function with density `prev_pdf` (`None`: a specular bounce or the camera ray).
    pub(crate) fn emission_weight(&self, prev_pdf: Option<f32>, light_pdf: f32) -> f32 {
        match (self.strategy, prev_pdf) {
            (_, None) => 1.0,
            (LightStrategy::Mis, Some(pdf)) => power_heuristic(pdf, light_pdf),
            (LightStrategy::NextEventOnly, Some(_)) => 0.0,
            (LightStrategy::BsdfOnly, Some(_)) => 1.0,
        }
    }

    /// MIS weight of a light sample whose direction the BSDF would pick with `bsdf_pdf`.
    pub(crate) fn light_sample_weight(&self, delta: bool, light_pdf: f32, bsdf_pdf: f32) -> f32 {
        match self.strategy {
            _ if delta => 1.0,
            LightStrategy::Mis => power_heuristic(light_pdf, bsdf_pdf),
            LightStrategy::NextEventOnly => 1.0,
            LightStrategy::BsdfOnly => 0.0,
        }
    }

    /// Picks one light uniformly and samples it from `point`: `(selection × light pdf, sample)`.
    fn pick_light(
        &self,
        scene: &Scene,
        point: Vec3,
        light_pick: f32,
        rng: &mut impl UniformSource,
    ) -> Option<(f32, LightSample)> {
        if scene.lights.is_empty() || self.strategy == LightStrategy::BsdfOnly {
            return None;
        }
        let pick = pick_light_index(scene, rng);
        let ls = scene.lights[pick].sample(point, rng.uniform2())?;
        (ls.pdf > 0.0).then_some((light_pick * ls.pdf, ls))
    }

    /// Continues the path with probability `min(max β, 0.95)` once it is long enough,
    /// dividing β by that probability to stay unbiased; false ends the path.
    pub(crate) fn russian_roulette(&self, segments: u32, beta: &mut Vec3, rng: &mut impl UniformSource) -> bool {
        if segments <= self.rr_depth {
            return true;
        }
        let q = beta.max_element().min(0.95);
        if rng.uniform() >= q {
            return false;
        }
        *beta /= q;
        true
    }

    /// Fraction of light that arrives along `ray` from `distance` away: 0 if an opaque
    /// surface is in the way, else the product of the media's transmittances, crossing
    /// index-matched boundaries.
    fn transmittance(&self, scene: &Scene, mut ray: Ray, distance: f32, mut medium: Option<u32>) -> Vec3 {
        let mut remaining = if distance.is_finite() { distance * (1.0 - 1e-3) } else { f32::INFINITY };
        if !scene.has_media() {
            return if scene.bvh.occluded(&ray, 0.0, remaining) { Vec3::ZERO } else { Vec3::ONE };
        }
        let mut tr = Vec3::ONE;
        for _ in 0..MAX_CROSSINGS {
            let found = scene.bvh.intersect(&ray, 0.0, remaining);
            if let Some(m) = medium {
                tr *= scene.media[m as usize].transmittance(found.map_or(remaining, |h| h.t));
            }
            let Some(hit) = found else { return tr };
            let primitive = &scene.bvh.primitives()[hit.primitive as usize];
            if !matches!(scene.materials[primitive.material as usize], Material::Interface) || tr == Vec3::ZERO {
                return Vec3::ZERO;
            }
            medium = medium_across(medium, primitive, ray.direction, &hit);
            remaining -= hit.t;
            ray = spawn(&hit, ray.direction);
        }
        Vec3::ZERO
    }
}

/// The probability with which [`pick_light_index`] picks any one light (0 without lights).
pub(crate) fn light_selection_probability(scene: &Scene) -> f32 {
    if scene.lights.is_empty() { 0.0 } else { 1.0 / scene.lights.len() as f32 }
}

/// One of the scene's lights, uniformly (the scene must have one); one draw from `rng`.
#[inline]
pub(crate) fn pick_light_index(scene: &Scene, rng: &mut impl UniformSource) -> usize {
    ((rng.uniform() * scene.lights.len() as f32) as usize).min(scene.lights.len() - 1)
}

/// Bound on boundary crossings along one ray, against degenerate geometry.
const MAX_CROSSINGS: u32 = 256;

/// The medium a ray is in after crossing `primitive` in `direction`: its interior when
/// entering (against the outward geometric normal), the scene's outer medium when leaving;
/// unchanged for surfaces that bound no medium.
fn medium_across(current: Option<u32>, primitive: &Primitive, direction: Vec3, hit: &Intersection) -> Option<u32> {
    match primitive.interior_medium {
        Some(inside) if direction.dot(hit.geometric_normal) < 0.0 => Some(inside),
        Some(_) => primitive.exterior_medium,
        None => current,
    }
}
