//! Bidirectional path tracing (Veach 1997, ch. 10; pbrt-v3's `BDPTIntegrator`): a camera
//! subpath and a light subpath per sample, every connection strategy (s light vertices,
//! t camera vertices) including light paths reaching the lens (t = 1, splatted to the film)
//! and camera paths hitting emitters (s = 0), weighted by the power heuristic over all
//! strategies that could have made the same path. Light tracing alone (`t = 1` only, plus
//! emitters seen directly) is the same machinery without MIS.
//!
//! Surfaces only: scenes with participating media are refused by
//! [`crate::render::Integrator::supports`] before a render starts.

mod camera;
pub(crate) mod emission;
mod film;
mod mis;
pub(crate) mod vertex;

use glam::{Vec2, Vec3};
use lucid_scene::Ray;

pub(crate) use camera::CameraImportance;
pub(crate) use film::{FixedRgb, SplatFilm};

use crate::bsdf::Bsdf;
use crate::integrator::{
    Frame, PathSample, PathTracer, light_selection_probability, pick_light_index, spawn, spawn_origin,
};
use crate::sampling::Rng;
use crate::scene::Scene;
use emission::{SceneSphere, sample_emission, sample_point_on};
use vertex::{Context, Transport, Vertex, VertexKind, distant_light_density, importance_factor};

/// Which strategies a bidirectional sample uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Strategies {
    /// All of them, weighted by the power heuristic.
    All,
    /// Light paths connected to the lens (t = 1), and emitters seen directly, unweighted.
    LightTracing,
}

/// Reused subpath buffers (one per worker).
#[derive(Default)]
pub(crate) struct Subpaths {
    camera: Vec<Vertex>,
    light: Vec<Vertex>,
}

/// A bidirectional sampler for one scene and camera.
pub(crate) struct Bidirectional<'a> {
    ctx: Context<'a>,
    max_depth: u32,
    rr_depth: u32,
    hide_emitters: bool,
    strategies: Strategies,
}

impl<'a> Bidirectional<'a> {
    pub(crate) fn new(scene: &'a Scene, camera: CameraImportance, path: &PathTracer, strategies: Strategies) -> Self {
        let ctx = Context {
            scene,
            camera,
            sphere: SceneSphere::around(scene),
            light_pick: light_selection_probability(scene),
        };
        Self { ctx, max_depth: path.max_depth, rr_depth: path.rr_depth, hide_emitters: path.hide_emitters, strategies }
    }

    /// One sample through the camera ray `ray`: returns what reaches the camera along it
    /// (with the first hit's buffers) and splats light paths that reach the lens to `film`.
    pub(crate) fn sample(&self, ray: Ray, rng: &mut Rng, film: &SplatFilm, paths: &mut Subpaths) -> PathSample {
        let mut out = PathSample::default();
        let max_vertices = self.max_depth as usize + 1;
        let (cam, lig) = (&mut paths.camera, &mut paths.light);
        cam.clear();
        lig.clear();
        cam.push(Vertex::camera(ray.origin, Vec3::ONE));
        let pdf_dir = self.ctx.camera.pdf(ray.origin, ray.direction).1;
        self.random_walk(ray, Vec3::ONE, pdf_dir, max_vertices, Transport::Radiance, rng, cam, &mut out);
        self.light_subpath(max_vertices - 1, rng, lig, &mut out);

        for t in 1..=cam.len() {
            for s in 0..=lig.len() {
                if (s == 1 && t == 1) || s + t < 2 || s + t - 1 > self.max_depth as usize {
                    continue;
                }
                if self.strategies == Strategies::LightTracing && !(t == 1 || (s == 0 && t == 2)) {
                    continue;
                }
                if self.hide_emitters && s == 0 && t == 2 {
                    continue;
                }
                let (radiance, raster) = self.connect(cam, lig, s, t, rng, &mut out.rays);
                if t == 1 {
                    film.add(raster, radiance);
                } else {
                    out.radiance += radiance;
                }
            }
        }
        out
    }

