//! 3D Gaussian splatting as a session's method.

use std::borrow::Cow;
use std::path::Path;

use lucid_burn::memory::MemoryEstimate;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::scene_model::SceneModel;
use lucid_scene::{Dataset, Split};
use lucid_splat::checkpoint::SPLAT_KIND;
use lucid_splat::config::SplatConfig;
use lucid_splat::run::SplatRun;
use lucid_splat::trained::TrainedSplats;
use lucid_splat::trainer::{SplatTrainer, initial_cloud};

use crate::method::{Method, TrainSettings};
use crate::request::{open_dataset, training_pixels};
use crate::{RunRequest, SessionError};

/// A splat run's dataset, training images and export path.
pub struct Splat {
    dataset: Dataset,
    images: Option<ImageSet>,
    export: std::path::PathBuf,
}

impl Splat {
    fn images(&self) -> &ImageSet {
        self.images.as_ref().expect("the session loads the images before the trainer")
    }

    fn run<'a>(&'a self, trainer: SplatTrainer) -> SplatRun<'a> {
        SplatRun { trainer, data: self.images(), held_out: Some(&self.dataset), export: Some(self.export.clone()) }
    }
}

impl Method for Splat {
    type Config = SplatConfig;
    type Trainer<'a> = SplatRun<'a>;

    const KIND: &'static str = SPLAT_KIND;
    const LABEL: &'static str = "splat";
    const WHAT: &'static str = "3D Gaussian splats";

    fn parse_config(text: &str, origin: &str) -> Result<SplatConfig, String> {
        SplatConfig::from_toml(text, origin)
    }

    fn open(request: &RunRequest, _: Option<&SplatConfig>) -> Result<Self, SessionError> {
        let dataset = open_dataset(request.dataset()?, &request.dataset)?;
        Ok(Self { dataset, images: None, export: request.output.join("splats.ply") })
    }

    fn memory_estimate(&self, config: &SplatConfig) -> MemoryEstimate {
        let (pixels, largest) = training_pixels(&self.dataset);
        config.memory_estimate(config.init.random_points, pixels, largest)
    }

    fn fingerprint(&self) -> Result<String, SessionError> {
        Ok(self.dataset.fingerprint())
    }

    fn load(&mut self) -> Result<(), SessionError> {
        let loaded = ImageSet::load(self.dataset.frames(Split::Train))
            .map_err(|e| SessionError::read("loading training images", e))?;
        // The rasterizer projects through pinholes: distorted captures train on undistorted
        // crops.
        let undistorted = match loaded.undistorted() {
            Cow::Owned(images) => Some(images),
            Cow::Borrowed(_) => None,
        };
        self.images = Some(undistorted.unwrap_or(loaded));
        Ok(())
    }

    fn init(&self, config: SplatConfig) -> Result<SplatRun<'_>, SessionError> {
        let cloud = initial_cloud(&config, &self.dataset, self.images())
            .map_err(|e| SessionError::read(format!("initialising from {}", self.dataset.root.display()), e))?;
        let device = lucid_burn::backend::training_device();
        Ok(self.run(SplatTrainer::for_dataset(config, &cloud, &self.dataset, self.images(), device)))
    }

    fn resume(&self, checkpoint: &Path) -> Result<(SplatRun<'_>, f64), SessionError> {
        let device = lucid_burn::backend::training_device();
        let loaded =
            lucid_splat::checkpoint::load(checkpoint, &device).map_err(|e| SessionError::read("resuming", e))?;
        Ok((self.run(loaded.trainer), loaded.header.elapsed))
    }

    fn settings(run: &SplatRun<'_>) -> TrainSettings {
        let t = &run.trainer.config.train;
        TrainSettings {
            steps: t.steps,
            time_limit: t.time_limit,
            checkpoint_every: t.checkpoint_every,
            log_every: t.log_every,
        }
    }

    fn set_steps(run: &mut SplatRun<'_>, steps: usize) {
        run.trainer.config.train.steps = steps;
    }

    fn config<'t>(run: &'t SplatRun<'_>) -> &'t SplatConfig {
        &run.trainer.config
    }

    fn snapshot(run: &SplatRun<'_>) -> Option<Box<dyn SceneModel>> {
        Some(Box::new(TrainedSplats::of(&run.trainer)))
    }

    fn dataset(&self) -> Option<&Dataset> {
        Some(&self.dataset)
    }

    fn describe(&self, run: &SplatRun<'_>) -> String {
        format!(
            "{} training views; {} Gaussians to start; scene extent {:.3}",
            self.images().len(),
            run.trainer.model.len(),
            run.trainer.extent
        )
    }
}
