//! Camera paths to their visible points and light paths from the lights: the two halves the
//! photon mapper and the many-light renderers (instant radiosity, lightcuts) share. A camera
//! path follows specular bounces to the non-specular surfaces it reaches (its visible points),
//! adding emitters it sees and one light sample of direct light at each; a light path reports
//! every non-specular surface it reaches with the power it carries there.

use glam::Vec3;
use lucid_scene::Ray;

use crate::bdpt::emission::{SceneSphere, sample_emission};
use crate::bdpt::vertex::importance_factor;
use crate::bsdf::Bsdf;
use crate::geometry::Intersection;
use crate::integrator::{Frame, spawn};
use crate::material::SurfaceBsdf;
use crate::render::RenderSettings;
use crate::sampling::Rng;
use crate::scene::Scene;

/// Visible points kept per pixel.
pub(crate) const SLOTS: usize = 3;

/// The seed of pass `pass` of a multi-pass render.
pub(crate) fn pass_seed(seed: u64, pass: u32) -> u64 {
    crate::sampling::mix(seed ^ (pass as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Lights picked uniformly for one-sample estimates: all of the scene's, or those a renderer
/// does not handle itself (lightcuts sums point and spot lights its own way).
pub(crate) struct LightChoice {
    indices: Vec<u32>,
}

impl LightChoice {
    /// Every light of `scene`.
    pub(crate) fn all(scene: &Scene) -> Self {
        Self { indices: (0..scene.lights.len() as u32).collect() }
    }

    /// The lights of `scene` for which `keep` holds.
    pub(crate) fn only(scene: &Scene, keep: impl Fn(&crate::light::Light) -> bool) -> Self {
        Self { indices: (0..scene.lights.len() as u32).filter(|&i| keep(&scene.lights[i as usize])).collect() }
    }

    fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The probability of each pick.
    fn probability(&self) -> f32 {
        1.0 / self.indices.len() as f32
    }

    /// One light, uniformly (one draw from `rng`; there must be one).
    fn pick(&self, rng: &mut Rng) -> usize {
        let n = self.indices.len();
        self.indices[((rng.uniform() * n as f32) as usize).min(n - 1)] as usize
    }
}

/// A non-specular surface a camera path reached.
#[derive(Clone, Copy)]
pub(crate) struct VisiblePoint {
    /// `pixel · SLOTS + slot`.
    pub(crate) slot: u32,
    pub(crate) point: Vec3,
    /// Geometric normal, for rays leaving the point.
    pub(crate) normal: Vec3,
    pub(crate) frame: Frame,
    pub(crate) wo: Vec3,
    pub(crate) bsdf: SurfaceBsdf,
    pub(crate) beta: Vec3,
    /// Width of a pixel at the point, along the path from the camera.
    pub(crate) footprint: f32,
    /// Path segments from the camera to the point.
    pub(crate) segments: u32,
    /// The light sample's estimate of direct light there (before `beta`).
    pub(crate) direct: Vec3,
}

/// What one pass's camera path gives a pixel.
#[derive(Default)]
pub(crate) struct CameraPass {
    pub(crate) sample: crate::integrator::PathSample,
    pub(crate) points: Vec<VisiblePoint>,
}

/// A camera path to its visible points: emitters seen directly or through specular bounces
/// and direct light at each visible point go to the sample's radiance.
pub(crate) fn camera_path(
    scene: &Scene,
    settings: &RenderSettings,
    lights: &LightChoice,
    camera_ray: Ray,
    pixel: u32,
    pixel_angle: f32,
    rng: &mut Rng,
) -> CameraPass {
    let mut out = CameraPass::default();
    let mut travelled = 0.0;
    let hide = settings.path.hide_emitters;
    let mut ray = camera_ray;
    let mut beta = Vec3::ONE;
    for segment in 1..=settings.path.max_depth {
        let found = scene.bvh.intersect(&ray, 0.0, f32::INFINITY);
        out.sample.rays += 1;
        let Some(hit) = found else {
            if let Some(env) = scene.environment
                && !(segment == 1 && hide)
                && let Some((radiance, _)) = scene.lights[env].environment(ray.direction)
            {
                out.sample.radiance += beta * radiance;
            }
            break;
        };
        travelled += hit.t;
        let primitive = &scene.bvh.primitives()[hit.primitive as usize];
        let material = &scene.materials[primitive.material as usize];
        if segment == 1 {
            out.sample.alpha = 1.0;
            out.sample.distance = hit.t;
            out.sample.normal = hit.shading_normal;
            out.sample.albedo = material.albedo(hit.uv);
        }
        if let Some(l) = primitive.light
            && !(segment == 1 && hide)
        {
            out.sample.radiance += beta * scene.lights[l as usize].emitted(hit.geometric_normal, -ray.direction);
        }
        let bsdf = material.bsdf(hit.uv);
        let frame = Frame::new(hit.shading_normal, hit.tangent);
        let wo = frame.to_local(-ray.direction);
        if !bsdf.is_specular() {
            let mut direct = Vec3::ZERO;
            if segment < settings.path.max_depth {
                direct = direct_light(scene, lights, &hit, &bsdf, frame, wo, rng, &mut out.sample.rays);
                out.sample.radiance += beta * direct;
            }
            if out.points.len() < SLOTS && segment < settings.path.max_depth {
                out.points.push(VisiblePoint {
                    slot: pixel * SLOTS as u32 + out.points.len() as u32,
                    point: hit.point,
                    normal: hit.geometric_normal,
                    frame,
                    wo,
                    bsdf,
                    beta,
                    footprint: (travelled * pixel_angle).max(1e-6),
                    segments: segment,
                    direct,
                });
            }
        }
        if segment >= settings.path.max_depth {
            break;
        }
        // Only specular lobes continue: the visible point stands for the rest.
        let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { break };
        if !s.specular || s.pdf <= 0.0 {
            break;
        }
        beta *= s.f * s.wi.z.abs() / s.pdf;
        if beta == Vec3::ZERO {
            break;
        }
        ray = spawn(&hit, frame.to_world(s.wi).normalize());
    }
    out
}

/// One light sample's direct light at a surface point, through the non-specular BSDF.
#[allow(clippy::too_many_arguments)]
fn direct_light(
    scene: &Scene,
    lights: &LightChoice,
    hit: &Intersection,
    bsdf: &SurfaceBsdf,
    frame: Frame,
    wo: Vec3,
    rng: &mut Rng,
    rays: &mut u32,
) -> Vec3 {
    if lights.is_empty() {
        return Vec3::ZERO;
    }
    let pick = lights.pick(rng);
    let Some(ls) = scene.lights[pick].sample(hit.point, rng.uniform2()) else { return Vec3::ZERO };
    if ls.pdf <= 0.0 {
        return Vec3::ZERO;
    }
    let wi = frame.to_local(ls.wi);
    let f = bsdf.eval(wo, wi);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    *rays += 1;
    let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-3) } else { f32::INFINITY };
    if scene.bvh.occluded(&spawn(hit, ls.wi), 0.0, t_max) {
        return Vec3::ZERO;
    }
    f * wi.z.abs() * ls.li / (ls.pdf * lights.probability())
}

/// A non-specular surface a light path reached.
pub(crate) struct LightVertex<'a> {
    /// Surfaces reached before this one along the path (0: lit directly by the light).
    pub(crate) bounce: u32,
    pub(crate) hit: &'a Intersection,
    pub(crate) bsdf: &'a SurfaceBsdf,
    pub(crate) frame: Frame,
    /// Unit direction towards where the light came from (world space).
    pub(crate) towards_light: Vec3,
    /// Power the path carries (an unbiased estimate of the flux when averaged over paths).
    pub(crate) beta: Vec3,
}

