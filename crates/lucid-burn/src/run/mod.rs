//! The one training loop every Lucid model runs through.
//!
//! A model implements [`Trainable`] (one step at a schedule position, its CSV columns, its
//! checkpoint); [`run`] owns everything around the steps: the [`Budget`] (steps, seconds or
//! whichever ends first, with the schedules stretched to it), `--until`, the CSV log (cut back
//! to the checkpoint on resume), checkpoints by steps and by time (atomic, and at the end),
//! the divergence guard, the progress bar, and an [`Observer`] hook that the demo and the
//! benchmarks use to score held-out views over training time without counting that time.
//! The folder it writes is a [`RunFolder`]: locked, and never mixed with another run.

mod budget;
mod folder;
mod log;

use std::path::{Path, PathBuf};
use std::time::Instant;

pub use budget::Budget;
pub use folder::{CHECKPOINT, MANIFEST, Manifest, RUN_FILES, RunFolder, Start};
pub use log::{TrainLog, format_value};

use crate::checkpoint::CheckpointError;

/// An error of a model's own (loading, saving, evaluating), as a boxed error.
pub type ModelError = Box<dyn std::error::Error + Send + Sync>;

/// Why a run stopped with an error; each message names the file or the step.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The OS refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file of the run could not be written.
    #[error(transparent)]
    Image(Box<lucid_image::ImageError>),
    /// The output is locked by another process.
    #[error(transparent)]
    Lock(Box<lucid_image::output::LockError>),
    /// The output folder holds something this run must not touch.
    #[error("{}: {reason}", dir.display())]
    Folder {
        /// The folder.
        dir: PathBuf,
        /// What it holds and what to do.
        reason: String,
    },
    /// A checkpoint could not be read or written.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The loss stopped being finite.
    #[error(
        "training diverged at step {step} (loss {loss}); the last checkpoint before it is kept; try a lower learning rate"
    )]
    Diverged {
        /// The step whose loss was not finite.
        step: usize,
        /// That loss.
        loss: f32,
    },
    /// A parameter stopped being finite while the loss still was (a splat cloud whose
    /// Gaussians all went NaN renders only background, at a finite loss).
    #[error(
        "training diverged by step {step}: {what} holds NaN or infinite values; the last checkpoint before it is kept; try a lower learning rate"
    )]
    NonFinite {
        /// The step at which it was found (checked at every log row and before every
        /// checkpoint).
        step: usize,
        /// Which parameter.
        what: String,
    },
    /// The model or an observer failed.
    #[error("{context}: {source}")]
    Model {
        /// What was being done.
        context: String,
        /// The cause.
        source: ModelError,
    },
}

/// What one step reports.
#[derive(Clone, Debug, Default)]
pub struct StepReport {
    /// The loss (averaged over each log row's steps).
    pub loss: f32,
    /// PSNR of the step's batch in dB, where the model measures one (averaged likewise).
    pub psnr: Option<f32>,
    /// The values of the model's [`Trainable::log_columns`] after this step.
    pub columns: Vec<f64>,
    /// Seconds spent in each named phase of the step.
    pub phases: Vec<(&'static str, f64)>,
}

/// A model that trains one step at a time.
pub trait Trainable {
    /// Steps taken so far.
    fn steps_taken(&self) -> usize;

    /// One optimisation step. `progress` in [0, 1] is the fraction of the run's budget used
    /// before it: the position of learning-rate decay, densification phases and the like.
    fn step(&mut self, progress: f64) -> StepReport;

    /// Names of the model's own CSV columns, after `step,seconds,loss,psnr`.
    fn log_columns(&self) -> &'static [&'static str];

    /// The name of a parameter holding NaN or an infinity, if any ([`crate::first_non_finite`]
    /// finds one in a burn module). The loop asks at every log row and before every
    /// checkpoint, so no checkpoint ever holds one.
    fn non_finite(&self) -> Option<String>;

    /// Saves everything needed to continue (atomically), with the training seconds so far.
    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError>;

    /// Work at the end of the run, after the last checkpoint (exports such as `splats.ply`);
    /// returns lines for a terminal.
    fn finish(&mut self) -> Result<Vec<String>, ModelError> {
        Ok(Vec::new())
    }

