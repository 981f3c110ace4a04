//! `lucid demo`: the README's main command. It path-traces a small dataset of the built-in
//! `object` scene, reads it back, and scores on the held-out test views: the 8-bit images
//! against the HDR truth, a nearest-training-view baseline (the floor every trained model
//! must beat), a NeRF and a 3D Gaussian splat cloud trained on the training views. Writes
//! `<out>/dataset/`, `<out>/nerf/`, `<out>/splat/` (checkpoints, test renders, `splats.ply`),
//! `<out>/metrics.json` and `<out>/report.html` (with its images in `<out>/images/`).

mod report;

use anyhow::{Context, bail};
use glam::Vec4Swizzles;
use lucid_datasets_gen::builtin::{load_named_scene, object_orbit_spec};
use lucid_datasets_gen::{PathTracedScene, Shard, generate_dataset};
use lucid_image::metrics::{MetricSpace, MetricSummary, compare_files};
use lucid_image::tonemap::ToneCurve;
use lucid_scene::{Dataset, Split};
use serde_json::json;

use std::path::Path;

use lucid_burn::run::{CHECKPOINT, ModelError, Start};
use lucid_scene::dataset::images::ImageSet;
use lucid_session::events::Event;
use lucid_session::{Method, RunRequest, methods};

use crate::cli::DemoArgs;
use report::{DemoFacts, ModelRun, held_out_psnr, novel_views, score_and_show, write_report};

/// Points on each held-out PSNR curve.
const CURVE_POINTS: usize = 8;

/// Evaluation background of the demo (the Blender set's convention).
const BACKGROUND: [f32; 3] = [1.0, 1.0, 1.0];

