//! Rendering an image: pixels in parallel (rows with rayon), each with its own random stream
//! derived from the seed and the pixel index, so the image is bit-identical whatever the
//! number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::{Camera, PinholeCamera, ThinLensCamera};
use rayon::prelude::*;

use crate::bdpt::{Bidirectional, CameraImportance, SplatFilm, Strategies, Subpaths};
use crate::integrator::{PathSample, PathTracer};
use crate::irradiance_cache::IrradianceCaching;
use crate::manylight::{Gather, InstantRadiosity, Lightcuts};
use crate::pssmlt::Metropolis;
use crate::sampling::{Rng, mix};
use crate::scene::Scene;
use crate::sppm::PhotonMapping;

/// The camera models a render can use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderCamera {
    /// Everything in focus.
    Pinhole(PinholeCamera),
    /// Depth of field.
    ThinLens(ThinLensCamera),
}

impl RenderCamera {
    pub(crate) fn pinhole(&self) -> &PinholeCamera {
        match self {
            RenderCamera::Pinhole(c) => c,
            RenderCamera::ThinLens(c) => &c.pinhole,
        }
    }

    pub(crate) fn ray(&self, px: f32, py: f32, lens: Vec2) -> lucid_scene::Ray {
        match self {
            RenderCamera::Pinhole(c) => c.generate_ray(px, py, lens),
            RenderCamera::ThinLens(c) => c.generate_ray(px, py, lens),
        }
    }

    /// A ray through pixel `(i, j)`: a sub-pixel jitter, then a lens point, from `rng`.
    #[inline]
    pub(crate) fn sample_ray(&self, i: usize, j: usize, rng: &mut Rng) -> lucid_scene::Ray {
        let jitter = rng.uniform2();
        let lens = rng.uniform2();
        self.ray(i as f32 + jitter.x, j as f32 + jitter.y, lens)
    }
}

/// The light-transport algorithm of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Integrator {
    /// Unidirectional path tracing with next-event estimation and MIS.
    #[default]
    Path,
    /// Bidirectional path tracing: every connection strategy, power-heuristic MIS.
    Bdpt,
    /// Light tracing: paths from the lights connected to the camera (and emitters seen
    /// directly); no path through a specular surface to the camera.
    LightTracing,
    /// Stochastic progressive photon mapping: `spp` passes of one camera path per pixel and
    /// a batch of photons, radii shrinking with α.
    Sppm(PhotonMapping),
    /// Instant radiosity: each pass's virtual point lights (clamped) summed at every visible
    /// point, direct light sampled.
    Vpl(InstantRadiosity),
    /// Lightcuts over the point and spot lights and the pass's diffuse virtual point lights.
    Lightcuts(Lightcuts),
    /// Irradiance caching for diffuse indirect light, path tracing for the rest.
    IrradianceCache(IrradianceCaching),
    /// Primary-sample-space Metropolis light transport over the path tracer.
    Pssmlt(Metropolis),
}

impl Integrator {
    /// Every integrator with the name the scene file and `--integrator` use.
    pub const ALL: [(Integrator, &'static str); 8] = {
        let all = [
            Integrator::Path,
            Integrator::Bdpt,
            Integrator::LightTracing,
            Integrator::Sppm(PhotonMapping::DEFAULT),
            Integrator::Vpl(InstantRadiosity::DEFAULT),
            Integrator::Lightcuts(Lightcuts::DEFAULT),
            Integrator::IrradianceCache(IrradianceCaching::DEFAULT),
            Integrator::Pssmlt(Metropolis::DEFAULT),
        ];
        let mut named = [(Integrator::Path, ""); 8];
        let mut k = 0;
        while k < all.len() {
            named[k] = (all[k], all[k].name());
            k += 1;
        }
        named
    };

    /// The integrator called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(i, _)| *i)
    }

