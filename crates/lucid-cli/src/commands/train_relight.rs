//! `lucid train relight OLAT_DATASET -o OUT`: the neural relighting head. Stage 1 trains a
//! splat cloud on the views lit uniformly (`OUT/geometry.lucid`, a resumable splat
//! checkpoint, and `OUT/geometry.ply`); stage 2 trains the head over the frozen geometry
//! (`OUT/checkpoint.lucid`, kind `relight`); then the test split is evaluated under its lights
//! and environment maps (`OUT/eval_test`).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use lucid_relight_head::checkpoint::{self, LightSet};
use lucid_relight_head::config::RelightConfig;
use lucid_relight_head::data::OlatSet;
use lucid_relight_head::trainer::RelightTrainer;
use lucid_scene::dataset::images::{ImageSet, scene_box};
use lucid_scene::{Dataset, Split};
use lucid_splat::trainer::{SplatTrainer, initial_cloud};
use lucid_splat::view::SplatRenderer;

use super::train::{Shortcuts, config_text, open_log};
use crate::cli::TrainModelArgs;

/// The configuration file (or the defaults) with `--set` and the shortcuts (which set the
/// head's `train` keys) applied.
pub fn relight_config(args: &TrainModelArgs) -> anyhow::Result<RelightConfig> {
    let (text, origin) = config_text(args.config.as_deref(), &args.overrides)?;
    let mut config = RelightConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?;
    let t = &mut config.train;
    Shortcuts::of(args).apply(&mut t.steps, &mut t.time_limit, Some(&mut t.seed));
    config.validate().map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    Ok(config)
}

/// Stage 1: trains (or resumes, or finds finished) the geometry; returns the trainer and the
/// seconds spent.
fn geometry_stage(
    config: &RelightConfig,
    dataset: &Dataset,
    images: &ImageSet,
    out: &Path,
    resume: bool,
) -> anyhow::Result<(SplatTrainer, f64)> {
    let ckpt = out.join("geometry.lucid");
    let device = lucid_burn::backend::training_device();
    let (mut trainer, mut elapsed) = if resume && ckpt.is_file() {
        let loaded = lucid_splat::checkpoint::load(&ckpt, &device).context("resuming the geometry")?;
        (loaded.trainer, loaded.header.elapsed)
    } else {
        let cloud = initial_cloud(&config.geometry, dataset)
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("initialising from {}", dataset.root.display()))?;
        let (lo, hi) = scene_box(dataset);
        (SplatTrainer::new(config.geometry.clone(), &cloud, images, (lo + hi) * 0.5, device), 0.0)
    };
    let t = trainer.config.train;
    let done = |trainer: &SplatTrainer, elapsed: f64| {
        trainer.step >= t.steps || (t.time_limit > 0.0 && elapsed >= t.time_limit)
    };
    if !done(&trainer, elapsed) {
        tracing::info!("geometry: {} uniformly lit views, {} Gaussians to start", images.len(), trainer.model.len());
        let bar = crate::progress::bar(t.steps as u64, "geometry");
        bar.set_position(trainer.step as u64);
        let start = Instant::now() - std::time::Duration::from_secs_f64(elapsed);
        while !done(&trainer, elapsed) {
            if t.time_limit > 0.0 {
                trainer.budget_progress = elapsed / t.time_limit;
            }
            let stats = trainer.step(images);
            elapsed = start.elapsed().as_secs_f64();
            bar.set_position(trainer.step as u64);
            if trainer.step % t.log_every == 0 {
                bar.set_message(format!("{:.2} dB {} Gaussians", stats.psnr, stats.gaussians));
            }
            if t.checkpoint_every > 0 && trainer.step % t.checkpoint_every == 0 {
                lucid_splat::checkpoint::save(&ckpt, &trainer, elapsed)?;
            }
        }
        bar.finish_and_clear();
        lucid_splat::checkpoint::save(&ckpt, &trainer, elapsed)?;
        lucid_splat::ply::write_splat_ply(&out.join("geometry.ply"), &trainer.model.to_cloud())?;
        println!("geometry: {} steps in {elapsed:.1} s, {} Gaussians", trainer.step, trainer.model.len());
    }
    Ok((trainer, elapsed))
}

/// The geometry against the held-out views under uniform light (their OLAT frames summed),
/// where the test split has OLAT frames: the ceiling the head works under.
fn report_geometry(test: &OlatSet, cloud: &lucid_splat::SplatCloud, trainer: &SplatTrainer) -> anyhow::Result<()> {
    if test.views.is_empty() || test.views.iter().any(|v| v.lights.is_empty()) {
        return Ok(());
    }
    let images = test.uniformly_lit()?;
    let renderer = SplatRenderer { cloud, settings: trainer.eval_settings() };
    let (_, summary) = lucid_scene::evaluation::evaluate(&renderer, &images, None, |_, _, _, _| {});
    println!(
        "geometry on {} held-out views under uniform light: PSNR {:.2} dB, SSIM {:.4}",
        summary.views, summary.psnr, summary.ssim
    );
    Ok(())
}

