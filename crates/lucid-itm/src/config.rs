//! Configuration of the ITM network and its training (`configs/itm/default.toml`).

use serde::{Deserialize, Serialize};

/// Everything that defines a training run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ItmConfig {
    /// The network.
    pub model: ModelConfig,
    /// The optimisation.
    pub train: TrainConfig,
}

/// Network size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Channels of the first level (doubled at each of the two coarser ones).
    pub width: usize,
    /// Display value above which the mask starts (τ).
    pub mask_threshold: f32,
}

/// Training settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Optimiser steps.
    pub steps: usize,
    /// Stop after this many seconds (0: no limit).
    pub time_limit: f64,
    /// Adam learning rate at the start (decays by 10× over the run, exponentially).
    pub learning_rate: f64,
    /// Patches per step.
    pub batch: usize,
    /// Patch side in pixels (a multiple of 4).
    pub patch: usize,
    /// Share of patches drawn where the input clips (the rest anywhere).
    pub clipped_patches: f32,
    /// Steps between checkpoints.
    pub checkpoint_every: usize,
    /// Random seed.
    pub seed: u64,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self { width: 16, mask_threshold: lucid_hdr::itm::MASK_THRESHOLD }
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            steps: 2000,
            time_limit: 0.0,
            learning_rate: 2e-3,
            batch: 8,
            patch: 64,
            clipped_patches: 0.8,
            checkpoint_every: 500,
            seed: 0,
        }
    }
}

impl ItmConfig {
    /// Parses TOML text (`origin` names it in errors) and validates it.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, String> {
        lucid_burn::config::parse_config(text, origin, Self::validate)
    }

    /// The memory training with this configuration needs at its peak, with `pixels` pixels
    /// of training pairs loaded (see [`lucid_burn::memory`]).
    pub fn memory_estimate(&self, pixels: usize) -> lucid_burn::memory::MemoryEstimate {
        use lucid_burn::memory::{MemoryEstimate, floats};
        let (w, t) = (self.model.width as f64, &self.train);
        let mut e = MemoryEstimate::new();
        // The U-Net keeps ~14·width activations per pixel (less at the coarser levels, more
        // with the skip concatenations), and the backward pass as many gradients again.
        let batch_pixels = (t.batch * t.patch * t.patch) as f64;
        e.add(
            format!("activations (train.batch = {}, train.patch = {}, model.width = {})", t.batch, t.patch, w),
            floats(3.0 * batch_pixels * (14.0 * w + 12.0)),
        );
        // Display, linear, truth and mask planes.
        e.add("training pairs", floats(10.0 * pixels as f64));
        e
    }

    /// Checks every value's range.
    pub fn validate(&self) -> Result<(), String> {
        use lucid_burn::config::{non_negative, positive};
        let (m, t) = (&self.model, &self.train);
        if !(1..=256).contains(&m.width) {
            return Err(format!("model.width must be in 1..=256, got {}", m.width));
        }
        if !(m.mask_threshold > 0.0 && m.mask_threshold < 1.0) {
            return Err(format!("model.mask_threshold must be in (0, 1), got {}", m.mask_threshold));
        }
        positive("train.steps", t.steps as f64)?;
        non_negative("train.time_limit", t.time_limit)?;
        positive("train.learning_rate", t.learning_rate)?;
        if !(1..=1024).contains(&t.batch) {
            return Err(format!("train.batch must be in 1..=1024, got {}", t.batch));
        }
        positive("train.checkpoint_every", t.checkpoint_every as f64)?;
        if t.patch < 8 || t.patch > 1024 || !t.patch.is_multiple_of(4) {
            return Err(format!("train.patch must be a multiple of 4 in 8..=1024, got {}", t.patch));
        }
        if !(0.0..=1.0).contains(&t.clipped_patches) {
            return Err(format!("train.clipped_patches must be in [0, 1], got {}", t.clipped_patches));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_file_is_the_defaults_and_bad_values_are_named() {
        let text = include_str!("../../../configs/itm/default.toml");
        assert_eq!(ItmConfig::from_toml(text, "configs/itm/default.toml").unwrap(), ItmConfig::default());
        let e = ItmConfig::from_toml("[train]\npatch = 30\n", "x.toml").unwrap_err();
        assert!(e.contains("x.toml") && e.contains("train.patch"), "{e}");
        let e = ItmConfig::from_toml("[train]\nlearning_rate = nan\n", "x.toml").unwrap_err();
        assert!(e.contains("learning_rate"), "{e}");
        let e = ItmConfig::from_toml("[model]\nwidht = 3\n", "x.toml").unwrap_err();
        assert!(e.contains("widht"), "{e}");
    }
}
