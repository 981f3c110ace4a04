//! The NeRF trainer in Lucid's one training loop ([`lucid_burn::run`]).

use std::path::Path;

use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::run::{ModelError, StepReport, Trainable};
use lucid_scene::{Dataset, Split};

use crate::data::ImageSet;
use crate::trainer::NerfTrainer;

/// The NeRF's own columns of the training log.
pub const LOG_COLUMNS: [&str; 4] = ["rays", "samples", "learning_rate", "occupied_fraction"];

/// A NeRF trainer with its training images.
pub struct NerfRun<'a> {
    /// The trainer.
    pub trainer: NerfTrainer,
    /// The training images.
    pub data: &'a ImageSet,
    /// The dataset whose test split the final evaluation scores.
    pub held_out: Option<&'a Dataset>,
}

impl Trainable for NerfRun<'_> {
    fn steps_taken(&self) -> usize {
        self.trainer.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        self.trainer.progress = progress;
        let stats = self.trainer.step(self.data);
        StepReport {
            loss: stats.loss,
            psnr: Some(stats.psnr),
            columns: vec![
                stats.rays as f64,
                stats.samples as f64,
                self.trainer.learning_rate(),
                f64::from(self.trainer.grid.occupied_fraction()),
            ],
            phases: stats.timings.named().to_vec(),
        }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &LOG_COLUMNS
    }

    fn non_finite(&self) -> Option<String> {
        lucid_burn::first_non_finite(&self.trainer.model)
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        crate::checkpoint::save(path, &self.trainer, elapsed)
    }

    fn evaluate(&mut self, out: &Path) -> Result<Vec<String>, ModelError> {
        let Some(dataset) = self.held_out.filter(|d| !d.frames(Split::Test).is_empty()) else { return Ok(Vec::new()) };
        let model = self.trainer.eval_model();
        Ok(lucid_scene::held_out::evaluate_test_split(
            &self.trainer.renderer(&model),
            self.trainer.step,
            dataset,
            out,
            &mut lucid_burn::run::eval_progress(),
        )?)
    }
}