    /// Its name.
    pub const fn name(self) -> &'static str {
        match self {
            Integrator::Path => "path",
            Integrator::Bdpt => "bdpt",
            Integrator::LightTracing => "light-tracing",
            Integrator::Sppm(_) => "sppm",
            Integrator::Vpl(_) => "vpl",
            Integrator::Lightcuts(_) => "lightcuts",
            Integrator::IrradianceCache(_) => "irradiance-cache",
            Integrator::Pssmlt(_) => "pssmlt",
        }
    }

    /// The names, for messages.
    pub fn names() -> String {
        Self::ALL.iter().map(|(_, n)| *n).collect::<Vec<_>>().join(", ")
    }

    /// Whether this integrator can render `scene`; [`render`] refuses a scene it cannot.
    pub fn supports(self, scene: &Scene) -> Result<(), String> {
        match self {
            Integrator::Path => Ok(()),
            Integrator::Bdpt
            | Integrator::LightTracing
            | Integrator::Sppm(_)
            | Integrator::Vpl(_)
            | Integrator::Lightcuts(_)
            | Integrator::IrradianceCache(_)
                if scene.has_media() =>
            {
                Err(format!(
                    "the {} integrator does not handle participating media or medium interfaces; use \"path\"",
                    self.name()
                ))
            }
            Integrator::Pssmlt(_) => Ok(()),
            _ if scene.has_subsurface() => Err(format!(
                "the {} integrator does not follow subsurface scattering; use \"path\" or \"pssmlt\"",
                self.name()
            )),
            _ => Ok(()),
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
    /// Path length, Russian roulette, emitter visibility and (for path tracing) how lights
    /// are found: shared by every integrator.
    pub path: PathTracer,
    /// The light-transport algorithm.
    pub integrator: Integrator,
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
///
/// # Panics
/// If the integrator does not support the scene ([`Integrator::supports`]): callers check
/// user input first.
pub fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<RenderOutput, Unsupported> {
    settings.integrator.supports(scene).map_err(Unsupported)?;
    Ok(render_supported(scene, camera, settings, progress))
}

/// Why an integrator cannot render a scene (the message names the integrator and what in the
/// scene it does not handle).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct Unsupported(pub String);

/// [`render`] of a scene the integrator is known to support.
pub(crate) fn render_supported(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    match settings.integrator {
        Integrator::Path => render_paths(scene, camera, settings, progress),
        Integrator::Bdpt => render_bidirectional(scene, camera, settings, Strategies::All, progress),
        Integrator::LightTracing => render_bidirectional(scene, camera, settings, Strategies::LightTracing, progress),
        Integrator::Sppm(params) => crate::sppm::render(scene, camera, settings, params, progress),
        Integrator::Vpl(params) => crate::manylight::render(scene, camera, settings, Gather::Vpl(params), progress),
        Integrator::Lightcuts(params) => {
            crate::manylight::render(scene, camera, settings, Gather::Lightcuts(params), progress)
        }
        Integrator::IrradianceCache(params) => {
            crate::irradiance_cache::render(scene, camera, settings, params, progress)
        }
        Integrator::Pssmlt(params) => crate::pssmlt::render(scene, camera, settings, params, progress),
    }
}

/// Bidirectional renders: each pixel's samples as in [`render_paths`]' scalar loop, plus the
/// light paths splatted to the film, added once every row is done.
fn render_bidirectional(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    strategies: Strategies,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let forward = camera.pinhole().forward();
    let spp = settings.spp.max(1);
    let done = AtomicUsize::new(0);
    let film = SplatFilm::new(w, h);
    let sampler = Bidirectional::new(scene, CameraImportance::new(camera), &settings.path, strategies);
    // One row per task, as in `render_paths`.
    let rows: Vec<Vec<PixelSum>> = (0..h)
        .into_par_iter()
        .with_max_len(1)
        .map_init(Subpaths::default, |paths, j| {
            let pixels = (0..w)
                .map(|i| {
                    pixel_samples(camera, settings, (i, j, w), forward, |ray, rng| {
                        sampler.sample(ray, rng, &film, paths)
                    })
                })
                .collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            pixels
        })
        .collect();
    let rays = rows.iter().flatten().map(|p| p.rays).sum();
    // With hidden emitters, light splatted to a pixel whose camera rays all missed is dropped
    // by `finish` with the rest of its transparent background.
    let pixels = rows.iter().enumerate().flat_map(|(j, row)| {
        let film = &film;
        row.iter().enumerate().map(move |(i, pixel)| {
            PixelSum { radiance: pixel.radiance + film.get(i, j), ..*pixel }.finish(spp, settings.path.hide_emitters)
        })
    });
    output_from_pixels(w, h, pixels, (w * h) as u64 * spp as u64, rays)
}

/// A render's images from its finished pixels in row order (colour, depth, normal, albedo).
pub(crate) fn output_from_pixels(
    w: usize,
    h: usize,
    pixels: impl Iterator<Item = [[f32; 4]; 4]>,
    paths: u64,
    rays: u64,
) -> RenderOutput {
    // Sized up front: collected from an iterator they grew by reallocation, each growth
    // faulting in fresh pages.
    let mut planes = [(); 4].map(|_| Vec::with_capacity(w * h));
    for pixel in pixels {
        for (plane, value) in planes.iter_mut().zip(pixel) {
            plane.push(value);
        }
    }
    let [colour, depth, normal, albedo] = planes.map(|p| Image::from_pixels(w, h, p));
    RenderOutput { colour, depth, normal, albedo, paths, rays }
}

/// Path tracing (in packets where the scene allows).
fn render_paths(
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
    let packets = PathTracer::packet_supports(scene);
    // One row per task: rows cost very different amounts (sky against geometry), and rayon's
    // adaptive splitting left one core idle for the last tenth of a studio render whose
    // rows it had handed out in large runs.
    let rows: Vec<(Vec<[[f32; 4]; 4]>, u64)> = (0..h)
        .into_par_iter()
        .with_max_len(1)
        .map(|j| {
            let row = if packets {
                render_row_in_packets(scene, camera, settings, forward, spp, j, w)
            } else {
                let mut rays = 0u64;
                let pixels = (0..w)
                    .map(|i| {
                        let pixel = pixel_samples(camera, settings, (i, j, w), forward, |ray, rng| {
                            settings.path.trace(scene, ray, rng)
                        });
                        rays += pixel.rays;
                        pixel.finish(spp, settings.path.hide_emitters)
                    })
                    .collect();
                (pixels, rays)
            };
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    let rays = rows.iter().map(|r| r.1).sum();
    output_from_pixels(w, h, rows.iter().flat_map(|r| r.0.iter().copied()), (w * h) as u64 * spp as u64, rays)
}

/// Pixel `(i, j)` of an image `width` wide, its samples traced one by one by `trace` from
/// the pixel's own random stream.
fn pixel_samples(
    camera: &RenderCamera,
    settings: &RenderSettings,
    (i, j, width): (usize, usize, usize),
    forward: Vec3,
    mut trace: impl FnMut(lucid_scene::Ray, &mut Rng) -> PathSample,
) -> PixelSum {
    let mut pixel = PixelSum::default();
    let mut rng = Rng::new(settings.seed, pixel_index(i, j, width));
    for _ in 0..settings.spp.max(1) {
        let ray = camera.sample_ray(i, j, &mut rng);
        pixel.add(&ray, &trace(ray, &mut rng), forward);
    }
    pixel
}

fn pixel_index(i: usize, j: usize, width: usize) -> u64 {
    (j * width + i) as u64
}

/// Row `j`'s pixels and rays traced, the samples of several pixels traced by one
/// [`PathTracer::trace_paths`]: its lanes take the next path as theirs end, so lanes idle
/// only while the last few paths of the call finish, which is a large part of a call with
/// only one pixel's samples.
#[allow(clippy::too_many_arguments)]
fn render_row_in_packets(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    forward: Vec3,
    spp: u32,
    j: usize,
    width: usize,
) -> (Vec<[[f32; 4]; 4]>, u64) {
    let spp = spp as usize;
    // Pixels per call: enough paths that the lanes' idle tail is a small part of the call
    // (the Cornell box renders 2 % faster with 4096 than with 1024), few enough that its
    // buffers (300 KB) stay in the cache.
    let chunk = PATHS_PER_CALL.div_ceil(spp).max(1);
    let mut samples = vec![PathSample::default(); chunk * spp];
    let mut camera_rays = vec![lucid_scene::Ray { origin: Vec3::ZERO, direction: Vec3::Z }; chunk * spp];
    let mut rays = 0u64;
    let mut pixels = Vec::with_capacity(width);
    for first in (0..width).step_by(chunk) {
        let n = chunk.min(width - first) * spp;
        settings.path.trace_paths(
            scene,
            |k| {
                // Each sample has its own generator, so that eight of them can be traced side
                // by side: the pixel's stream started at a state hashed from the sample's index
                // (PCG streams whose increments differ by a little are correlated; one stream
                // at far-apart states is not).
                let (i, s) = (first + k / spp, k % spp);
                let pixel = pixel_index(i, j, width);
                let mut rng = Rng::new(settings.seed ^ mix(pixel * spp as u64 + s as u64), pixel);
                camera_rays[k] = camera.sample_ray(i, j, &mut rng);
                (camera_rays[k], rng)
            },
            &mut samples[..n],
        );
        for (rays_of_pixel, samples_of_pixel) in camera_rays[..n].chunks(spp).zip(samples[..n].chunks(spp)) {
            let mut pixel = PixelSum::default();
            for (ray, sample) in rays_of_pixel.iter().zip(samples_of_pixel) {
                pixel.add(ray, sample, forward);
            }
            rays += pixel.rays;
            pixels.push(pixel.finish(spp as u32, settings.path.hide_emitters));
        }
    }
    (pixels, rays)
}

/// Paths per [`PathTracer::trace_paths`] call of the packet renderer (at least).
const PATHS_PER_CALL: usize = 4096;

/// A pixel's samples summed.
#[derive(Clone, Copy, Default)]
pub(crate) struct PixelSum {
    pub(crate) radiance: Vec3,
    normal: Vec3,
    albedo: Vec3,
    /// Samples whose camera ray hit geometry.
    alpha: f32,
    depth: f32,
    pub(crate) rays: u64,
}

impl PixelSum {
    pub(crate) fn add(&mut self, ray: &lucid_scene::Ray, s: &PathSample, forward: Vec3) {
        self.rays += s.rays as u64;
        // Samples that produce NaN/∞ (numerical accidents) are dropped rather than
        // poisoning the pixel; a finite image is part of the contract.
        if s.radiance.is_finite() {
            self.radiance += s.radiance;
        }
        if s.alpha > 0.0 {
            self.alpha += 1.0;
            self.depth += s.distance * ray.direction.dot(forward);
            self.normal += s.normal;
            self.albedo += s.albedo;
        }
    }

    /// Colour, depth, normal and albedo with alpha.
    pub(crate) fn finish(&self, spp: u32, hide_emitters: bool) -> [[f32; 4]; 4] {
        let n = spp as f32;
        let (radiance, alpha) = (self.radiance, self.alpha);
        // Straight alpha: the colour of covered samples is divided by coverage when some
        // samples miss; background radiance (visible environment) keeps alpha 1 via
        // `hide_emitters` off.
        let (colour, a) = if hide_emitters && alpha > 0.0 {
            (radiance / alpha, alpha / n)
        } else if hide_emitters {
            (Vec3::ZERO, 0.0)
        } else {
            (radiance / n, 1.0)
        };
        let covered = alpha.max(1.0);
        let d = self.depth / covered;
        [
            colour.extend(a).to_array(),
            [d, d, d, a],
            self.normal.normalize_or_zero().extend(a).to_array(),
            (self.albedo / covered).extend(a).to_array(),
        ]
    }
}
