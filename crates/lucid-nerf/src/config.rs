//! The NeRF configuration: model, sampling, occupancy grid and training schedule, read from
//! TOML (`configs/nerf/*.toml`) with every field defaulted, and validated as a whole so that
//! a bad value is reported with its key before any work starts.

use serde::{Deserialize, Serialize};

pub use lucid_burn::config::{Background, toml_error};
use lucid_burn::config::{non_negative, parse_config, positive};
use lucid_burn::memory::{MemoryEstimate, floats};

/// Copies of the hash table alive at the peak of a step: the parameter, its gradient, Adam's
/// moments, and burn's temporaries around the update. Measured, not derived: peak RSS grew by
/// 2.23 GiB from `log2_table_size` 19 to 22 on 64×64 images (`/usr/bin/time -f %M lucid train
/// nerf … --steps 30`), ~9 table copies; 10 leaves a margin.
const TABLE_COPIES: f64 = 10.0;

use crate::field::FieldConfig;
use crate::render::march::MarchSettings;

/// Everything a NeRF run needs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NerfConfig {
    /// The radiance field.
    pub field: FieldConfig,
    /// Ray marching.
    pub march: MarchSettings,
    /// The occupancy grid.
    pub occupancy: OccupancyConfig,
    /// The optimisation.
    pub train: TrainConfig,
}

/// Occupancy-grid settings (instant-ngp's defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OccupancyConfig {
    /// Cells per axis.
    pub resolution: u32,
    /// Decay of the density moving average per update.
    pub decay: f32,
    /// Upper bound of the occupancy threshold (optical thickness over the smallest step).
    pub threshold: f32,
    /// Steps between updates.
    pub update_every: usize,
    /// Steps before the first update (every cell is sampled until then).
    pub warmup_steps: usize,
    /// Fraction of the cells sampled uniformly at each update, and at most as many occupied
    /// cells again (instant-ngp samples a quarter on the GPU; on the CPU a sixteenth keeps the
    /// refresh below a tenth of the training time, while occupied cells are still revisited
    /// almost every update and every cell within about 16 updates).
    pub sample_fraction: f32,
}

impl Default for OccupancyConfig {
    fn default() -> Self {
        Self {
            resolution: 128,
            decay: 0.95,
            threshold: 0.01,
            update_every: 16,
            warmup_steps: 256,
            sample_fraction: 0.0625,
        }
    }
}

/// The training loss on colours.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Loss {
    /// Squared error: the loss PSNR scores, and the one whose minimiser is the mean of the
    /// noisy truth (the default).
    L2,
    /// Huber with δ = 0.1: robust to fireflies, but it weighs the errors above δ (glossy
    /// highlights, edges: most of a held-out view's squared error) only linearly.
    Huber,
}

/// The most rays per pixel `train.pixel_rays` and `train.eval_pixel_rays` take.
pub const MAX_PIXEL_RAYS: usize = 64;

