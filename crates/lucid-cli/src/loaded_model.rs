//! Trained view models (NeRF, splats) behind one interface, so `lucid eval`, `lucid render` and
//! `lucid view` read every checkpoint the trainers write, and a viewer can show a model while
//! it trains.

use std::path::Path;

use crate::cli::NerfViewArgs;
use anyhow::bail;
use glam::Vec3;
use lucid_nerf::render::march::MarchSettings;
use lucid_nerf::trainer::NerfTrainer;
use lucid_scene::dataset::images::ViewInfo;
use lucid_scene::evaluation::ViewModel;
use lucid_splat::trainer::SplatTrainer;
use lucid_splat::view::SplatRenderer;

/// A checkpoint, loaded for rendering.
pub enum LoadedModel {
    /// A hash-grid NeRF.
    Nerf(Box<NerfTrainer>),
    /// A splat cloud.
    Splat(Box<SplatTrainer>),
}

/// A model borrowed from a checkpoint or from a run that is training it.
#[derive(Clone, Copy)]
pub enum ModelRef<'a> {
    /// A hash-grid NeRF.
    Nerf(&'a NerfTrainer),
    /// A splat cloud.
    Splat(&'a SplatTrainer),
}

impl LoadedModel {
    /// Loads `path`, whatever kind it is.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let kind = lucid_burn::checkpoint::read_kind(path)?;
        let device = lucid_burn::backend::default_device();
        Ok(match kind.as_str() {
            lucid_nerf::checkpoint::NERF_KIND => {
                Self::Nerf(Box::new(lucid_nerf::checkpoint::load(path, &device)?.trainer))
            }
            lucid_splat::checkpoint::SPLAT_KIND => {
                Self::Splat(Box::new(lucid_splat::checkpoint::load(path, &device)?.trainer))
            }
            other => bail!("{}: a '{other}' checkpoint; this build reads 'nerf' and 'splat' ones", path.display()),
        })
    }

    /// Casts a NeRF's rays as `args` say (what they leave out stays the run's own); an error
    /// naming the flag for splat checkpoints and for values out of range.
    pub fn set_nerf_view(&mut self, args: &NerfViewArgs) -> anyhow::Result<()> {
        let flag = match (args.pixel_rays, args.step_scale) {
            (None, None) => return Ok(()),
            (Some(_), _) => "--pixel-rays",
            (None, Some(_)) => "--step-scale",
        };
        // Splats are drawn by area already (each Gaussian is integrated over the pixel's
        // low-pass footprint) and have no steps.
        let Self::Nerf(t) = self else { bail!("{flag} applies to NeRF checkpoints; this one holds splats") };
        if let Some(rays) = args.pixel_rays {
            let max = lucid_nerf::config::MAX_PIXEL_RAYS;
            anyhow::ensure!((1..=max).contains(&rays), "--pixel-rays must be in 1..={max}, got {rays}");
            t.config.train.eval_pixel_rays = rays;
        }
        if let Some(scale) = args.step_scale {
            anyhow::ensure!(MarchSettings::is_render_step_scale(scale), "--step-scale must be in (0, 1], got {scale}");
            t.config.march.render_step_scale = scale;
        }
        Ok(())
    }

    /// The model, borrowed.
    pub fn model(&self) -> ModelRef<'_> {
        match self {
            Self::Nerf(t) => ModelRef::Nerf(t),
            Self::Splat(t) => ModelRef::Splat(t),
        }
    }

    /// Training steps taken.
    pub fn step(&self) -> usize {
        self.model().step()
    }

    /// How the training cameras saw the scene.
    pub fn view(&self) -> ViewInfo {
        self.model().view()
    }

    /// The centre of the scene (the target of orbit paths).
    pub fn centre(&self) -> Vec3 {
        self.model().centre()
    }

    /// Runs `f` with a renderer of the model.
    pub fn with_renderer<R>(&self, f: impl FnOnce(&dyn ViewModel) -> R) -> R {
        self.model().with_renderer(f)
    }
}

impl ModelRef<'_> {
    /// `nerf` or `splat`, as checkpoints name their kind.
    pub fn kind(self) -> &'static str {
        match self {
            Self::Nerf(_) => lucid_nerf::checkpoint::NERF_KIND,
            Self::Splat(_) => lucid_splat::checkpoint::SPLAT_KIND,
        }
    }

    /// Training steps taken.
    pub fn step(self) -> usize {
        match self {
            Self::Nerf(t) => t.step,
            Self::Splat(t) => t.step,
        }
    }

    /// How the training cameras saw the scene.
    pub fn view(self) -> ViewInfo {
        match self {
            Self::Nerf(t) => t.view,
            Self::Splat(t) => t.view,
        }
    }

    /// The centre of the scene (the target of orbit paths).
    pub fn centre(self) -> Vec3 {
        match self {
            Self::Nerf(t) => {
                let (lo, hi) = t.grid.bounds();
                (lo + hi) * 0.5
            }
            Self::Splat(t) => t.centre,
        }
    }

    /// Runs `f` with a renderer of the model as it is now.
    pub fn with_renderer<R>(self, f: impl FnOnce(&dyn ViewModel) -> R) -> R {
        match self {
            Self::Nerf(t) => {
                let model = t.eval_model();
                f(&t.renderer(&model))
            }
            Self::Splat(t) => {
                let cloud = t.model.to_cloud();
                f(&SplatRenderer { cloud: &cloud, settings: t.eval_settings() })
            }
        }
    }
}
