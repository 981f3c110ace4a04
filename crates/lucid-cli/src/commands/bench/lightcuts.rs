//! `lucid bench lightcuts`: lightcuts against brute-force summation over the same lights, on
//! the same camera paths and VPLs (one seed): render time, shadow rays and the per-pixel
//! relative difference, for the scene's point lights alone and with the default VPLs.

use std::time::Instant;

use lucid_image::Image;
use lucid_trace::manylight::{InstantRadiosity, Lightcuts};
use lucid_trace::{Integrator, LoadedScene, RenderOutput, RenderSettings, render};
use serde_json::{Value, json};

/// What one benchmark run is given.
pub struct LightcutsBench {
    pub scenes: Vec<String>,
    pub width: u32,
    pub spp: u32,
}

/// Per-pixel relative differences (grey, pixels the reference lights above 10⁻³): mean, 99th
/// percentile, largest, and the fraction above 2 %.
pub fn relative_differences(image: &Image, reference: &Image) -> [f64; 4] {
    let grey = |p: &[f32; 4]| ((p[0] + p[1] + p[2]) / 3.0) as f64;
    let mut d: Vec<f64> = image
        .pixels()
        .iter()
        .zip(reference.pixels())
        .filter(|(_, r)| grey(r) > 1e-3)
        .map(|(x, r)| (grey(x) - grey(r)).abs() / grey(r))
        .collect();
    if d.is_empty() {
        return [0.0; 4];
    }
    d.sort_by(f64::total_cmp);
    let n = d.len();
    let mean = d.iter().sum::<f64>() / n as f64;
    let above = d.iter().filter(|&&x| x > 0.02).count() as f64 / n as f64;
    [mean, d[((n - 1) as f64 * 0.99).round() as usize], d[n - 1], above]
}

fn timed(loaded: &LoadedScene, integrator: Integrator, spp: u32) -> anyhow::Result<(RenderOutput, f64)> {
    let settings = RenderSettings { spp, seed: 1, integrator, ..loaded.settings };
    let started = Instant::now();
    let out = render(&loaded.scene, &loaded.camera, &settings, &|_| {})?;
    Ok((out, started.elapsed().as_secs_f64()))
}

/// Runs the benchmark, prints its table and returns one JSON result per scene.
pub fn run(bench: &LightcutsBench) -> anyhow::Result<Vec<Value>> {
    println!(
        "{:<12} {:<13} {:>9} {:>10} {:>8} {:>10} {:>9} {:>9} {:>9} {:>8}",
        "scene", "lights", "brute s", "cuts s", "speed-up", "rays ÷", "mean err", "p99 err", "max err", ">2 %"
    );
    let mut results = Vec::new();
    for name in &bench.scenes {
        let loaded = lucid_datasets_gen::builtin::load_named_scene(name)?;
        let loaded = super::integrators::resized(loaded, bench.width);
        if let Err(e) = Integrator::Lightcuts(Lightcuts::DEFAULT).supports(&loaded.scene) {
            println!("{name:<12} skipped: {e}");
            continue;
        }
        let mut rows = Vec::new();
        for (label, light_paths) in [("point lights", 0), ("+ VPLs", Lightcuts::DEFAULT.vpls.light_paths)] {
            let with = |error| {
                let vpls = InstantRadiosity { light_paths, ..Lightcuts::DEFAULT.vpls };
                Integrator::Lightcuts(Lightcuts { vpls, error })
            };
            let (brute, brute_s) = timed(&loaded, with(0.0), bench.spp)?;
            let (cut, cut_s) = timed(&loaded, with(Lightcuts::DEFAULT.error), bench.spp)?;
            let [mean, p99, max, above] = relative_differences(&cut.colour, &brute.colour);
            let rays = brute.rays as f64 / cut.rays.max(1) as f64;
            println!(
                "{name:<12} {label:<13} {brute_s:>9.2} {cut_s:>10.2} {:>7.1}× {rays:>9.1}× {:>8.2}% {:>8.2}% {:>8.2}% {:>7.2}%",
                brute_s / cut_s,
                100.0 * mean,
                100.0 * p99,
                100.0 * max,
                100.0 * above
            );
            rows.push(json!({
                "lights": label,
                "light_paths": light_paths,
                "brute_force_seconds": brute_s,
                "lightcuts_seconds": cut_s,
                "speed_up": brute_s / cut_s,
                "brute_force_rays": brute.rays,
                "lightcuts_rays": cut.rays,
                "relative_difference": {"mean": mean, "p99": p99, "max": max, "fraction_above_2_percent": above},
            }));
        }
        let (w, h) = super::integrators::dimensions(&loaded.camera);
        results.push(json!({
            "benchmark": "lightcuts",
            "scene": name,
            "width": w,
            "height": h,
            "spp": bench.spp,
            "error_bound": Lightcuts::DEFAULT.error,
            "threads": rayon::current_num_threads(),
            "runs": rows,
        }));
    }
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_differences_are_read_per_pixel() {
        let reference = Image::from_pixels(4, 1, vec![[1.0, 1.0, 1.0, 1.0]; 4]);
        let mut pixels = vec![[1.0, 1.0, 1.0, 1.0]; 4];
        pixels[0] = [1.03, 1.03, 1.03, 1.0];
        pixels[1] = [0.99, 0.99, 0.99, 1.0];
        let [mean, _, max, above] = relative_differences(&Image::from_pixels(4, 1, pixels), &reference);
        assert!((mean - 0.01).abs() < 1e-6 && (max - 0.03).abs() < 1e-6 && (above - 0.25).abs() < 1e-12);
    }
}