/// The optimisation schedule.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Optimiser steps.
    pub steps: usize,
    /// Stop after this many seconds of training even if steps remain (0: no limit).
    pub time_limit: f64,
    /// Samples per batch, counted after each ray is cut where it stops (the samples behind
    /// get no gradient and are not evaluated): the number of rays adapts to keep this many.
    /// 2^14 keeps about the rays per step of 2^15 before the cut (about half the marched
    /// samples lay behind surfaces), so the steps got cheaper rather than fewer. Validation
    /// views at 120 s: toys 33.61 dB at 2^14, 32.94 at 2^15, 33.59 at 2^13; trophy 32.23 at
    /// 2^14, 32.13 at 2^13 (31.95 at 2^15 before the empty-space samples). (Before the cut,
    /// 2^15 measured best: 3-minute runs on the object set, 2^14 28.56 dB, 2^15 28.72, 2^16
    /// 28.13.)
    pub batch_samples: usize,
    /// The factor the batch grows by over the run's budget (steps or seconds), geometrically
    /// from `batch_samples`: early steps many and cheap while the model is coarse, late ones
    /// averaging more rays as the learning rate decays. 1: a constant batch.
    pub batch_growth: f64,
    /// Rays of the first batch, before the adaptation has a measurement.
    pub initial_rays: usize,
    /// Adam learning rate of the grid and the MLPs.
    pub learning_rate: f64,
    /// Learning rate at the end of the run, as a fraction of the initial one
    /// (exponential decay in between).
    pub final_learning_rate: f64,
    /// Adam β₁.
    pub beta1: f32,
    /// Adam β₂.
    pub beta2: f32,
    /// Adam ε.
    pub epsilon: f32,
    /// L2 weight decay on the MLP weights (not the grid).
    pub weight_decay: f32,
    /// Factor on the learning rate of the hash table (the MLPs follow `learning_rate`).
    pub table_learning_rate_scale: f32,
    /// The finest level's factor over the coarsest's on top of `table_learning_rate_scale`,
    /// geometric over the levels between (1: one rate for the whole table).
    pub table_level_learning_rate_ratio: f32,
    /// The colour loss. Squared error measured better than Huber on validation views
    /// (`lucid train nerf out/bench/SET --steps N --set train.loss=huber`, README).
    pub loss: Loss,
    /// Background during training.
    pub background: Background,
    /// Background for evaluation and rendering.
    pub eval_background: Background,
    /// Rays stop once transmittance falls below this.
    pub min_transmittance: f32,
    /// Fraction of each batch's pixels drawn in proportion to a running estimate of their
    /// loss (instant-ngp's error map, [`crate::error_map`]); the rest uniformly. 0 turns it off.
    pub error_sampling: f32,
    /// Each training ray passes through a random point of its pixel (true) or its centre,
    /// where evaluation and rendering cast theirs (false).
    pub pixel_jitter: bool,
    /// Rays per training pixel, spread over its area (a grid of cells, each ray at a
    /// random point of its cell with `pixel_jitter`), whose colours are averaged before the
    /// loss: the truth of a pixel is the mean over its area, which one ray can only match
    /// on average.
    pub pixel_rays: usize,
    /// Rays per pixel when evaluating and rendering, on a regular grid over the pixel's area
    /// and averaged: the truth of a pixel is its area's mean, which one ray through the
    /// centre only approximates where an edge or fine texture crosses it.
    pub eval_pixel_rays: usize,
    /// Weight of mip-NeRF 360's distortion loss (distances in scene-box diagonals), which
    /// draws each ray's weight together into a sharp surface; 0 turns it off.
    pub distortion: f32,
    /// Time constant of the running average of the parameters that is evaluated and
    /// rendered, as a fraction of the run's budget ([`crate::average`]); 0 turns it off and
    /// the last parameters are used.
    pub average_window: f64,
    /// Random seed (initialisation, pixel and jitter sampling).
    pub seed: u64,
    /// Steps between checkpoints (0: only at the end).
    pub checkpoint_every: usize,
    /// Steps between log lines and CSV rows.
    pub log_every: usize,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            steps: 3000,
            time_limit: 0.0,
            batch_samples: 1 << 14,
            batch_growth: 1.0,
            initial_rays: 4096,
            learning_rate: 1e-2,
            final_learning_rate: 0.1,
            beta1: 0.9,
            beta2: 0.99,
            epsilon: 1e-15,
            weight_decay: 1e-6,
            table_learning_rate_scale: 8.0,
            table_level_learning_rate_ratio: 1.0,
            loss: Loss::L2,
            background: Background::Random,
            eval_background: Background::White,
            min_transmittance: 1e-4,
            error_sampling: 0.5,
            pixel_jitter: true,
            pixel_rays: 1,
            eval_pixel_rays: 1,
            distortion: 0.0,
            average_window: 0.1,
            seed: 0,
            checkpoint_every: 1000,
            log_every: 50,
        }
    }
}

