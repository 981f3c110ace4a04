//! Splat checkpoints, in the container every Lucid trainer writes
//! ([`lucid_burn::checkpoint`]): a JSON header (kind `"splat"`, configuration, step, scene
//! extent, number of Gaussians), burn's record of the parameters, and Adam's state per
//! parameter kind (steps taken, first and second moments as `f32`), and the densification
//! statistics gathered since the last densification (so a resumed run continues exactly).

use std::path::Path;

use burn::module::Module;
use burn::store::ModuleRecord;
use burn::tensor::{Bytes, Device};
use lucid_scene::dataset::images::ViewInfo;
use serde::{Deserialize, Serialize};

pub use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::checkpoint::{invalid, read_kind_sections, write_sections};

use crate::cloud::SplatCloud;
use crate::config::SplatConfig;
use crate::densify::DensifyStats;
use crate::model::{HostMoments, SplatModel, SplatOptimizer, WIDTHS};
use crate::trainer::SplatTrainer;

/// The kind this module reads and writes.
pub const SPLAT_KIND: &str = "splat";

/// The JSON header.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SplatCheckpointHeader {
    /// `"splat"`.
    pub kind: String,
    /// The configuration the cloud was trained with.
    pub config: SplatConfig,
    /// Steps taken.
    pub step: usize,
    /// Scene extent.
    pub extent: f32,
    /// Number of Gaussians.
    pub gaussians: usize,
    /// Training time so far, in seconds.
    pub elapsed: f64,
    /// How the training cameras saw the scene.
    pub view: ViewInfo,
    /// Centre of the scene.
    pub centre: [f32; 3],
    /// Position in the reference schedule.
    pub schedule: usize,
    /// Steps since the last densification.
    pub since_densify: usize,
}

fn f32_bytes(v: &[f32]) -> impl Iterator<Item = u8> + '_ {
    v.iter().flat_map(|x| x.to_le_bytes())
}

/// Saves a trainer's state to `path` (atomically).
pub fn save(path: &Path, trainer: &SplatTrainer, elapsed: f64) -> Result<(), CheckpointError> {
    let header = SplatCheckpointHeader {
        kind: SPLAT_KIND.into(),
        config: trainer.config.clone(),
        step: trainer.step,
        extent: trainer.extent,
        gaussians: trainer.model.len(),
        elapsed,
        view: trainer.view,
        centre: trainer.centre.to_array(),
        schedule: trainer.schedule,
        since_densify: trainer.since_densify,
    };
    let header = serde_json::to_vec_pretty(&header).expect("the header serialises");
    let model = trainer.model.clone().into_record().into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    let moments: Vec<Vec<u8>> = trainer
        .optimizer
        .to_host()
        .iter()
        .map(|m| match m {
            None => Vec::new(),
            Some(m) => {
                let mut out = (m.time as u64).to_le_bytes().to_vec();
                out.extend(f32_bytes(&m.m));
                out.extend(f32_bytes(&m.v));
                out
            }
        })
        .collect();
    let st = &trainer.stats;
    let stats: Vec<u8> = f32_bytes(&st.grad_sum)
        .chain(st.count.iter().flat_map(|c| c.to_le_bytes()))
        .chain(f32_bytes(&st.max_radius))
        .collect();
    let mut sections: Vec<&[u8]> = vec![&header, &model];
    sections.extend(moments.iter().map(Vec::as_slice));
    sections.push(&stats);
    write_sections(path, &sections)
}

/// A loaded checkpoint.
pub struct LoadedSplats {
    /// Its header.
    pub header: SplatCheckpointHeader,
    /// The trainer state, on the device given to [`load`].
    pub trainer: SplatTrainer,
}

