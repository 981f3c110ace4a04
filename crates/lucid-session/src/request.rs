//! What a training run is asked to do, as data (the command line's `lucid train` flags, or a
//! caller's), and the checks and settings every method's run derives from it the same way.

use std::path::{Path, PathBuf};

use lucid_burn::run::{Budget, RunError, RunFolder, RunOptions, Start};
use lucid_scene::dataset::OpenOptions;
use lucid_scene::{Dataset, Split};

use crate::SessionError;

/// A training run's request.
///
/// The budget has one meaning for every method: `steps` alone trains that many steps;
/// `time_limit` alone trains that many seconds, with the schedules stretched over them; both:
/// whichever ends first; neither: the configuration's `train.steps` (and `train.time_limit`
/// where set).
#[derive(Clone, Debug)]
pub struct RunRequest {
    /// The dataset folders (one, or several for methods that train across scenes).
    pub datasets: Vec<PathBuf>,
    /// The run's folder.
    pub output: PathBuf,
    /// A configuration file; its method's defaults fill what it leaves out.
    pub config: Option<PathBuf>,
    /// `key=value` overrides of the configuration (TOML values).
    pub overrides: Vec<String>,
    /// Optimiser steps (`train.steps`).
    pub steps: Option<usize>,
    /// Seconds of training.
    pub time_limit: Option<f64>,
    /// The random seed (`train.seed`).
    pub seed: Option<u64>,
    /// Stop and save at this step as if interrupted there.
    pub until: Option<usize>,
    /// A new run, the folder's run continued, or the folder's run replaced.
    pub start: Start,
    /// Seconds of training between checkpoints (0: not by time).
    pub checkpoint_seconds: f64,
    /// Whether the test split is scored at the end.
    pub evaluate: bool,
    /// Whether the run keeps its CSV log and checkpoints (a benchmark's timed run keeps
    /// neither: writing them would count as training time).
    pub records: bool,
    /// How datasets without split files are split, and captures scaled.
    pub dataset: OpenOptions,
}

impl RunRequest {
    /// A new run on `dataset` writing `output`, with the defaults of everything else.
    pub fn new(dataset: impl Into<PathBuf>, output: impl Into<PathBuf>) -> Self {
        Self {
            datasets: vec![dataset.into()],
            output: output.into(),
            config: None,
            overrides: Vec::new(),
            steps: None,
            time_limit: None,
            seed: None,
            until: None,
            start: Start::New,
            checkpoint_seconds: lucid_burn::run::DEFAULT_CHECKPOINT_SECONDS,
            evaluate: true,
            records: true,
            dataset: OpenOptions::default(),
        }
    }

    /// Whether the run continues the one in its folder.
    pub fn resumes(&self) -> bool {
        self.start == Start::Resume
    }

    /// The one dataset of a method that trains on one.
    pub fn dataset(&self) -> Result<&Path, SessionError> {
        match &self.datasets[..] {
            [one] => Ok(one),
            other => Err(SessionError::Invalid(format!("this method trains on one dataset, given {}", other.len()))),
        }
    }

    /// A new run's configuration text (the file, or the defaults) with the overrides applied,
    /// and `steps` and `seed` as `train.steps` and `train.seed`; and its origin.
    pub fn config_text(&self) -> Result<(String, String), SessionError> {
        let mut overrides = self.overrides.clone();
        overrides.extend(self.steps.map(|s| format!("train.steps={s}")));
        overrides.extend(self.seed.map(|s| format!("train.seed={s}")));
        lucid_burn::config::config_text(self.config.as_deref(), &overrides).map_err(SessionError::Invalid)
    }

    /// On resume, refuses a configuration, override or seed that would change the run's
    /// recorded configuration (`config.toml` in its folder): a run continues as it began.
    pub fn refuse_resume_changes(&self, folder: &RunFolder) -> Result<(), SessionError> {
        if !self.resumes() || (self.config.is_none() && self.overrides.is_empty() && self.seed.is_none()) {
            return Ok(());
        }
        // The requested steps are free to differ (they set a resumed run's new budget).
        let (requested, _) = self.config_text()?;
        let path = folder.path("config.toml");
        let recorded = lucid_scene::text_file::read_text(&path)
            .map_err(|e| SessionError::Invalid(format!("{}: {e}", path.display())))?;
        let changed = lucid_burn::config::changed_keys(&requested, &recorded, &["train.steps"])
            .map_err(|e| SessionError::Invalid(format!("{}: {e}", path.display())))?;
        if !changed.is_empty() {
            return Err(SessionError::Invalid(format!(
                "--resume continues the run in {} as it was configured, and --config/--set/--seed would change {}; \
                 start a new run (or --overwrite) to train with other settings",
                folder.dir().display(),
                changed.join(", ")
            )));
        }
        Ok(())
    }

