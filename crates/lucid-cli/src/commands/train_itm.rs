//! `lucid train itm DATASETS... -o OUT`: trains the inverse tone mapping network on the
//! bracket frames of several datasets, with progress, a CSV log, atomic checkpoints and a
//! closing evaluation against the analytic baseline on their test splits.

use std::io::Write;
use std::time::Instant;

use anyhow::{Context, bail};
use lucid_itm::checkpoint;
use lucid_itm::config::ItmConfig;
use lucid_itm::data::{check_patch, load};
use lucid_itm::trainer::ItmTrainer;
use lucid_scene::Split;

use crate::cli::TrainItmArgs;

pub fn run(args: TrainItmArgs) -> anyhow::Result<()> {
    let ckpt = args.output.join("checkpoint.lucid");
    let device = lucid_burn::backend::training_device();
    let (mut trainer, mut elapsed) = if args.resume {
        if !ckpt.is_file() {
            bail!("{}: no checkpoint to resume", ckpt.display());
        }
        let loaded = checkpoint::load(&ckpt, &device)?;
        let mut trainer = loaded.trainer;
        if let Some(s) = args.steps {
            trainer.config.train.steps = s;
        }
        if let Some(t) = args.time_limit {
            trainer.config.train.time_limit = t;
        }
        (trainer, loaded.header.elapsed)
    } else {
        let (text, origin) = super::train::config_text(args.config.as_deref(), &args.overrides)?;
        let mut config = ItmConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?;
        let t = &mut config.train;
        super::train::Shortcuts { steps: args.steps, time_limit: args.time_limit, seed: args.seed }.apply(
            &mut t.steps,
            &mut t.time_limit,
            Some(&mut t.seed),
        );
        config.validate().map_err(anyhow::Error::msg)?;
        (ItmTrainer::new(config, device.clone()), 0.0)
    };
    let threshold = trainer.config.model.mask_threshold;
    let train = load(&args.datasets, Split::Train, threshold).context("loading training pairs")?;
    check_patch(&train, trainer.config.train.patch)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    super::write_text(&args.output.join("config.toml"), &toml::to_string(&trainer.config)?)?;
    let mut log =
        super::train::open_log(&args.output.join("train_log.csv"), args.resume, "step,seconds,loss,learning_rate")?;
    let t = trainer.config.train.clone();
    tracing::info!("training ITM on {} pairs from {} dataset(s)", train.len(), args.datasets.len());
    let bar = crate::progress::bar(t.steps as u64, "itm");
    bar.set_position(trainer.step as u64);
    let started = Instant::now();
    let base = elapsed;
    let mut smoothed = f32::NAN;
    while trainer.step < t.steps {
        if t.time_limit > 0.0 && elapsed >= t.time_limit {
            break;
        }
        let lr = trainer.learning_rate();
        let loss = trainer.train_step(&train);
        if !loss.is_finite() {
            bail!("training diverged at step {} (loss {loss}); try a lower train.learning_rate", trainer.step);
        }
        smoothed = if smoothed.is_nan() { loss } else { 0.95 * smoothed + 0.05 * loss };
        elapsed = base + started.elapsed().as_secs_f64();
        writeln!(log, "{},{elapsed:.3},{loss:.6},{lr:.3e}", trainer.step)?;
        bar.set_position(trainer.step as u64);
        bar.set_message(format!("loss {smoothed:.4}"));
        if trainer.step % t.checkpoint_every == 0 {
            log.flush()?;
            checkpoint::save(&ckpt, &trainer, elapsed)?;
        }
    }
    bar.finish_and_clear();
    log.flush()?;
    checkpoint::save(&ckpt, &trainer, elapsed)?;
    println!("trained {} steps in {elapsed:.1} s -> {}", trainer.step, ckpt.display());
    if !args.no_eval {
        let test = load(&args.datasets, Split::Test, threshold).context("loading test pairs")?;
        let report = lucid_itm::eval::evaluate(&trainer.net, &test, &device);
        super::eval_itm::print_report(&report);
        let out = args.output.join("eval_test");
        std::fs::create_dir_all(&out)?;
        super::write_text(&out.join("metrics.json"), &serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}
