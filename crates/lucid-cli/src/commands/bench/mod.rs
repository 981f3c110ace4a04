//! `lucid bench`: fixed-seed benchmarks that print a table (and optionally JSON).

mod hdr;
mod integrators;
mod lightcuts;
mod materials;
mod nerf;
mod report;
mod splat;

use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::{RenderCamera, render};
use serde_json::json;

use crate::cli::{BenchArgs, BenchTarget};

/// The reference scene, compiled in so the benchmark runs from any directory.
/// Image mean of the reference render (shared/reference/cornell-box.md).
const CORNELL_REFERENCE_MEAN: f64 = 0.1470;

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let targets = match args.target {
        BenchTarget::All => vec![BenchTarget::Trace, BenchTarget::Nerf, BenchTarget::Splat, BenchTarget::Hdr],
        t => vec![t],
    };
    if let Some(dir) = &args.write_stack {
        anyhow::ensure!(
            matches!(args.target, BenchTarget::Hdr | BenchTarget::All),
            "--write-stack {}: only the hdr benchmark has a bracket to write",
            dir.display()
        );
        anyhow::ensure!(!dir.exists(), "--write-stack {}: already exists (give a new folder)", dir.display());
    }
    let mut results = Vec::new();
    for target in targets {
        match target {
            BenchTarget::Trace => results.push(bench_trace(args.quick)?),
            BenchTarget::Hdr => results.push(hdr::run(args.quick, args.write_stack.as_deref())?),
            BenchTarget::Integrators => results.extend(integrators::run(&integrator_bench(&args))?),
            BenchTarget::Materials => {
                results.push(materials::run(if args.quick { 4 } else { 32 }, if args.quick { 1 } else { 5 })?)
            }
            BenchTarget::Lightcuts => results.extend(lightcuts::run(&lightcuts::LightcutsBench {
                scenes: args.scenes.clone().unwrap_or_else(|| vec!["many-lights".into()]),
                width: if args.quick { args.width.min(64) } else { args.width },
                spp: if args.quick { 1 } else { 4 },
            })?),
            BenchTarget::Nerf | BenchTarget::Splat => {
                for dataset in BenchDataset::all(&args)? {
                    results.push(run_trainer(&args, target, dataset)?);
                }
            }
            BenchTarget::All => unreachable!("expanded above"),
        }
    }
    let result = match &results[..] {
        [one] => one.clone(),
        all => serde_json::Value::Array(all.to_vec()),
    };
    if let Some(path) = &args.json {
        crate::commands::write_text(path, &serde_json::to_string_pretty(&result)?)?;
        println!("results written to {}", path.display());
    }
    let report_dir = match (&args.report, args.target) {
        (Some(dir), _) => Some(dir.clone()),
        (None, BenchTarget::All) => Some(std::path::PathBuf::from("out/bench")),
        _ => None,
    };
    if let Some(dir) = report_dir {
        std::fs::create_dir_all(&dir).map_err(|e| anyhow::anyhow!("creating {}: {e}", dir.display()))?;
        crate::commands::write_text(&dir.join("results.json"), &serde_json::to_string_pretty(&result)?)?;
        let html = report::write_report(&results, args.quick, &dir)?;
        println!("report written to {}", html.display());
    }
    Ok(())
}

/// The integrator benchmark's settings from the command line (`--quick`: 2 s, 64 pixels wide).
fn integrator_bench(args: &BenchArgs) -> integrators::IntegratorBench {
    integrators::IntegratorBench {
        scenes: args.scenes.clone().unwrap_or_else(|| vec!["cornell".into(), "caustic".into()]),
        integrators: args.integrators.clone().unwrap_or_else(|| lucid_trace::Integrator::ALL.map(|(i, _)| i).to_vec()),
        seconds: if args.quick { args.seconds.min(2.0) } else { args.seconds },
        width: if args.quick { args.width.min(64) } else { args.width },
        reference_factor: args.reference_factor,
        cache: integrators::default_cache(),
    }
}

