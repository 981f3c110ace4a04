//! `lucid gen SCENE --rig capture`: photographs and the sparse COLMAP model of a hand-held
//! capture ([`lucid_datasets_gen::capture`]).

use anyhow::{Context, bail};
use glam::Vec3;
use lucid_datasets_gen::PathTracedScene;
use lucid_datasets_gen::capture::{CaptureSpec, HandheldRing, generate_capture};
use lucid_image::tonemap::ToneCurve;
use lucid_scene::LensDistortion;
use serde::Serialize;

use crate::cli::GenArgs;
use lucid_datasets_gen::reference_spheres::ReferenceSphere;

/// What `dataset.toml` records for a capture.
#[derive(Serialize)]
struct CaptureRecord<'a> {
    generator: String,
    scene: &'a str,
    rig: &'static str,
    images: usize,
    width: u32,
    height: u32,
    fov_degrees: f32,
    k1: f32,
    radius: f32,
    spp: u32,
    #[serde(skip_serializing_if = "super::is_path_tracing")]
    integrator: &'static str,
    max_depth: u32,
    seed: u64,
    pose_noise_degrees: f32,
    position_noise: f32,
    point_noise: f32,
    points: usize,
    /// Last: arrays of tables follow plain keys in TOML.
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    reference_spheres: &'a [ReferenceSphere],
}

pub fn run(args: &GenArgs, loaded: lucid_trace::LoadedScene, spheres: &[ReferenceSphere]) -> anyhow::Result<()> {
    let height = args.height.unwrap_or(args.res);
    if height == 0 || height > 8192 {
        bail!("--height {height} must be in 1..=8192");
    }
    if args.images < 2 || args.images > 100_000 {
        bail!("--images {} must be in 2..=100000", args.images);
    }
    let finite_non_negative = |v: f32| v.is_finite() && v >= 0.0;
    if ![args.pose_noise, args.position_noise, args.point_noise].into_iter().all(finite_non_negative) {
        bail!("--pose-noise, --position-noise and --point-noise must be non-negative numbers");
    }
    if !(args.k1.is_finite() && args.k1.abs() < 1.0) {
        bail!("--k1 {} must be within ±1", args.k1);
    }
    if args.shard.is_some() || args.merge {
        bail!("the capture rig renders in one run (resumable): --shard and --merge are for the other rigs");
    }
    let spec = CaptureSpec {
        width: args.res,
        height,
        fov_x: args.fov.to_radians(),
        lens: LensDistortion::opencv(args.k1, 0.0, 0.0, 0.0),
        images: args.images,
        ring: HandheldRing {
            radius: args.radius,
            heights: (0.2 * args.radius, 0.5 * args.radius),
            target: Vec3::new(0.0, 0.0, 0.5),
            seed: loaded.settings.seed,
        },
        rotation_noise_degrees: args.pose_noise,
        position_noise: args.position_noise,
        point_noise: args.point_noise,
        points: args.points,
        exposure: 0.0,
        tone_curve: ToneCurve::Aces,
    };
    let record = CaptureRecord {
        generator: format!("lucid {}", env!("CARGO_PKG_VERSION")),
        scene: &args.scene,
        rig: "capture",
        images: args.images,
        width: args.res,
        height,
        fov_degrees: args.fov,
        k1: args.k1,
        radius: args.radius,
        spp: loaded.settings.spp,
        integrator: loaded.settings.integrator.name(),
        max_depth: loaded.settings.path.max_depth,
        seed: loaded.settings.seed,
        pose_noise_degrees: args.pose_noise,
        position_noise: args.position_noise,
        point_noise: args.point_noise,
        points: args.points,
        reference_spheres: spheres,
    };
    let toml_text = toml::to_string_pretty(&record).context("serialising dataset.toml")?;
    super::refuse_foreign_folder(&args.output)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("{}: cannot create", args.output.display()))?;
    let _lock = lucid_image::output::OutputLock::folder(&args.output)?;
    super::pin_settings(&args.output, &toml_text)?;
    tracing::info!(
        "rendering a capture of {} ({}x{}, {} spp, {} photographs) into {}",
        args.scene,
        args.res,
        height,
        loaded.settings.spp,
        args.images,
        args.output.display()
    );
    let renderer = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    let bar = crate::progress::bar(0, "rendering");
    let started = std::time::Instant::now();
    let out = generate_capture(&args.output, &spec, &renderer, &|done, to_do| {
        bar.set_length(to_do as u64);
        bar.set_position(done as u64)
    })
    .with_context(|| format!("generating {}", args.output.display()))?;
    bar.finish_and_clear();
    println!(
        "{}: rendered {} photographs, {} already there ({} at {}x{}) in {:.1} s; sparse model with {} points in sparse/0 (COLMAP) and transforms.json + sparse_pc.ply (nerfstudio)",
        args.output.display(),
        out.rendered,
        out.skipped,
        args.scene,
        args.res,
        height,
        started.elapsed().as_secs_f64(),
        out.points
    );
    Ok(())
}
