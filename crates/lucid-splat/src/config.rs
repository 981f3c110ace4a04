//! The 3DGS configuration (`configs/splat/*.toml`): rendering, initialisation, the
//! optimisation schedule and densification, with the reference implementation's defaults, every
//! field defaulted and validated with its key named.

use serde::{Deserialize, Serialize};

pub use lucid_burn::config::{Background, toml_error};
use lucid_burn::config::{non_negative, parse_config, positive};
use lucid_burn::memory::{MemoryEstimate, floats};

/// Everything a splatting run needs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SplatConfig {
    /// Projection and blending.
    pub render: RenderConfig,
    /// Where the Gaussians start.
    pub init: InitConfig,
    /// The optimisation.
    pub train: TrainConfig,
    /// Adaptive density control.
    pub densify: DensifyConfig,
}

/// Projection and blending.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderConfig {
    /// Gaussians nearer than this to a camera (view depth, as a fraction of the scene extent)
    /// are culled.
    pub near: f32,
    /// Screen-space low-pass variance in px².
    pub low_pass: f32,
    /// Background during training (`random`: a new colour per step, so the splats cannot
    /// paint the background and must learn transparency).
    pub background: Background,
    /// Background for evaluation and rendering.
    pub eval_background: Background,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self { near: 0.01, low_pass: 0.3, background: Background::Random, eval_background: Background::White }
    }
}

/// Initialisation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitConfig {
    /// Start from the dataset's `points3d.ply` when it has one.
    pub use_points: bool,
    /// Otherwise (or with `use_points = false`), this many random points in the scene box
    /// (the reference's choice for the Blender scenes).
    pub random_points: usize,
    /// Initial opacity.
    pub opacity: f32,
    /// Where the training images have no transparent background (captures), this many points
    /// are spread over a far sphere for the sky and distant scenery (those no image sees are
    /// dropped); 0: none.
    pub background_points: usize,
}

impl Default for InitConfig {
    fn default() -> Self {
        Self { use_points: true, random_points: 100_000, opacity: 0.1, background_points: 10_000 }
    }
}

/// The optimisation (learning rates as in the 3DGS paper).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Optimiser steps (one training view each).
    pub steps: usize,
    /// Wall-clock limit in seconds (0: none); the schedules follow whichever budget is
    /// further along.
    pub time_limit: f64,
    /// Initial position learning rate, times the scene extent.
    pub position_lr: f64,
    /// Final position learning rate, times the scene extent (exponential decay).
    pub position_lr_final: f64,
    /// DC colour learning rate.
    pub sh_dc_lr: f64,
    /// Higher-order SH learning rate.
    pub sh_rest_lr: f64,
    /// Opacity-logit learning rate.
    pub opacity_lr: f64,
    /// Log-scale learning rate.
    pub scale_lr: f64,
    /// Quaternion learning rate.
    pub rotation_lr: f64,
    /// Adam's β1.
    pub beta1: f32,
    /// Adam's β2.
    pub beta2: f32,
    /// Adam's ε.
    pub epsilon: f32,
    /// Weight of the D-SSIM term: loss = (1 − λ)·L1 + λ·(1 − SSIM).
    pub ssim_weight: f32,
    /// Highest SH degree (0..=3).
    pub sh_degree: usize,
    /// Steps between raising the SH degree by one.
    pub sh_degree_every: usize,
    /// Random seed (initialisation, view order, backgrounds).
    pub seed: u64,
    /// Steps between checkpoints (0: only at the end).
    pub checkpoint_every: usize,
    /// Steps between log lines and CSV rows.
    pub log_every: usize,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            steps: 30_000,
            time_limit: 0.0,
            position_lr: 1.6e-4,
            position_lr_final: 1.6e-6,
            sh_dc_lr: 2.5e-3,
            sh_rest_lr: 2.5e-3 / 20.0,
            opacity_lr: 0.05,
            scale_lr: 5e-3,
            rotation_lr: 1e-3,
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-15,
            ssim_weight: 0.2,
            sh_degree: 3,
            sh_degree_every: 1000,
            seed: 0,
            checkpoint_every: 5000,
            log_every: 100,
        }
    }
}

/// Adaptive density control (clone, split, prune, opacity reset).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DensifyConfig {
    /// First step that densifies.
    pub from: usize,
    /// No densification from this step on.
    pub until: usize,
    /// Steps between densifications.
    pub every: usize,
    /// Mean NDC gradient of a Gaussian's screen centre above which it is cloned or split.
    pub grad_threshold: f32,
    /// Gaussians larger than this fraction of the scene extent are split, smaller ones cloned.
    pub percent_dense: f32,
    /// Gaussians below this opacity are pruned.
    pub min_opacity: f32,
    /// Steps between opacity resets (opacities capped at 0.01).
    pub opacity_reset_every: usize,
    /// After the first reset, Gaussians wider on screen than this (px) are pruned.
    pub max_screen_size: f32,
    /// Gaussians larger than this fraction of the scene extent are pruned.
    pub max_world_size: f32,
    /// Upper bound on the number of Gaussians (memory and time on a CPU); densification
    /// keeps the largest gradients when it would exceed it.
    pub max_gaussians: usize,
}

impl Default for DensifyConfig {
    fn default() -> Self {
        Self {
            from: 500,
            until: 15_000,
            every: 100,
            grad_threshold: 2e-4,
            percent_dense: 0.01,
            min_opacity: 0.005,
            opacity_reset_every: 3000,
            max_screen_size: 20.0,
            max_world_size: 0.1,
            max_gaussians: 1_000_000,
        }
    }
}

