//! Checkpoints: one file holding everything to evaluate a model or continue training it.
//!
//! Layout: the magic `LUCIDCKP`, a little-endian `u32` format version, then length-prefixed
//! (`u64`) sections: a JSON header (model kind, configuration, scene box, step, pixel
//! angle), burn's record of the model parameters, burn's record of the optimiser state, and
//! the occupancy grid (thickness per cell as `f32`, bitfield as `u64`), and, when the run
//! samples pixels by their loss, the error map ([`ErrorMap::to_bytes`]), and last, when the
//! header records one, the parameters' running average ([`ParameterAverage::to_bytes`]).
//! Written to a temporary name and renamed, so a crash never leaves a torn file under the real
//! name.

use std::path::Path;

use burn::module::Module;
use burn::store::ModuleRecord;
use burn::tensor::{Bytes, Device};
use glam::Vec3;
use serde::{Deserialize, Serialize};

pub use lucid_burn::checkpoint::{CheckpointError, is_checkpoint, read_kind};
use lucid_burn::checkpoint::{invalid, read_kind_sections, write_sections};

use crate::average::{AverageState, ParameterAverage};
use crate::config::NerfConfig;
use crate::data::ViewInfo;
use crate::error_map::ErrorMap;
use crate::model::NerfModel;
use crate::occupancy::OccupancyGrid;
use crate::optimizer::optimizer;
use crate::trainer::NerfTrainer;

/// The kind this module reads and writes.
pub const NERF_KIND: &str = "nerf";

/// The JSON header.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CheckpointHeader {
    /// `"nerf"` (other trainers write their own kinds).
    pub kind: String,
    /// The configuration the model was trained with.
    pub config: NerfConfig,
    /// Scene box.
    pub bounds: [[f32; 3]; 2],
    /// Steps taken.
    pub step: usize,
    /// Angular size of a training pixel.
    pub pixel_angle: f32,
    /// Rays per batch at the time of saving.
    pub rays_per_batch: f32,
    /// Training time so far, in seconds.
    pub elapsed: f64,
    /// How the training cameras saw the scene.
    #[serde(default)]
    pub view: ViewInfo,
    /// The running average of the parameters, whose values are the last section.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub average: Option<AverageState>,
}

/// Saves a trainer's full state to `path`.
pub fn save(path: &Path, trainer: &NerfTrainer, elapsed: f64) -> Result<(), CheckpointError> {
    let (lo, hi) = trainer.grid.bounds();
    let header = CheckpointHeader {
        kind: NERF_KIND.into(),
        config: trainer.config.clone(),
        bounds: [lo.to_array(), hi.to_array()],
        step: trainer.step,
        pixel_angle: trainer.pixel_angle,
        rays_per_batch: trainer.rays_per_batch,
        elapsed,
        view: trainer.view,
        average: trainer.average.as_ref().map(|a| a.state),
    };
    let header = serde_json::to_vec_pretty(&header).expect("the header serialises");
    let model = trainer.model.clone().into_record().into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    let optim = trainer.optimizer.into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    let thickness: Vec<u8> = trainer.grid.thickness().iter().flat_map(|v| v.to_le_bytes()).collect();
    let bits: Vec<u8> = trainer.grid.bits().iter().flat_map(|v| v.to_le_bytes()).collect();
    let errors = trainer.error_map.as_ref().map(ErrorMap::to_bytes);
    let average = trainer.average.as_ref().map(ParameterAverage::to_bytes);
    let mut sections = vec![&header[..], &model[..], &optim[..], &thickness[..], &bits[..]];
    sections.extend(errors.as_deref());
    sections.extend(average.as_deref());
    write_sections(path, &sections)
}

/// A loaded checkpoint.
pub struct Loaded {
    /// Its header.
    pub header: CheckpointHeader,
    /// The trainer state, on `device`.
    pub trainer: NerfTrainer,
}

/// What a checkpoint holds, read: everything but the optimiser state, whose bytes are kept
/// for a trainer to parse.
pub(crate) struct Parts {
    pub(crate) header: CheckpointHeader,
    pub(crate) model: NerfModel,
    pub(crate) optimizer: Vec<u8>,
    pub(crate) grid: OccupancyGrid,
    pub(crate) error_map: Option<ErrorMap>,
    pub(crate) average: Option<ParameterAverage>,
}

