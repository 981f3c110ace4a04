//! Adaptive density control, as in the 3DGS paper: Gaussians whose screen centres keep
//! receiving large gradients are in under-reconstructed regions; small ones are cloned, large
//! ones split in two smaller ones sampled from themselves. Transparent, and (after the first
//! opacity reset) oversized, Gaussians are pruned. Done on the host every few hundred steps;
//! Adam's moments follow their rows (new rows start at zero, as in the reference).

use glam::{Quat, Vec3};
use lucid_scene::sampling::Rng;

use crate::cloud::{SplatCloud, logit};
use crate::config::DensifyConfig;
use crate::model::{HostMoments, WIDTHS, cloud_fields, cloud_fields_mut};

/// Per-Gaussian statistics gathered between densifications.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensifyStats {
    /// Sum over views of `|∂loss/∂centre|` in NDC.
    pub grad_sum: Vec<f32>,
    /// Views in which the Gaussian was on screen.
    pub count: Vec<u32>,
    /// Largest screen radius (px) seen.
    pub max_radius: Vec<f32>,
}

impl DensifyStats {
    /// Zeroed statistics for `n` Gaussians.
    pub fn new(n: usize) -> Self {
        Self { grad_sum: vec![0.0; n], count: vec![0; n], max_radius: vec![0.0; n] }
    }

    /// Adds one view: the NDC centre gradients (`N×2`) and screen radii (0 = not drawn).
    pub fn record(&mut self, means_2d_grad: &[f32], radii: impl Iterator<Item = f32>) {
        for (i, r) in radii.enumerate() {
            if r > 0.0 {
                self.grad_sum[i] += means_2d_grad[2 * i].hypot(means_2d_grad[2 * i + 1]);
                self.count[i] += 1;
                self.max_radius[i] = self.max_radius[i].max(r);
            }
        }
    }
}

/// What one densification did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DensifyReport {
    /// Gaussians cloned.
    pub cloned: usize,
    /// Gaussians split (each replaced by two).
    pub split: usize,
    /// Gaussians removed by pruning.
    pub pruned: usize,
    /// Gaussians after the step.
    pub total: usize,
}

enum Source {
    Keep(usize),
    Clone(usize),
    Child(usize, Vec3, Vec3),
}

fn row(v: &[f32], width: usize, i: usize) -> &[f32] {
    &v[width * i..width * (i + 1)]
}

fn scale_of(c: &SplatCloud, i: usize) -> Vec3 {
    Vec3::from_slice(row(&c.log_scales, 3, i)).exp()
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// Clones, splits and prunes `cloud` (and its Adam `moments`) from `stats`.
/// How large the scene is: sizes are judged against it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneExtent {
    /// The reference's extent (1.1 × the cameras' radius).
    pub extent: f32,
    /// The centre of the scene.
    pub centre: Vec3,
}

/// `prune_oversized` turns on the screen- and world-size pruning.
pub fn densify_and_prune(
    cloud: &mut SplatCloud,
    moments: &mut [Option<HostMoments>; 6],
    stats: &DensifyStats,
    config: &DensifyConfig,
    scene: SceneExtent,
    prune_oversized: bool,
    rng: &mut Rng,
) -> DensifyReport {
    let SceneExtent { extent, centre } = scene;
    let n = cloud.len();
    let threshold_size = config.percent_dense * extent;
    let mut candidates: Vec<(f32, usize)> = (0..n)
        .filter_map(|i| {
            let g = if stats.count[i] > 0 { stats.grad_sum[i] / stats.count[i] as f32 } else { 0.0 };
            (g >= config.grad_threshold).then_some((g, i))
        })
        .collect();
    // Within the budget, the largest gradients first (ties by index: deterministic).
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut room = config.max_gaussians.saturating_sub(n);
    let mut clone = vec![false; n];
    let mut split = vec![false; n];
    for &(_, i) in &candidates {
        if room == 0 {
            break;
        }
        if scale_of(cloud, i).max_element() > threshold_size {
            split[i] = true;
        } else {
            clone[i] = true;
        }
        room -= 1;
    }
    let mut sources: Vec<Source> = (0..n).filter(|&i| !split[i]).map(Source::Keep).collect();
    sources.extend((0..n).filter(|&i| clone[i]).map(Source::Clone));
    for i in (0..n).filter(|&i| split[i]) {
        let s = scale_of(cloud, i);
        let r = &cloud.rotations[4 * i..4 * i + 4];
        let q = Quat::from_xyzw(r[1], r[2], r[3], r[0]).normalize();
        let mean = Vec3::from_slice(row(&cloud.means, 3, i));
        for _ in 0..2 {
            let z = Vec3::new(rng.normal(), rng.normal(), rng.normal());
            sources.push(Source::Child(i, mean + q * (s * z), (s / 1.6).max(Vec3::splat(1e-7)).ln()));
        }
    }
    let (cloned, split_count) = (clone.iter().filter(|c| **c).count(), split.iter().filter(|s| **s).count());

    // Prune over the new rows: transparent, and oversized once the opacities have been reset.
    let keep: Vec<bool> = sources
        .iter()
        .map(|s| {
            let (i, log_scale) = match s {
                Source::Keep(i) | Source::Clone(i) => (*i, Vec3::from_slice(row(&cloud.log_scales, 3, *i))),
                Source::Child(i, _, ls) => (*i, *ls),
            };
            if sigmoid(cloud.opacities[i]) < config.min_opacity {
                return false;
            }
            if prune_oversized {
                let screen = matches!(s, Source::Keep(_)) && stats.max_radius[i] > config.max_screen_size;
                // Judged by angular size where a Gaussian lies beyond the cameras' extent (the
                // far background of a capture): the same limit as seen from the cameras.
                let mean = match s {
                    Source::Keep(i) | Source::Clone(i) => Vec3::from_slice(row(&cloud.means, 3, *i)),
                    Source::Child(_, m, _) => *m,
                };
                let reach = (mean - centre).length().max(extent) / extent;
                let world = log_scale.exp().max_element() > config.max_world_size * extent * reach;
                return !(screen || world);
            }
            true
        })
        .collect();
    let pruned = keep.iter().filter(|k| !**k).count();
    let sources: Vec<&Source> = sources.iter().zip(&keep).filter(|(_, k)| **k).map(|(s, _)| s).collect();

    let old = cloud.clone();
    for (k, field) in cloud_fields_mut(cloud).into_iter().enumerate() {
        let w = WIDTHS[k];
        let src = cloud_fields(&old)[k];
        let mut out = Vec::with_capacity(sources.len() * w);
        for s in &sources {
            match s {
                Source::Keep(i) | Source::Clone(i) => out.extend_from_slice(row(src, w, *i)),
                Source::Child(i, mean, log_scale) => match k {
                    0 => out.extend(mean.to_array()),
                    1 => out.extend(log_scale.to_array()),
                    _ => out.extend_from_slice(row(src, w, *i)),
                },
            }
        }
        *field = out;
    }
    for (k, m) in moments.iter_mut().enumerate() {
        let Some(m) = m else { continue };
        let w = WIDTHS[k];
        let edit = |v: &Vec<f32>| {
            let mut out = Vec::with_capacity(sources.len() * w);
            for s in &sources {
                match s {
                    Source::Keep(i) => out.extend_from_slice(row(v, w, *i)),
                    _ => out.extend(std::iter::repeat_n(0.0, w)),
                }
            }
            out
        };
        m.m = edit(&m.m);
        m.v = edit(&m.v);
    }
    DensifyReport { cloned, split: split_count, pruned, total: cloud.len() }
}