    /// Scores the trained model on its held-out data, writing the results into `out`;
    /// returns lines for a terminal (none where the model has no held-out data).
    fn evaluate(&mut self, _out: &Path) -> Result<Vec<String>, ModelError> {
        Ok(Vec::new())
    }

    /// The progress bar's message after a log row (mean loss and PSNR of its window).
    fn status(&self, loss: f64, psnr: Option<f64>) -> String {
        match psnr {
            Some(p) => format!("loss {loss:.5} {p:.2} dB"),
            None => format!("loss {loss:.5}"),
        }
    }
}

/// Watches a run; its own time is not counted as training time.
pub trait Observer<T: ?Sized> {
    /// Called after every step with the model, the step's report and the training seconds.
    fn after_step(&mut self, model: &T, report: &StepReport, elapsed: f64) -> Result<(), ModelError>;

    /// Called for each log row (whether or not a log file is kept): the step, the training
    /// seconds, and the mean loss and batch PSNR of the steps since the last row.
    fn logged(&mut self, _step: usize, _elapsed: f64, _loss: f64, _psnr: Option<f64>) -> Result<(), ModelError> {
        Ok(())
    }

    /// Called after each checkpoint is written, with its step.
    fn checkpointed(&mut self, _path: &Path, _step: usize) -> Result<(), ModelError> {
        Ok(())
    }
}

/// Any closure of the model, the step's report and the training seconds observes.
impl<T: ?Sized, F: FnMut(&T, &StepReport, f64) -> Result<(), ModelError>> Observer<T> for F {
    fn after_step(&mut self, model: &T, report: &StepReport, elapsed: f64) -> Result<(), ModelError> {
        self(model, report, elapsed)
    }
}

/// An observer that does nothing.
pub struct NoObserver;

impl<T: ?Sized> Observer<T> for NoObserver {
    fn after_step(&mut self, _: &T, _: &StepReport, _: f64) -> Result<(), ModelError> {
        Ok(())
    }
}

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// What ends the run.
    pub budget: Budget,
    /// Stop and save at this step as if interrupted there (the schedules still span the
    /// budget; a resumed run continues).
    pub until: Option<usize>,
    /// Where checkpoints go (none: no checkpoints).
    pub checkpoint: Option<PathBuf>,
    /// Steps between checkpoints (0: not by steps).
    pub checkpoint_every: usize,
    /// Seconds of training between checkpoints (0: not by time).
    pub checkpoint_seconds: f64,
    /// The CSV log (none: no log).
    pub log: Option<PathBuf>,
    /// Steps between log rows; a row holds the mean loss and PSNR of the steps since the last
    /// row this process logged (after a resume between rows, of fewer steps).
    pub log_every: usize,
    /// Training seconds already spent (a resumed run's, from its checkpoint); a run with
    /// `resumed` keeps its log rows up to its current step.
    pub elapsed: f64,
    /// Whether this continues an earlier run.
    pub resumed: bool,
    /// The progress bar's label (empty: no bar).
    pub label: String,
    /// Where the final evaluation writes (none: no evaluation). A run stopped by `until`
    /// is not evaluated.
    pub evaluate: Option<PathBuf>,
}

impl RunOptions {
    /// Options for `budget` with the defaults: checkpoints every 60 s of training and at the
    /// end, a log row every 100 steps, no bar.
    pub fn new(budget: Budget) -> Self {
        Self {
            budget,
            until: None,
            checkpoint: None,
            checkpoint_every: 0,
            checkpoint_seconds: DEFAULT_CHECKPOINT_SECONDS,
            log: None,
            log_every: 100,
            elapsed: 0.0,
            resumed: false,
            label: String::new(),
            evaluate: None,
        }
    }

    /// Options for a run in `dir` (`checkpoint.lucid`, `train_log.csv`, a row every
    /// `log_every` steps) of `steps` steps, stopped at `until` if given: the shape of a
    /// resume test.
    pub fn in_folder(dir: &Path, steps: usize, until: Option<usize>, log_every: usize) -> Self {
        Self {
            until,
            checkpoint: Some(dir.join(CHECKPOINT)),
            log: Some(dir.join("train_log.csv")),
            log_every,
            ..Self::new(Budget::Steps { steps })
        }
    }
}