/// Traces one light path from a light picked uniformly, calling `deposit` at every
/// non-specular surface it reaches in fewer than `settings.path.max_depth` segments; returns
/// the rays traced.
pub(crate) fn trace_light_path(
    scene: &Scene,
    settings: &RenderSettings,
    sphere: SceneSphere,
    rng: &mut Rng,
    mut deposit: impl FnMut(&LightVertex),
) -> u32 {
    if scene.lights.is_empty() {
        return 0;
    }
    let pick_pdf = crate::integrator::light_selection_probability(scene);
    let pick = crate::integrator::pick_light_index(scene, rng);
    let Some(e) = sample_emission(&scene.lights[pick], sphere, rng.uniform2(), rng.uniform2()) else { return 0 };
    let mut beta = e.throughput(pick_pdf);
    let mut ray = e.ray();
    let mut rays = 0;
    // The camera path adds at least one segment to the photon's.
    for bounce in 0..settings.path.max_depth.saturating_sub(1) {
        let found = scene.bvh.intersect(&ray, 0.0, f32::INFINITY);
        rays += 1;
        let Some(hit) = found else { break };
        let primitive = &scene.bvh.primitives()[hit.primitive as usize];
        let bsdf = scene.materials[primitive.material as usize].bsdf(hit.uv);
        let towards_light = -ray.direction;
        let frame = Frame::new(hit.shading_normal, hit.tangent);
        if !bsdf.is_specular() {
            deposit(&LightVertex { bounce, hit: &hit, bsdf: &bsdf, frame, towards_light, beta });
        }
        let wo = frame.to_local(towards_light);
        let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { break };
        if s.pdf <= 0.0 || s.f == Vec3::ZERO {
            break;
        }
        let wi = frame.to_world(s.wi).normalize();
        let scattered = beta
            * bsdf.sample_value_adjoint(wo, &s)
            * s.wi.z.abs()
            * (importance_factor(&bsdf, frame, hit.geometric_normal, towards_light, wi, &s) / s.pdf);
        // Russian roulette by how much of its power the bounce kept.
        let q = (scattered.max_element() / beta.max_element()).min(1.0);
        if rng.uniform() >= q {
            break;
        }
        beta = scattered / q;
        ray = spawn(&hit, wi);
    }
    rays
}