impl NerfConfig {
    /// The memory training with this configuration needs at its peak, with `training_pixels`
    /// pixels of training images loaded (see [`lucid_burn::memory`]).
    pub fn memory_estimate(&self, training_pixels: usize) -> MemoryEstimate {
        let layout = self.field.layout();
        let g = &self.field.grid;
        let mut e = MemoryEstimate::new();
        e.add(
            format!(
                "hash table (field.grid.log2_table_size = {}, levels = {}, features_per_level = {})",
                g.log2_table_size, g.levels, g.features_per_level
            ),
            TABLE_COPIES * floats((layout.grid.entries * layout.grid.features) as f64),
        );
        let t = &self.train;
        // Each sample keeps its activations for the backward pass, which writes as many
        // gradients; positions, directions, outputs and compositing take about 32 more.
        let per_sample = 2 * layout.saved_per_sample() + 32;
        e.add(
            format!(
                "samples per step (train.batch_samples = {}, batch_growth = {}, field.hidden = {})",
                t.batch_samples, t.batch_growth, self.field.hidden
            ),
            floats(t.batch_samples as f64 * t.batch_growth.max(1.0) * per_sample as f64),
        );
        // The ray count adapts up to four times the initial one; each ray holds ~32 values.
        e.add(
            format!("rays per step (train.initial_rays = {})", t.initial_rays),
            floats(4.0 * 32.0 * t.initial_rays as f64),
        );
        let cells = (self.occupancy.resolution as f64).powi(3);
        e.add(format!("occupancy grid (occupancy.resolution = {})", self.occupancy.resolution), floats(2.0 * cells));
        // RGBA floats, and the error map's share.
        e.add("training images", floats(5.0 * training_pixels as f64));
        e
    }