/// Loads a NeRF checkpoint onto `device` (use the autodiff device to continue training).
pub fn load(path: &Path, device: &Device) -> Result<Loaded, CheckpointError> {
    let Parts { header, model, optimizer: state, grid, error_map, average } = read(path, device)?;
    let optimizer = optimizer(&header.config)
        .from_bytes(Bytes::from_bytes_vec(state))
        .map_err(|e| invalid(path, format!("optimiser state: {e}")))?;
    let mut trainer = NerfTrainer::resume(
        header.config.clone(),
        model,
        Some(optimizer),
        grid,
        header.step,
        header.pixel_angle,
        device.clone(),
    );
    trainer.rays_per_batch = header.rays_per_batch;
    trainer.view = header.view;
    trainer.error_map = error_map;
    trainer.average = average;
    Ok(Loaded { header, trainer })
}

/// Reads a checkpoint's sections onto `device`, checking each against the header.
pub(crate) fn read(path: &Path, device: &Device) -> Result<Parts, CheckpointError> {
    let (value, sections) = read_kind_sections(path, NERF_KIND)?;
    let header: CheckpointHeader =
        serde_json::from_value(value).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    header.config.validate().map_err(|e| invalid(path, format!("bad configuration: {e}")))?;
    let (sections, average) = match (&header.average, sections.split_last()) {
        (Some(state), Some((last, rest))) if rest.len() >= 4 => (rest, Some((*state, last))),
        (None, _) => (&sections[..], None),
        _ => return Err(invalid(path, "the header records a parameter average but the file holds none")),
    };
    let (model, optim, thickness, bits, errors) = match sections {
        [m, o, t, b] => (m, o, t, b, None),
        [m, o, t, b, e] => (m, o, t, b, Some(e)),
        _ => return Err(invalid(path, format!("expected 5 or 6 sections, found {}", sections.len() + 1))),
    };
    let error_map =
        errors.map(|e| ErrorMap::from_bytes(e).ok_or_else(|| invalid(path, "malformed error map"))).transpose()?;
    // The configuration sizes the model built before its parameters are read: a header that
    // claims more than the file holds is damage, not a reason to allocate.
    let layout = header.config.field.layout();
    let needed = 4 * (layout.grid.entries * layout.grid.features + layout.mlp_params()) as u64;
    if (model.len() as u64) < needed {
        return Err(invalid(
            path,
            format!("model parameters: {} bytes, the configuration needs {needed}", model.len()),
        ));
    }
    let average = average
        .map(|(state, bytes)| {
            let (table, mlp) = (layout.grid.entries * layout.grid.features, layout.mlp_params());
            let values = le_f32s(bytes).ok_or("parameter average: not a whole number of f32 values")?;
            ParameterAverage::from_parts(state, values, table, mlp).map_err(|e| e.to_string())
        })
        .transpose()
        .map_err(|e| invalid(path, e))?;
    let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(model.to_vec()))
        .map_err(|e| invalid(path, format!("model parameters: {e}")))?;
    let fresh = NerfModel::init(&header.config.field, device, header.config.train.seed);
    let model = fresh.try_load_record(record).map_err(|e| invalid(path, format!("model parameters: {e}")))?;
    let res = header.config.occupancy.resolution;
    let thickness = le_f32s(thickness).ok_or_else(|| invalid(path, "occupancy thickness: not whole f32 values"))?;
    let bits: Vec<u64> = bits.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().expect("8"))).collect();
    let [lo, hi] = header.bounds;
    let grid = OccupancyGrid::from_parts(res, Vec3::from(lo), Vec3::from(hi), thickness, bits)
        .ok_or_else(|| invalid(path, "occupancy grid does not match its resolution"))?;
    Ok(Parts { header, model, optimizer: optim.to_vec(), grid, error_map, average })
}

