//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009; pbrt-v3's `SPPMIntegrator`).
//! Each pass traces one camera path per pixel to its visible points — the non-specular
//! surfaces it reaches through specular bounces, where direct light is estimated by light
//! sampling — then shoots photons from the lights and adds each photon that lands within a
//! visible point's radius to that point's flux. After the pass every point's radius shrinks so
//! that the photons it keeps grow by a fraction α of those it received:
//! N ← N + αM, R ← R √(N_new/(N + M)), τ ← (τ + β Φ) R_new²/R². The pixel is
//! L_direct/passes + τ / (passes · photons per pass · π R²): biased for any finite number of
//! passes, consistent as they grow (the bias shrinks with the radius; a test shows it).
//!
//! A visible point stands for the non-specular part of its BSDF; a mixed material (plastic)
//! continues the camera path only when its sample picks the specular lobe, weighted by that
//! choice, so specular reflections of diffuse surfaces are not lost. Each pixel keeps up to
//! [`SLOTS`] visible points (first, second, third non-specular surface along such a chain),
//! each with its own radius and flux. Photon and flux sums are fixed-point atomics, so an
//! image is bit-identical whatever the number of threads.

mod grid;

use std::f32::consts::PI;
use std::sync::atomic::{AtomicU32, Ordering};

use glam::Vec3;
use lucid_scene::Ray;
use rayon::prelude::*;

use crate::bdpt::FixedRgb;
use crate::bdpt::emission::SceneSphere;
use crate::bsdf::Bsdf;
use crate::render::{PixelSum, RenderCamera, RenderOutput, RenderSettings, output_from_pixels};
use crate::sampling::{Rng, mix};
use crate::scene::Scene;
use crate::visible::{CameraPass, LightChoice, SLOTS, camera_path, pass_seed, trace_light_path};
use grid::PointGrid;

/// Photons per pass per pixel by default, and the default initial radius in pixel widths at
/// the visible point: chosen by `lucid bench integrators` on cornell, caustic and door at
/// 10 s (2026-12-04: of 1 or 4 photons per pixel and 1–8 pixel widths, per point or at the
/// scene's centre, this had the lowest geometric mean of the error relative to the path
/// tracer's: 1.92, 0.39 and 1.27). Caustics want small radii (bias), diffuse light large ones
/// (noise).
const DEFAULT_PHOTONS_PER_PIXEL: usize = 4;
const DEFAULT_RADIUS_IN_FOOTPRINTS: f32 = 2.0;

/// Parameters of photon mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonMapping {
    /// Photons per pass (0: four per pixel).
    pub photons: u32,
    /// Initial search radius in world units (0: each visible point's slot starts at two pixel
    /// widths at that point, measured along the path from the camera).
    pub radius: f32,
    /// Fraction of a pass's photons a visible point keeps (Hachisuka–Jensen's α).
    pub alpha: f32,
}

impl PhotonMapping {
    /// Four photons per pixel, radii of two pixel widths, α = 2/3.
    pub const DEFAULT: PhotonMapping = PhotonMapping { photons: 0, radius: 0.0, alpha: 2.0 / 3.0 };
}

