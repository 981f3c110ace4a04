//! `lucid bench integrators`: every light-transport algorithm against a long reference render,
//! at equal time. Each integrator renders passes of increasing samples per pixel with fresh
//! seeds, averaged (each pass unbiased for unbiased integrators, so the average is too), and
//! after every pass its relative MSE against the reference is recorded with the render time
//! so far. From that curve: the error after the time budget, the time to reach the path
//! tracer's error at the budget, and the slope of log error against log time (−1 where the
//! error falls like 1/time, i.e. per-pixel RMSE like 1/√time). Photon mapping (consistent but
//! biased), Metropolis and irradiance caching (a bootstrap or a cache per render) render from
//! scratch with doubling samples instead (see [`consistent`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use lucid_image::Image;
use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::{Integrator, LoadedScene, RenderCamera, RenderSettings, render};
use serde_json::{Value, json};

/// Relative MSE's ε: keeps black pixels of the reference from dominating (as in pbrt's and
/// Mitsuba's comparisons).
const RELATIVE_MSE_EPSILON: f64 = 1e-2;

/// What one benchmark run is given.
pub struct IntegratorBench {
    pub scenes: Vec<String>,
    pub integrators: Vec<Integrator>,
    /// Render time per integrator and scene.
    pub seconds: f64,
    /// Image width (height from the scene's aspect).
    pub width: u32,
    /// Render time of a missing reference, in multiples of `seconds`.
    pub reference_factor: f64,
    /// Where references are kept between runs.
    pub cache: PathBuf,
}

/// The mean over pixels and channels of (x − r)² / (r² + ε).
pub fn relative_mse(image: &Image, reference: &Image) -> f64 {
    let mut sum = 0.0f64;
    for (x, r) in image.pixels().iter().zip(reference.pixels()) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            sum += (x - r) * (x - r) / (r * r + RELATIVE_MSE_EPSILON);
        }
    }
    sum / (3 * image.pixels().len()).max(1) as f64
}

/// A running average of passes rendered with different seeds, weighted by their samples.
struct Accumulator {
    sum: Vec<[f64; 3]>,
    samples: u64,
    width: usize,
    height: usize,
}

impl Accumulator {
    fn new(width: usize, height: usize) -> Self {
        Self { sum: vec![[0.0; 3]; width * height], samples: 0, width, height }
    }

    fn add(&mut self, image: &Image, spp: u32) {
        for (s, p) in self.sum.iter_mut().zip(image.pixels()) {
            for c in 0..3 {
                s[c] += p[c] as f64 * spp as f64;
            }
        }
        self.samples += spp as u64;
    }