/// The dataset a NeRF or splat benchmark trains on.
pub struct BenchDataset {
    /// Its folder.
    pub root: std::path::PathBuf,
    /// The built-in scene rendered there first if missing or incomplete; `None` for a dataset
    /// read as it is and never written to.
    pub built_in: Option<String>,
    /// How a split-less dataset or capture is read.
    pub options: lucid_scene::dataset::OpenOptions,
}

impl BenchDataset {
    /// One set per `--scenes` entry in `out/bench/SCENE`, or the one `--dataset` names.
    fn all(args: &BenchArgs) -> anyhow::Result<Vec<Self>> {
        let allowed = lucid_datasets_gen::builtin::BENCHMARK_SCENES;
        let scenes = args.trainer_scenes();
        for scene in &scenes {
            anyhow::ensure!(
                allowed.contains(&scene.as_str()) || scene == "object",
                "--scenes: {scene:?} is not a benchmark scene (expected {} or object)",
                allowed.join(", ")
            );
        }
        anyhow::ensure!(!scenes.is_empty(), "--scenes: name at least one scene");
        Ok(match &args.dataset {
            // A folder that is not there yet (or a generation of Lucid's cut short) gets the
            // first built-in scene; any dataset already there is benchmarked as it is.
            Some(root) => {
                let unfinished = root.join("dataset.toml").is_file() && lucid_scene::Dataset::open(root).is_err();
                let built_in = (!root.exists() || unfinished).then(|| scenes[0].clone());
                vec![Self { root: root.clone(), built_in, options: args.data.options() }]
            }
            None => scenes
                .iter()
                .map(|scene| Self {
                    root: std::path::PathBuf::from(format!(
                        "out/bench/{scene}{}",
                        if args.quick { ".quick" } else { "" }
                    )),
                    built_in: Some(scene.clone()),
                    options: Default::default(),
                })
                .collect(),
        })
    }

    /// What the benchmark trains on, for its report.
    pub fn describe(&self) -> String {
        match &self.built_in {
            Some(scene) => format!("the built-in {scene} orbit set ({})", self.root.display()),
            None => format!("dataset {}", self.root.display()),
        }
    }

    /// Renders the built-in set if needed, then opens the dataset; with it, the noise ceiling
    /// of its truth where one was measured (the built-in sets have one).
    pub fn open(
        &self,
        quick: bool,
    ) -> anyhow::Result<(lucid_scene::Dataset, Option<lucid_datasets_gen::builtin::NoiseCeiling>)> {
        use anyhow::Context;
        if let Some(scene) = &self.built_in {
            crate::progress::with_bar("rendering", |progress| {
                lucid_datasets_gen::builtin::ensure_benchmark_set(&self.root, scene, quick, progress)
            })
            .with_context(|| format!("generating the benchmark dataset in {}", self.root.display()))?;
        }
        let dataset = lucid_scene::Dataset::open_with(&self.root, &self.options)
            .with_context(|| format!("reading dataset {}", self.root.display()))?;
        if dataset.frames(lucid_scene::Split::Train).is_empty() || dataset.frames(lucid_scene::Split::Test).is_empty() {
            anyhow::bail!("{}: a benchmark needs training and test views", self.root.display());
        }
        let ceiling = lucid_datasets_gen::builtin::NoiseCeiling::read(&self.root);
        if let Some(c) = &ceiling {
            println!(
                "noise ceiling of {}: {:.2} dB (its {} spp truth against {} spp renders, {} test views)",
                self.root.display(),
                c.mean_psnr,
                c.spp,
                c.reference_spp,
                c.psnr.len()
            );
        }
        Ok((dataset, ceiling))
    }
}

/// `" (noise ceiling 46.12 dB)"` where the set's ceiling is known, for every printed result.
pub fn ceiling_note(ceiling: Option<&lucid_datasets_gen::builtin::NoiseCeiling>) -> String {
    ceiling.map_or_else(String::new, |c| format!(" (noise ceiling {:.2} dB)", c.mean_psnr))
}

