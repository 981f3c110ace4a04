//! The relighting head's second stage in Lucid's one training loop ([`lucid_burn::run`]);
//! the first stage is a [`lucid_splat::run::SplatRun`] on the uniformly lit views.

use std::path::{Path, PathBuf};

use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::run::{ModelError, StepReport, Trainable};

use crate::checkpoint::LightSet;
use crate::data::OlatSet;
use crate::trainer::RelightTrainer;

/// The head's trainer with its OLAT frames and their lights.
pub struct HeadRun<'a> {
    /// The trainer.
    pub trainer: RelightTrainer,
    /// The training frames.
    pub data: &'a OlatSet,
    /// The training lights (saved with the head).
    pub lights: &'a LightSet,
    /// The held-out views the final evaluation scores, and the checkpoint it reloads the head
    /// from onto the plain device: rendering needs no gradients, and on the autodiff device a
    /// graph would build up over an environment integration's hundreds of decodes.
    pub held_out: Option<(&'a OlatSet, PathBuf)>,
}

impl Trainable for HeadRun<'_> {
    fn steps_taken(&self) -> usize {
        self.trainer.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        self.trainer.progress = progress;
        let learning_rate = self.trainer.learning_rate();
        let stats = self.trainer.step(self.data);
        StepReport { loss: stats.loss, psnr: Some(stats.psnr), columns: vec![learning_rate], phases: Vec::new() }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &["learning_rate"]
    }

    fn non_finite(&self) -> Option<String> {
        lucid_burn::first_non_finite(&self.trainer.head)
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        crate::checkpoint::save(path, &self.trainer, self.lights, elapsed)
    }

    fn evaluate(&mut self, out: &Path) -> Result<Vec<String>, ModelError> {
        let Some((test, checkpoint)) = self.held_out.as_ref().filter(|(t, _)| !t.views.is_empty()) else {
            return Ok(Vec::new());
        };
        let device = lucid_burn::backend::default_device();
        let trained = crate::checkpoint::load_model(checkpoint, &device)?;
        let report = crate::eval::evaluate_into(&trained, &test.views, out, &device)?;
        Ok(report.lines())
    }
}
