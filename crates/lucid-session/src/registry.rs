//! One place that opens a model file as a [`SceneModel`]: every checkpoint kind Lucid's
//! trainers write that renders views. `eval`, `render`, `view` and `export` open models here
//! and never build a trainer.

use std::path::{Path, PathBuf};

use lucid_burn::checkpoint::CheckpointError;
use lucid_nerf::checkpoint::NERF_KIND;
use lucid_nerf::trained::TrainedNerf;
use lucid_scene::scene_model::SceneModel;
use lucid_splat::checkpoint::SPLAT_KIND;
use lucid_splat::trained::TrainedSplats;

/// Why a model file could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// Not readable, not a checkpoint, or damaged.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A checkpoint of a kind that does not render views on its own.
    #[error("{}: a '{kind}' checkpoint; views render from {} ones", path.display(), RENDERABLE.join(" and "))]
    NotRenderable {
        /// The file.
        path: PathBuf,
        /// The kind it holds.
        kind: String,
    },
}

/// The checkpoint kinds that open as models.
pub const RENDERABLE: [&str; 2] = [NERF_KIND, SPLAT_KIND];

/// Opens `path` as a model to render, whatever kind of checkpoint it is.
pub fn open(path: &Path) -> Result<Box<dyn SceneModel>, OpenError> {
    let kind = lucid_burn::checkpoint::read_kind(path)?;
    Ok(match kind.as_str() {
        NERF_KIND => Box::new(TrainedNerf::load(path)?),
        SPLAT_KIND => Box::new(TrainedSplats::load(path)?),
        _ => return Err(OpenError::NotRenderable { path: path.to_path_buf(), kind }),
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use lucid_nerf::config::NerfConfig;
    use lucid_nerf::field::FieldConfig;
    use lucid_nerf::trainer::NerfTrainer;
    use lucid_scene::dataset::images::ViewInfo;
    use lucid_scene::scene_model::RenderOptions;
    use lucid_splat::cloud::SplatCloud;
    use lucid_splat::config::SplatConfig;
    use lucid_splat::model::{SplatModel, SplatOptimizer};
    use lucid_splat::trainer::SplatTrainer;

    use super::*;

    fn nerf_checkpoint(path: &Path) {
        let mut config = NerfConfig {
            field: FieldConfig { hidden: 8, geometry_features: 4, ..FieldConfig::default() },
            ..Default::default()
        };
        config.field.grid.log2_table_size = 8;
        config.field.grid.levels = 2;
        config.occupancy.resolution = 8;
        let device = lucid_burn::backend::training_device();
        let trainer = NerfTrainer::new(config, (Vec3::splat(-1.0), Vec3::splat(3.0)), 0.01, device);
        lucid_nerf::checkpoint::save(path, &trainer, 1.0).unwrap();
    }

    fn splat_checkpoint(path: &Path) {
        let n = 3;
        let cloud = SplatCloud {
            means: (0..3 * n).map(|i| i as f32 * 0.1).collect(),
            log_scales: vec![-2.0; 3 * n],
            rotations: [1.0, 0.0, 0.0, 0.0].repeat(n),
            opacities: vec![0.5; n],
            sh_dc: vec![0.2; 3 * n],
            sh_rest: vec![0.0; 45 * n],
        };
        let device = lucid_burn::backend::training_device();
        let config = SplatConfig::default();
        let t = config.train;
        let model = SplatModel::from_cloud(&cloud, &device);
        let optimizer = SplatOptimizer::new(t.beta1, t.beta2, t.epsilon);
        let view = ViewInfo { radius: 2.5, ..ViewInfo::default() };
        let trainer =
            SplatTrainer::from_parts(config, model, optimizer, 7, 1.0, view, Vec3::new(0.0, 1.0, 2.0), device);
        lucid_splat::checkpoint::save(path, &trainer, 1.0).unwrap();
    }

    #[test]
    fn every_renderable_kind_opens_and_others_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let nerf = dir.path().join("nerf.lucid");
        nerf_checkpoint(&nerf);
        let mut model = open(&nerf).unwrap();
        assert_eq!((model.kind(), model.step()), ("nerf", 0));
        assert_eq!(model.centre(), Vec3::splat(1.0));
        model.set_render_options(&RenderOptions { pixel_rays: Some(4), step_scale: Some(0.5) }).unwrap();
        let err = model.set_render_options(&RenderOptions { pixel_rays: Some(0), ..Default::default() });
        assert!(err.unwrap_err().contains("--pixel-rays must be in 1..="));
        let err = model.set_render_options(&RenderOptions { step_scale: Some(1.5), ..Default::default() });
        assert!(err.unwrap_err().contains("--step-scale must be in (0, 1]"));

        let splat = dir.path().join("splat.lucid");
        splat_checkpoint(&splat);
        let model = open(&splat).unwrap();
        assert_eq!((model.kind(), model.step(), model.view().radius), ("splat", 7, 2.5));
        assert_eq!(model.centre(), Vec3::new(0.0, 1.0, 2.0));
        let cloud = model.as_any().downcast_ref::<TrainedSplats>().expect("splats").cloud();
        assert_eq!(cloud.len(), 3);
        let mut model = model;
        let err = model.set_render_options(&RenderOptions { step_scale: Some(0.5), ..Default::default() });
        assert!(err.unwrap_err().contains("--step-scale applies to NeRF models"));

        let itm = dir.path().join("itm.lucid");
        lucid_burn::checkpoint::write_sections(&itm, &[br#"{"kind": "itm"}"#]).unwrap();
        let err = open(&itm).err().expect("refused").to_string();
        assert!(err.contains("itm.lucid") && err.contains("'itm' checkpoint"), "{err}");
        let junk = dir.path().join("junk.lucid");
        std::fs::write(&junk, b"not a model").unwrap();
        let err = open(&junk).err().expect("refused").to_string();
        assert!(err.contains("junk.lucid") && err.contains("not a Lucid checkpoint"), "{err}");
    }
}
