//! `lucid train splat DATASET -o OUT`: 3D Gaussian splatting with progress (loss, PSNR,
//! Gaussians), a CSV log over wall time, atomic resumable checkpoints, the standard `.ply`
//! export (`OUT/splats.ply`), and a closing evaluation on the test split.

use std::io::Write;
use std::time::Instant;

use anyhow::Context;
use lucid_scene::Split;
use lucid_scene::dataset::images::scene_box;
use lucid_splat::checkpoint;
use lucid_splat::config::SplatConfig;
use lucid_splat::trainer::{SplatTrainer, initial_cloud};
use lucid_splat::view::SplatRenderer;

use super::train::{Shortcuts, config_text, open_log, training_data};
use crate::cli::TrainModelArgs;

const PHASES: [&str; 4] = ["render", "loss+backward", "optimizer", "densify"];

/// The configuration file (or the defaults) with `--set` and the shortcuts applied.
pub fn splat_config(args: &TrainModelArgs) -> anyhow::Result<SplatConfig> {
    let (text, origin) = config_text(args.config.as_deref(), &args.overrides)?;
    let mut config = SplatConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?;
    let t = &mut config.train;
    Shortcuts::of(args).apply(&mut t.steps, &mut t.time_limit, Some(&mut t.seed));
    config.validate().map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    Ok(config)
}

pub fn run(args: TrainModelArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let (dataset, data, ckpt) = training_data(&args)?;
    let device = lucid_burn::backend::training_device();
    let (mut trainer, mut elapsed) = if args.resume {
        let loaded = checkpoint::load(&ckpt, &device).context("resuming")?;
        let mut trainer = loaded.trainer;
        let t = &mut trainer.config.train;
        Shortcuts::of(&args).apply(&mut t.steps, &mut t.time_limit, None);
        tracing::info!("resuming {} at step {}", ckpt.display(), trainer.step);
        (trainer, loaded.header.elapsed)
    } else {
        let config = splat_config(&args)?;
        let cloud = initial_cloud(&config, &dataset)
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("initialising from {}", dataset.root.display()))?;
        let (lo, hi) = scene_box(&dataset);
        (SplatTrainer::new(config, &cloud, &data, (lo + hi) * 0.5, device), 0.0)
    };
    super::write_text(&args.output.join("config.toml"), &toml::to_string(&trainer.config)?)?;
    tracing::info!(
        "{} training views loaded in {:.1} s; {} Gaussians to start; scene extent {:.3}; {} steps",
        data.len(),
        load_start.elapsed().as_secs_f64(),
        trainer.model.len(),
        trainer.extent,
        trainer.config.train.steps
    );

    let log_path = args.output.join("train_log.csv");
    let mut log = open_log(&log_path, args.resume, "step,seconds,loss,psnr,gaussians,sh_degree,position_lr")?;
    let t = trainer.config.train;
    let bar = crate::progress::bar(t.steps as u64, "splat");
    bar.set_position(trainer.step as u64);
    let start = Instant::now() - std::time::Duration::from_secs_f64(elapsed);
    let mut phases = [0.0f64; 4];
    let last = args.until.unwrap_or(t.steps).min(t.steps);
    let (mut loss_sum, mut psnr_sum, mut window) = (0.0f64, 0.0f64, 0usize);
    while trainer.step < last && (t.time_limit == 0.0 || elapsed < t.time_limit) {
        if t.time_limit > 0.0 {
            trainer.budget_progress = elapsed / t.time_limit;
        }
        let stats = trainer.step(&data);
        elapsed = start.elapsed().as_secs_f64();
        for (p, s) in phases.iter_mut().zip(stats.timings) {
            *p += s;
        }
        (loss_sum, psnr_sum, window) = (loss_sum + stats.loss as f64, psnr_sum + stats.psnr as f64, window + 1);
        if let Some(d) = stats.densified {
            tracing::debug!(
                step = trainer.step,
                cloned = d.cloned,
                split = d.split,
                pruned = d.pruned,
                total = d.total
            );
        }
        bar.inc(1);
        if trainer.step % t.log_every == 0 || trainer.step == t.steps {
            let (loss, psnr) = (loss_sum / window as f64, psnr_sum / window as f64);
            (loss_sum, psnr_sum, window) = (0.0, 0.0, 0);
            writeln!(
                log,
                "{},{:.3},{:.6},{:.3},{},{},{:.3e}",
                trainer.step,
                elapsed,
                loss,
                psnr,
                stats.gaussians,
                trainer.sh_degree(),
                trainer.learning_rates()[0]
            )
            .with_context(|| log_path.display().to_string())?;
            log.flush().with_context(|| log_path.display().to_string())?;
            bar.set_message(format!("loss {loss:.4} {psnr:.2} dB {} Gaussians", stats.gaussians));
        }
        if t.checkpoint_every > 0 && trainer.step % t.checkpoint_every == 0 {
            checkpoint::save(&ckpt, &trainer, elapsed)?;
        }
    }
    bar.finish_and_clear();
    checkpoint::save(&ckpt, &trainer, elapsed)?;
    let cloud = trainer.model.to_cloud();
    let ply = args.output.join("splats.ply");
    lucid_splat::ply::write_splat_ply(&ply, &cloud)?;
    println!(
        "trained {} steps in {:.1} s: {} Gaussians -> {} and {}",
        trainer.step,
        elapsed,
        cloud.len(),
        ckpt.display(),
        ply.display()
    );
    let total: f64 = phases.iter().sum();
    let shares: Vec<String> =
        PHASES.iter().zip(phases).map(|(n, t)| format!("{n} {:.0}%", 100.0 * t / total.max(1e-9))).collect();
    println!("time per phase: {}", shares.join(", "));
    if args.until.is_some_and(|u| u < t.steps) {
        println!("stopped at step {} of {}; continue with --resume", trainer.step, t.steps);
    } else if !args.no_eval && !dataset.frames(Split::Test).is_empty() {
        let renderer = SplatRenderer { cloud: &cloud, settings: trainer.eval_settings() };
        crate::commands::eval::evaluate_model(
            &renderer,
            trainer.step,
            &dataset,
            Split::Test,
            None,
            &args.output.join("eval_test"),
            false,
            false,
        )?;
    }
    Ok(())
}
