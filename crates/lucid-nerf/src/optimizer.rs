//! The NeRF's optimiser: Adam over the hash table and the MLPs, each group at its own rate.

use burn::module::ParamGroup;
use burn::optim::ModuleOptimizer;
use lucid_burn::FusedAdam;
use lucid_burn::optim::RateSegments;

use crate::config::NerfConfig;

/// Adam with the configured betas and ε ([`FusedAdam`], burn's update in one pass) in
/// burn's module optimiser; weight decay on the MLP weights only.
pub fn optimizer(config: &NerfConfig) -> ModuleOptimizer {
    let t = &config.train;
    let table = FusedAdam {
        beta1: t.beta1,
        beta2: t.beta2,
        epsilon: t.epsilon,
        weight_decay: 0.0,
        lr_scale: t.table_learning_rate_scale,
        segments: level_rates(config),
    };
    let mlp = FusedAdam { weight_decay: t.weight_decay, lr_scale: 1.0, segments: None, ..table.clone() };
    ModuleOptimizer::from(table).with_group(ParamGroup::from_path("mlp"), mlp, None)
}

/// The hash table's learning-rate factor per level (rows `levels[l].offset..` times the
/// features): `train.table_level_learning_rate_ratio` to the power `l / (L − 1)`, so the
/// coarsest level learns at the table's rate and the finest at `ratio` times it. `None` for a
/// ratio of 1.
pub fn level_rates(config: &NerfConfig) -> Option<RateSegments> {
    let ratio = config.train.table_level_learning_rate_ratio;
    if ratio == 1.0 {
        return None;
    }
    let layout = config.field.grid.layout();
    let last = (layout.levels.len() - 1).max(1) as f32;
    let segments = layout
        .levels
        .iter()
        .enumerate()
        .map(|(l, level)| ((level.offset + level.size) * layout.features, ratio.powf(l as f32 / last)))
        .collect();
    Some(segments)
}

#[cfg(test)]
mod tests {
    use super::level_rates;
    use crate::config::NerfConfig;

    /// Each level's rows get `ratio^(l/(L−1))`: 1 on the coarsest, `ratio` on the finest.
    #[test]
    fn levels_get_a_geometric_ramp_of_rates() {
        let mut config = NerfConfig::default();
        config.field.grid.finest_resolution = 512.0;
        assert!(level_rates(&config).is_none());
        config.train.table_level_learning_rate_ratio = 16.0;
        let segments = level_rates(&config).unwrap();
        let layout = config.field.grid.layout();
        assert_eq!(segments.len(), layout.levels.len());
        assert_eq!(segments.last().unwrap().0, layout.entries * layout.features);
        let last = (layout.levels.len() - 1) as f32;
        for (l, (&(end, factor), level)) in segments.iter().zip(&layout.levels).enumerate() {
            assert_eq!(end, (level.offset + level.size) * layout.features);
            let expected = 16f32.powf(l as f32 / last);
            assert!((factor - expected).abs() < 1e-5 * expected, "level {l}: {factor} against {expected}");
        }
        assert_eq!(segments[0].1, 1.0);
        assert!((segments.last().unwrap().1 - 16.0).abs() < 1e-4);
    }
}
