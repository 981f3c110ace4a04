//! `lucid gen SCENE --rig orbit -o DIR`: path-traced datasets in the NeRF-synthetic layout,
//! with a `dataset.toml` that records how to regenerate them.

mod capture;
mod rig_file;

use std::path::Path;

use anyhow::{Context, bail};
use glam::Vec3;
use lucid_datasets_gen::writer::DatasetSpec;
use lucid_datasets_gen::{
    LightFieldRig, OrbitRig, PathTracedScene, Rig, Shard, finish_dataset, generate_dataset, missing_frames,
};
use lucid_image::tonemap::ToneCurve;
use serde::Serialize;

use crate::cli::{GenArgs, ResponseArg, RigArg};
use lucid_datasets_gen::brackets::{BracketSpec, CameraResponse, SensorNoise};
use lucid_datasets_gen::olat::{OlatSpec, builtin_environments, held_out_directions, sphere_directions};
use lucid_datasets_gen::reference_spheres::{ReferenceSphere, add_to_scene, place_spheres};
use lucid_datasets_gen::writer::ViewRenderer;

/// Whether an integrator's name is the default's.
pub(crate) fn is_path_tracing(name: &&'static str) -> bool {
    *name == lucid_trace::Integrator::Path.name()
}

/// What `dataset.toml` records.
#[derive(Serialize)]
struct DatasetRecord<'a> {
    generator: String,
    scene: &'a str,
    rig: &'a str,
    views: [usize; 3],
    resolution: u32,
    fov_degrees: f32,
    radius: f32,
    full_sphere: bool,
    spp: u32,
    /// Written only when not the default, so that folders made before it existed resume.
    #[serde(skip_serializing_if = "is_path_tracing")]
    integrator: &'static str,
    max_depth: u32,
    seed: u64,
    exposure_times: Option<Vec<f32>>,
    response: Option<&'a str>,
    full_well: Option<f32>,
    read_noise: Option<f32>,
    grid: Option<Vec<usize>>,
    spacing: Option<f32>,
    ground_truth: Option<Vec<(f32, f32)>>,
    lights: Option<usize>,
    light_irradiance: Option<f32>,
    held_out_lights: Option<usize>,
    /// Last: arrays of tables follow plain keys in TOML.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    reference_spheres: Vec<ReferenceSphere>,
}

/// `gen` writes only into a missing or empty folder, or one holding a dataset it made (its
/// `dataset.toml`): a dataset from elsewhere (a Blender set, a capture) would otherwise have
/// its transforms files rewritten under it.
fn refuse_foreign_folder(dir: &Path) -> anyhow::Result<()> {
    if dir.join("dataset.toml").is_file() {
        return Ok(());
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        // Missing (created below) or not a folder (creating it names the problem).
        return Ok(());
    };
    let mut found: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !lucid_image::output::is_lock_file(n))
        .collect();
    if found.is_empty() {
        return Ok(());
    }
    found.sort();
    let shown = found.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
    let more = if found.len() > 4 { format!(" and {} more", found.len() - 4) } else { String::new() };
    bail!(
        "{}: holds files that lucid gen did not write ({shown}{more}; no dataset.toml); gen writes only into a new or empty folder or one it made, and leaves this one untouched: choose another output",
        dir.display()
    )
}

/// Writes `dataset.toml` into `dir`, or checks that the one there records the same settings.
fn pin_settings(dir: &Path, toml_text: &str) -> anyhow::Result<()> {
    let path = dir.join("dataset.toml");
    match std::fs::read_to_string(&path) {
        Ok(existing) if existing != toml_text => bail!(
            "{}: this folder holds a dataset made with other settings; use another folder (or delete it)",
            path.display()
        ),
        Ok(_) => Ok(()),
        Err(_) => Ok(lucid_image::output::write_text(&path, toml_text)?),
    }
}

/// The most views of one split.
const MAX_VIEWS: usize = 100_000;
/// Bytes per pixel while a frame renders: colour, normal, albedo and depth buffers with their
/// accumulators and the encoded files.
const GEN_BYTES_PER_PIXEL: f64 = 160.0;

