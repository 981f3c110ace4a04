//! The 3DGS trainer in Lucid's one training loop ([`lucid_burn::run`]).

use std::path::Path;

use lucid_burn::checkpoint::CheckpointError;
use std::path::PathBuf;

use lucid_burn::run::{ModelError, StepReport, Trainable};
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::{Dataset, Split};

use crate::trainer::SplatTrainer;

/// Names of [`crate::trainer::StepStats::timings`].
pub const PHASES: [&str; 4] = ["render", "loss+backward", "optimizer", "densify"];

/// A splat trainer with its training images.
pub struct SplatRun<'a> {
    /// The trainer.
    pub trainer: SplatTrainer,
    /// The training images.
    pub data: &'a ImageSet,
    /// The dataset whose test split the final evaluation scores.
    pub held_out: Option<&'a Dataset>,
    /// Where the trained cloud is exported as a standard 3DGS `.ply` at the end (in the
    /// dataset's own frame, for a capture).
    pub export: Option<PathBuf>,
}

impl Trainable for SplatRun<'_> {
    fn steps_taken(&self) -> usize {
        self.trainer.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        self.trainer.progress = progress;
        let stats = self.trainer.step(self.data);
        if let Some(d) = stats.densified {
            tracing::debug!(
                step = self.trainer.step,
                cloned = d.cloned,
                split = d.split,
                pruned = d.pruned,
                total = d.total
            );
        }
        StepReport {
            loss: stats.loss,
            psnr: Some(stats.psnr),
            columns: vec![stats.gaussians as f64, self.trainer.sh_degree() as f64, self.trainer.learning_rates()[0]],
            phases: PHASES.iter().copied().zip(stats.timings).collect(),
        }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &["gaussians", "sh_degree", "position_lr"]
    }

    fn non_finite(&self) -> Option<String> {
        lucid_burn::first_non_finite(&self.trainer.model)
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        crate::checkpoint::save(path, &self.trainer, elapsed)
    }

    fn finish(&mut self) -> Result<Vec<String>, ModelError> {
        let Some(path) = &self.export else { return Ok(Vec::new()) };
        let mut cloud = self.trainer.model.to_cloud();
        let mut frame = "";
        if let Some(normalisation) = &self.trainer.view.frame {
            cloud = crate::frame::cloud_in_dataset_frame(&cloud, normalisation);
            frame = " (in the dataset's frame)";
        }
        crate::ply::write_splat_ply(path, &cloud)?;
        Ok(vec![format!("{} Gaussians -> {}{frame}", cloud.len(), path.display())])
    }

    fn evaluate(&mut self, out: &Path) -> Result<Vec<String>, ModelError> {
        let Some(dataset) = self.held_out.filter(|d| !d.frames(Split::Test).is_empty()) else { return Ok(Vec::new()) };
        let cloud = self.trainer.model.to_cloud();
        let renderer = crate::view::SplatRenderer { cloud: &cloud, settings: self.trainer.eval_settings() };
        Ok(lucid_scene::held_out::evaluate_test_split(
            &renderer,
            self.trainer.step,
            dataset,
            out,
            &mut lucid_burn::run::eval_progress(),
        )?)
    }

    fn status(&self, loss: f64, psnr: Option<f64>) -> String {
        format!("loss {loss:.4} {:.2} dB {} Gaussians", psnr.unwrap_or(0.0), self.trainer.model.len())
    }
}
