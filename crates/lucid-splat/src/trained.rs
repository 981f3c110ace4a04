//! A trained splat cloud apart from its trainer: the Gaussians and the settings to render
//! them. What a checkpoint opens as for `eval`, `render`, `view` and `export`, and what a run
//! shows while it trains.

use std::path::Path;

use glam::Vec3;
use lucid_scene::dataset::images::ViewInfo;
use lucid_scene::scene_model::{RendersThrough, SceneModel};

use crate::checkpoint::SPLAT_KIND;
use crate::cloud::SplatCloud;
use crate::config::SplatConfig;
use crate::project::RenderSettings;
use crate::trainer::SplatTrainer;
use crate::view::SplatRenderer;
use lucid_burn::checkpoint::CheckpointError;

/// Gaussians to render, without optimiser state or densification statistics.
pub struct TrainedSplats {
    cloud: SplatCloud,
    config: SplatConfig,
    settings: RenderSettings,
    view: ViewInfo,
    centre: Vec3,
    step: usize,
}

impl TrainedSplats {
    /// The cloud `trainer` holds now, with its evaluation settings.
    pub fn of(trainer: &SplatTrainer) -> Self {
        Self {
            cloud: trainer.model.to_cloud(),
            config: trainer.config.clone(),
            settings: trainer.eval_settings(),
            view: trainer.view,
            centre: trainer.centre,
            step: trainer.step,
        }
    }

    /// The cloud a splat checkpoint holds (its optimiser state and densification statistics
    /// unread).
    pub fn load(path: &Path) -> Result<Self, CheckpointError> {
        let (header, model, _) = crate::checkpoint::read(path, &lucid_burn::backend::default_device())?;
        Ok(Self {
            cloud: model.to_cloud(),
            settings: crate::trainer::eval_settings(&header.config, header.extent, header.schedule),
            config: header.config,
            view: header.view,
            centre: header.centre.into(),
            step: header.step,
        })
    }

    /// The Gaussians.
    pub fn cloud(&self) -> &SplatCloud {
        &self.cloud
    }

    /// The configuration they were trained with.
    pub fn config(&self) -> &SplatConfig {
        &self.config
    }

    /// How they are rendered.
    pub fn settings(&self) -> RenderSettings {
        self.settings
    }
}

impl RendersThrough for TrainedSplats {
    type Renderer<'a> = SplatRenderer<'a>;

    fn renderer(&self) -> SplatRenderer<'_> {
        SplatRenderer { cloud: &self.cloud, settings: self.settings }
    }
}

impl SceneModel for TrainedSplats {
    fn kind(&self) -> &'static str {
        SPLAT_KIND
    }

    fn step(&self) -> usize {
        self.step
    }

    fn view(&self) -> ViewInfo {
        self.view
    }

    fn centre(&self) -> Vec3 {
        self.centre
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
