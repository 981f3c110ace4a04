//! Primary-sample-space Metropolis light transport (Kelemen et al. 2002) over the path
//! tracer: the path tracer's uniforms — image position and lens first, then every choice along
//! the path — are a point of the unit hypercube, and Markov chains explore that space in
//! proportion to the luminance the path carries, so rare bright paths (light through a door
//! ajar, caustics) are found once and then explored by small mutations.
//!
//! The normalisation b = ∫ luminance comes from independent bootstrap samples (large steps
//! only); chains start at bootstrap samples picked in proportion to their luminance (no
//! start-up bias) and each proposal splats both states with the expected-value weights
//! (1 − a) and a (Veach). A pixel is its splats × b / mutations per pixel. Chains run in
//! parallel with their own streams and splat into fixed-point sums, so an image is
//! bit-identical for any number of threads. Depth, normals, albedo and coverage come from a
//! short path-traced pass.

mod sampler;

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use lucid_image::Image;
use rayon::prelude::*;

use crate::bdpt::SplatFilm;
use crate::render::{Integrator, RenderCamera, RenderOutput, RenderSettings};
use crate::sampling::{Rng, UniformSource, mix};
use crate::scene::Scene;
use sampler::PrimarySampleSpace;

/// Parameters of Metropolis light transport.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metropolis {
    /// Independent samples estimating the normalisation (and where chains start); 0: a quarter
    /// of the mutations, at least 100 000. The image's mean luminance is their mean, so its
    /// error is theirs.
    pub bootstrap: u32,
    /// Markov chains (each runs `spp × pixels / chains` mutations); 0: one per 10 000
    /// mutations, 16 to 1000 (short chains are mostly start-up).
    pub chains: u32,
    /// Probability of a large step (a fresh independent sample).
    pub large_step: f32,
    /// Standard deviation of a small step's perturbation of each coordinate.
    pub sigma: f32,
}

impl Metropolis {
    /// pbrt-v3's large steps (30 %) and σ (0.01); its 100 000 bootstrap samples and 1000
    /// chains whatever the image become a quarter of the mutations (at least 100 000) and one
    /// chain per 10 000 mutations (16 to 1000).
    pub const DEFAULT: Metropolis = Metropolis { bootstrap: 0, chains: 0, large_step: 0.3, sigma: 0.01 };
}

impl Default for Metropolis {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The scalar a chain's density is proportional to.
fn luminance(c: Vec3) -> f32 {
    lucid_image::color::luminance(c.to_array())
}

/// What one evaluation of the path tracer at a point of primary sample space gives.
struct PathValue {
    raster: Vec2,
    radiance: Vec3,
    rays: u32,
}

/// The path tracer as a function of primary sample space: the first two coordinates choose
/// the image position, the next two the lens point.
fn evaluate(scene: &Scene, camera: &RenderCamera, settings: &RenderSettings, x: &mut impl UniformSource) -> PathValue {
    let k = camera.pinhole().intrinsics;
    let u = x.uniform2();
    let raster = Vec2::new(u.x * k.width as f32, u.y * k.height as f32);
    let lens = x.uniform2();
    let ray = camera.ray(raster.x, raster.y, lens);
    let sample = settings.path.trace(scene, ray, x);
    // A non-finite sample (a numerical accident) carries no weight, as in the other renderers.
    let radiance = if sample.radiance.is_finite() { sample.radiance.max(Vec3::ZERO) } else { Vec3::ZERO };
    PathValue { raster, radiance, rays: sample.rays }
}

/// Renders `settings.spp` mutations per pixel.
pub(crate) fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    params: Metropolis,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let seed = mix(settings.seed ^ 0x4D4C_5400);
    let new_point = |stream: u64| PrimarySampleSpace::new(seed, stream, params.sigma, params.large_step);

    // 1. Bootstrap: independent samples, their mean luminance the normalisation.
    let total_mutations = settings.spp.max(1) as u64 * (w * h) as u64;
    let bootstrap = match params.bootstrap {
        0 => (total_mutations / 4).max(100_000) as usize,
        n => n as usize,
    };
    let weights: Vec<(f32, u32)> = (0..bootstrap)
        .into_par_iter()
        .map(|i| {
            let v = evaluate(scene, camera, settings, &mut new_point(i as u64));
            (luminance(v.radiance), v.rays)
        })
        .collect();
    let mut rays: u64 = weights.iter().map(|w| w.1 as u64).sum();
    let b = weights.iter().map(|w| w.0 as f64).sum::<f64>() / bootstrap as f64;
    let mut cdf = Vec::with_capacity(bootstrap);
    let mut total = 0.0f64;
    for (y, _) in &weights {
        total += *y as f64;
        cdf.push(total);
    }

    // 2. Chains.
    let film = SplatFilm::new(w, h);
    let chains = match params.chains {
        0 => (total_mutations / 10_000).clamp(16, 1000),
        n => n as u64,
    }
    .min(total_mutations);
    let done = AtomicUsize::new(0);
    if total > 0.0 {
        rays += (0..chains)
            .into_par_iter()
            .map(|c| {
                let mutations = total_mutations / chains + u64::from(c < total_mutations % chains);
                let mut rng = Rng::new(seed ^ 0x0043_4841_494E, c);
                // The bootstrap sample to start from, in proportion to its luminance.
                let target = rng.uniform() as f64 * total;
                let start = cdf.partition_point(|&v| v <= target).min(bootstrap - 1);
                let mut x = new_point(start as u64);
                let mut current = evaluate(scene, camera, settings, &mut x);
                let mut chain_rays = current.rays as u64;
                for _ in 0..mutations {
                    x.start_iteration();
                    let proposed = evaluate(scene, camera, settings, &mut x);
                    chain_rays += proposed.rays as u64;
                    let (y0, y1) = (luminance(current.radiance), luminance(proposed.radiance));
                    let accept = if y0 > 0.0 { (y1 / y0).min(1.0) } else { 1.0 };
                    if accept > 0.0 {
                        film.add(proposed.raster, proposed.radiance * (accept / y1));
                    }
                    if accept < 1.0 && y0 > 0.0 {
                        film.add(current.raster, current.radiance * ((1.0 - accept) / y0));
                    }
                    if rng.uniform() < accept {
                        x.accept();
                        current = proposed;
                    } else {
                        x.reject();
                    }
                }
                let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(finished * h / chains as usize);
                chain_rays
            })
            .sum::<u64>();
    }

    // 3. Coverage and the auxiliary buffers from a short path-traced pass.
    let aux_settings = RenderSettings { spp: settings.spp.clamp(1, 4), integrator: Integrator::Path, ..*settings };
    let mut out = crate::render::render_supported(scene, camera, &aux_settings, &|_| {});
    rays += out.rays;
    let scale = (b * (w * h) as f64 / total_mutations as f64) as f32;
    let pixels = (0..w * h)
        .map(|p| {
            let (i, j) = (p % w, p / w);
            let alpha = out.colour.pixels()[p][3];
            let c = film.get(i, j) * scale;
            // Straight alpha, as the other renderers: hidden emitters leave the background
            // transparent and the colour of covered samples is divided by the coverage.
            let c = if settings.path.hide_emitters { if alpha > 0.0 { c / alpha } else { Vec3::ZERO } } else { c };
            c.extend(alpha).to_array()
        })
        .collect();
    out.colour = Image::from_pixels(w, h, pixels);
    out.rays = rays;
    out.paths = bootstrap as u64 + total_mutations;
    out
}