fn run_trainer(args: &BenchArgs, target: BenchTarget, dataset: BenchDataset) -> anyhow::Result<serde_json::Value> {
    Ok(match target {
        BenchTarget::Nerf => nerf::run(nerf::NerfBench {
            dataset,
            quick: args.quick,
            overrides: args.overrides.clone(),
            curve_views: args.curve_views,
        })?,
        BenchTarget::Splat => splat::run(splat::SplatBench {
            dataset,
            quick: args.quick,
            overrides: args.overrides.clone(),
            curve_views: args.curve_views,
        })?,
        _ => unreachable!("only the trainers take a dataset"),
    })
}

/// Prints the validation split's scores, the ones settings are to be chosen on.
fn print_validation(val: &lucid_scene::evaluation::EvalSummary) {
    println!(
        "validation split (choose settings on this): {} views, PSNR {:.2} dB, SSIM {:.4}",
        val.views, val.psnr, val.ssim
    );
}

/// A benchmark's timed run of `dataset` for `seconds` with `overrides`, in `folder`: no log,
/// no checkpoints (writing them would count as training time), no closing evaluation (the
/// benchmark scores its own curve).
fn timed_request(
    dataset: &BenchDataset,
    overrides: &[String],
    seconds: f64,
    folder: &std::path::Path,
) -> lucid_session::RunRequest {
    lucid_session::RunRequest {
        overrides: overrides.to_vec(),
        time_limit: Some(seconds),
        checkpoint_seconds: 0.0,
        evaluate: false,
        records: false,
        dataset: dataset.options,
        ..lucid_session::RunRequest::new(&dataset.root, folder.join("run"))
    }
}

fn bench_trace(quick: bool) -> anyhow::Result<serde_json::Value> {
    let mut loaded = lucid_datasets_gen::builtin::load_named_scene("cornell")?;
    if quick {
        let RenderCamera::Pinhole(c) = loaded.camera else { anyhow::bail!("the Cornell camera is a pinhole") };
        loaded.camera = RenderCamera::Pinhole(PinholeCamera::new(
            Intrinsics::from_fov_x(64, 64, c.intrinsics.fov_x()),
            c.camera_to_world,
        ));
        loaded.settings.spp = 16;
    }
    let k = match &loaded.camera {
        RenderCamera::Pinhole(c) => c.intrinsics,
        RenderCamera::ThinLens(c) => c.pinhole.intrinsics,
    };
    let threads = rayon::current_num_threads();
    let bar = crate::progress::bar(k.height as u64, "cornell");
    let started = std::time::Instant::now();
    let out = render(&loaded.scene, &loaded.camera, &loaded.settings, &|rows| bar.set_position(rows as u64))?;
    let seconds = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let m = out.colour.mean();
    let mean = (m[0] + m[1] + m[2]) / 3.0;
    println!(
        "lucid bench trace{}: Cornell box {}x{}, {} spp, max depth {}, {threads} threads",
        if quick { " --quick" } else { "" },
        k.width,
        k.height,
        loaded.settings.spp,
        loaded.settings.path.max_depth
    );
    println!("{:<22} {:>14}", "metric", "value");
    println!("{:<22} {:>14.3}", "wall time (s)", seconds);
    println!("{:<22} {:>14.3}", "paths/s (M)", out.paths as f64 / seconds / 1e6);
    println!("{:<22} {:>14.3}", "rays/s (M)", out.rays as f64 / seconds / 1e6);
    println!("{:<22} {:>14.2}", "rays per path", out.rays as f64 / out.paths as f64);
    println!("{:<22} {:>14.5}", "image mean", mean);
    println!("{:<22} {:>14.5}", "reference mean", CORNELL_REFERENCE_MEAN);
    Ok(json!({
        "benchmark": "trace", "quick": quick, "width": k.width, "height": k.height,
        "spp": loaded.settings.spp, "max_depth": loaded.settings.path.max_depth, "threads": threads,
        "seconds": seconds, "paths": out.paths, "rays": out.rays,
        "paths_per_second": out.paths as f64 / seconds, "rays_per_second": out.rays as f64 / seconds,
        "image_mean": mean, "reference_mean": CORNELL_REFERENCE_MEAN,
    }))
}
