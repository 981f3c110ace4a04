//! The inverse tone mapping network as a session's method: it trains across the bracket
//! frames of several datasets.

use std::cell::OnceCell;
use std::path::{Path, PathBuf};

use lucid_burn::memory::MemoryEstimate;
use lucid_itm::checkpoint::ITM_KIND;
use lucid_itm::config::ItmConfig;
use lucid_itm::data::{ItmImage, check_patch, load};
use lucid_itm::run::ItmRun;
use lucid_itm::trainer::ItmTrainer;
use lucid_scene::Split;

use crate::method::{Method, TrainSettings};
use crate::request::fingerprint_of;
use crate::{RunRequest, SessionError};

/// An ITM run's datasets and training pairs (read as soon as the mask threshold is known:
/// from a new run's configuration, or from the checkpoint a run resumes).
pub struct Itm {
    datasets: Vec<PathBuf>,
    pairs: OnceCell<Vec<ItmImage>>,
}

impl Itm {
    /// The training pairs at `threshold`, read on first use; their size checked against the
    /// training patch.
    fn pairs(&self, threshold: f32, patch: usize) -> Result<&[ItmImage], SessionError> {
        if self.pairs.get().is_none() {
            let pairs = load(&self.datasets, Split::Train, threshold)
                .map_err(|e| SessionError::read("loading training pairs", e))?;
            let _ = self.pairs.set(pairs);
        }
        let pairs = self.pairs.get().expect("set above");
        check_patch(pairs, patch).map_err(|e| SessionError::Invalid(e.to_string()))?;
        Ok(pairs)
    }

    fn run<'a>(&'a self, trainer: ItmTrainer) -> Result<ItmRun<'a>, SessionError> {
        let data = self.pairs(trainer.config.model.mask_threshold, trainer.config.train.patch)?;
        Ok(ItmRun { trainer, data, held_out: &self.datasets })
    }
}

impl Method for Itm {
    type Config = ItmConfig;
    type Trainer<'a> = ItmRun<'a>;

    const KIND: &'static str = ITM_KIND;
    const LABEL: &'static str = "itm";
    const WHAT: &'static str = "the ITM network";

    fn parse_config(text: &str, origin: &str) -> Result<ItmConfig, String> {
        ItmConfig::from_toml(text, origin)
    }

    fn open(request: &RunRequest, config: Option<&ItmConfig>) -> Result<Self, SessionError> {
        let itm = Self { datasets: request.datasets.clone(), pairs: OnceCell::new() };
        // Read before the folder is touched when the configuration is known (a new run).
        if let Some(config) = config {
            itm.pairs(config.model.mask_threshold, config.train.patch)?;
        }
        Ok(itm)
    }

    fn memory_estimate(&self, config: &ItmConfig) -> MemoryEstimate {
        let pixels = self.pairs.get().map_or(0, |pairs| pairs.iter().map(|i| i.width * i.height).sum());
        config.memory_estimate(pixels)
    }

    fn fingerprint(&self) -> Result<String, SessionError> {
        fingerprint_of(&self.datasets)
    }

    fn init(&self, config: ItmConfig) -> Result<ItmRun<'_>, SessionError> {
        self.run(ItmTrainer::new(config, lucid_burn::backend::training_device()))
    }

    fn resume(&self, checkpoint: &Path) -> Result<(ItmRun<'_>, f64), SessionError> {
        let device = lucid_burn::backend::training_device();
        let loaded = lucid_itm::checkpoint::load(checkpoint, &device).map_err(|e| SessionError::read("resuming", e))?;
        Ok((self.run(loaded.trainer)?, loaded.header.elapsed))
    }

    fn settings(run: &ItmRun<'_>) -> TrainSettings {
        let t = &run.trainer.config.train;
        // A row every step: an ITM step is short and its loss noisy.
        TrainSettings { steps: t.steps, time_limit: t.time_limit, checkpoint_every: t.checkpoint_every, log_every: 1 }
    }

    fn set_steps(run: &mut ItmRun<'_>, steps: usize) {
        run.trainer.config.train.steps = steps;
    }

    fn config<'t>(run: &'t ItmRun<'_>) -> &'t ItmConfig {
        &run.trainer.config
    }

    fn describe(&self, run: &ItmRun<'_>) -> String {
        format!("training ITM on {} pairs from {} dataset(s)", run.data.len(), self.datasets.len())
    }
}