pub fn run(mut args: GenArgs, matches: &clap::ArgMatches) -> anyhow::Result<()> {
    let rig = rig_file::resolve_rig(&mut args, matches)?;
    if args.res == 0 || args.res > 8192 {
        bail!("--res {} must be in 1..=8192", args.res);
    }
    if !(args.fov > 0.0 && args.fov < 180.0) {
        bail!("--fov {} must be in (0, 180) degrees", args.fov);
    }
    // The readers' limit on a pose's entries, with room for the scene's extent.
    let max_radius = lucid_scene::dataset::MAX_POSE_ENTRY as f32 / 10.0;
    if !(args.radius.is_finite() && args.radius > 0.0 && args.radius <= max_radius) {
        bail!("--radius {} must be a positive number of at most {max_radius:e}", args.radius);
    }
    if args.views[0] == 0 {
        bail!("--views needs at least one training view");
    }
    if args.views.iter().any(|&n| n > MAX_VIEWS) {
        bail!("--views {:?}: at most {MAX_VIEWS} views a split", args.views);
    }
    crate::commands::check_image_memory(args.res, args.res, GEN_BYTES_PER_PIXEL, "--res")?;
    let spheres = place_spheres(&args.reference_spheres).map_err(|e| anyhow::anyhow!("--reference-sphere: {e}"))?;
    let mut loaded = if spheres.is_empty() {
        lucid_datasets_gen::builtin::load_named_scene(&args.scene)?
    } else {
        let (text, path) = lucid_datasets_gen::builtin::named_scene_text(&args.scene)?;
        let text = add_to_scene(&text, &spheres)
            .map_err(|e| anyhow::anyhow!("{}: cannot add reference spheres: {e}", args.scene))?;
        lucid_trace::parse_scene(&text, &path)?
    };
    crate::commands::override_samples(&mut loaded.settings, args.spp, args.seed)?;
    crate::commands::override_integrator(&mut loaded, args.integrator, &args.scene)?;
    if let RigArg::Capture = rig {
        return capture::run(&args, loaded, &spheres);
    }
    let orbit = OrbitRig {
        radius: args.radius,
        target: Vec3::ZERO,
        upper_hemisphere: !args.full_sphere,
        seed: loaded.settings.seed,
    };
    let rig = match rig {
        RigArg::Orbit => Rig::Orbit(orbit),
        RigArg::Brackets => {
            if args.exposures.is_empty() || args.exposures.iter().any(|s| !s.is_finite() || s.abs() > 30.0) {
                bail!("--exposures must list finite stops within ±30");
            }
            let non_negative = |v: f32| v.is_finite() && v >= 0.0;
            if !(non_negative(args.full_well) && non_negative(args.read_noise)) {
                bail!("--full-well and --read-noise must be non-negative numbers");
            }
            Rig::Brackets(
                orbit,
                BracketSpec {
                    exposure_times: args.exposures.iter().map(|s| s.exp2()).collect(),
                    response: match args.response {
                        ResponseArg::Srgb => CameraResponse::Srgb,
                        ResponseArg::Scurve => CameraResponse::SCurve { contrast: 1.6 },
                    },
                    noise: SensorNoise {
                        full_well_electrons: if args.full_well > 0.0 { args.full_well } else { f32::INFINITY },
                        read_noise: if args.full_well > 0.0 { args.read_noise } else { 0.0 },
                    },
                },
            )
        }
        RigArg::Lightfield => {
            let [u, v] = args.grid[..] else { bail!("--grid takes two counts, U,V") };
            if u == 0 || v == 0 || u * v > 10_000 {
                bail!("--grid {u},{v} must have 1..=10000 cameras");
            }
            if !(args.spacing.is_finite() && args.spacing > 0.0) {
                bail!("--spacing must be positive");
            }
            if args.focus.iter().chain(&args.apertures).any(|x| !x.is_finite() || *x < 0.0) || args.focus.contains(&0.0)
            {
                bail!("--focus must be positive and --apertures non-negative");
            }
            let ground_truth = args.focus.iter().flat_map(|&f| args.apertures.iter().map(move |&a| (f, a))).collect();
            // The grid faces the origin from the front, slightly above, at the orbit radius.
            let centre = Vec3::new(0.0, -1.0, 0.35).normalize() * args.radius;
            Rig::LightField(LightFieldRig {
                centre,
                target: Vec3::ZERO,
                up: Vec3::Z,
                grid: [u, v],
                spacing: args.spacing,
                ground_truth,
            })
        }
        RigArg::Capture => unreachable!("handled above"),
        RigArg::Olat => {
            if args.lights == 0 || args.lights > 4096 {
                bail!("--lights must be in 1..=4096");
            }
            if !(args.light_irradiance.is_finite() && args.light_irradiance > 0.0) {
                bail!("--light-irradiance must be positive");
            }
            if args.held_out_lights > 1024 {
                bail!("--held-out-lights must be at most 1024");
            }
            Rig::Olat(
                orbit,
                OlatSpec {
                    directions: sphere_directions(args.lights),
                    held_out: held_out_directions(args.held_out_lights),
                    irradiance: args.light_irradiance,
                    environments: builtin_environments(),
                },
            )
        }
    };
    let spec = DatasetSpec {
        width: args.res,
        height: args.res,
        fov_x: args.fov.to_radians(),
        counts: args.views,
        rig,
        aabb: (Vec3::splat(-1.5), Vec3::splat(1.5)),
        exposure: 0.0,
        tone_curve: ToneCurve::Clip,
    };
    let (brackets, light_field, olat) = (spec.rig.brackets(), spec.rig.light_field(), spec.rig.olat());
    let record = DatasetRecord {
        generator: format!("lucid {}", env!("CARGO_PKG_VERSION")),
        scene: &args.scene,
        rig: spec.rig.name(),
        views: args.views,
        resolution: args.res,
        fov_degrees: args.fov,
        radius: args.radius,
        full_sphere: args.full_sphere,
        spp: loaded.settings.spp,
        integrator: loaded.settings.integrator.name(),
        max_depth: loaded.settings.path.max_depth,
        seed: loaded.settings.seed,
        exposure_times: brackets.as_ref().map(|b| b.exposure_times.clone()),
        response: brackets.as_ref().map(|_| match args.response {
            ResponseArg::Srgb => "srgb",
            ResponseArg::Scurve => "scurve",
        }),
        full_well: brackets.as_ref().map(|_| args.full_well),
        read_noise: brackets.as_ref().map(|_| args.read_noise),
        grid: light_field.as_ref().map(|l| l.grid.to_vec()),
        spacing: light_field.as_ref().map(|l| l.spacing),
        ground_truth: light_field.as_ref().map(|l| l.ground_truth.clone()),
        lights: olat.as_ref().map(|o| o.directions.len()),
        light_irradiance: olat.as_ref().map(|o| o.irradiance),
        held_out_lights: olat.as_ref().map(|o| o.held_out.len()),
        reference_spheres: spheres,
    };
    let renderer = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    if olat.is_some() {
        renderer.can_relight().map_err(|e| anyhow::anyhow!("{}: cannot make an OLAT set: {e}", args.scene))?;
    }
    // dataset.toml first: it pins the settings, so a resumed or sharded run into the same
    // folder cannot mix frames made with different ones.
    let toml_text = toml::to_string_pretty(&record).context("serialising dataset.toml")?;
    refuse_foreign_folder(&args.output)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("{}: cannot create", args.output.display()))?;
    // One writer per folder; the shards of a sharded run each lock only their own share.
    let _lock = match args.shard {
        Some((index, count)) if !args.merge => {
            lucid_image::output::OutputLock::file(&args.output.join(format!("shard-{index}-of-{count}")))?
        }
        _ => lucid_image::output::OutputLock::folder(&args.output)?,
    };
    pin_settings(&args.output, &toml_text)?;
    if args.merge {
        if !finish_dataset(&args.output, &spec)? {
            bail!(
                "{}: {} frames are still missing; run the remaining shards first",
                args.output.display(),
                missing_frames(&args.output, &spec)
            );
        }
        println!("merged {}: transforms files and points3d.ply written", args.output.display());
        return Ok(());
    }
    let shard = args.shard.map_or(Shard::ALL, |(index, count)| Shard { index, count });
    tracing::info!(
        "rendering {} ({}x{}, {} spp) into {}",
        args.scene,
        args.res,
        args.res,
        loaded.settings.spp,
        args.output.display()
    );
    let bar = crate::progress::bar(0, "rendering");
    let started = std::time::Instant::now();
    let out = generate_dataset(&args.output, &spec, &renderer, shard, &|done, to_do| {
        bar.set_length(to_do as u64);
        bar.set_position(done as u64)
    })
    .with_context(|| format!("generating {}", args.output.display()))?;
    bar.finish_and_clear();
    println!(
        "{}: rendered {} views, {} already there ({} at {}x{}, shard {}/{}) in {:.1} s; {}",
        args.output.display(),
        out.rendered,
        out.skipped,
        args.scene,
        args.res,
        args.res,
        shard.index,
        shard.count,
        started.elapsed().as_secs_f64(),
        if out.complete { "dataset complete" } else { "other shards still to run" }
    );
    Ok(())
}