    /// Starts a light subpath of at most `max_vertices` vertices at a uniformly picked light.
    fn light_subpath(&self, max_vertices: usize, rng: &mut Rng, path: &mut Vec<Vertex>, out: &mut PathSample) {
        let scene = self.ctx.scene;
        if scene.lights.is_empty() || max_vertices == 0 {
            return;
        }
        let pick = pick_light_index(scene, rng);
        let Some(e) = sample_emission(&scene.lights[pick], self.ctx.sphere, rng.uniform2(), rng.uniform2()) else {
            return;
        };
        path.push(Vertex::light(pick as u32, e.origin, e.normal, e.le, e.pdf_pos * self.ctx.light_pick));
        self.random_walk(
            e.ray(),
            e.throughput(self.ctx.light_pick),
            e.pdf_dir,
            max_vertices,
            Transport::Importance,
            rng,
            path,
            out,
        );
        if path[0].is_distant_light(&self.ctx) {
            // The walk converted the first hit's density from the disk's solid angle as if
            // from a point; a distant light's is the disk's area density projected.
            if let Some(first) = path.get_mut(1) {
                first.pdf_fwd =
                    e.pdf_pos * if first.is_on_surface() { first.normal.dot(e.direction).abs() } else { 1.0 };
            }
            path[0].pdf_fwd = distant_light_density(&self.ctx, -e.direction);
        }
    }