/// The rows of a run's CSV log without its `seconds` column: what two runs of one seed must
/// share whatever their timing.
pub fn log_without_seconds(path: &Path) -> Result<Vec<String>, RunError> {
    let text = std::fs::read_to_string(path).map_err(|source| RunError::Io { path: path.to_path_buf(), source })?;
    Ok(text
        .lines()
        .map(|l| l.split(',').enumerate().filter(|(i, _)| *i != 1).map(|(_, f)| f).collect::<Vec<_>>().join(","))
        .collect())
}

/// Default seconds of training between checkpoints: a run killed after its first minute
/// always has one to resume from.
pub const DEFAULT_CHECKPOINT_SECONDS: f64 = 60.0;

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Steps taken in all (a resumed run's earlier steps included).
    pub steps: usize,
    /// Training seconds in all.
    pub elapsed: f64,
    /// Whether `until` stopped it before its budget was spent.
    pub interrupted: bool,
    /// Seconds per named phase over this process's steps.
    pub phases: Vec<(&'static str, f64)>,
    /// Lines for a terminal from the model's [`Trainable::finish`] and
    /// [`Trainable::evaluate`].
    pub report: Vec<String>,
}

impl RunSummary {
    /// "render 40%, backward 30%, …".
    pub fn phase_shares(&self) -> String {
        let total: f64 = self.phases.iter().map(|p| p.1).sum::<f64>().max(1e-9);
        self.phases.iter().map(|(n, t)| format!("{n} {:.0}%", 100.0 * t / total)).collect::<Vec<_>>().join(", ")
    }
}

/// Trains `model` until its budget is spent (or `until`), logging, checkpointing and
/// reporting to `observer` on the way.
pub fn run<T: Trainable + ?Sized>(
    model: &mut T,
    options: &RunOptions,
    observer: &mut dyn Observer<T>,
) -> Result<RunSummary, RunError> {
    let budget = options.budget;
    budget.validate().map_err(|reason| RunError::Model { context: "the budget".into(), source: reason.into() })?;
    let columns = model.log_columns();
    let header = ["step", "seconds", "loss", "psnr"].iter().chain(columns).copied().collect::<Vec<_>>().join(",");
    let resume_from = options.resumed.then(|| model.steps_taken());
    let mut log = options.log.as_deref().map(|p| TrainLog::open(p, &header, resume_from)).transpose()?;
    let bar = ProgressDisplay::new(&options.label, budget, model.steps_taken(), options.elapsed);

    let mut elapsed = options.elapsed;
    let mut saved_at = elapsed;
    let mut phases: Vec<(&'static str, f64)> = Vec::new();
    let (mut loss_sum, mut psnr_sum, mut window) = (0.0f64, 0.0f64, 0usize);
    let stop_at = options.until.unwrap_or(usize::MAX);
    let check = |model: &T| match model.non_finite() {
        Some(what) => {
            bar.clear();
            Err(RunError::NonFinite { step: model.steps_taken(), what })
        }
        None => Ok(()),
    };
    let save = |model: &T, elapsed: f64, observer: &mut dyn Observer<T>| -> Result<(), RunError> {
        check(model)?;
        let Some(path) = &options.checkpoint else { return Ok(()) };
        model.save(path, elapsed)?;
        let step = model.steps_taken();
        observer
            .checkpointed(path, step)
            .map_err(|source| RunError::Model { context: format!("after the checkpoint of step {step}"), source })
    };
    while !budget.spent(model.steps_taken(), elapsed) && model.steps_taken() < stop_at {
        let started = Instant::now();
        let report = model.step(budget.progress(model.steps_taken(), elapsed));
        elapsed += started.elapsed().as_secs_f64();
        let step = model.steps_taken();
        if !report.loss.is_finite() {
            bar.clear();
            return Err(RunError::Diverged { step, loss: report.loss });
        }
        for &(name, seconds) in &report.phases {
            match phases.iter_mut().find(|p| p.0 == name) {
                Some(p) => p.1 += seconds,
                None => phases.push((name, seconds)),
            }
        }
        loss_sum += f64::from(report.loss);
        psnr_sum += report.psnr.map_or(f64::NAN, f64::from);
        window += 1;
        let io_started = Instant::now();
        // The last step of the budget gets a row whatever its number (a time budget ends
        // anywhere); a stop at `until` does not, as if the run had been killed there.
        if step.is_multiple_of(options.log_every.max(1)) || budget.spent(step, elapsed) {
            check(model)?;
            let (loss, psnr) = (loss_sum / window as f64, psnr_sum / window as f64);
            (loss_sum, psnr_sum, window) = (0.0, 0.0, 0);
            let psnr = psnr.is_finite().then_some(psnr);
            if let Some(log) = &mut log {
                let mut row = vec![step.to_string(), format!("{elapsed:.3}"), format_value(loss)];
                row.push(psnr.map(format_value).unwrap_or_default());
                row.extend(report.columns.iter().map(|&v| format_value(v)));
                log.row(&row)?;
            }
            bar.message(model.status(loss, psnr));
            observer
                .logged(step, elapsed, loss, psnr)
                .map_err(|source| RunError::Model { context: format!("after the log row of step {step}"), source })?;
        }
        let by_steps = options.checkpoint_every > 0 && step.is_multiple_of(options.checkpoint_every);
        let by_time = options.checkpoint_seconds > 0.0 && elapsed - saved_at >= options.checkpoint_seconds;
        if by_steps || by_time {
            save(model, elapsed, observer)?;
            saved_at = elapsed;
        }
        // Logging and saving are part of training; only the observer's time is not.
        elapsed += io_started.elapsed().as_secs_f64();
        bar.update(step, elapsed);
        observer
            .after_step(model, &report, elapsed)
            .map_err(|source| RunError::Model { context: format!("after step {step}"), source })?;
    }
    bar.clear();
    save(model, elapsed, observer)?;
    let steps = model.steps_taken();
    let interrupted = !budget.spent(steps, elapsed);
    let mut report = model.finish().map_err(|source| RunError::Model { context: "finishing".into(), source })?;
    if let (Some(out), false) = (&options.evaluate, interrupted) {
        let lines = model.evaluate(out).map_err(|source| RunError::Model { context: "evaluating".into(), source })?;
        report.extend(lines);
    }
    Ok(RunSummary { steps, elapsed, interrupted, phases, report })
}

/// The run's progress bar on stderr (hidden when stderr is not a terminal): by steps where
/// the budget has a step count, by seconds otherwise.
struct ProgressDisplay {
    bar: Option<indicatif::ProgressBar>,
    by_steps: bool,
}

impl ProgressDisplay {
    fn new(label: &str, budget: Budget, step: usize, elapsed: f64) -> Self {
        if label.is_empty() {
            return Self { bar: None, by_steps: true };
        }
        let by_steps = budget.steps().is_some();
        let (total, unit) = match budget.steps() {
            Some(n) => (n as u64, ""),
            None => (budget.seconds().unwrap_or(0.0).ceil() as u64, " s"),
        };
        let bar = progress_bar(total, label, unit);
        bar.set_position(if by_steps { step as u64 } else { elapsed as u64 });
        Self { bar: Some(bar), by_steps }
    }

    fn update(&self, step: usize, elapsed: f64) {
        if let Some(bar) = &self.bar {
            bar.set_position(if self.by_steps { step as u64 } else { elapsed as u64 });
        }
    }

    fn message(&self, text: String) {
        if let Some(bar) = &self.bar {
            bar.set_prefix(text);
        }
    }

    fn clear(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

/// A progress bar for `total` units (`unit` after the counts, e.g. " s") labelled `label`,
/// the one style of every Lucid bar.
pub fn progress_bar(total: u64, label: &str, unit: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total);
    let template = format!("{{msg:>12}} [{{bar:30}}] {{pos}}/{{len}}{unit} ({{elapsed}}, eta {{eta}}) {{prefix}}");
    bar.set_style(indicatif::ProgressStyle::with_template(&template).expect("valid template").progress_chars("=> "));
    bar.set_message(label.to_string());
    bar
}

/// A progress callback for an evaluation (views done, views in all) that shows a bar on
/// stderr while it runs and clears it when the last view is done.
pub fn eval_progress() -> impl FnMut(usize, usize) {
    let mut bar: Option<indicatif::ProgressBar> = None;
    move |done, all| {
        let b = bar.get_or_insert_with(|| progress_bar(all as u64, "eval", ""));
        b.set_position(done as u64);
        if done >= all {
            b.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests;
