//! `lucid bench splat`: the 3DGS benchmark. Trains on the default `object` orbit set (the
//! NeRF benchmark's dataset, 200×200, 100 training views) with the default configuration for
//! a wall-clock budget, scoring held-out PSNR/SSIM at fixed times (30 s, 1, 2, 5, 10 min;
//! evaluation not counted); then measures the rasterizer alone on a 100k-Gaussian cloud:
//! forward+backward splat-pixel blends per second per core, and images per second at 200×200
//! and 800×800.

use std::time::Instant;

use anyhow::Context;
use glam::Vec3;
use lucid_burn::run::ModelError;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::{Intrinsics, PinholeCamera, Split, look_at};
use lucid_session::SceneModel;
use lucid_session::events::Event;
use lucid_session::methods::Splat;
use lucid_splat::raster::{rasterize, rasterize_backward};
use lucid_splat::run::PHASES;
use lucid_splat::trained::TrainedSplats;
use lucid_splat::{RenderSettings, RenderState, SplatCamera, SplatCloud, render, render_backward};
use serde_json::json;

use lucid_session::Listener;
use lucid_session::curve::BudgetCurve;

/// Options of the splat benchmark.
pub struct SplatBench {
    /// The dataset.
    pub dataset: super::BenchDataset,
    /// Smoke version: tiny dataset, 20 s of training, a small cloud.
    pub quick: bool,
    /// Configuration overrides (`--set`).
    pub overrides: Vec<String>,
    /// Test views scored at the intermediate points (all of them at the end).
    pub curve_views: usize,
}

/// One training run of the benchmark: the trained cloud, its curve and the loop's summary.
struct TrainedRun<'a> {
    splats: Box<dyn SceneModel>,
    curve: BudgetCurve<'a>,
    summary: lucid_burn::run::RunSummary,
}

impl TrainedRun<'_> {
    fn splats(&self) -> &TrainedSplats {
        self.splats.as_any().downcast_ref().expect("a splat run trains splats")
    }
}

/// Trains with the benchmark's `overrides` for its budget, scoring the curve on `test` (and
/// the last point on `val`) as it goes.
fn train_run<'a>(
    bench: &SplatBench,
    overrides: &[String],
    [val, test]: [&'a ImageSet; 2],
) -> anyhow::Result<TrainedRun<'a>> {
    let mut curve = BudgetCurve::benchmark(bench.quick, test, Some(val), bench.curve_views);
    let mut trained = None;
    let total = curve.total();
    let mut listener = |event: &Event<'_>| -> Result<(), ModelError> {
        if let Event::Finished { model, .. } = *event {
            trained = model();
        }
        curve.on(event)
    };
    // Time ends the run, and the schedules stretch over it.
    let folder = tempfile::tempdir().context("a folder for the benchmark's run")?;
    let request = super::timed_request(&bench.dataset, overrides, total, folder.path());
    let summary = lucid_session::train::<Splat>(&request, &mut listener)?;
    let splats = trained.context("the trained splats")?;
    Ok(TrainedRun { splats, curve, summary })
}