    fn image(&self) -> Image {
        let n = self.samples.max(1) as f64;
        let pixels = self.sum.iter().map(|s| [(s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32, 1.0]).collect();
        Image::from_pixels(self.width, self.height, pixels)
    }
}

/// Renders `integrator` in passes until `seconds` of render time have passed: the average
/// image, its samples per pixel and the curve of (seconds, relative MSE) after each pass.
/// An image, the samples per pixel it took, and its error curve (seconds, relative MSE).
type Converged = (Image, u64, Vec<(f64, f64)>);

fn progressive(
    loaded: &LoadedScene,
    integrator: Integrator,
    seconds: f64,
    reference: Option<&Image>,
    seed: u64,
) -> anyhow::Result<Converged> {
    // Photon mapping is consistent, not unbiased; Metropolis and the irradiance cache pay a
    // start-up (bootstrap, cache) per render: all three render from scratch.
    if let Integrator::Sppm(_) | Integrator::Pssmlt(_) | Integrator::IrradianceCache(_) = integrator {
        return consistent(loaded, integrator, seconds, reference, seed);
    }
    let (w, h) = dimensions(&loaded.camera);
    let mut acc = Accumulator::new(w, h);
    let mut curve = Vec::new();
    let mut elapsed = 0.0;
    let mut spp = 1u32;
    let mut pass = 0u64;
    while elapsed < seconds {
        let pass_seed = lucid_trace::sampling::mix(seed ^ (pass + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let (image, took) = timed_render(loaded, integrator, spp, pass_seed)?;
        elapsed += took;
        acc.add(&image, spp);
        if let Some(r) = reference {
            curve.push((elapsed, relative_mse(&acc.image(), r)));
        }
        pass += 1;
        // Passes grow with the time already spent (each about a quarter of it), so the curve
        // has points spread evenly in log time and the last pass overshoots the budget little.
        let per_sample = took / spp as f64;
        let next = (0.25 * elapsed / per_sample).max(1.0);
        let left = ((seconds - elapsed) / per_sample).max(1.0);
        spp = next.min(left).round().clamp(1.0, 1_000_000.0) as u32;
    }
    Ok((acc.image(), acc.samples, curve))
}

/// A consistent but biased integrator (photon mapping) cannot average independent renders, and
/// one with a start-up cost per render should not: each curve point is one render from
/// scratch with twice the passes of the one before, up to the last that fits the budget; the
/// image returned is that last render.
fn consistent(
    loaded: &LoadedScene,
    integrator: Integrator,
    seconds: f64,
    reference: Option<&Image>,
    seed: u64,
) -> anyhow::Result<Converged> {
    let mut curve = Vec::new();
    let mut spp = 1u32;
    loop {
        let (image, took) = timed_render(loaded, integrator, spp, seed)?;
        if let Some(r) = reference {
            curve.push((took, relative_mse(&image, r)));
        }
        if 2.0 * took > seconds || spp >= 1 << 20 {
            return Ok((image, spp as u64, curve));
        }
        spp *= 2;
    }
}

/// One render's colour and its wall time in seconds.
fn timed_render(loaded: &LoadedScene, integrator: Integrator, spp: u32, seed: u64) -> anyhow::Result<(Image, f64)> {
    let settings = RenderSettings { spp, seed, integrator, ..loaded.settings };
    let started = Instant::now();
    let image = render(&loaded.scene, &loaded.camera, &settings, &|_| {})?.colour;
    Ok((image, started.elapsed().as_secs_f64()))
}

pub fn dimensions(camera: &RenderCamera) -> (usize, usize) {
    let k = match camera {
        RenderCamera::Pinhole(c) => c.intrinsics,
        RenderCamera::ThinLens(c) => c.pinhole.intrinsics,
    };
    (k.width as usize, k.height as usize)
}

/// The curve's log-log interpolation at time `t`; beyond its end, extrapolated along its last
/// segment but never faster than error ∝ 1/time (a render from scratch whose fixed start-up
/// dominates — a cache, a bootstrap — has a last segment far steeper than its error keeps).
pub fn error_at(curve: &[(f64, f64)], t: f64) -> f64 {
    match curve {
        [] => f64::NAN,
        [only] => only.1 * only.0 / t,
        _ => {
            let k = curve.windows(2).position(|w| w[1].0 >= t).unwrap_or(curve.len() - 2);
            let ((t0, e0), (t1, e1)) = (curve[k], curve[k + 1]);
            let mut slope = (e1.ln() - e0.ln()) / (t1.ln() - t0.ln());
            if t > t1 {
                slope = slope.max(-1.0);
                return (e1.ln() + slope * (t.ln() - t1.ln())).exp();
            }
            (e0.ln() + slope * (t.ln() - t0.ln())).exp()
        }
    }
}

/// The first time the curve reaches `error` (log-log interpolation; beyond its end, extrapolated
/// as error ∝ 1/time from its last point).
pub fn time_to(curve: &[(f64, f64)], error: f64) -> f64 {
    if let Some(k) = curve.iter().position(|&(_, e)| e <= error) {
        if k == 0 {
            return curve[0].0 * curve[0].1 / error;
        }
        let ((t0, e0), (t1, e1)) = (curve[k - 1], curve[k]);
        let slope = (t1.ln() - t0.ln()) / (e1.ln() - e0.ln());
        return (t0.ln() + slope * (error.ln() - e0.ln())).exp();
    }
    curve.last().map_or(f64::NAN, |&(t, e)| t * e / error)
}

/// Least-squares slope of log error against log time over the curve's second half (the first
/// passes are short and noisy).
pub fn log_slope(curve: &[(f64, f64)]) -> f64 {
    let tail = &curve[curve.len() / 2..];
    if tail.len() < 2 {
        return f64::NAN;
    }
    let n = tail.len() as f64;
    let (xs, ys): (Vec<f64>, Vec<f64>) = tail.iter().map(|&(t, e)| (t.ln(), e.ln())).unzip();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

/// The scene at the benchmark's width, keeping its aspect and field of view.
pub fn resized(mut loaded: LoadedScene, width: u32) -> LoadedScene {
    let pinhole = match loaded.camera {
        RenderCamera::Pinhole(c) => c,
        RenderCamera::ThinLens(c) => c.pinhole,
    };
    let k = pinhole.intrinsics;
    let height = ((width as f64 * k.height as f64 / k.width as f64).round() as u32).max(1);
    let p = PinholeCamera::new(Intrinsics::from_fov_x(width, height, k.fov_x()), pinhole.camera_to_world);
    loaded.camera = match loaded.camera {
        RenderCamera::Pinhole(_) => RenderCamera::Pinhole(p),
        RenderCamera::ThinLens(c) => RenderCamera::ThinLens(lucid_scene::ThinLensCamera { pinhole: p, ..c }),
    };
    loaded
}

/// The reference of `scene`: read from the cache, or rendered (BDPT where the scene allows,
/// for its caustics; the path tracer otherwise) and stored there.
fn reference(bench: &IntegratorBench, name: &str, loaded: &LoadedScene) -> anyhow::Result<(Image, Value)> {
    let (w, h) = dimensions(&loaded.camera);
    let integrator = if Integrator::Bdpt.supports(&loaded.scene).is_ok() { Integrator::Bdpt } else { Integrator::Path };
    let stem = format!("{name}-{w}x{h}-depth{}-{}", loaded.settings.path.max_depth, integrator.name());
    let exr = bench.cache.join(format!("{stem}.exr"));
    let meta = bench.cache.join(format!("{stem}.json"));
    if exr.is_file() && meta.is_file() {
        let image = lucid_image::read_image(&exr)?;
        let info: Value = serde_json::from_str(&std::fs::read_to_string(&meta)?)
            .with_context(|| format!("{}: not the reference's record", meta.display()))?;
        if image.dimensions() == (w, h) {
            return Ok((image, info));
        }
    }
    let seconds = bench.seconds * bench.reference_factor;
    println!(
        "rendering the {name} reference with {} for {seconds:.0} s (kept in {})",
        integrator.name(),
        exr.display()
    );
    let (image, samples, _) = progressive(loaded, integrator, seconds, None, 0x0005_EED0_F4EF)?;
    std::fs::create_dir_all(&bench.cache).with_context(|| format!("creating {}", bench.cache.display()))?;
    lucid_image::write_image(&exr, &image)?;
    let info = json!({"integrator": integrator.name(), "spp": samples, "seconds": seconds});
    crate::commands::write_text(&meta, &serde_json::to_string_pretty(&info)?)?;
    Ok((image, info))
}

/// Runs the benchmark, prints its table and returns one JSON result per scene.
pub fn run(bench: &IntegratorBench) -> anyhow::Result<Vec<Value>> {
    anyhow::ensure!(bench.seconds.is_finite() && bench.seconds > 0.0, "--seconds must be a positive number");
    let mut results = Vec::new();
    println!(
        "{:<10} {:<14} {:>8} {:>9} {:>12} {:>10} {:>8} {:>14}",
        "scene", "integrator", "spp", "seconds", "relMSE", "vs path", "slope", "time to path's"
    );
    for name in &bench.scenes {
        let loaded = lucid_datasets_gen::builtin::load_named_scene(name)?;
        let loaded = resized(loaded, bench.width);
        let (reference, reference_info) = reference(bench, name, &loaded)?;
        let mut rows = Vec::new();
        for &integrator in &bench.integrators {
            if let Err(e) = integrator.supports(&loaded.scene) {
                println!("{name:<10} {:<14} skipped: {e}", integrator.name());
                continue;
            }
            let (image, samples, curve) = progressive(&loaded, integrator, bench.seconds, Some(&reference), 1)?;
            let mean = image.mean();
            rows.push((integrator, samples, curve, (mean[0] + mean[1] + mean[2]) / 3.0));
        }
        let path_error =
            rows.iter().find(|r| r.0 == Integrator::Path).map(|r| error_at(&r.2, bench.seconds)).unwrap_or(f64::NAN);
        let mut entries = Vec::new();
        for (integrator, samples, curve, mean) in rows {
            let error = error_at(&curve, bench.seconds);
            let seconds = curve.last().map_or(0.0, |p| p.0);
            let to_target = time_to(&curve, path_error);
            let slope = log_slope(&curve);
            println!(
                "{name:<10} {:<14} {:>8} {:>9.2} {:>12.4e} {:>10.3} {:>8.2} {:>13.1}s",
                integrator.name(),
                samples,
                seconds,
                error,
                error / path_error,
                slope,
                to_target
            );
            entries.push(json!({
                "integrator": integrator.name(),
                "spp": samples,
                "seconds": seconds,
                "relative_mse": error,
                "relative_mse_vs_path": error / path_error,
                "log_slope": slope,
                "seconds_to_path_error": to_target,
                "image_mean": mean,
                "curve": curve.iter().map(|(t, e)| json!({"seconds": t, "relative_mse": e})).collect::<Vec<_>>(),
            }));
        }
        let (w, h) = dimensions(&loaded.camera);
        let m = reference.mean();
        results.push(json!({
            "benchmark": "integrators",
            "scene": name,
            "width": w,
            "height": h,
            "max_depth": loaded.settings.path.max_depth,
            "budget_seconds": bench.seconds,
            "threads": rayon::current_num_threads(),
            "reference": reference_info,
            "reference_mean": (m[0] + m[1] + m[2]) / 3.0,
            "integrators": entries,
        }));
    }
    Ok(results)
}

/// Where references are cached by default.
pub fn default_cache() -> PathBuf {
    Path::new("out/bench/integrators").to_path_buf()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_are_read_in_log_log() {
        // error = 2/t exactly: interpolation, the time to an error and the slope are exact.
        let curve: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0].iter().map(|&t| (t, 2.0 / t)).collect();
        assert!((error_at(&curve, 3.0) - 2.0 / 3.0).abs() < 1e-12);
        assert!((error_at(&curve, 16.0) - 0.125).abs() < 1e-12, "extrapolated along the last segment");
        assert!((time_to(&curve, 0.5) - 4.0).abs() < 1e-12);
        assert!((time_to(&curve, 0.1) - 20.0).abs() < 1e-9, "beyond the curve: error ∝ 1/time");
        assert!((log_slope(&curve) + 1.0).abs() < 1e-12);
        // A steep last segment (start-up cost) is extrapolated as 1/time only.
        let steep = [(4.0, 1.0), (5.0, 0.25)];
        assert!((error_at(&steep, 10.0) - 0.125).abs() < 1e-12);
    }

    #[test]
    fn relative_mse_weighs_errors_by_the_reference() {
        let reference = Image::from_pixels(2, 1, vec![[1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0]]);
        let image = Image::from_pixels(2, 1, vec![[1.1, 1.1, 1.1, 1.0], [0.1, 0.1, 0.1, 1.0]]);
        let expected = (0.01 / 1.01 + 0.01 / 0.01) / 2.0;
        assert!((relative_mse(&image, &reference) - expected).abs() < 1e-6);
        assert_eq!(relative_mse(&reference, &reference), 0.0);
    }
}