    /// Parses TOML text; `origin` names the file in messages.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, String> {
        parse_config(text, origin, Self::validate)
    }

    /// Checks every value; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        self.field.validate().map_err(|e| format!("field: {e}"))?;
        self.march.validate().map_err(|e| format!("march: {e}"))?;
        let o = &self.occupancy;
        if !(8..=512).contains(&o.resolution) {
            return Err(format!("occupancy.resolution must be in 8..=512, got {}", o.resolution));
        }
        if !(o.decay.is_finite() && (0.0..1.0).contains(&o.decay)) {
            return Err(format!("occupancy.decay must be in [0, 1), got {}", o.decay));
        }
        if !(o.threshold.is_finite() && o.threshold >= 0.0) {
            return Err(format!("occupancy.threshold must be zero or positive, got {}", o.threshold));
        }
        if !(o.sample_fraction.is_finite() && o.sample_fraction > 0.0 && o.sample_fraction <= 1.0) {
            return Err(format!("occupancy.sample_fraction must be in (0, 1], got {}", o.sample_fraction));
        }
        if o.update_every == 0 {
            return Err("occupancy.update_every must be at least 1".into());
        }
        let t = &self.train;
        if t.steps == 0 {
            return Err("train.steps must be at least 1".into());
        }
        non_negative("train.time_limit", t.time_limit)?;
        if !(1024..=1 << 22).contains(&t.batch_samples) {
            return Err(format!("train.batch_samples must be in 1024..=4194304, got {}", t.batch_samples));
        }
        if !(t.batch_growth.is_finite() && (1.0 / 64.0..=64.0).contains(&t.batch_growth)) {
            return Err(format!("train.batch_growth must be in [1/64, 64], got {}", t.batch_growth));
        }
        let last = t.batch_samples as f64 * t.batch_growth;
        if !(1024.0..=(1u64 << 22) as f64).contains(&last) {
            return Err(format!(
                "train.batch_samples × train.batch_growth (the last batch) must be in 1024..=4194304, got {last}"
            ));
        }
        if !(1..=1 << 20).contains(&t.initial_rays) {
            return Err(format!("train.initial_rays must be in 1..=1048576, got {}", t.initial_rays));
        }
        positive("train.learning_rate", t.learning_rate)?;
        positive("train.final_learning_rate", t.final_learning_rate)?;
        positive("train.epsilon", t.epsilon as f64)?;
        for (name, b) in [("beta1", t.beta1), ("beta2", t.beta2)] {
            if !(b.is_finite() && (0.0..1.0).contains(&b)) {
                return Err(format!("train.{name} must be in [0, 1), got {b}"));
            }
        }
        for (name, factor) in [
            ("table_learning_rate_scale", t.table_learning_rate_scale),
            ("table_level_learning_rate_ratio", t.table_level_learning_rate_ratio),
        ] {
            if !(factor.is_finite() && factor > 0.0) {
                return Err(format!("train.{name} must be positive, got {factor}"));
            }
        }
        if !(t.weight_decay.is_finite() && t.weight_decay >= 0.0) {
            return Err(format!("train.weight_decay must be zero or positive, got {}", t.weight_decay));
        }
        if !(t.min_transmittance.is_finite() && (0.0..1.0).contains(&t.min_transmittance)) {
            return Err(format!("train.min_transmittance must be in [0, 1), got {}", t.min_transmittance));
        }
        if !(t.distortion.is_finite() && t.distortion >= 0.0) {
            return Err(format!("train.distortion must be zero or positive, got {}", t.distortion));
        }
        if !(t.average_window.is_finite() && (0.0..=0.25).contains(&t.average_window)) {
            return Err(format!("train.average_window must be in [0, 0.25], got {}", t.average_window));
        }
        if !(t.error_sampling.is_finite() && (0.0..=1.0).contains(&t.error_sampling)) {
            return Err(format!("train.error_sampling must be in [0, 1], got {}", t.error_sampling));
        }
        for (name, rays) in [("pixel_rays", t.pixel_rays), ("eval_pixel_rays", t.eval_pixel_rays)] {
            if !(1..=MAX_PIXEL_RAYS).contains(&rays) {
                return Err(format!("train.{name} must be in 1..={MAX_PIXEL_RAYS}, got {rays}"));
            }
        }
        if t.eval_background == Background::Random {
            return Err("train.eval_background must be white or black".into());
        }
        if t.log_every == 0 {
            return Err("train.log_every must be at least 1".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_round_trip_through_toml_and_validate() {
        let c = NerfConfig::default();
        let text = toml::to_string(&c).unwrap();
        assert_eq!(NerfConfig::from_toml(&text, "x.toml").unwrap(), c);
    }

    #[test]
    fn the_shipped_default_file_is_the_default() {
        let text = include_str!("../../../configs/nerf/default.toml");
        assert_eq!(NerfConfig::from_toml(text, "configs/nerf/default.toml").unwrap(), NerfConfig::default());
    }

    #[test]
    fn bad_values_name_their_key_and_file() {
        let err = NerfConfig::from_toml("[train]\nlearning_rate = nan\n", "bad.toml").unwrap_err();
        assert!(err.contains("bad.toml") && err.contains("train.learning_rate"), "{err}");
        let err = NerfConfig::from_toml("[train]\nstepz = 3\n", "bad.toml").unwrap_err();
        assert!(err.contains("bad.toml") && err.contains("stepz"), "{err}");
        let err = NerfConfig::from_toml("[train]\ndistortion = -0.1\n", "d.toml").unwrap_err();
        assert!(err.contains("d.toml") && err.contains("train.distortion"), "{err}");
        let err = NerfConfig::from_toml("[train]\naverage_window = nan\n", "w.toml").unwrap_err();
        assert!(err.contains("w.toml") && err.contains("train.average_window"), "{err}");
        let err = NerfConfig::from_toml("[train]\ntable_learning_rate_scale = 0\n", "t.toml").unwrap_err();
        assert!(err.contains("t.toml") && err.contains("train.table_learning_rate_scale"), "{err}");
        let err = NerfConfig::from_toml("[train]\ntable_level_learning_rate_ratio = inf\n", "r.toml").unwrap_err();
        assert!(err.contains("r.toml") && err.contains("train.table_level_learning_rate_ratio"), "{err}");
        let err = NerfConfig::from_toml("[field.grid]\nlevels = 0\n", "g.toml").unwrap_err();
        assert!(err.contains("levels"), "{err}");
    }
}
