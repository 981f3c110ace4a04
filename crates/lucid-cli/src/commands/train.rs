//! `lucid train nerf DATASET -o OUT`: trains with progress, a CSV log of loss and PSNR over
//! wall time, atomic checkpoints (resumable), and a closing evaluation on the test split.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use lucid_nerf::checkpoint;
use lucid_nerf::config::NerfConfig;
use lucid_nerf::data::ImageSet;
use lucid_nerf::trainer::Trainer;
use lucid_scene::{Dataset, Split};

use crate::cli::{TrainArgs, TrainModel, TrainModelArgs};

pub fn run(args: TrainArgs) -> anyhow::Result<()> {
    match args.model {
        TrainModel::Nerf(args) => nerf(args),
        TrainModel::Splat(args) => super::train_splat::run(args),
        TrainModel::Itm(args) => super::train_itm::run(args),
        TrainModel::Relight(args) => super::train_relight::run(args),
    }
}

/// The configuration file's text (empty for the defaults) with the `--set KEY=VALUE`
/// overrides applied, as TOML, and a description of where it came from for messages.
pub fn config_text(file: Option<&Path>, overrides: &[String]) -> anyhow::Result<(String, String)> {
    let (text, origin) = match file {
        Some(path) => {
            (std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?, path.display().to_string())
        }
        None => (String::new(), "default configuration".to_string()),
    };
    let mut value: toml::Table = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{origin}: {}", lucid_nerf::config::toml_error(&text, &e)))?;
    for item in overrides {
        let (key, raw) = item.split_once('=').with_context(|| format!("--set {item}: expected KEY=VALUE"))?;
        // Parse the value as TOML; a bare word that is not TOML is taken as a string.
        let parsed: toml::Value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(raw.to_string()));
        let mut table = &mut value;
        let parts: Vec<&str> = key.trim().split('.').collect();
        for part in &parts[..parts.len() - 1] {
            table = table
                .entry(part.to_string())
                .or_insert_with(|| toml::Value::Table(Default::default()))
                .as_table_mut()
                .with_context(|| format!("--set {item}: {part} is not a table"))?;
        }
        table.insert(parts[parts.len() - 1].to_string(), parsed);
    }
    let origin = if overrides.is_empty() { origin } else { format!("{origin} with --set {}", overrides.join(" ")) };
    Ok((toml::to_string(&value)?, origin))
}

/// The dataset, its training images and the checkpoint path in the (created) output folder.
pub fn training_data(args: &TrainModelArgs) -> anyhow::Result<(Dataset, ImageSet, PathBuf)> {
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    let frames = dataset.frames(Split::Train);
    if frames.is_empty() {
        bail!("{}: no training frames (transforms_train.json or transforms.json)", args.dataset.display());
    }
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    let data = ImageSet::load(frames).context("loading training images")?;
    Ok((dataset, data, args.output.join("checkpoint.lucid")))
}

/// `--steps`, `--time-limit` and `--seed`, each only where given.
#[derive(Clone, Copy, Debug, Default)]
pub struct Shortcuts {
    /// `train.steps`.
    pub steps: Option<usize>,
    /// `train.time_limit`.
    pub time_limit: Option<f64>,
    /// `train.seed`.
    pub seed: Option<u64>,
}

impl Shortcuts {
    /// The shortcuts of a training command.
    pub fn of(args: &TrainModelArgs) -> Self {
        Self { steps: args.steps, time_limit: args.time_limit, seed: args.seed }
    }

    /// Writes the given ones into a configuration's `train` section (a resumed run passes no
    /// `seed`: it keeps its own).
    pub fn apply(&self, steps: &mut usize, time_limit: &mut f64, seed: Option<&mut u64>) {
        if let Some(s) = self.steps {
            *steps = s;
        }
        if let Some(t) = self.time_limit {
            *time_limit = t;
        }
        if let (Some(s), Some(seed)) = (self.seed, seed) {
            *seed = s;
        }
    }
}

/// Reads the configuration file (or the defaults) and applies `--set` and the shortcuts.
pub fn nerf_config(file: Option<&Path>, overrides: &[String], shortcuts: Shortcuts) -> anyhow::Result<NerfConfig> {
    let (text, origin) = config_text(file, overrides)?;
    let mut config = NerfConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?;
    let t = &mut config.train;
    shortcuts.apply(&mut t.steps, &mut t.time_limit, Some(&mut t.seed));
    config.validate().map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    Ok(config)
}