impl Default for PhotonMapping {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A slot's statistics across passes.
#[derive(Clone, Copy)]
struct SlotStats {
    photons: f32,
    radius: f32,
    tau: Vec3,
}

/// Renders with SPPM: `settings.spp` passes.
pub(crate) fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    params: PhotonMapping,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let forward = camera.pinhole().forward();
    let passes = settings.spp.max(1);
    let photons = if params.photons > 0 { params.photons as usize } else { DEFAULT_PHOTONS_PER_PIXEL * w * h };
    let sphere = SceneSphere::around(scene);
    let lights = LightChoice::all(scene);
    // 0: each slot takes its radius from its first visible point's pixel footprint.
    let radius = params.radius;
    let mut stats = vec![SlotStats { photons: 0.0, radius, tau: Vec3::ZERO }; w * h * SLOTS];
    let mut pixels = vec![PixelSum::default(); w * h];
    let mut photon_rays = 0u64;
    for pass in 0..passes {
        let pass_seed = pass_seed(settings.seed, pass);
        // 1. Camera paths to their visible points.
        let camera_passes: Vec<(Ray, CameraPass)> = (0..w * h)
            .into_par_iter()
            .map(|p| {
                let (i, j) = (p % w, p / w);
                let mut rng = Rng::new(pass_seed, p as u64);
                let ray = camera.sample_ray(i, j, &mut rng);
                (ray, camera_path(scene, settings, &lights, ray, p as u32, 1.0 / k.fx, &mut rng))
            })
            .collect();
        let mut points = Vec::new();
        for (p, (ray, cp)) in camera_passes.into_iter().enumerate() {
            pixels[p].add(&ray, &cp.sample, forward);
            for vp in &cp.points {
                let s = &mut stats[vp.slot as usize];
                if s.radius == 0.0 {
                    s.radius = DEFAULT_RADIUS_IN_FOOTPRINTS * vp.footprint;
                }
            }
            points.extend(cp.points);
        }
        // 2. The grid over this pass's visible points with their slots' current radii.
        let spheres: Vec<(Vec3, f32)> = points.iter().map(|v| (v.point, stats[v.slot as usize].radius)).collect();
        let grid = PointGrid::new(&spheres);
        let flux: Vec<FixedRgb> = (0..points.len()).map(|_| FixedRgb::default()).collect();
        let counts: Vec<AtomicU32> = (0..points.len()).map(|_| AtomicU32::new(0)).collect();
        // 3. Photons.
        let photon_seed = mix(pass_seed ^ 0x0050_4F54_4F4E);
        photon_rays += (0..photons)
            .into_par_iter()
            .map(|n| {
                let mut rng = Rng::new(photon_seed, n as u64);
                trace_light_path(scene, settings, sphere, &mut rng, |vertex| {
                    // Direct light is the camera side's.
                    if vertex.bounce == 0 {
                        return;
                    }
                    let (at, wi, beta) = (vertex.hit.point, vertex.towards_light, vertex.beta);
                    for &v in grid.candidates(at) {
                        let vp = &points[v as usize];
                        let r = spheres[v as usize].1;
                        if (vp.point - at).length_squared() > r * r {
                            continue;
                        }
                        let f = vp.bsdf.eval(vp.wo, vp.frame.to_local(wi));
                        flux[v as usize].add(beta * f);
                        counts[v as usize].fetch_add(1, Ordering::Relaxed);
                    }
                }) as u64
            })
            .sum::<u64>();
        // 4. Shrink the radii of the slots that received photons.
        for (v, vp) in points.iter().enumerate() {
            let m = counts[v].load(Ordering::Relaxed) as f32;
            let s = &mut stats[vp.slot as usize];
            let phi = vp.beta * flux[v].get();
            // A point no photon reached has no flux either: nothing changes.
            if m > 0.0 {
                let n_new = s.photons + params.alpha * m;
                let r_new = s.radius * (n_new / (s.photons + m)).sqrt();
                s.tau = (s.tau + phi) * (r_new * r_new) / (s.radius * s.radius);
                s.photons = n_new;
                s.radius = r_new;
            }
        }
        // Progress in rows, as the other renderers report it.
        progress((pass + 1) as usize * h / passes as usize);
    }
    let emitted = (passes as f64 * photons as f64) as f32;
    let rays = photon_rays + pixels.iter().map(|p| p.rays).sum::<u64>();
    let finished = pixels.iter().zip(stats.chunks(SLOTS)).map(|(pixel, slots)| {
        let mut pixel = *pixel;
        // Slots no visible point ever used have no radius and no flux.
        for s in slots.iter().filter(|s| s.radius > 0.0) {
            // τ / (N_e π R²) per pass, times the passes `finish` divides by.
            pixel.radiance += passes as f32 * s.tau / (emitted * PI * s.radius * s.radius);
        }
        pixel.finish(passes, settings.path.hide_emitters)
    });
    output_from_pixels(w, h, finished, (w * h) as u64 * passes as u64, rays)
}