/// Little-endian `f32`s of a section, or `None` if its length is not a whole number of them.
pub(crate) fn le_f32s(bytes: &[u8]) -> Option<Vec<f32>> {
    let values = bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")));
    bytes.len().is_multiple_of(4).then(|| values.collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::FieldConfig;

    fn tiny_trainer() -> NerfTrainer {
        let mut config = NerfConfig {
            field: FieldConfig { hidden: 8, geometry_features: 4, ..FieldConfig::default() },
            ..Default::default()
        };
        config.field.grid.log2_table_size = 8;
        config.field.grid.levels = 2;
        config.occupancy.resolution = 8;
        NerfTrainer::new(config, (Vec3::splat(-1.0), Vec3::splat(1.0)), 0.01, crate::backend::training_device())
    }

    /// Rewrites the header section of a checkpoint, as a valid container.
    fn with_header(path: &Path, edit: impl Fn(&str) -> String) -> Vec<u8> {
        let (value, sections) = lucid_burn::checkpoint::read_kind_sections(path, NERF_KIND).unwrap();
        let header = edit(&serde_json::to_string_pretty(&value).unwrap());
        let out = path.with_extension("edited");
        let mut all: Vec<&[u8]> = vec![header.as_bytes()];
        all.extend(sections.iter().map(Vec::as_slice));
        lucid_burn::checkpoint::write_sections(&out, &all).unwrap();
        std::fs::read(&out).unwrap()
    }

    #[test]
    fn round_trip_and_clear_errors_for_other_kinds_versions_and_damage() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.lucid");
        let trainer = tiny_trainer();
        save(&path, &trainer, 1.5).unwrap();
        let loaded = load(&path, &crate::backend::default_device()).unwrap();
        assert_eq!(loaded.header.elapsed, 1.5);
        assert_eq!(loaded.trainer.grid, trainer.grid);
        let values = |m: &NerfModel| m.mlp.val().into_data().try_to_vec::<f32>().unwrap();
        assert_eq!(values(&loaded.trainer.model), values(&trainer.model));

        let bytes = std::fs::read(&path).unwrap();
        let err = |bytes: &[u8]| {
            let p = dir.path().join("x.lucid");
            std::fs::write(&p, bytes).unwrap();
            load(&p, &crate::backend::default_device()).err().expect("an error").to_string()
        };
        let splat = with_header(&path, |h| h.replace("\"kind\": \"nerf\"", "\"kind\": \"splat\""));
        assert!(err(&splat).contains("holds a 'splat' model, expected 'nerf'"), "{}", err(&splat));
        let mut version = bytes.clone();
        version[8] = 9;
        assert!(err(&version).contains("version 9"), "{}", err(&version));
        assert!(err(&bytes[..bytes.len() - 10]).contains("truncated"), "{}", err(&bytes[..bytes.len() - 10]));
        assert!(err(b"hello").contains("not a Lucid checkpoint"));
        let garbled = with_header(&path, |h| h.replace("\"step\"", "\"stop\""));
        assert!(err(&garbled).contains("malformed header"), "{}", err(&garbled));
    }

    /// The raw parameters go on training and the average is what is evaluated; both survive
    /// a checkpoint, and a header that claims an average the file does not hold is refused.
    #[test]
    fn the_parameter_average_is_kept_beside_the_parameters() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("avg.lucid");
        let mut trainer = tiny_trainer();
        let values = |m: &NerfModel| {
            (
                m.table.val().into_data().try_to_vec::<f32>().unwrap(),
                m.mlp.val().into_data().try_to_vec::<f32>().unwrap(),
            )
        };
        let (table, mlp) = values(&trainer.model);
        let shifted = |v: &[f32]| v.iter().map(|x| x + 1.0).collect::<Vec<f32>>();
        trainer.average = Some(ParameterAverage::start(0.9, shifted(&table), shifted(&mlp)));
        trainer.error_map = Some(ErrorMap::new(&[(8, 8)], 1.0));
        save(&path, &trainer, 2.0).unwrap();
        let loaded = load(&path, &crate::backend::default_device()).unwrap().trainer;
        assert_eq!(loaded.average, trainer.average);
        assert_eq!(values(&loaded.model), (table.clone(), mlp.clone()));
        assert_eq!(values(&loaded.eval_model()), (shifted(&table), shifted(&mlp)));
        assert!(loaded.error_map.is_some());
        // A header written before the window left it (the window is the configuration's).
        let old = with_header(&path, |h| {
            let old = h.replacen("\"average\": {", "\"average\": {\"window\": 0.1,", 1);
            assert_ne!(old, h, "the header has an average to add the window to");
            old
        });
        let old_path = dir.path().join("old.lucid");
        std::fs::write(&old_path, old).unwrap();
        let old = load(&old_path, &crate::backend::default_device()).unwrap().trainer;
        assert_eq!(old.average, trainer.average);

        let plain = dir.path().join("plain.lucid");
        save(&plain, &tiny_trainer(), 1.0).unwrap();
        let claimed = with_header(&plain, |h| h.replacen('{', "{\"average\": {\"progress\": 0.9, \"updates\": 3},", 1));
        let p = dir.path().join("claimed.lucid");
        std::fs::write(&p, claimed).unwrap();
        let err = load(&p, &crate::backend::default_device()).err().expect("an error").to_string();
        assert!(err.contains("claimed.lucid") && err.contains("parameter average"), "{err}");
    }
}