/// The most Gaussians a cloud may start with or grow to: 20 million take ~30 GiB in training,
/// beyond any machine this is meant for; the memory check refuses what the machine cannot
/// hold well below it.
pub const MAX_GAUSSIANS: usize = 20_000_000;

impl SplatConfig {
    /// The memory training with this configuration needs at its peak, starting from
    /// `initial` Gaussians with `training_pixels` pixels of training images loaded, the
    /// largest image having `largest_image` pixels (see [`lucid_burn::memory`]).
    pub fn memory_estimate(&self, initial: usize, training_pixels: usize, largest_image: usize) -> MemoryEstimate {
        let mut e = MemoryEstimate::new();
        let (what, n) = if initial >= self.densify.max_gaussians {
            (format!("{initial} initial Gaussians (init.random_points or the point cloud)"), initial)
        } else {
            (format!("Gaussians (densify.max_gaussians = {})", self.densify.max_gaussians), self.densify.max_gaussians)
        };
        // 59 parameters per Gaussian in all their copies (value, gradient, Adam's moments and
        // burn's temporaries), projection and its gradients, tile lists and densification
        // statistics. Measured: peak RSS grew by 2.07 KB per Gaussian from 100 k to 1 M random
        // Gaussians (`/usr/bin/time -f %M lucid train splat … --steps 30`); 560 floats (2.2 KB)
        // leave a margin.
        e.add(what, floats(n as f64 * 560.0));
        // RGBA floats per training pixel; a render, its gradients and the SSIM maps of one.
        e.add("training images", floats(4.0 * training_pixels as f64 + 40.0 * largest_image as f64));
        e
    }

    /// Parses TOML text; `origin` names the file in messages.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, String> {
        parse_config(text, origin, Self::validate)
    }

    /// Checks every value; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        let r = &self.render;
        non_negative("render.near", r.near as f64)?;
        non_negative("render.low_pass", r.low_pass as f64)?;
        if r.eval_background == Background::Random {
            return Err("render.eval_background must be white or black".into());
        }
        let i = &self.init;
        if !(i.opacity.is_finite() && i.opacity > 0.0 && i.opacity < 1.0) {
            return Err(format!("init.opacity must be in (0, 1), got {}", i.opacity));
        }
        if !(1..=MAX_GAUSSIANS).contains(&i.random_points) {
            return Err(format!("init.random_points must be in 1..={MAX_GAUSSIANS}, got {}", i.random_points));
        }
        let t = &self.train;
        if t.steps == 0 {
            return Err("train.steps must be at least 1".into());
        }
        non_negative("train.time_limit", t.time_limit)?;
        for (name, v) in [
            ("position_lr", t.position_lr),
            ("position_lr_final", t.position_lr_final),
            ("sh_dc_lr", t.sh_dc_lr),
            ("sh_rest_lr", t.sh_rest_lr),
            ("opacity_lr", t.opacity_lr),
            ("scale_lr", t.scale_lr),
            ("rotation_lr", t.rotation_lr),
            ("epsilon", t.epsilon as f64),
        ] {
            positive(&format!("train.{name}"), v)?;
        }
        for (name, b) in [("beta1", t.beta1), ("beta2", t.beta2)] {
            if !(b.is_finite() && (0.0..1.0).contains(&b)) {
                return Err(format!("train.{name} must be in [0, 1), got {b}"));
            }
        }
        if !(t.ssim_weight.is_finite() && (0.0..=1.0).contains(&t.ssim_weight)) {
            return Err(format!("train.ssim_weight must be in [0, 1], got {}", t.ssim_weight));
        }
        if t.sh_degree > 3 {
            return Err(format!("train.sh_degree must be 0..=3, got {}", t.sh_degree));
        }
        if t.sh_degree_every == 0 || t.log_every == 0 {
            return Err("train.sh_degree_every and train.log_every must be at least 1".into());
        }
        let d = &self.densify;
        if d.every == 0 || d.opacity_reset_every == 0 {
            return Err("densify.every and densify.opacity_reset_every must be at least 1".into());
        }
        positive("densify.grad_threshold", d.grad_threshold as f64)?;
        positive("densify.percent_dense", d.percent_dense as f64)?;
        non_negative("densify.min_opacity", d.min_opacity as f64)?;
        positive("densify.max_screen_size", d.max_screen_size as f64)?;
        positive("densify.max_world_size", d.max_world_size as f64)?;
        if !(1..=MAX_GAUSSIANS).contains(&d.max_gaussians) {
            return Err(format!("densify.max_gaussians must be in 1..={MAX_GAUSSIANS}, got {}", d.max_gaussians));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_default_file_is_the_default() {
        let text = include_str!("../../../configs/splat/default.toml");
        assert_eq!(SplatConfig::from_toml(text, "configs/splat/default.toml").unwrap(), SplatConfig::default());
        let round = toml::to_string(&SplatConfig::default()).unwrap();
        assert_eq!(SplatConfig::from_toml(&round, "x").unwrap(), SplatConfig::default());
    }

    #[test]
    fn bad_values_name_their_key_and_file() {
        let err = SplatConfig::from_toml("[train]\nopacity_lr = nan\n", "bad.toml").unwrap_err();
        assert!(err.contains("bad.toml") && err.contains("train.opacity_lr"), "{err}");
        let err = SplatConfig::from_toml("[densify]\nevry = 3\n", "bad.toml").unwrap_err();
        assert!(err.contains("evry"), "{err}");
        let err = SplatConfig::from_toml("[densify]\ngrad_threshold = -1.0\n", "d.toml").unwrap_err();
        assert!(err.contains("densify.grad_threshold"), "{err}");
    }
}
