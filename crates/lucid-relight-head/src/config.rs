//! Configuration of a relighting run (`configs/relight/default.toml`): the geometry stage (a
//! full 3DGS configuration, with shorter defaults than `lucid train splat`'s), the head and its
//! training, and how environments are integrated.

use lucid_splat::config::SplatConfig;
use serde::{Deserialize, Serialize};

/// Everything a relighting run needs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RelightConfig {
    /// The geometry stage: 3DGS on each view's image under uniform white light (the sum of its
    /// OLAT images weighted by the lights' solid angles).
    pub geometry: SplatConfig,
    /// The head's size.
    pub head: HeadConfig,
    /// The head's training.
    pub train: TrainConfig,
    /// Rendering under environment maps.
    pub environment: EnvironmentConfig,
}

/// The head's size.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HeadConfig {
    /// Feature values per Gaussian.
    pub features: usize,
    /// Width of the decoder's hidden layers.
    pub hidden: usize,
    /// Hidden layers of the decoder (at least 1).
    pub layers: usize,
    /// Degree of the spherical harmonics encoding the light direction (0..=3).
    pub light_degree: usize,
    /// Degree of the spherical harmonics encoding the viewing direction (0..=3).
    pub view_degree: usize,
}

/// The head's training.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Optimiser steps (one view under one light each).
    pub steps: usize,
    /// Stop after this many seconds of head training (0: no limit).
    pub time_limit: f64,
    /// Adam's learning rate of the decoder at the start (decays 10× over the run).
    pub learning_rate: f64,
    /// Adam's learning rate of the per-Gaussian features at the start (decays 10× too).
    pub feature_learning_rate: f64,
    /// Lights per step (each a separate render of the step's view).
    pub lights_per_step: usize,
    /// The loss (see [`crate::trainer`]).
    pub loss: LossKind,
    /// Random seed.
    pub seed: u64,
    /// Steps between checkpoints.
    pub checkpoint_every: usize,
    /// Steps between log lines.
    pub log_every: usize,
}

/// The head's loss on linear radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LossKind {
    /// `(p − t)² / (sg(p) + ε)²`: seeks the mean of noisy targets.
    RelativeL2,
    /// `(p − t)²·(sg(p) + ε)^(2/2.2 − 2)`: the squared error in gamma space (close to the
    /// sRGB space PSNR is measured in) linearised at the prediction, so it seeks the mean too.
    GammaL2,
    /// `|(p + ε)^(1/2.2) − (t + ε)^(1/2.2)|`: seeks the median (darker than the truth where
    /// the targets' noise is skewed).
    GammaL1,
}

/// Rendering under environment maps: the map is integrated over a set of light directions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnvironmentConfig {
    /// Directions the head is evaluated at (spread evenly over the sphere); 0 uses the
    /// training lights' directions.
    pub directions: usize,
}

impl Default for RelightConfig {
    fn default() -> Self {
        let mut geometry = SplatConfig::default();
        // Small OLAT views: a short schedule whose densification and single opacity reset
        // end well before the run does.
        geometry.train.steps = 6000;
        geometry.train.checkpoint_every = 1000;
        geometry.densify.until = 4000;
        Self {
            geometry,
            head: HeadConfig::default(),
            train: TrainConfig::default(),
            environment: EnvironmentConfig::default(),
        }
    }
}

impl Default for HeadConfig {
    fn default() -> Self {
        Self { features: 32, hidden: 64, layers: 2, light_degree: 3, view_degree: 2 }
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            steps: 6000,
            time_limit: 0.0,
            learning_rate: 3e-3,
            feature_learning_rate: 1e-2,
            lights_per_step: 1,
            loss: LossKind::GammaL2,
            seed: 0,
            checkpoint_every: 1000,
            log_every: 100,
        }
    }
}

impl Default for EnvironmentConfig {
    fn default() -> Self {
        Self { directions: 512 }
    }
}

/// Lays `over` onto `base` key by key, tables recursively.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

