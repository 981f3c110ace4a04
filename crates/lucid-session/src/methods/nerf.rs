//! The hash-grid NeRF as a session's method.

use std::path::Path;

use lucid_burn::memory::MemoryEstimate;
use lucid_nerf::checkpoint::NERF_KIND;
use lucid_nerf::config::NerfConfig;
use lucid_nerf::run::NerfRun;
use lucid_nerf::trained::TrainedNerf;
use lucid_nerf::trainer::NerfTrainer;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::scene_model::SceneModel;
use lucid_scene::{Dataset, Split};

use crate::method::{Method, TrainSettings};
use crate::request::{open_dataset, training_pixels};
use crate::{RunRequest, SessionError};

/// A NeRF run's dataset and training images.
pub struct Nerf {
    dataset: Dataset,
    images: Option<ImageSet>,
}

impl Nerf {
    fn images(&self) -> &ImageSet {
        self.images.as_ref().expect("the session loads the images before the trainer")
    }
}

impl Method for Nerf {
    type Config = NerfConfig;
    type Trainer<'a> = NerfRun<'a>;

    const KIND: &'static str = NERF_KIND;
    const LABEL: &'static str = "nerf";
    const WHAT: &'static str = "a NeRF";

    fn parse_config(text: &str, origin: &str) -> Result<NerfConfig, String> {
        NerfConfig::from_toml(text, origin)
    }

    fn open(request: &RunRequest, _: Option<&NerfConfig>) -> Result<Self, SessionError> {
        Ok(Self { dataset: open_dataset(request.dataset()?, &request.dataset)?, images: None })
    }

    fn memory_estimate(&self, config: &NerfConfig) -> MemoryEstimate {
        config.memory_estimate(training_pixels(&self.dataset).0)
    }

    fn fingerprint(&self) -> Result<String, SessionError> {
        Ok(self.dataset.fingerprint())
    }

    fn load(&mut self) -> Result<(), SessionError> {
        let images = ImageSet::load(self.dataset.frames(Split::Train))
            .map_err(|e| SessionError::read("loading training images", e))?;
        self.images = Some(images);
        Ok(())
    }

    fn init(&self, config: NerfConfig) -> Result<NerfRun<'_>, SessionError> {
        let device = lucid_nerf::backend::training_device();
        let trainer = NerfTrainer::for_dataset(config, &self.dataset, self.images(), device);
        Ok(NerfRun { trainer, data: self.images(), held_out: Some(&self.dataset) })
    }

    fn resume(&self, checkpoint: &Path) -> Result<(NerfRun<'_>, f64), SessionError> {
        let device = lucid_nerf::backend::training_device();
        let loaded =
            lucid_nerf::checkpoint::load(checkpoint, &device).map_err(|e| SessionError::read("resuming", e))?;
        let run = NerfRun { trainer: loaded.trainer, data: self.images(), held_out: Some(&self.dataset) };
        Ok((run, loaded.header.elapsed))
    }

    fn settings(run: &NerfRun<'_>) -> TrainSettings {
        let t = &run.trainer.config.train;
        TrainSettings {
            steps: t.steps,
            time_limit: t.time_limit,
            checkpoint_every: t.checkpoint_every,
            log_every: t.log_every,
        }
    }

    fn set_steps(run: &mut NerfRun<'_>, steps: usize) {
        run.trainer.config.train.steps = steps;
    }

    fn config<'t>(run: &'t NerfRun<'_>) -> &'t NerfConfig {
        &run.trainer.config
    }

    fn snapshot(run: &NerfRun<'_>) -> Option<Box<dyn SceneModel>> {
        Some(Box::new(TrainedNerf::of(&run.trainer)))
    }

    fn dataset(&self) -> Option<&Dataset> {
        Some(&self.dataset)
    }

    fn describe(&self, run: &NerfRun<'_>) -> String {
        let (lo, hi) = run.trainer.grid.bounds();
        format!(
            "{} training views; box {:?}..{:?}; {} samples a step",
            self.images().len(),
            lo.to_array(),
            hi.to_array(),
            run.trainer.config.train.batch_samples
        )
    }
}