/// Loads a splat checkpoint onto `device` (the autodiff device to continue training).
pub fn load(path: &Path, device: &Device) -> Result<LoadedSplats, CheckpointError> {
    let (header, model, sections) = read(path, device)?;
    let [_, moments @ .., stats] = &sections[..] else { unreachable!("read checks the sections") };
    let n = header.gaussians;
    let mut host: [Option<HostMoments>; 6] = Default::default();
    for (k, bytes) in moments.iter().enumerate() {
        if bytes.is_empty() {
            continue;
        }
        let want = 8 + 2 * 4 * WIDTHS[k] * n;
        if bytes.len() != want {
            return Err(invalid(path, format!("optimiser state {k}: {} bytes, expected {want}", bytes.len())));
        }
        let time = u64::from_le_bytes(bytes[..8].try_into().expect("8 bytes")) as usize;
        let floats: Vec<f32> =
            bytes[8..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4"))).collect();
        let (m, v) = floats.split_at(floats.len() / 2);
        host[k] = Some(HostMoments { time, m: m.to_vec(), v: v.to_vec() });
    }
    if stats.len() != 12 * n {
        return Err(invalid(path, format!("densification statistics: {} bytes, expected {}", stats.len(), 12 * n)));
    }
    let word = |k: usize| -> [u8; 4] { stats[4 * k..4 * k + 4].try_into().expect("4 bytes") };
    let stats = DensifyStats {
        grad_sum: (0..n).map(|i| f32::from_le_bytes(word(i))).collect(),
        count: (0..n).map(|i| u32::from_le_bytes(word(n + i))).collect(),
        max_radius: (0..n).map(|i| f32::from_le_bytes(word(2 * n + i))).collect(),
    };
    let t = &header.config.train;
    let mut optimizer = SplatOptimizer::new(t.beta1, t.beta2, t.epsilon);
    optimizer.set_from_host(host, device);
    let mut trainer = SplatTrainer::from_parts(
        header.config.clone(),
        model,
        optimizer,
        header.step,
        header.extent,
        header.view,
        header.centre.into(),
        device.clone(),
    );
    trainer.stats = stats;
    trainer.schedule = header.schedule;
    trainer.since_densify = header.since_densify;
    Ok(LoadedSplats { header, trainer })
}

/// The header and the parameters of a checkpoint on `device`, checked against each other, and
/// all its sections (the optimiser's and the densification statistics' still to parse).
pub(crate) fn read(
    path: &Path,
    device: &Device,
) -> Result<(SplatCheckpointHeader, SplatModel, Vec<Vec<u8>>), CheckpointError> {
    let (value, sections) = read_kind_sections(path, SPLAT_KIND)?;
    let header: SplatCheckpointHeader =
        serde_json::from_value(value).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    header.config.validate().map_err(|e| invalid(path, format!("bad configuration: {e}")))?;
    let [model, moments @ .., _] = &sections[..] else {
        return Err(invalid(path, "truncated (missing sections)"));
    };
    if moments.len() != 6 {
        return Err(invalid(path, format!("expected 9 sections, found {}", sections.len() + 1)));
    }
    let n = header.gaussians;
    // A header that claims more Gaussians than the file holds is damage, not a reason to
    // allocate.
    if n > crate::config::MAX_GAUSSIANS || model.len() < 4 * WIDTHS.iter().sum::<usize>() * n {
        return Err(invalid(path, format!("header says {n} Gaussians, the parameters hold {} bytes", model.len())));
    }
    let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(model.clone()))
        .map_err(|e| invalid(path, format!("splat parameters: {e}")))?;
    let blank = SplatCloud {
        means: vec![0.0; 3 * n],
        log_scales: vec![0.0; 3 * n],
        rotations: vec![0.0; 4 * n],
        opacities: vec![0.0; n],
        sh_dc: vec![0.0; 3 * n],
        sh_rest: vec![0.0; 45 * n],
    };
    let model = SplatModel::from_cloud(&blank, device)
        .try_load_record(record)
        .map_err(|e| invalid(path, format!("splat parameters: {e}")))?;
    if model.len() != n {
        return Err(invalid(path, format!("header says {n} Gaussians, the parameters hold {}", model.len())));
    }
    Ok((header, model, sections))
}