    /// The run's budget: the request's where given, else a resumed run's own, else the
    /// configuration's `train.steps` and `train.time_limit`.
    pub fn budget(&self, folder: &RunFolder, config_steps: usize, config_seconds: f64) -> Result<Budget, SessionError> {
        let previous = folder.previous_budget().filter(|_| self.steps.is_none() && self.time_limit.is_none());
        match previous {
            Some(budget) => Ok(budget),
            None => Budget::from_limits(self.steps, self.time_limit, config_steps, config_seconds)
                .map_err(|e| SessionError::Invalid(format!("--steps/--time-limit: {e}"))),
        }
    }

    /// The loop's options for a run in `folder` (`checkpoint.lucid`, `train_log.csv`,
    /// `eval_test/`).
    pub fn options(
        &self,
        folder: &RunFolder,
        budget: Budget,
        elapsed: f64,
        (checkpoint_every, log_every): (usize, usize),
        label: &str,
    ) -> Result<RunOptions, SessionError> {
        if !(self.checkpoint_seconds.is_finite() && self.checkpoint_seconds >= 0.0) {
            return Err(SessionError::Invalid(format!(
                "--checkpoint-seconds must be zero or a positive number, got {}",
                self.checkpoint_seconds
            )));
        }
        Ok(RunOptions {
            until: self.until,
            checkpoint: self.records.then(|| folder.checkpoint()),
            checkpoint_every,
            checkpoint_seconds: self.checkpoint_seconds,
            log: self.records.then(|| folder.path("train_log.csv")),
            log_every,
            elapsed,
            resumed: self.resumes(),
            label: label.to_string(),
            evaluate: self.evaluate.then(|| folder.path("eval_test")),
            ..RunOptions::new(budget)
        })
    }
}

/// Writes the configuration a run trains with into its folder.
pub fn write_config(folder: &RunFolder, config: &impl serde::Serialize) -> Result<(), SessionError> {
    let text = toml::to_string(config).map_err(|e| SessionError::Invalid(format!("the configuration: {e}")))?;
    lucid_image::output::write_text(&folder.path("config.toml"), &text)
        .map_err(|e| SessionError::Run(RunError::Image(Box::new(e))))
}

/// The dataset of a training run, with at least one training frame.
pub fn open_dataset(root: &Path, options: &OpenOptions) -> Result<Dataset, SessionError> {
    let dataset = Dataset::open_with(root, options)
        .map_err(|e| SessionError::Read { context: format!("reading dataset {}", root.display()), source: e.into() })?;
    if dataset.frames(Split::Train).is_empty() {
        return Err(SessionError::Invalid(format!(
            "{}: no training frames (transforms_train.json, transforms.json or a COLMAP model)",
            root.display()
        )));
    }
    Ok(dataset)
}

/// One fingerprint of several datasets' training data, in order.
pub fn fingerprint_of(roots: &[PathBuf]) -> Result<String, SessionError> {
    let prints = roots
        .iter()
        .map(|root| {
            Dataset::open(root).map(|d| d.fingerprint()).map_err(|e| SessionError::Read {
                context: format!("reading dataset {}", root.display()),
                source: e.into(),
            })
        })
        .collect::<Result<Vec<String>, _>>()?;
    Ok(prints.join("-"))
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
pub fn check_memory(estimate: &lucid_burn::memory::MemoryEstimate) -> Result<(), SessionError> {
    let available = lucid_burn::memory::available().map_err(SessionError::Invalid)?;
    estimate.check(available).map_err(SessionError::Invalid)
}

/// The checkpoint a resumed run continues from, or an error saying why there is none.
pub fn checkpoint_to_resume(folder: &RunFolder) -> Result<PathBuf, SessionError> {
    let path = folder.checkpoint();
    if !path.is_file() {
        return Err(SessionError::Invalid(format!(
            "{}: the run stopped before its first checkpoint (one is saved every --checkpoint-seconds of \
             training, 60 by default); start it again with --overwrite",
            path.display()
        )));
    }
    Ok(path)
}
