//! The ITM trainer in Lucid's one training loop ([`lucid_burn::run`]).

use std::path::{Path, PathBuf};

use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::run::{ModelError, StepReport, Trainable};
use lucid_scene::Split;

use crate::data::ItmImage;
use crate::trainer::ItmTrainer;

/// An ITM trainer with its training pairs.
pub struct ItmRun<'a> {
    /// The trainer.
    pub trainer: ItmTrainer,
    /// The training pairs.
    pub data: &'a [ItmImage],
    /// The datasets whose test splits the final evaluation scores.
    pub held_out: &'a [PathBuf],
}

impl Trainable for ItmRun<'_> {
    fn steps_taken(&self) -> usize {
        self.trainer.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        self.trainer.progress = progress;
        let learning_rate = self.trainer.learning_rate();
        let loss = self.trainer.step(self.data);
        StepReport { loss, psnr: None, columns: vec![learning_rate], phases: Vec::new() }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &["learning_rate"]
    }

    fn non_finite(&self) -> Option<String> {
        lucid_burn::first_non_finite(&self.trainer.net)
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        crate::checkpoint::save(path, &self.trainer, elapsed)
    }

    fn evaluate(&mut self, out: &Path) -> Result<Vec<String>, ModelError> {
        if self.held_out.is_empty() {
            return Ok(Vec::new());
        }
        let test = crate::data::load(self.held_out, Split::Test, self.trainer.config.model.mask_threshold)?;
        // The baseline's boost is tuned on the training pairs, as the network is.
        let boost = crate::eval::best_boost(self.data);
        let report = crate::eval::evaluate_into(&self.trainer.net, &test, &self.trainer.device, boost, out)?;
        Ok(report.lines())
    }
}
