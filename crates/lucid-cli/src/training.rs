//! What every `lucid train` command maps the same way: `--resume`/`--overwrite` to how the
//! run starts in its folder, `--steps`/`--time-limit` to a budget, the rest to the training
//! loop's options ([`lucid_burn::run`]), and the loop's summary to the terminal.

use std::path::Path;

use anyhow::{Context, bail};
use lucid_burn::run::{Budget, RunFolder, RunOptions, RunSummary, Start};
use lucid_scene::{Dataset, Split};

use crate::cli::RunArgs;

/// How the run starts in its folder.
pub fn start(args: &RunArgs) -> Start {
    match (args.resume, args.overwrite) {
        (true, _) => Start::Resume,
        (false, true) => Start::Overwrite,
        (false, false) => Start::New,
    }
}

/// A new run's configuration text (the file, or the defaults) with `--set` applied, and
/// `--steps` and `--seed` as the overrides `train.steps` and `train.seed`; and its origin.
pub fn config_text(file: Option<&Path>, overrides: &[String], args: &RunArgs) -> anyhow::Result<(String, String)> {
    let mut overrides = overrides.to_vec();
    overrides.extend(args.steps.map(|s| format!("train.steps={s}")));
    overrides.extend(args.seed.map(|s| format!("train.seed={s}")));
    lucid_burn::config::config_text(file, &overrides).map_err(anyhow::Error::msg)
}

/// On `--resume`, refuses a `--config`, `--set` or `--seed` that would change the run's
/// recorded configuration (`config.toml` in its folder): a run continues as it began.
pub fn refuse_resume_changes(
    args: &RunArgs,
    file: Option<&Path>,
    overrides: &[String],
    folder: &RunFolder,
) -> anyhow::Result<()> {
    if !args.resume || (file.is_none() && overrides.is_empty() && args.seed.is_none()) {
        return Ok(());
    }
    // `--steps` in the requested text is free to differ (it sets a resumed run's new budget).
    let (requested, _) = config_text(file, overrides, args)?;
    let path = folder.path("config.toml");
    let recorded = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
    let changed = lucid_burn::config::changed_keys(&requested, &recorded, &["train.steps"])
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    if !changed.is_empty() {
        bail!(
            "--resume continues the run in {} as it was configured, and --config/--set/--seed would change {}; \
             start a new run (or --overwrite) to train with other settings",
            folder.dir().display(),
            changed.join(", ")
        );
    }
    Ok(())
}

/// `--steps` on a resumed run: its new `train.steps`.
pub fn extend_steps(args: &RunArgs, steps: &mut usize) {
    if let Some(s) = args.steps {
        *steps = s;
    }
}

/// The run's budget: the flags where given, else a resumed run's own, else the
/// configuration's `train.steps` and `train.time_limit`.
pub fn budget(args: &RunArgs, folder: &RunFolder, config_steps: usize, config_seconds: f64) -> anyhow::Result<Budget> {
    let previous = folder.previous_budget().filter(|_| args.steps.is_none() && args.time_limit.is_none());
    let budget = match previous {
        Some(budget) => budget,
        None => Budget::from_limits(args.steps, args.time_limit, config_steps, config_seconds)
            .map_err(|e| anyhow::anyhow!("--steps/--time-limit: {e}"))?,
    };
    Ok(budget)
}

/// The loop's options for a run in `folder` (`checkpoint.lucid`, `train_log.csv`,
/// `eval_test/`).
pub fn options(
    args: &RunArgs,
    folder: &RunFolder,
    budget: Budget,
    elapsed: f64,
    (checkpoint_every, log_every): (usize, usize),
    label: &str,
) -> anyhow::Result<RunOptions> {
    if !(args.checkpoint_seconds.is_finite() && args.checkpoint_seconds >= 0.0) {
        anyhow::bail!("--checkpoint-seconds must be zero or a positive number, got {}", args.checkpoint_seconds);
    }
    Ok(RunOptions {
        until: args.until,
        checkpoint: Some(folder.checkpoint()),
        checkpoint_every,
        checkpoint_seconds: args.checkpoint_seconds,
        log: Some(folder.path("train_log.csv")),
        log_every,
        elapsed,
        resumed: args.resume,
        label: label.to_string(),
        evaluate: (!args.no_eval).then(|| folder.path("eval_test")),
        ..RunOptions::new(budget)
    })
}

/// Writes the configuration a run trains with into its folder.
pub fn write_config(folder: &RunFolder, config: &impl serde::Serialize) -> anyhow::Result<()> {
    crate::commands::write_text(&folder.path("config.toml"), &toml::to_string(config)?)
}

/// Prints what a run did.
pub fn print_summary(summary: &RunSummary, what: &str, checkpoint: &Path) {
    println!("trained {what} {} steps in {:.1} s -> {}", summary.steps, summary.elapsed, checkpoint.display());
    if !summary.phases.is_empty() {
        println!("time per phase: {}", summary.phase_shares());
    }
    if summary.interrupted {
        println!("stopped at step {}; continue with --resume", summary.steps);
    }
    for line in &summary.report {
        println!("{line}");
    }
}

/// One fingerprint of several datasets' training data, in order.
pub fn fingerprint_of(roots: &[std::path::PathBuf]) -> anyhow::Result<String> {
    let prints = roots
        .iter()
        .map(|root| {
            Ok(Dataset::open(root).with_context(|| format!("reading dataset {}", root.display()))?.fingerprint())
        })
        .collect::<anyhow::Result<Vec<String>>>()?;
    Ok(prints.join("-"))
}

/// The dataset of a training command, with at least one training frame.
pub fn open_dataset(root: &Path, options: &lucid_scene::dataset::OpenOptions) -> anyhow::Result<Dataset> {
    let dataset = Dataset::open_with(root, options).with_context(|| format!("reading dataset {}", root.display()))?;
    if dataset.frames(Split::Train).is_empty() {
        bail!("{}: no training frames (transforms_train.json, transforms.json or a COLMAP model)", root.display());
    }
    Ok(dataset)
}

/// Pixels of the training frames (from their intrinsics, before any is read): in all, and of
/// the largest.
pub fn training_pixels(dataset: &Dataset) -> (usize, usize) {
    let sizes = dataset.frames(Split::Train).iter().map(|f| {
        let k = f.camera.intrinsics;
        k.width as usize * k.height as usize
    });
    sizes.fold((0, 0), |(sum, max), n| (sum + n, max.max(n)))
}

/// Refuses a configuration whose estimated peak memory exceeds what this process may use,
/// before anything is allocated or written.
pub fn check_memory(estimate: &lucid_burn::memory::MemoryEstimate) -> anyhow::Result<()> {
    let available = lucid_burn::memory::available().map_err(anyhow::Error::msg)?;
    estimate.check(available).map_err(anyhow::Error::msg)
}

/// The checkpoint a resumed run continues from, or an error saying why there is none.
pub fn checkpoint_to_resume(folder: &RunFolder) -> anyhow::Result<std::path::PathBuf> {
    let path = folder.checkpoint();
    if !path.is_file() {
        bail!(
            "{}: the run stopped before its first checkpoint (one is saved every --checkpoint-seconds of \
             training, 60 by default); start it again with --overwrite",
            path.display()
        );
    }
    Ok(path)
}