    /// Extends `path` (which holds its first vertex) by sampling BSDFs until it has
    /// `max_vertices` vertices or ends; camera paths that escape end on the environment.
    #[allow(clippy::too_many_arguments)]
    fn random_walk(
        &self,
        mut ray: Ray,
        mut beta: Vec3,
        pdf_dir: f32,
        max_vertices: usize,
        mode: Transport,
        rng: &mut Rng,
        path: &mut Vec<Vertex>,
        out: &mut PathSample,
    ) {
        let scene = self.ctx.scene;
        let mut pdf_fwd = pdf_dir;
        // Russian roulette on the throughput relative to the start (light paths start at the
        // light's power, not 1). The MIS weights ignore it, as pbrt's and Mitsuba's do: they
        // are still a partition of unity over the strategies, and each strategy divides by
        // its survival probabilities, so the estimate stays unbiased.
        let start = beta.max_element();
        while path.len() < max_vertices && beta != Vec3::ZERO {
            let found = scene.bvh.intersect(&ray, 0.0, f32::INFINITY);
            out.rays += 1;
            let Some(hit) = found else {
                if mode == Transport::Radiance
                    && let Some(env) = scene.environment
                {
                    path.push(Vertex::light(env as u32, ray.origin + ray.direction, Vec3::ZERO, beta, pdf_fwd));
                }
                break;
            };
            let primitive = &scene.bvh.primitives()[hit.primitive as usize];
            let material = &scene.materials[primitive.material as usize];
            if mode == Transport::Radiance && path.len() == 1 {
                out.alpha = 1.0;
                out.distance = hit.t;
                out.normal = hit.shading_normal;
                out.albedo = material.albedo(hit.uv);
            }
            let bsdf = material.bsdf(hit.uv);
            let frame = Frame::new(hit.shading_normal, hit.tangent);
            let wo = -ray.direction;
            let mut vertex = Vertex {
                kind: VertexKind::Surface { bsdf, frame, wo, emitter: primitive.light },
                point: hit.point,
                normal: hit.geometric_normal,
                beta,
                pdf_fwd: 0.0,
                pdf_rev: 0.0,
                delta: false,
            };
            vertex.pdf_fwd = path[path.len() - 1].convert_density(pdf_fwd, &vertex, &self.ctx);
            path.push(vertex);
            if path.len() >= max_vertices {
                break;
            }
            let wo_local = frame.to_local(wo);
            let Some(s) = bsdf.sample(wo_local, rng.uniform2(), rng.uniform()) else { break };
            if s.pdf <= 0.0 || s.f == Vec3::ZERO {
                break;
            }
            let wi = frame.to_world(s.wi).normalize();
            let f = match mode {
                Transport::Radiance => s.f,
                Transport::Importance => bsdf.sample_value_adjoint(wo_local, &s),
            };
            beta *= f * s.wi.z.abs() / s.pdf;
            let mut pdf_rev = bsdf.pdf(s.wi, wo_local);
            pdf_fwd = s.pdf;
            if s.specular {
                path.last_mut().expect("just pushed").delta = true;
                pdf_rev = 0.0;
                pdf_fwd = 0.0;
            }
            if mode == Transport::Importance {
                beta *= importance_factor(&bsdf, frame, hit.geometric_normal, wo, wi, &s);
            }
            ray = spawn(&hit, wi);
            let n = path.len();
            path[n - 2].pdf_rev = path[n - 1].convert_density(pdf_rev, &path[n - 2], &self.ctx);
            if n > self.rr_depth as usize {
                let q = (beta.max_element() / start).min(0.95);
                if rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
        }
    }

    /// The contribution of strategy (s, t), MIS-weighted, and for t = 1 the image point it
    /// lands on.
    fn connect(
        &self,
        cam: &[Vertex],
        lig: &[Vertex],
        s: usize,
        t: usize,
        rng: &mut Rng,
        rays: &mut u32,
    ) -> (Vec3, Vec2) {
        let ctx = &self.ctx;
        let none = (Vec3::ZERO, Vec2::ZERO);
        // A camera path that escaped ends on the environment, which only s = 0 can use.
        if t > 1 && s != 0 && matches!(cam[t - 1].kind, VertexKind::Light { .. }) {
            return none;
        }
        let mut raster = Vec2::ZERO;
        let mut sampled = None;
        let radiance = if s == 0 {
            let pt = &cam[t - 1];
            pt.le(ctx, &cam[t - 2]) * pt.beta
        } else if t == 1 {
            let qs = &lig[s - 1];
            if !qs.is_connectible(ctx) {
                return none;
            }
            let Some(lens) = ctx.camera.sample_lens(qs.point, rng.uniform2()) else { return none };
            if lens.pdf <= 0.0 || lens.importance <= 0.0 {
                return none;
            }
            let camera = Vertex::camera(lens.point, Vec3::splat(lens.importance / lens.pdf));
            raster = lens.raster;
            let mut l = qs.beta * qs.f(&camera, Transport::Importance) * camera.beta;
            if qs.is_on_surface() {
                l *= lens.wi.dot(qs.shading_normal()).abs();
            }
            if l != Vec3::ZERO && !self.visible(qs, lens.wi, lens.distance, rays) {
                l = Vec3::ZERO;
            }
            sampled = Some(camera);
            l
        } else if s == 1 {
            let pt = &cam[t - 1];
            if !pt.is_connectible(ctx) {
                return none;
            }
            let pick = pick_light_index(ctx.scene, rng);
            let Some(on) = sample_point_on(&ctx.scene.lights[pick], pt.point, ctx.sphere, rng.uniform2()) else {
                return none;
            };
            if on.sample.pdf <= 0.0 || on.sample.li == Vec3::ZERO {
                return none;
            }
            let beta = on.sample.li / (on.sample.pdf * ctx.light_pick);
            let mut light = Vertex::light(pick as u32, on.point, on.normal, beta, 0.0);
            light.pdf_fwd = light.pdf_light_origin(ctx, pt);
            let mut l = pt.beta * pt.f(&light, Transport::Radiance) * light.beta;
            if pt.is_on_surface() {
                l *= on.sample.wi.dot(pt.shading_normal()).abs();
            }
            if l != Vec3::ZERO && !self.visible(pt, on.sample.wi, on.sample.distance, rays) {
                l = Vec3::ZERO;
            }
            sampled = Some(light);
            l
        } else {
            let (qs, pt) = (&lig[s - 1], &cam[t - 1]);
            if !qs.is_connectible(ctx) || !pt.is_connectible(ctx) {
                return none;
            }
            let l = qs.beta * qs.f(pt, Transport::Importance) * pt.f(qs, Transport::Radiance) * pt.beta;
            if l == Vec3::ZERO { l } else { l * self.geometry(qs, pt, rays) }
        };
        if radiance == Vec3::ZERO {
            return none;
        }
        let weight = match self.strategies {
            Strategies::LightTracing => 1.0,
            Strategies::All => mis::weight(ctx, cam, lig, sampled.as_ref(), s, t),
        };
        (radiance * weight, raster)
    }

    /// Whether nothing blocks the segment from vertex `from` along `direction` for `distance`.
    fn visible(&self, from: &Vertex, direction: Vec3, distance: f32, rays: &mut u32) -> bool {
        *rays += 1;
        let ray = Ray { origin: spawn_origin(from.point, from.normal, direction), direction };
        let t_max = if distance.is_finite() { distance * (1.0 - 1e-3) } else { f32::INFINITY };
        !self.ctx.scene.bvh.occluded(&ray, 0.0, t_max)
    }

    /// The geometry term between two vertices (shading cosines), zero if occluded.
    fn geometry(&self, a: &Vertex, b: &Vertex, rays: &mut u32) -> f32 {
        let d = b.point - a.point;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let distance = d2.sqrt();
        let w = d / distance;
        let mut g = 1.0 / d2;
        if a.is_on_surface() {
            g *= a.shading_normal().dot(w).abs();
        }
        if b.is_on_surface() {
            g *= b.shading_normal().dot(w).abs();
        }
        if g == 0.0 || !self.visible(a, w, distance, rays) { 0.0 } else { g }
    }
}