/// Caps every opacity at 0.01 and restarts the opacities' Adam moments (the reference's
/// periodic reset, which lets densification prune what stays transparent).
pub fn reset_opacity(cloud: &mut SplatCloud, moments: &mut [Option<HostMoments>; 6]) {
    let cap = logit(0.01);
    for o in &mut cloud.opacities {
        *o = o.min(cap);
    }
    if let Some(m) = &mut moments[3] {
        m.m.iter_mut().for_each(|v| *v = 0.0);
        m.v.iter_mut().for_each(|v| *v = 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> SplatCloud {
        let mut c = SplatCloud::default();
        c.push(Vec3::ZERO, 0.001, 0.5, [0.5; 3]); // small: cloned
        c.push(Vec3::X, 0.5, 0.5, [0.5; 3]); // large: split
        c.push(Vec3::Y, 0.001, 0.5, [0.5; 3]); // low gradient: kept
        c.push(Vec3::Z, 0.001, 0.001, [0.5; 3]); // transparent: pruned
        c
    }

    #[test]
    fn clone_split_prune_and_moments() {
        let mut c = cloud();
        let mut moments: [Option<HostMoments>; 6] = Default::default();
        moments[0] = Some(HostMoments { time: 7, m: (0..12).map(|v| v as f32).collect(), v: vec![1.0; 12] });
        let mut stats = DensifyStats::new(4);
        stats.record(&[1e-3, 0.0, 1e-3, 0.0, 1e-6, 0.0, 0.0, 0.0], [3.0, 3.0, 3.0, 3.0].into_iter());
        let config = DensifyConfig::default();
        let mut rng = Rng::new(1, 2);
        let r = densify_and_prune(
            &mut c,
            &mut moments,
            &stats,
            &config,
            SceneExtent { extent: 1.0, centre: Vec3::ZERO },
            false,
            &mut rng,
        );
        assert_eq!(r, DensifyReport { cloned: 1, split: 1, pruned: 1, total: 5 });
        c.validate().unwrap();
        // Rows: kept 0, kept 2, clone of 0, two children of 1.
        assert_eq!(&c.means[0..3], &[0.0, 0.0, 0.0]);
        assert_eq!(&c.means[3..6], &[0.0, 1.0, 0.0]);
        assert_eq!(&c.means[6..9], &[0.0, 0.0, 0.0]);
        let child_scale = c.log_scales[9].exp();
        assert!((child_scale - 0.5 / 1.6).abs() < 1e-5);
        let m = moments[0].as_ref().unwrap();
        assert_eq!(m.m.len(), 15);
        assert_eq!(&m.m[0..6], &[0.0, 1.0, 2.0, 6.0, 7.0, 8.0]);
        assert!(m.m[6..].iter().all(|v| *v == 0.0));
        assert_eq!(m.time, 7);
    }

    #[test]
    fn the_budget_keeps_the_largest_gradients() {
        let mut c = cloud();
        let mut moments: [Option<HostMoments>; 6] = Default::default();
        let mut stats = DensifyStats::new(4);
        stats.record(&[1e-3, 0.0, 2e-3, 0.0, 0.0, 0.0, 0.0, 0.0], [3.0; 4].into_iter());
        let config = DensifyConfig { max_gaussians: 5, ..Default::default() };
        let r = densify_and_prune(
            &mut c,
            &mut moments,
            &stats,
            &config,
            SceneExtent { extent: 1.0, centre: Vec3::ZERO },
            false,
            &mut Rng::new(1, 2),
        );
        assert_eq!((r.cloned, r.split), (0, 1));
    }
}