fn nerf(args: TrainModelArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let (dataset, data, ckpt) = training_data(&args)?;
    let device = lucid_nerf::backend::training_device();
    let (mut trainer, mut elapsed) = if args.resume {
        let loaded = checkpoint::load(&ckpt, &device).context("resuming")?;
        let mut trainer = loaded.trainer;
        let t = &mut trainer.config.train;
        Shortcuts::of(&args).apply(&mut t.steps, &mut t.time_limit, None);
        tracing::info!("resuming {} at step {}", ckpt.display(), trainer.step);
        (trainer, loaded.header.elapsed)
    } else {
        let config = nerf_config(args.config.as_deref(), &args.overrides, Shortcuts::of(&args))?;
        (Trainer::for_dataset(config, &dataset, &data, device), 0.0)
    };
    let config_text = toml::to_string(&trainer.config)?;
    super::write_text(&args.output.join("config.toml"), &config_text)?;

    let (lo, hi) = trainer.grid.bounds();
    tracing::info!(
        "{} training views loaded in {:.1} s; box {:?}..{:?}; {} steps of {} samples",
        data.len(),
        load_start.elapsed().as_secs_f64(),
        lo.to_array(),
        hi.to_array(),
        trainer.config.train.steps,
        trainer.config.train.batch_samples
    );

    let log_path = args.output.join("train_log.csv");
    let mut log = open_log(
        &log_path,
        args.resume,
        "step,seconds,loss,batch_psnr,rays,samples,samples_per_second,learning_rate,occupied_fraction",
    )?;
    let t = trainer.config.train;
    let bar = crate::progress::bar(t.steps as u64, "nerf");
    bar.set_position(trainer.step as u64);
    let start = Instant::now() - std::time::Duration::from_secs_f64(elapsed);
    let (mut window_samples, mut window_start) = (0usize, Instant::now());
    let mut phases = lucid_nerf::trainer::StepTimings::default();
    let last = args.until.unwrap_or(t.steps).min(t.steps);
    while trainer.step < last && (t.time_limit == 0.0 || elapsed < t.time_limit) {
        if t.time_limit > 0.0 {
            trainer.budget_progress = elapsed / t.time_limit;
        }
        let stats = trainer.step(&data);
        elapsed = start.elapsed().as_secs_f64();
        window_samples += stats.samples;
        phases.add(&stats.timings);
        bar.inc(1);
        if trainer.step % t.log_every == 0 || trainer.step == t.steps {
            let rate = window_samples as f64 / window_start.elapsed().as_secs_f64().max(1e-9);
            (window_samples, window_start) = (0, Instant::now());
            writeln!(
                log,
                "{},{:.3},{:.6},{:.3},{},{},{:.0},{:.3e},{:.4}",
                trainer.step,
                elapsed,
                stats.loss,
                stats.psnr,
                stats.rays,
                stats.samples,
                rate,
                trainer.learning_rate(),
                trainer.grid.occupied_fraction()
            )
            .with_context(|| log_path.display().to_string())?;
            log.flush().with_context(|| log_path.display().to_string())?;
            bar.set_message(format!("loss {:.5} {:.2} dB {:.0}k samples/s", stats.loss, stats.psnr, rate / 1e3));
            tracing::debug!(step = trainer.step, loss = stats.loss, psnr = stats.psnr, samples_per_s = rate);
        }
        if t.checkpoint_every > 0 && trainer.step % t.checkpoint_every == 0 {
            checkpoint::save(&ckpt, &trainer, elapsed)?;
        }
    }
    bar.finish_and_clear();
    checkpoint::save(&ckpt, &trainer, elapsed)?;
    println!("trained {} steps in {:.1} s -> {}", trainer.step, elapsed, ckpt.display());
    let total: f64 = phases.named().iter().map(|p| p.1).sum();
    let shares: Vec<String> =
        phases.named().iter().map(|(n, t)| format!("{n} {:.0}%", 100.0 * t / total.max(1e-9))).collect();
    println!("time per phase: {}", shares.join(", "));
    if args.until.is_some_and(|u| u < t.steps) {
        println!("stopped at step {} of {}; continue with --resume", trainer.step, t.steps);
    } else if !args.no_eval && !dataset.frames(Split::Test).is_empty() {
        let model = trainer.eval_model();
        crate::commands::eval::evaluate_model(
            &trainer.renderer(&model),
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

pub fn open_log(path: &PathBuf, append: bool, header: &str) -> anyhow::Result<std::io::BufWriter<std::fs::File>> {
    let exists = path.exists();
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(append)
        .write(true)
        .truncate(!append)
        .open(path)
        .with_context(|| path.display().to_string())?;
    let mut w = std::io::BufWriter::new(file);
    if !(append && exists) {
        writeln!(w, "{header}")?;
    }
    Ok(w)
}