pub fn run(mut args: DemoArgs) -> anyhow::Result<()> {
    if args.full {
        (args.size, args.views, args.spp, args.nerf_steps, args.splat_steps) = (200, [100, 0, 200], 32, 4000, 7000);
    }
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    if args.size < 16 {
        bail!("--size {} is too small: SSIM needs images of at least 16 pixels", args.size);
    }
    let [train, val, test] = args.views;
    if train == 0 || test == 0 {
        bail!("--views needs at least one train and one test view");
    }
    let started = std::time::Instant::now();
    // A new or empty folder, or an earlier demo's (one process at a time).
    adopt_unrecorded_demo(&args.out)?;
    let folder = lucid_image::owned_folder::OwnedFolder::claim(&args.out, "lucid demo", &[])?;
    pin_dataset_settings(&args)?;
    let root = args.out.join("dataset");
    let spec = object_orbit_spec(args.size, [train, val, test], args.seed);
    let mut loaded = load_named_scene("object")?;
    loaded.settings.spp = args.spp;
    loaded.settings.seed = args.seed;
    tracing::info!("path-tracing {} views of the object scene into {}", train + val + test, root.display());
    let renderer = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    let bar = crate::progress::bar((train + val + test) as u64, "rendering");
    generate_dataset(&root, &spec, &renderer, Shard::ALL, &|done, _| bar.set_position(done as u64))
        .context("generating the demo dataset")?;
    bar.finish_and_clear();
    let generation_seconds = started.elapsed().as_secs_f64();

    let dataset = Dataset::open(&root)?;
    let summary = lucid_scene::dataset::summary::summarise(&dataset);

    // 1. The LDR images against the exact HDR truth through the same tone curve: only 8-bit
    //    quantisation separates them, so this is a check of the file pipeline.
    let mut quantisation = Vec::new();
    for frame in dataset.frames(Split::Test) {
        let hdr_path = frame.extras.hdr_path.as_ref().context("test frame without hdr_file_path")?;
        let hdr = lucid_image::read_image(hdr_path)?;
        let tone_mapped = args.out.join(".demo_tonemapped.exr");
        lucid_image::write_image(&tone_mapped, &ToneCurve::Aces.map_image(&hdr, 0.0))?;
        quantisation.push(compare_files(&frame.image_path, &tone_mapped, BACKGROUND, MetricSpace::Srgb)?);
        std::fs::remove_file(&tone_mapped).ok();
    }
    // 2. Nearest training view as the prediction of each test view.
    let train_frames = dataset.frames(Split::Train);
    let mut nearest = Vec::new();
    for frame in dataset.frames(Split::Test) {
        let p = frame.camera.camera_to_world.w_axis.xyz();
        let best = train_frames
            .iter()
            .min_by(|a, b| {
                let da = a.camera.camera_to_world.w_axis.xyz().distance(p);
                let db = b.camera.camera_to_world.w_axis.xyz().distance(p);
                da.total_cmp(&db)
            })
            .expect("at least one training view");
        nearest.push(compare_files(&best.image_path, &frame.image_path, BACKGROUND, MetricSpace::Srgb)?);
    }
    let q = MetricSummary::from_images(&quantisation);
    let n = MetricSummary::from_images(&nearest);
    // 3. A NeRF trained on the training views, scored on the same test views.
    let test_set = ImageSet::load(dataset.frames(Split::Test))?;
    let nerf = if args.nerf_steps > 0 { Some(train_nerf(&root, &test_set, &args)?) } else { None };
    // 4. A 3DGS cloud, likewise.
    let splat = if args.splat_steps > 0 { Some(train_splat(&root, &test_set, &args)?) } else { None };
    let elapsed = started.elapsed().as_secs_f64();

    println!(
        "Lucid demo: object scene, {0}x{0} pixels, {1} spp, {train}/{val}/{test} train/val/test views",
        args.size, args.spp
    );
    println!("dataset: {}", root.display());
    println!();
    println!("{:<44} {:>9} {:>7}", "test views (sRGB, white background)", "PSNR dB", "SSIM");
    println!("{:<44} {:>9.2} {:>7.4}", "8-bit PNG vs HDR truth (quantisation only)", q.psnr, q.ssim);
    println!("{:<44} {:>9.2} {:>7.4}", "nearest training view (baseline)", n.psnr, n.ssim);
    if let Some(r) = &nerf {
        let label = format!("NeRF ({} steps, {:.0} s of training)", r.steps, r.seconds);
        println!("{:<44} {:>9.2} {:>7.4}", label, r.summary.psnr, r.summary.ssim);
    }
    if let Some(r) = &splat {
        let label = format!("3DGS ({} steps, {:.0} s of training)", r.steps, r.seconds);
        println!("{:<44} {:>9.2} {:>7.4}", label, r.summary.psnr, r.summary.ssim);
    }
    println!();
    println!("done in {elapsed:.1} s");

    let report = json!({
        "scene": "object", "size": args.size, "spp": args.spp, "views": [train, val, test], "seed": args.seed,
        "background": BACKGROUND, "space": "srgb",
        "dataset": summary,
        "metrics": {
            "ldr_vs_hdr_truth": {"psnr": q.psnr, "ssim": q.ssim, "count": q.count},
            "nearest_train_view": {"psnr": n.psnr, "ssim": n.ssim, "count": n.count},
            "nerf": nerf.as_ref().map(|r| json!({
                "psnr": r.summary.psnr, "ssim": r.summary.ssim, "count": r.summary.views, "steps": r.steps,
                "training_seconds": r.seconds, "seconds_per_view": r.summary.seconds_per_view,
                "checkpoint": r.checkpoint.display().to_string(),
            })),
            "splat": splat.as_ref().map(|r| json!({
                "psnr": r.summary.psnr, "ssim": r.summary.ssim, "count": r.summary.views, "steps": r.steps,
                "training_seconds": r.seconds, "seconds_per_view": r.summary.seconds_per_view,
                "checkpoint": r.checkpoint.display().to_string(),
            })),
        },
        "seconds": elapsed,
    });
    let path = args.out.join("metrics.json");
    crate::commands::write_text(&path, &serde_json::to_string_pretty(&report)?)?;
    println!("metrics written to {}", path.display());
    let facts = DemoFacts {
        size: args.size,
        spp: args.spp,
        views: args.views,
        seed: args.seed,
        generation_seconds,
        total_seconds: elapsed,
        quantisation: (q.psnr, q.ssim),
        nearest: (n.psnr, n.ssim),
        dataset: &root,
    };
    let runs: Vec<ModelRun> = nerf.into_iter().chain(splat).collect();
    let html = write_report(&facts, &runs, &args.out)?;
    folder.finish()?;
    println!("report written to {}", html.display());
    Ok(())
}

/// Marks a demo written before folders kept records (its `metrics.json` and `report.html`) as
/// Lucid's, recording none of its files: the demo rewrites its own by name, and anything else
/// in the folder stays unrecorded. Its settings, from its `metrics.json`, become `demo.json`.
fn adopt_unrecorded_demo(out: &std::path::Path) -> anyhow::Result<()> {
    if lucid_image::owned_folder::is_owned(out) || !out.join("report.html").is_file() {
        return Ok(());
    }
    let Ok(text) = std::fs::read_to_string(out.join("metrics.json")) else { return Ok(()) };
    let Ok(metrics) = serde_json::from_str::<serde_json::Value>(&text) else { return Ok(()) };
    if metrics["scene"] != "object" || metrics.get("metrics").is_none() {
        return Ok(());
    }
    let settings =
        json!({ "size": metrics["size"], "views": metrics["views"], "spp": metrics["spp"], "seed": metrics["seed"] });
    if !out.join("demo.json").exists() {
        crate::commands::write_text(&out.join("demo.json"), &serde_json::to_string_pretty(&settings)?)?;
    }
    Ok(lucid_image::owned_folder::write_record(out, "lucid demo", std::iter::empty::<&str>())?)
}