impl RelightConfig {
    /// The memory training with this configuration needs at its peak: the geometry's splat
    /// estimate for `training_pixels` pixels (the largest image `largest_image`), the head's
    /// features per Gaussian, and `olat_values` linear values of OLAT frames (see
    /// [`lucid_burn::memory`]).
    pub fn memory_estimate(
        &self,
        training_pixels: usize,
        largest_image: usize,
        olat_values: usize,
    ) -> lucid_burn::memory::MemoryEstimate {
        use lucid_burn::memory::floats;
        let g = &self.geometry;
        let mut estimate = g.memory_estimate(g.init.random_points, training_pixels, largest_image);
        let gaussians = g.densify.max_gaussians.max(g.init.random_points) as f64;
        estimate.add(
            format!("head features (head.features = {}, one row per Gaussian)", self.head.features),
            floats(10.0 * gaussians * self.head.features as f64),
        );
        estimate.add("OLAT training frames", floats(olat_values as f64));
        estimate
    }

    /// Parses TOML text (`origin` names it in errors) over the defaults, key by key (a
    /// `[geometry.train]` table changes only the keys it names), and validates it.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, String> {
        let user: toml::Table =
            toml::from_str(text).map_err(|e| format!("{origin}: {}", lucid_burn::config::toml_error(text, &e)))?;
        let mut table = toml::Table::try_from(Self::default()).expect("the defaults serialise");
        merge(&mut table, user);
        let config: Self = table.try_into().map_err(|e: toml::de::Error| format!("{origin}: {}", e.message()))?;
        config.validate().map_err(|e| format!("{origin}: {e}"))?;
        Ok(config)
    }

    /// How much faster the features learn than the decoder (see [`crate::head`]).
    pub fn feature_scale(&self) -> f32 {
        (self.train.feature_learning_rate / self.train.learning_rate) as f32
    }

    /// Checks every value's range.
    pub fn validate(&self) -> Result<(), String> {
        use lucid_burn::config::{non_negative, positive};
        self.geometry.validate().map_err(|e| format!("geometry: {e}"))?;
        let (h, t) = (&self.head, &self.train);
        for (key, v, max) in
            [("head.features", h.features, 256), ("head.hidden", h.hidden, 1024), ("head.layers", h.layers, 16)]
        {
            if !(1..=max).contains(&v) {
                return Err(format!("{key} must be in 1..={max}, got {v}"));
            }
        }
        for (key, d) in [("head.light_degree", h.light_degree), ("head.view_degree", h.view_degree)] {
            if d > 3 {
                return Err(format!("{key} must be 0, 1, 2 or 3, got {d}"));
            }
        }
        positive("train.steps", t.steps as f64)?;
        non_negative("train.time_limit", t.time_limit)?;
        positive("train.learning_rate", t.learning_rate)?;
        positive("train.feature_learning_rate", t.feature_learning_rate)?;
        if !(1..=64).contains(&t.lights_per_step) {
            return Err(format!("train.lights_per_step must be in 1..=64, got {}", t.lights_per_step));
        }
        positive("train.checkpoint_every", t.checkpoint_every as f64)?;
        positive("train.log_every", t.log_every as f64)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_file_is_the_defaults_and_bad_values_are_named() {
        let text = include_str!("../../../configs/relight/default.toml");
        assert_eq!(RelightConfig::from_toml(text, "default.toml").unwrap(), RelightConfig::default());
        // A nested table changes only its own keys.
        let c = RelightConfig::from_toml("[geometry.train]\nsteps = 10\n", "x.toml").unwrap();
        assert_eq!(c.geometry.train.steps, 10);
        assert_eq!(c.geometry.densify.until, RelightConfig::default().geometry.densify.until);
        let e = RelightConfig::from_toml("[head]\nlight_degree = 5\n", "x.toml").unwrap_err();
        assert!(e.contains("x.toml") && e.contains("head.light_degree"), "{e}");
        let e = RelightConfig::from_toml("[train]\nlearning_rate = nan\n", "x.toml").unwrap_err();
        assert!(e.contains("learning_rate"), "{e}");
        let e = RelightConfig::from_toml("[head]\nwidht = 3\n", "x.toml").unwrap_err();
        assert!(e.contains("widht"), "{e}");
        let e = RelightConfig::from_toml("[geometry.train]\nposition_lr = -1.0\n", "x.toml").unwrap_err();
        assert!(e.contains("geometry") && e.contains("position_lr"), "{e}");
    }
}
