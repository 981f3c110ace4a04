//! ITM checkpoints in Lucid's container ([`lucid_burn::checkpoint`]): a JSON header (kind
//! `"itm"`, configuration, step, training time), burn's record of the network and the Adam
//! state (burn's optimiser record), so that `--resume` continues exactly.

use std::path::Path;

use burn::module::Module;
use burn::optim::AdamConfig;
use burn::store::ModuleRecord;
use burn::tensor::{Bytes, Device};
use serde::{Deserialize, Serialize};

pub use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::checkpoint::{invalid, read_kind_sections, write_sections};

use crate::config::ItmConfig;
use crate::model::ItmNet;
use crate::trainer::ItmTrainer;

/// The kind this module reads and writes.
pub const ITM_KIND: &str = "itm";

/// The JSON header.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ItmCheckpointHeader {
    /// `"itm"`.
    pub kind: String,
    /// The configuration.
    pub config: ItmConfig,
    /// Steps taken.
    pub step: usize,
    /// Training time so far, seconds.
    pub elapsed: f64,
}

/// Saves a trainer (atomically).
pub fn save(path: &Path, trainer: &ItmTrainer, elapsed: f64) -> Result<(), CheckpointError> {
    let header =
        ItmCheckpointHeader { kind: ITM_KIND.into(), config: trainer.config.clone(), step: trainer.step, elapsed };
    let header = serde_json::to_vec_pretty(&header).expect("the header serialises");
    let net = trainer.net.clone().into_record().into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    let optimizer = trainer.optimizer.into_bytes().map_err(|e| invalid(path, e.to_string()))?;
    write_sections(path, &[&header, &net, &optimizer])
}

/// A loaded checkpoint.
pub struct LoadedItm {
    /// The header.
    pub header: ItmCheckpointHeader,
    /// The trainer, on `device`.
    pub trainer: ItmTrainer,
}

/// Loads the network of an ITM checkpoint onto `device` (its optimiser state unread), with
/// the header.
pub fn load_net(path: &Path, device: &Device) -> Result<(ItmCheckpointHeader, ItmNet), CheckpointError> {
    let (header, net, _) = read(path, device)?;
    Ok((header, net))
}

/// Loads an ITM checkpoint onto `device`, to continue training.
pub fn load(path: &Path, device: &Device) -> Result<LoadedItm, CheckpointError> {
    let (header, net, optimizer) = read(path, device)?;
    let optimizer = AdamConfig::new()
        .init()
        .from_bytes(Bytes::from_bytes_vec(optimizer))
        .map_err(|e| invalid(path, format!("optimiser state: {e}")))?;
    let trainer = ItmTrainer::from_parts(header.config.clone(), net, optimizer, header.step, device.clone());
    Ok(LoadedItm { header, trainer })
}

/// The header, the network and the optimiser section's bytes of a checkpoint.
fn read(path: &Path, device: &Device) -> Result<(ItmCheckpointHeader, ItmNet, Vec<u8>), CheckpointError> {
    let (value, sections) = read_kind_sections(path, ITM_KIND)?;
    let header: ItmCheckpointHeader =
        serde_json::from_value(value).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    header.config.validate().map_err(|e| invalid(path, format!("bad configuration: {e}")))?;
    let [net, optimizer] = &sections[..] else {
        return Err(invalid(path, format!("expected 3 sections, found {}", sections.len() + 1)));
    };
    let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(net.clone()))
        .map_err(|e| invalid(path, format!("network parameters: {e}")))?;
    let net = ItmNet::new(header.config.model.width, device)
        .try_load_record(record)
        .map_err(|e| invalid(path, format!("network parameters: {e}")))?;
    Ok((header, net, optimizer.clone()))
}