/// Records what the dataset was made with in `demo.json`, or checks that an earlier demo in
/// the folder made its dataset the same way: its finished frames are kept on a rerun, so
/// frames of another seed or size must never be mixed with the new poses.
fn pin_dataset_settings(args: &DemoArgs) -> anyhow::Result<()> {
    let path = args.out.join("demo.json");
    let settings = json!({ "size": args.size, "views": args.views, "spp": args.spp, "seed": args.seed });
    match std::fs::read_to_string(&path) {
        Ok(text) => {
            let earlier: serde_json::Value =
                serde_json::from_str(&text).with_context(|| format!("{}: not a demo's settings", path.display()))?;
            if earlier != settings {
                bail!(
                    "{}: holds a demo made with other settings ({earlier}, now {settings}); choose another --out",
                    args.out.display()
                );
            }
            Ok(())
        }
        Err(_) => Ok(crate::commands::write_text(&path, &serde_json::to_string_pretty(&settings)?)?),
    }
}

/// Trains the default NeRF for `args.nerf_steps` steps in `<out>/nerf/` and scores it on the
/// test views (renders written beside the checkpoint).
fn train_nerf(root: &Path, test: &ImageSet, args: &DemoArgs) -> anyhow::Result<ModelRun> {
    tracing::info!("training a NeRF for {} steps", args.nerf_steps);
    train_model::<methods::Nerf>("NeRF", root, test, args, args.nerf_steps, Vec::new())
}

/// Trains the default 3DGS configuration for `args.splat_steps` steps (its schedule scaled to
/// them) in `<out>/splat/` with `splats.ply`, and scores it on the test views.
fn train_splat(root: &Path, test: &ImageSet, args: &DemoArgs) -> anyhow::Result<ModelRun> {
    let config = lucid_splat::config::SplatConfig::default();
    let steps = args.splat_steps;
    // The reference schedule spans 30k steps; a short run keeps its proportions.
    let scale = |v: usize| (v * steps / config.train.steps).max(1);
    let (d, t) = (config.densify, config.train);
    let every = scale(d.every).max(t.steps.min(steps) / 100).max(10);
    let schedule = [
        ("densify.from", scale(d.from)),
        ("densify.until", scale(d.until)),
        ("densify.opacity_reset_every", scale(d.opacity_reset_every)),
        ("train.sh_degree_every", scale(t.sh_degree_every)),
        ("densify.every", every),
    ];
    tracing::info!("training 3D Gaussian splats for {steps} steps");
    let overrides = schedule.iter().map(|(key, value)| format!("{key}={value}")).collect();
    train_model::<methods::Splat>("3DGS", root, test, args, steps, overrides)
}

/// Trains method `M` with its defaults and `overrides` for `steps` steps in `<out>/<kind>/`
/// (replacing an earlier demo's run there), recording its held-out PSNR curve on the way, and
/// scores the result on the test views.
fn train_model<M: Method>(
    name: &'static str,
    root: &Path,
    test: &ImageSet,
    args: &DemoArgs,
    steps: usize,
    overrides: Vec<String>,
) -> anyhow::Result<ModelRun> {
    let dir = args.out.join(M::KIND);
    let request = RunRequest {
        overrides,
        steps: Some(steps),
        seed: Some(args.seed),
        start: Start::Overwrite,
        checkpoint_seconds: 0.0,
        evaluate: false,
        ..RunRequest::new(root, &dir)
    };
    let every = curve_interval(steps);
    let (mut curve, mut trained) = (Vec::new(), None);
    let mut listener = |event: &Event<'_>| -> Result<(), ModelError> {
        match *event {
            Event::Step { step, elapsed, model, .. } if step.is_multiple_of(every) || step == steps => {
                curve.push((elapsed, held_out_psnr(&*model().ok_or("a model that renders views")?, test)));
            }
            Event::Finished { model, .. } => trained = model(),
            _ => {}
        }
        Ok(())
    };
    let summary = lucid_session::train::<M>(&request, &mut listener)?;
    let model = trained.context("the trained model")?;
    show_run(name, &*model, &summary, curve, test, &dir, args)
}

/// A trained model's part of the report: its scores on every test view (renders in `dir`),
/// the views shown and the novel views.
fn show_run(
    name: &'static str,
    renderer: &dyn lucid_scene::evaluation::ViewModel,
    run: &lucid_burn::run::RunSummary,
    curve: Vec<(f64, f64)>,
    test: &ImageSet,
    dir: &std::path::Path,
    args: &DemoArgs,
) -> anyhow::Result<ModelRun> {
    let (summary, views) = score_and_show(renderer, test, dir, &args.out, name)?;
    let novel = novel_views(renderer, test, &args.out, name)?;
    let checkpoint = dir.join(CHECKPOINT);
    Ok(ModelRun { name, steps: run.steps, seconds: run.elapsed, summary, checkpoint, curve, views, novel })
}

/// Steps between the points of a held-out PSNR curve over `steps`.
fn curve_interval(steps: usize) -> usize {
    (steps / CURVE_POINTS).max(1)
}
