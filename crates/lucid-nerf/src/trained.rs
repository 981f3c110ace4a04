//! A trained NeRF apart from its trainer: the parameters to render (the running average where
//! the run keeps one), the occupancy grid, and the settings its rays are cast with. What a
//! checkpoint opens as for `eval`, `render` and `view`, and what a run shows while it trains.

use std::path::Path;

use glam::Vec3;
use lucid_scene::scene_model::{RenderOptions, RendersThrough, SceneModel};

use crate::average::ParameterAverage;
use crate::checkpoint::{CheckpointError, NERF_KIND};
use crate::config::{Background, MAX_PIXEL_RAYS, NerfConfig};
use crate::data::ViewInfo;
use crate::model::NerfModel;
use crate::occupancy::OccupancyGrid;
use crate::render::march::{MarchSettings, RayMarcher};
use crate::render::view::ViewRenderer;
use crate::trainer::NerfTrainer;

/// A NeRF to render, without optimiser state.
pub struct TrainedNerf {
    model: NerfModel,
    grid: OccupancyGrid,
    config: NerfConfig,
    pixel_angle: f32,
    view: ViewInfo,
    step: usize,
}

impl TrainedNerf {
    /// The model `trainer` holds now.
    pub fn of(trainer: &NerfTrainer) -> Self {
        Self {
            model: trainer.eval_model(),
            grid: trainer.grid.clone(),
            config: trainer.config.clone(),
            pixel_angle: trainer.pixel_angle,
            view: trainer.view,
            step: trainer.step,
        }
    }

    /// The model a NeRF checkpoint holds (its optimiser state unread).
    pub fn load(path: &Path) -> Result<Self, CheckpointError> {
        let parts = crate::checkpoint::read(path, &crate::backend::default_device())?;
        let h = parts.header;
        Ok(Self {
            model: eval_model(&h.config, &parts.model, parts.average.as_ref()),
            grid: parts.grid,
            config: h.config,
            pixel_angle: h.pixel_angle,
            view: h.view,
            step: h.step,
        })
    }

    /// The configuration it was trained with (its render settings as changed since).
    pub fn config(&self) -> &NerfConfig {
        &self.config
    }
}

/// The parameters to evaluate and render, without autodiff tracking, on the inner device:
/// the running average `average` once there is one, else `model`'s.
pub(crate) fn eval_model(config: &NerfConfig, model: &NerfModel, average: Option<&ParameterAverage>) -> NerfModel {
    match average {
        Some(average) => NerfModel::from_values(
            &config.field,
            average.table.clone(),
            average.mlp.clone(),
            &crate::backend::default_device(),
        ),
        None => burn::module::Module::valid(model),
    }
}

/// The marcher of a scene whose occupancy is `grid`, for pixels of angle `pixel_angle`.
pub(crate) fn marcher(config: &NerfConfig, grid: &OccupancyGrid, pixel_angle: f32) -> RayMarcher {
    let (lo, hi) = grid.bounds();
    RayMarcher::new(&config.march, (hi - lo).length(), pixel_angle, grid.resolution())
}

/// A renderer of `model` (parameters without autodiff tracking) over `grid` with the
/// settings of `config`: its evaluation background, its march at the render step scale and
/// its rays per pixel.
pub fn renderer<'a>(
    config: &NerfConfig,
    model: &'a NerfModel,
    grid: &'a OccupancyGrid,
    pixel_angle: f32,
) -> ViewRenderer<'a> {
    let background = match config.train.eval_background {
        Background::Black => [0.0; 3],
        _ => [1.0; 3],
    };
    ViewRenderer {
        model,
        config: config.field,
        grid,
        marcher: marcher(config, grid, pixel_angle).with_step_scale(config.march.render_step_scale),
        min_transmittance: config.train.min_transmittance,
        background,
        device: crate::backend::default_device(),
        pixel_rays: config.train.eval_pixel_rays,
    }
}

impl RendersThrough for TrainedNerf {
    type Renderer<'a> = ViewRenderer<'a>;

    fn renderer(&self) -> ViewRenderer<'_> {
        renderer(&self.config, &self.model, &self.grid, self.pixel_angle)
    }
}

impl SceneModel for TrainedNerf {
    fn kind(&self) -> &'static str {
        NERF_KIND
    }

    fn step(&self) -> usize {
        self.step
    }

    fn view(&self) -> ViewInfo {
        self.view
    }

    fn centre(&self) -> Vec3 {
        let (lo, hi) = self.grid.bounds();
        (lo + hi) * 0.5
    }

    fn set_render_options(&mut self, options: &RenderOptions) -> Result<(), String> {
        if let Some(rays) = options.pixel_rays {
            if !(1..=MAX_PIXEL_RAYS).contains(&rays) {
                return Err(format!("--pixel-rays must be in 1..={MAX_PIXEL_RAYS}, got {rays}"));
            }
            self.config.train.eval_pixel_rays = rays;
        }
        if let Some(scale) = options.step_scale {
            if !MarchSettings::is_render_step_scale(scale) {
                return Err(format!("--step-scale must be in (0, 1], got {scale}"));
            }
            self.config.march.render_step_scale = scale;
        }
        Ok(())
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