pub fn run(bench: SplatBench) -> anyhow::Result<serde_json::Value> {
    let (dataset, ceiling) = bench.dataset.open(bench.quick)?;
    let note = super::ceiling_note(ceiling.as_ref());
    let val = ImageSet::load(dataset.frames(Split::Val))?;
    let test = ImageSet::load(dataset.frames(Split::Test))?;
    // The default starts from the dataset's point cloud, which Lucid back-projects from the
    // renderer's exact depth: a capture never has that. The same run from random points in
    // the scene box is reported beside it.
    let mut random_overrides = bench.overrides.clone();
    random_overrides.push("init.use_points=false".into());
    let TrainedRun { splats, mut curve, summary } = train_run(&bench, &bench.overrides, [&val, &test])?;
    let last = curve.last.take().context("the last budget point is scored")?;
    let last_val = curve.last_val.take();
    let mut random = train_run(&bench, &random_overrides, [&val, &test])?;
    let random_last = random.curve.last.take().context("the last budget point is scored")?;
    let random_val = random.curve.last_val.take();
    let curve = curve.points;
    let trained = splats.as_any().downcast_ref::<TrainedSplats>().context("splats")?;
    let phases: Vec<f64> =
        PHASES.iter().map(|n| summary.phases.iter().find(|p| p.0 == *n).map_or(0.0, |p| p.1)).collect();
    let trained_seconds = summary.elapsed;
    // The rasterizer projects through pinholes: distorted captures train on undistorted crops.
    let loaded = ImageSet::load(dataset.frames(Split::Train))?;
    let workload = training_workload(trained.cloud(), &loaded.undistorted(), &trained.settings());
    let raster = rasterizer_throughput(100_000);

    println!("lucid bench splat{}: {}", if bench.quick { " --quick" } else { "" }, bench.dataset.describe());
    println!("{:>10} {:>7} {:>9} {:>8} {:>10}", "train (s)", "step", "PSNR", "SSIM", "Gaussians");
    for p in &curve {
        println!("{:>10.1} {:>7} {:>9.2} {:>8.4} {:>10}", p.seconds, p.step, p.psnr, p.ssim, p.gaussians.unwrap_or(0));
    }
    println!("final: {} test views, PSNR {:.2} dB{note}, SSIM {:.4}", last.views, last.psnr, last.ssim);
    if let Some(val) = &last_val {
        super::print_validation(val);
    }
    println!(
        "from random points instead of the exact-depth point cloud ({} in the scene box): test PSNR {:.2} dB{note}, SSIM {:.4}, {} Gaussians",
        random.splats().config().init.random_points,
        random_last.psnr,
        random_last.ssim,
        random.splats().cloud().len()
    );
    println!("render time per held-out view: {:.3} s", last.seconds_per_view);
    let total_phase: f64 = phases.iter().sum::<f64>().max(1e-9);
    let names = ["render", "loss_and_backward", "optimizer", "densify"];
    println!(
        "time per phase: {}",
        names
            .iter()
            .zip(&phases)
            .map(|(n, t)| format!("{n} {:.0}%", 100.0 * t / total_phase))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mega = |v: &serde_json::Value| v.as_f64().unwrap_or(0.0) / 1e6;
    println!(
        "rasterizer on the trained cloud ({} Gaussians, training views), forward+backward: tile compositing {:.1} M blends/s/core; whole render (with projection, binning, SH) {:.1} M blends/s/core, {:.1} ms per view",
        workload["gaussians"],
        mega(&workload["compositing_blends_per_second_per_core"]),
        mega(&workload["blends_per_second_per_core"]),
        workload["forward_backward_seconds_per_view"].as_f64().unwrap_or(0.0) * 1e3
    );
    println!(
        "rasterizer ({} random Gaussians), forward+backward: tile compositing {:.1} M blends/s/core; whole render {:.1} M blends/s/core; {:.1} images/s at 200x200, {:.1} at 800x800",
        raster["gaussians"],
        mega(&raster["compositing_blends_per_second_per_core"]),
        mega(&raster["blends_per_second_per_core"]),
        raster["images_per_second_200"].as_f64().unwrap_or(0.0),
        raster["images_per_second_800"].as_f64().unwrap_or(0.0)
    );
    Ok(json!({
        "benchmark": "splat", "dataset": bench.dataset.root.display().to_string(), "scene": bench.dataset.built_in,
        "ceiling": ceiling, "quick": bench.quick, "threads": rayon::current_num_threads(),
        "curve": curve, "final": last, "steps": summary.steps, "training_seconds": trained_seconds,
        "time_shares": names.iter().zip(&phases).map(|(n, t)| (n.to_string(), json!(t / total_phase))).collect::<serde_json::Map<_, _>>(),
        "rasterizer": raster, "rasterizer_trained_cloud": workload, "config": trained.config(),
        "final_val": last_val, "init": "point cloud from the renderer's exact depth (points3d.ply)",
        "random_init": {
            "init": format!("{} random points in the scene box", random.splats().config().init.random_points),
            "curve": random.curve.points, "final": random_last, "final_val": random_val,
            "gaussians": random.splats().cloud().len(),
        },
    }))
}

/// Forward+backward of the trained cloud over (up to) 10 training views: the training
/// workload's splat-pixel blends per second per core.
fn training_workload(cloud: &SplatCloud, train: &ImageSet, settings: &RenderSettings) -> serde_json::Value {
    let params = cloud.params();
    let views = train.len().min(10);
    let (mut blends, mut seconds, mut compositing) = (0u64, 0.0f64, 0.0f64);
    for camera in &train.cameras[..views] {
        let cam = SplatCamera::from_pinhole(camera);
        let grad = vec![1e-3f32; cam.width as usize * cam.height as usize * 4];
        let t = Instant::now();
        let (_, state) = render(&params, &cam, settings);
        std::hint::black_box(render_backward(&params, &state, &grad));
        seconds += t.elapsed().as_secs_f64();
        // Best of three, as for the random cloud: this machine's noise only ever adds time.
        compositing += (0..3).map(|_| compositing_seconds(&state, &grad)).fold(f64::INFINITY, f64::min);
        blends += state.pixels.blends;
    }
    let threads = rayon::current_num_threads() as f64;
    json!({
        "gaussians": cloud.len(), "views": views, "blends_per_view": blends as f64 / views.max(1) as f64,
        "forward_backward_seconds_per_view": seconds / views.max(1) as f64,
        "blends_per_second_per_core": blends as f64 / seconds.max(1e-9) / threads,
        "compositing_seconds_per_view": compositing / views.max(1) as f64,
        "compositing_blends_per_second_per_core": blends as f64 / compositing.max(1e-9) / threads,
    })
}

/// Seconds of the tile compositing alone (forward and backward over the binned splats of a
/// rendered view), the part of a render that is not per-Gaussian projection.
fn compositing_seconds(state: &RenderState, grad: &[f32]) -> f64 {
    let (w, h) = (state.camera.width as usize, state.camera.height as usize);
    let (bg, min_alpha) = (state.settings.background, state.settings.min_alpha);
    let t = Instant::now();
    let (_, pixels) = rasterize(&state.projected, &state.bins, w, h, bg, min_alpha);
    std::hint::black_box(rasterize_backward(&state.projected, &state.bins, &pixels, w, h, bg, min_alpha, grad));
    t.elapsed().as_secs_f64()
}

/// A random cloud of `n` Gaussians in a 2-unit ball with trained-looking sizes, timed from a
/// camera at distance 4: forward+backward blends per second per core, forward images per
/// second at two resolutions.
fn rasterizer_throughput(n: usize) -> serde_json::Value {
    let mut rng = lucid_scene::sampling::Rng::new(11, 3);
    let mut cloud = SplatCloud::default();
    while cloud.len() < n {
        let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
        if p.length() <= 1.0 {
            let colour = [rng.uniform(), rng.uniform(), rng.uniform()];
            cloud.push(p, 0.005 + 0.02 * rng.uniform(), 0.2 + 0.6 * rng.uniform(), colour);
        }
    }
    let settings = RenderSettings::default();
    let camera = |size: u32| {
        let k = Intrinsics::from_fov_x(size, size, 0.69);
        SplatCamera::from_pinhole(&PinholeCamera::new(k, look_at(Vec3::new(0.0, -4.0, 1.0), Vec3::ZERO, Vec3::Z)))
    };
    let time = |f: &mut dyn FnMut()| {
        f(); // warm up
        let reps = 5;
        let t = Instant::now();
        for _ in 0..reps {
            f();
        }
        t.elapsed().as_secs_f64() / reps as f64
    };
    let params = cloud.params();
    let cam200 = camera(200);
    let (_, state) = render(&params, &cam200, &settings);
    let blends = state.pixels.blends;
    let grad = vec![1e-3f32; 200 * 200 * 4];
    let fwd_bwd = time(&mut || {
        let (_, state) = render(&params, &cam200, &settings);
        std::hint::black_box(render_backward(&params, &state, &grad));
    });
    let f200 = time(&mut || {
        std::hint::black_box(render(&params, &cam200, &settings));
    });
    let cam800 = camera(800);
    let f800 = time(&mut || {
        std::hint::black_box(render(&params, &cam800, &settings));
    });
    let compositing = (0..5).map(|_| compositing_seconds(&state, &grad)).fold(f64::INFINITY, f64::min);
    let threads = rayon::current_num_threads() as f64;
    json!({
        "gaussians": n,
        "blends_200": blends,
        "forward_backward_seconds_200": fwd_bwd,
        // Each blend is visited once forward and once backward.
        "blends_per_second_per_core": blends as f64 / fwd_bwd / threads,
        "compositing_blends_per_second_per_core": blends as f64 / compositing / threads,
        "images_per_second_200": 1.0 / f200,
        "images_per_second_800": 1.0 / f800,
    })
}
