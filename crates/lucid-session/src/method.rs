//! A trainable method, as a session drives it: its configuration, what it reads, how it
//! starts and resumes, and the model it shows.

use std::path::Path;

use lucid_burn::memory::MemoryEstimate;
use lucid_burn::run::Trainable;
use lucid_scene::Dataset;
use lucid_scene::scene_model::SceneModel;

use crate::{RunRequest, SessionError};

/// The schedule keys every method's `train` section has.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainSettings {
    /// `train.steps`.
    pub steps: usize,
    /// `train.time_limit` (0: none).
    pub time_limit: f64,
    /// Steps between checkpoints (0: not by steps).
    pub checkpoint_every: usize,
    /// Steps between log rows.
    pub log_every: usize,
}

/// A method: the value is what it read for a run (its datasets), and it lends the trainer
/// that the training loop steps.
pub trait Method: Sized {
    /// The configuration (the TOML file's sections).
    type Config: serde::Serialize;
    /// The trainer with the data it trains on, in the training loop.
    type Trainer<'a>: Trainable
    where
        Self: 'a;

    /// The kind its checkpoints and run folders name.
    const KIND: &'static str;
    /// The progress bar's label.
    const LABEL: &'static str;
    /// What it trains, for a sentence ("a NeRF").
    const WHAT: &'static str;

    /// A configuration from TOML text (`origin` names where it came from, for errors).
    fn parse_config(text: &str, origin: &str) -> Result<Self::Config, String>;

    /// Reads what the run needs to know before it touches its folder: the datasets' cameras
    /// (no images yet), and where the configuration is known (a new run) whatever else its
    /// memory estimate needs.
    fn open(request: &RunRequest, config: Option<&Self::Config>) -> Result<Self, SessionError>;

    /// The peak memory a new run with `config` needs.
    fn memory_estimate(&self, config: &Self::Config) -> MemoryEstimate;

    /// The fingerprint of the training data (a resumed run must train on what it began on).
    fn fingerprint(&self) -> Result<String, SessionError>;

    /// Reads the training images, once the folder is known to be this run's.
    fn load(&mut self) -> Result<(), SessionError> {
        Ok(())
    }

    /// A new trainer with `config`.
    fn init(&self, config: Self::Config) -> Result<Self::Trainer<'_>, SessionError>;

    /// The trainer a checkpoint holds, and the training seconds it records.
    fn resume(&self, checkpoint: &Path) -> Result<(Self::Trainer<'_>, f64), SessionError>;

    /// The trainer's schedule keys.
    fn settings(trainer: &Self::Trainer<'_>) -> TrainSettings;

    /// Sets a resumed run's `train.steps` (its new budget).
    fn set_steps(trainer: &mut Self::Trainer<'_>, steps: usize);

    /// The configuration the trainer trains with.
    fn config<'t>(trainer: &'t Self::Trainer<'_>) -> &'t Self::Config;

    /// The model as it is now, for listeners that render it (none: the method renders no
    /// views).
    fn snapshot(_trainer: &Self::Trainer<'_>) -> Option<Box<dyn SceneModel>> {
        None
    }

    /// The dataset the run trains on, where it trains on one.
    fn dataset(&self) -> Option<&Dataset> {
        None
    }

    /// A line for the log before the first step.
    fn describe(&self, trainer: &Self::Trainer<'_>) -> String;
}
