//! Relighting checkpoints in Lucid's container ([`lucid_burn::checkpoint`]): a JSON header
//! (kind `"relight"`, configuration, render settings, the training lights, step, time), the
//! frozen geometry as little-endian `f32` arrays, burn's record of the head and Adam's state
//! (burn's optimiser record), so that `--resume` continues exactly.

use std::path::Path;

use burn::module::Module;
use burn::optim::AdamConfig;
use burn::store::ModuleRecord;
use burn::tensor::{Bytes, Device};
use glam::Vec3;
use lucid_splat::cloud::SplatCloud;
use lucid_splat::model::{WIDTHS, cloud_fields, cloud_fields_mut};
use lucid_splat::project::RenderSettings;
use serde::{Deserialize, Serialize};

pub use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::checkpoint::{invalid, read_kind_sections, write_sections};

use crate::config::RelightConfig;
use crate::head::RelightHead;
use crate::render::Geometry;
use crate::trainer::RelightTrainer;

/// The kind this module reads and writes.
pub const RELIGHT_KIND: &str = "relight";

/// The JSON header.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RelightCheckpointHeader {
    /// `"relight"`.
    pub kind: String,
    /// The configuration.
    pub config: RelightConfig,
    /// How the geometry is projected.
    pub settings: RenderSettings,
    /// Gaussians in the geometry.
    pub gaussians: usize,
    /// Directions of the training lights.
    pub training_directions: Vec<[f32; 3]>,
    /// Irradiance of one training light.
    pub irradiance: f32,
    /// Head steps taken.
    pub step: usize,
    /// Training time so far (both stages), seconds.
    pub elapsed: f64,
}

/// What a checkpoint holds besides the trainer.
#[derive(Clone, Debug)]
pub struct LightSet {
    /// Directions of the training lights.
    pub directions: Vec<Vec3>,
    /// Irradiance of one.
    pub irradiance: f32,
}

fn cloud_bytes(cloud: &SplatCloud) -> Vec<u8> {
    cloud_fields(cloud).into_iter().flat_map(|v| v.iter().flat_map(|x| x.to_le_bytes())).collect()
}

fn cloud_from_bytes(path: &Path, bytes: &[u8], n: usize) -> Result<SplatCloud, CheckpointError> {
    let floats = WIDTHS.iter().sum::<usize>() * n;
    if bytes.len() != 4 * floats {
        return Err(invalid(
            path,
            format!("geometry: {} bytes for {n} Gaussians, expected {}", bytes.len(), 4 * floats),
        ));
    }
    let mut values = bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")));
    let mut cloud = SplatCloud::default();
    for (field, width) in cloud_fields_mut(&mut cloud).into_iter().zip(WIDTHS) {
        field.extend(values.by_ref().take(width * n));
    }
    cloud.validate().map_err(|e| invalid(path, format!("geometry: {e}")))?;
    Ok(cloud)
}

/// Saves a trainer (atomically).
pub fn save(path: &Path, trainer: &RelightTrainer, lights: &LightSet, elapsed: f64) -> Result<(), CheckpointError> {
    let header = RelightCheckpointHeader {
        kind: RELIGHT_KIND.into(),
        config: trainer.config.clone(),
        settings: trainer.geometry.settings,
        gaussians: trainer.geometry.len(),
        training_directions: lights.directions.iter().map(|d| d.to_array()).collect(),
        irradiance: lights.irradiance,
        step: trainer.step,
        elapsed,
    };
    let header = serde_json::to_vec_pretty(&header).expect("the header serialises");
    let head = trainer.head.clone().into_record().into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    let optimizer = trainer.optimizer.into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    write_sections(path, &[&header, &cloud_bytes(&trainer.geometry.cloud), &head, &optimizer])
}

/// A loaded checkpoint.
pub struct LoadedRelight {
    /// The header.
    pub header: RelightCheckpointHeader,
    /// The trainer, on `device`.
    pub trainer: RelightTrainer,
    /// The training lights.
    pub lights: LightSet,
}

/// A relighting model apart from its trainer: the frozen geometry, the head and the lights
/// it was trained under, without optimiser state.
pub struct TrainedRelight {
    /// The header.
    pub header: RelightCheckpointHeader,
    /// The frozen geometry.
    pub geometry: Geometry,
    /// The head, on the device it was loaded onto.
    pub head: RelightHead,
    /// The training lights.
    pub lights: LightSet,
}

/// Loads the model of a relighting checkpoint onto `device` (its optimiser state unread).
pub fn load_model(path: &Path, device: &Device) -> Result<TrainedRelight, CheckpointError> {
    Ok(read(path, device)?.0)
}

/// Loads a relighting checkpoint onto `device`, to continue training.
pub fn load(path: &Path, device: &Device) -> Result<LoadedRelight, CheckpointError> {
    let (model, optimizer) = read(path, device)?;
    let optimizer = AdamConfig::new()
        .init()
        .from_bytes(Bytes::from_bytes_vec(optimizer))
        .map_err(|e| invalid(path, format!("optimiser state: {e}")))?;
    let TrainedRelight { header, geometry, head, lights } = model;
    let trainer =
        RelightTrainer::from_parts(header.config.clone(), geometry, head, optimizer, header.step, device.clone());
    Ok(LoadedRelight { header, trainer, lights })
}

/// The model of a checkpoint and its optimiser section's bytes.
fn read(path: &Path, device: &Device) -> Result<(TrainedRelight, Vec<u8>), CheckpointError> {
    let (value, sections) = read_kind_sections(path, RELIGHT_KIND)?;
    let header: RelightCheckpointHeader =
        serde_json::from_value(value).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    header.config.validate().map_err(|e| invalid(path, format!("bad configuration: {e}")))?;
    let [cloud, head, optimizer] = &sections[..] else {
        return Err(invalid(path, format!("expected 4 sections, found {}", sections.len() + 1)));
    };
    let cloud = cloud_from_bytes(path, cloud, header.gaussians)?;
    let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(head.clone()))
        .map_err(|e| invalid(path, format!("head parameters: {e}")))?;
    let head = RelightHead::new(&header.config, header.gaussians, device)
        .try_load_record(record)
        .map_err(|e| invalid(path, format!("head parameters: {e}")))?;
    let geometry = Geometry::new(cloud, header.settings, device);
    let lights = LightSet {
        directions: header.training_directions.iter().map(|d| Vec3::from_array(*d)).collect(),
        irradiance: header.irradiance,
    };
    Ok((TrainedRelight { header, geometry, head, lights }, optimizer.clone()))
}
