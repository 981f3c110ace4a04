//! `lucid demo`: the README's main command. It path-traces a small dataset of the built-in
//! `object` scene, reads it back and evaluates what can be evaluated so far: the 8-bit images
//! against the HDR truth, and a nearest-training-view baseline on the held-out test views (the
//! floor every trained model must beat). Writes `<out>/dataset/` and `<out>/metrics.json`.

use std::io::Write;

use anyhow::{Context, bail};
use glam::{Vec3, Vec4Swizzles};
use lucid_datasets_gen::writer::DatasetSpec;
use lucid_datasets_gen::{OrbitRig, PathTracedScene, Shard, generate_dataset};
use lucid_image::metrics::{MetricSpace, MetricSummary};
use lucid_image::tonemap::ToneCurve;
use lucid_scene::{Dataset, Split};
use serde_json::json;

use super::metrics::compare_files;
use crate::cli::DemoArgs;

/// Evaluation background of the demo (the Blender set's convention).
const BACKGROUND: [f32; 3] = [1.0, 1.0, 1.0];

pub fn run(args: DemoArgs) -> anyhow::Result<()> {
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
    let root = args.out.join("dataset");
    let spec = DatasetSpec {
        width: args.size,
        height: args.size,
        fov_x: 40f32.to_radians(),
        counts: [train, val, test],
        rig: OrbitRig { radius: 4.0, target: Vec3::ZERO, upper_hemisphere: true, seed: args.seed },
        aabb: (Vec3::splat(-1.0), Vec3::splat(1.0)),
        exposure: 0.0,
        tone_curve: ToneCurve::Aces,
        brackets: None,
        light_field: None,
        olat: None,
    };
    let mut loaded = super::generate::load_named_scene("object")?;
    loaded.settings.spp = args.spp;
    loaded.settings.seed = args.seed;
    tracing::info!("path-tracing {} views of the object scene into {}", train + val + test, root.display());
    let renderer = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    let bar = crate::progress::bar((train + val + test) as u64, "rendering");
    generate_dataset(&root, &spec, &renderer, Shard::ALL, &|done, _| bar.set_position(done as u64))
        .context("generating the demo dataset")?;
    bar.finish_and_clear();

    let dataset = Dataset::open(&root)?;
    let summary = super::info::summarise(&dataset);

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
    println!();
    println!("done in {elapsed:.1} s");

    let report = json!({
        "scene": "object", "size": args.size, "spp": args.spp, "views": [train, val, test], "seed": args.seed,
        "background": BACKGROUND, "space": "srgb",
        "dataset": summary,
        "metrics": {
            "ldr_vs_hdr_truth": {"psnr": q.psnr, "ssim": q.ssim, "count": q.count},
            "nearest_train_view": {"psnr": n.psnr, "ssim": n.ssim, "count": n.count},
        },
        "seconds": elapsed,
    });
    let path = args.out.join("metrics.json");
    lucid_image::write_atomically(&path, |out| {
        out.write_all(serde_json::to_string_pretty(&report).expect("serialisable").as_bytes())
            .map_err(|e| lucid_image::ImageError::Io { path: path.clone(), source: e })
    })?;
    println!("metrics written to {}", path.display());
    Ok(())
}
