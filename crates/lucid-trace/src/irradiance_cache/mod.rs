//! Irradiance caching (Ward, Rubinstein & Clear 1988) for the diffuse indirect light.
//!
//! Camera paths reach their visible points as in photon mapping (through specular bounces),
//! with emitters seen and one light sample of direct light added on the way. At a Lambertian
//! visible point the indirect light is `ρ/π · E`, `E` interpolated from cached irradiance
//! records; each record is a final gather — stratified cosine-distributed rays, each traced
//! on by the path tracer with emitters hidden from its first segment (that light is the
//! direct light already sampled) — at a point no record covered. Every other visible point
//! (glossy and plastic surfaces, and any that no record covers) gets its indirect light from
//! one BSDF-sampled path: the final gather for the rest.
//!
//! Records are made before the render, level by level over pixel centres on grids of
//! spacing 16, 8, 4, 2 and 1 pixels: a level's points look up the records of the levels
//! before, the misses gather in parallel, and the new records enter the cache in pixel order
//! — so the cache, and the image, do not depend on the number of threads. Interpolation is
//! biased (smooth where the light is not); the bias shrinks with the error threshold `a` and
//! with `a = 0` no record is reused: every visible point path-traces its indirect light and
//! the render is unbiased. Gradients (Ward & Heckbert 1992) are not used.

mod octree;

use glam::{Vec2, Vec3};
use lucid_scene::Ray;
use rayon::prelude::*;

use crate::bsdf::Bsdf;
use crate::integrator::{PathTracer, spawn_origin};
use crate::material::SurfaceBsdf;
use crate::render::{PixelSum, RenderCamera, RenderOutput, RenderSettings, output_from_pixels};
use crate::sampling::{Rng, cosine_hemisphere, mix};
use crate::scene::Scene;
use crate::visible::{LightChoice, VisiblePoint, camera_path, pass_seed};
use octree::{IrradianceCache, IrradianceRecord};

/// Parameters of irradiance caching.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceCaching {
    /// Ward's error threshold `a` (0: no interpolation, unbiased).
    pub error: f32,
    /// Gather rays per record (rounded up to a square number of strata).
    pub gather: u32,
}

impl IrradianceCaching {
    /// a = 0.2 (pbrt's default), 1024 gather rays per record.
    pub const DEFAULT: IrradianceCaching = IrradianceCaching { error: 0.2, gather: 1024 };
}

impl Default for IrradianceCaching {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A record's harmonic-mean distance is clamped to this range of pixel widths at its point
/// (pbrt-v2's minimum and maximum pixel spacing): records neither crowd into corners nor
/// spread over a whole wall.
const MIN_RADIUS_PIXELS: f32 = 2.5;
const MAX_RADIUS_PIXELS: f32 = 15.0;

/// Grid spacings, in pixels, of the levels that build the cache.
const LEVELS: [usize; 5] = [16, 8, 4, 2, 1];

/// Renders `settings.spp` passes with a cache built first.
pub(crate) fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    params: IrradianceCaching,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let forward = camera.pinhole().forward();
    let passes = settings.spp.max(1);
    let lights = LightChoice::all(scene);
    let pixel_angle = 1.0 / k.fx;
    let (cache, mut rays) = if params.error > 0.0 {
        build_cache(scene, camera, settings, params, &lights)
    } else {
        (IrradianceCache::new(scene.bvh.bounds(), 1.0), 0)
    };
    let use_cache = params.error > 0.0;
    let mut pixels = vec![PixelSum::default(); w * h];
    for pass in 0..passes {
        let seed = pass_seed(settings.seed, pass);
        pixels.par_iter_mut().enumerate().for_each(|(p, pixel)| {
            let (i, j) = (p % w, p / w);
            let mut rng = Rng::new(seed, p as u64);
            let ray: Ray = camera.sample_ray(i, j, &mut rng);
            let mut cp = camera_path(scene, settings, &lights, ray, p as u32, pixel_angle, &mut rng);
            for vp in &cp.points {
                let cached = match vp.bsdf {
                    SurfaceBsdf::Lambertian(b) if use_cache => cache
                        .lookup(vp.point, facing_normal(vp), vp.segments)
                        .map(|e| b.albedo * std::f32::consts::FRAC_1_PI * e),
                    _ => None,
                };
                let indirect =
                    cached.unwrap_or_else(|| indirect_path(scene, settings, vp, &mut rng, &mut cp.sample.rays));
                cp.sample.radiance += vp.beta * indirect;
            }
            pixel.add(&ray, &cp.sample, forward);
        });
        progress((pass + 1) as usize * h / passes as usize);
    }
    rays += pixels.iter().map(|p| p.rays).sum::<u64>();
    let finished = pixels.iter().map(|p| p.finish(passes, settings.path.hide_emitters));
    output_from_pixels(w, h, finished, (w * h) as u64 * passes as u64, rays)
}

