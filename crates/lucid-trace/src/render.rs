//! Rendering an image: pixels in parallel (rows with rayon), each with its own random stream
//! derived from the seed and the pixel index, so the image is bit-identical whatever the
//! number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::{Camera, PinholeCamera, ThinLensCamera};
use rayon::prelude::*;

use crate::integrator::{PathSample, PathTracer};
use crate::sampling::{Rng, mix};
use crate::scene::Scene;

/// The camera models a render can use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderCamera {
    /// Everything in focus.
    Pinhole(PinholeCamera),
    /// Depth of field.
    ThinLens(ThinLensCamera),
}

impl RenderCamera {
    fn pinhole(&self) -> &PinholeCamera {
        match self {
            RenderCamera::Pinhole(c) => c,
            RenderCamera::ThinLens(c) => &c.pinhole,
        }
    }

    fn ray(&self, px: f32, py: f32, lens: Vec2) -> lucid_scene::Ray {
        match self {
            RenderCamera::Pinhole(c) => c.generate_ray(px, py, lens),
            RenderCamera::ThinLens(c) => c.generate_ray(px, py, lens),
        }
    }
}

/// How to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of all random streams.
    pub seed: u64,
    /// The integrator.
    pub integrator: PathTracer,
}

/// A rendered view: linear HDR colour with alpha, and its auxiliary buffers.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Radiance (straight alpha: the fraction of samples whose camera ray hit geometry).
    pub colour: Image,
    /// Depth along the camera's viewing axis, averaged over the samples that hit; 0 on the background.
    pub depth: Image,
    /// World-space shading normal of the first hit.
    pub normal: Image,
    /// Albedo of the first hit.
    pub albedo: Image,
    /// Camera paths traced.
    pub paths: u64,
    /// Rays traced (closest-hit and shadow rays).
    pub rays: u64,
}

/// Renders `scene` through `camera`; `progress(rows_done)` is called as rows finish.
pub fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let forward = camera.pinhole().forward();
    let spp = settings.spp.max(1);
    let done = AtomicUsize::new(0);
    let rows: Vec<(Vec<[[f32; 4]; 4]>, u64)> = (0..h)
        .into_par_iter()
        .map(|j| {
            let mut rays = 0u64;
            let row = (0..w)
                .map(|i| {
                    let (pixel, r) = render_pixel(scene, camera, settings, forward, spp, i, j, w);
                    rays += r;
                    pixel
                })
                .collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            (row, rays)
        })
        .collect();
    let plane = |c: usize| Image::from_pixels(w, h, rows.iter().flat_map(|r| r.0.iter().map(|p| p[c])).collect());
    RenderOutput {
        colour: plane(0),
        depth: plane(1),
        normal: plane(2),
        albedo: plane(3),
        paths: (w * h) as u64 * spp as u64,
        rays: rows.iter().map(|r| r.1).sum(),
    }
}

#[allow(clippy::too_many_arguments)]
fn render_pixel(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    forward: Vec3,
    spp: u32,
    i: usize,
    j: usize,
    width: usize,
) -> ([[f32; 4]; 4], u64) {
    let pixel = (j * width + i) as u64;
    let mut rays = 0u64;
    let (mut radiance, mut normal, mut albedo) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    let (mut alpha, mut depth) = (0.0f32, 0.0f32);
    let mut add = |ray: &lucid_scene::Ray, s: &PathSample| {
        rays += s.rays as u64;
        // Samples that produce NaN/∞ (numerical accidents) are dropped rather than
        // poisoning the pixel; a finite image is part of the contract.
        if s.radiance.is_finite() {
            radiance += s.radiance;
        }
        if s.alpha > 0.0 {
            alpha += 1.0;
            depth += s.distance * ray.direction.dot(forward);
            normal += s.normal;
            albedo += s.albedo;
        }
    };
    if PathTracer::packet_supports(scene) {
        // Each sample has its own generator, so that eight of them can be traced side by side:
        // the pixel's stream started at a state hashed from the sample's index (PCG streams
        // whose increments differ by a little are correlated; one stream at far-apart states
        // is not).
        let mut samples = vec![PathSample::default(); spp as usize];
        let mut camera_rays = vec![lucid_scene::Ray { origin: Vec3::ZERO, direction: Vec3::Z }; spp as usize];
        settings.integrator.trace_paths(
            scene,
            |k| {
                let mut rng = Rng::new(settings.seed ^ mix(pixel * spp as u64 + k as u64), pixel);
                let jitter = rng.uniform2();
                let lens = rng.uniform2();
                camera_rays[k] = camera.ray(i as f32 + jitter.x, j as f32 + jitter.y, lens);
                (camera_rays[k], rng)
            },
            &mut samples,
        );
        for (ray, sample) in camera_rays.iter().zip(&samples) {
            add(ray, sample);
        }
    } else {
        let mut rng = Rng::new(settings.seed, pixel);
        for _ in 0..spp {
            let jitter = rng.uniform2();
            let lens = rng.uniform2();
            let ray = camera.ray(i as f32 + jitter.x, j as f32 + jitter.y, lens);
            let s = settings.integrator.trace(scene, ray, &mut rng);
            add(&ray, &s);
        }
    }
    let n = spp as f32;
    // Straight alpha: the colour of covered samples is divided by coverage when some samples
    // miss; background radiance (visible environment) keeps alpha 1 via `hide_emitters` off.
    let (colour, a) = if settings.integrator.hide_emitters && alpha > 0.0 {
        (radiance / alpha, alpha / n)
    } else if settings.integrator.hide_emitters {
        (Vec3::ZERO, 0.0)
    } else {
        (radiance / n, 1.0)
    };
    let covered = alpha.max(1.0);
    let d = depth / covered;
    let pixel = [
        colour.extend(a).to_array(),
        [d, d, d, a],
        normal.normalize_or_zero().extend(a).to_array(),
        (albedo / covered).extend(a).to_array(),
    ];
    (pixel, rays)
}