pub fn run(args: TrainModelArgs) -> anyhow::Result<()> {
    let ckpt = args.output.join("checkpoint.lucid");
    // A bad configuration fails before any data is read.
    let config = if args.resume && ckpt.is_file() { None } else { Some(relight_config(&args)?) };
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    // Read once for the geometry's report and the closing evaluation, when either runs.
    let test = if config.is_some() || !args.no_eval {
        OlatSet::load(&args.dataset, Split::Test).context("loading the test views")?
    } else {
        OlatSet { views: Vec::new(), irradiance: 0.0 }
    };
    let data = OlatSet::load(&args.dataset, Split::Train)
        .context("loading the OLAT training frames")?
        .without_held_out_lights();
    data.require_lights(&args.dataset, Split::Train)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    let device = lucid_burn::backend::training_device();
    let (mut trainer, lights, mut elapsed) = match config {
        Some(config) => {
            if args.resume && !args.output.join("geometry.lucid").is_file() {
                bail!("{}: nothing to resume (no checkpoint.lucid or geometry.lucid)", args.output.display());
            }
            let images = data.uniformly_lit()?;
            let (geometry, seconds) = geometry_stage(&config, &dataset, &images, &args.output, args.resume)?;
            let cloud = geometry.model.to_cloud();
            report_geometry(&test, &cloud, &geometry)?;
            let lights = LightSet { directions: data.directions(), irradiance: data.irradiance };
            (RelightTrainer::new(config, cloud, geometry.eval_settings(), device), lights, seconds)
        }
        None => {
            let loaded = checkpoint::load(&ckpt, &device).context("resuming")?;
            let mut trainer = loaded.trainer;
            let t = &mut trainer.config.train;
            Shortcuts::of(&args).apply(&mut t.steps, &mut t.time_limit, None);
            tracing::info!("resuming {} at head step {}", ckpt.display(), trainer.step);
            (trainer, loaded.lights, loaded.header.elapsed)
        }
    };
    super::write_text(&args.output.join("config.toml"), &toml::to_string(&trainer.config)?)?;
    tracing::info!(
        "head: {} OLAT frames of {} views, {} lights, {} Gaussians",
        data.lit_images(),
        data.views.len(),
        lights.directions.len(),
        trainer.geometry.len()
    );

    let log_path = args.output.join("train_log.csv");
    let mut log = open_log(&log_path, args.resume, "step,seconds,loss,psnr,learning_rate")?;
    let t = trainer.config.train;
    let bar = crate::progress::bar(t.steps as u64, "relight");
    bar.set_position(trainer.step as u64);
    let head_start_elapsed = elapsed;
    let start = Instant::now();
    let last = args.until.unwrap_or(t.steps).min(t.steps);
    let (mut loss_sum, mut psnr_sum, mut window) = (0.0f64, 0.0f64, 0usize);
    let mut head_seconds = 0.0;
    while trainer.step < last && (t.time_limit == 0.0 || head_seconds < t.time_limit) {
        if t.time_limit > 0.0 {
            trainer.budget_progress = head_seconds / t.time_limit;
        }
        let lr = trainer.learning_rate();
        let stats = trainer.train_step(&data);
        if !stats.loss.is_finite() {
            bail!("training diverged at step {} (loss {}); try a lower train.learning_rate", trainer.step, stats.loss);
        }
        head_seconds = start.elapsed().as_secs_f64();
        elapsed = head_start_elapsed + head_seconds;
        (loss_sum, psnr_sum, window) = (loss_sum + stats.loss as f64, psnr_sum + stats.psnr as f64, window + 1);
        bar.inc(1);
        if trainer.step % t.log_every == 0 || trainer.step == t.steps {
            let (loss, psnr) = (loss_sum / window as f64, psnr_sum / window as f64);
            (loss_sum, psnr_sum, window) = (0.0, 0.0, 0);
            writeln!(log, "{},{elapsed:.3},{loss:.6},{psnr:.3},{lr:.3e}", trainer.step)
                .with_context(|| log_path.display().to_string())?;
            log.flush().with_context(|| log_path.display().to_string())?;
            bar.set_message(format!("loss {loss:.4} {psnr:.2} dB"));
        }
        if trainer.step % t.checkpoint_every == 0 {
            checkpoint::save(&ckpt, &trainer, &lights, elapsed)?;
        }
    }
    bar.finish_and_clear();
    checkpoint::save(&ckpt, &trainer, &lights, elapsed)?;
    println!("trained the head {} steps ({elapsed:.1} s in all) -> {}", trainer.step, ckpt.display());
    if args.until.is_some_and(|u| u < t.steps) {
        println!("stopped at step {} of {}; continue with --resume", trainer.step, t.steps);
    } else if !args.no_eval && !test.views.is_empty() {
        // Rendering needs no gradients: reload on the plain device, where no autodiff graph
        // builds up over the environment integration's hundreds of decodes.
        let device = lucid_burn::backend::default_device();
        let loaded = checkpoint::load(&ckpt, &device)?;
        let out = args.output.join("eval_test");
        super::eval_relight::evaluate(&loaded.trainer, &lights, &test, &out, None, false, &device)?;
    }
    Ok(())
}