/// The path tracer for light arriving at a point `segments` from the camera: the path budget
/// that is left, and emitters hidden from its first segment (direct light is sampled apart).
fn indirect_tracer(settings: &RenderSettings, segments: u32) -> Option<PathTracer> {
    let left = settings.path.max_depth.checked_sub(segments)?;
    (left >= 2).then_some(PathTracer { max_depth: left, hide_emitters: true, ..settings.path })
}

/// One BSDF-sampled path's estimate of the indirect light leaving `vp` through its
/// non-specular lobes (specular ones are the camera path's).
fn indirect_path(scene: &Scene, settings: &RenderSettings, vp: &VisiblePoint, rng: &mut Rng, rays: &mut u32) -> Vec3 {
    let Some(tracer) = indirect_tracer(settings, vp.segments) else { return Vec3::ZERO };
    let Some(s) = vp.bsdf.sample(vp.wo, rng.uniform2(), rng.uniform()) else { return Vec3::ZERO };
    if s.specular || s.pdf <= 0.0 || s.f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let direction = vp.frame.to_world(s.wi).normalize();
    let ray = Ray { origin: spawn_origin(vp.point, vp.normal, direction), direction };
    let sample = tracer.trace(scene, ray, rng);
    *rays += sample.rays;
    s.f * s.wi.z.abs() / s.pdf * sample.radiance
}

/// The shading normal on the side the point is seen from.
fn facing_normal(vp: &VisiblePoint) -> Vec3 {
    if vp.wo.z < 0.0 { -vp.frame.n } else { vp.frame.n }
}

/// A final gather at `vp`: its indirect irradiance from stratified cosine-distributed rays and
/// the harmonic mean of their hit distances; `None` past the path budget.
fn gather(
    scene: &Scene,
    settings: &RenderSettings,
    vp: &VisiblePoint,
    rays_per_record: u32,
    rng: &mut Rng,
    rays: &mut u64,
) -> Option<IrradianceRecord> {
    let tracer = indirect_tracer(settings, vp.segments)?;
    let strata = (rays_per_record.max(1) as f32).sqrt().ceil() as u32;
    let n = facing_normal(vp);
    let (mut sum, mut inverse_distance) = (Vec3::ZERO, 0.0f32);
    for a in 0..strata {
        for b in 0..strata {
            let u = (Vec2::new(a as f32, b as f32) + rng.uniform2()) / strata as f32;
            let local = cosine_hemisphere(u);
            let local = if vp.wo.z < 0.0 { -local } else { local };
            let direction = vp.frame.to_world(local).normalize();
            let ray = Ray { origin: spawn_origin(vp.point, vp.normal, direction), direction };
            let sample = tracer.trace(scene, ray, rng);
            *rays += sample.rays as u64;
            if sample.radiance.is_finite() {
                sum += sample.radiance;
            }
            if sample.alpha > 0.0 && sample.distance > 0.0 {
                inverse_distance += 1.0 / sample.distance;
            }
        }
    }
    let count = (strata * strata) as f32;
    // E = ∫ L cos dω, estimated with pdf cos/π: π times the mean radiance.
    let irradiance = sum * (std::f32::consts::PI / count);
    let harmonic = if inverse_distance > 0.0 { count / inverse_distance } else { f32::INFINITY };
    let radius = harmonic.clamp(MIN_RADIUS_PIXELS * vp.footprint, MAX_RADIUS_PIXELS * vp.footprint);
    Some(IrradianceRecord { point: vp.point, normal: n, irradiance, radius, segments: vp.segments })
}

/// The cache over pixel centres, level by level (see the module notes); and the rays traced.
fn build_cache(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    params: IrradianceCaching,
    lights: &LightChoice,
) -> (IrradianceCache, u64) {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let mut cache = IrradianceCache::new(scene.bvh.bounds(), params.error);
    let seed = mix(settings.seed ^ 0x4952_5241_4449);
    let mut total_rays = 0u64;
    for spacing in LEVELS {
        let level: Vec<usize> =
            (0..h).step_by(spacing).flat_map(|j| (0..w).step_by(spacing).map(move |i| j * w + i)).collect();
        let found: Vec<(Vec<IrradianceRecord>, u64)> = level
            .par_iter()
            .map(|&p| {
                let (i, j) = (p % w, p / w);
                let mut rng = Rng::new(seed, p as u64);
                let ray = camera.ray(i as f32 + 0.5, j as f32 + 0.5, Vec2::splat(0.5));
                let cp = camera_path(scene, settings, lights, ray, p as u32, 1.0 / k.fx, &mut rng);
                let mut rays = cp.sample.rays as u64;
                let mut records = Vec::new();
                for vp in cp.points.iter().filter(|vp| matches!(vp.bsdf, SurfaceBsdf::Lambertian(_))) {
                    if cache.lookup(vp.point, facing_normal(vp), vp.segments).is_none()
                        && let Some(r) = gather(scene, settings, vp, params.gather, &mut rng, &mut rays)
                    {
                        records.push(r);
                    }
                }
                (records, rays)
            })
            .collect();
        for (records, rays) in found {
            total_rays += rays;
            for r in records {
                cache.insert(r);
            }
        }
    }
    (cache, total_rays)
}
