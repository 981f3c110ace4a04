//! A splat cloud in host memory: the interchange form between files, initialisation and the
//! burn model.

use glam::Vec3;
use lucid_scene::sampling::Rng;

use crate::project::{SH_REST, SplatParams};
use crate::sh::C0;

/// Gaussians as flat row-major arrays (see [`SplatParams`] for the layout).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplatCloud {
    /// `N×3` centres.
    pub means: Vec<f32>,
    /// `N×3` log standard deviations.
    pub log_scales: Vec<f32>,
    /// `N×4` quaternions `(w, x, y, z)`.
    pub rotations: Vec<f32>,
    /// `N` opacity logits.
    pub opacities: Vec<f32>,
    /// `N×3` DC SH coefficients.
    pub sh_dc: Vec<f32>,
    /// `N×45` rest SH coefficients (zero above the cloud's degree).
    pub sh_rest: Vec<f32>,
}

/// `log(p / (1 − p))`.
pub fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

impl SplatCloud {
    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.opacities.len()
    }

    /// Whether the cloud is empty.
    pub fn is_empty(&self) -> bool {
        self.opacities.is_empty()
    }

    /// Borrowed view for the kernels.
    pub fn params(&self) -> SplatParams<'_> {
        SplatParams::from_kinds([
            &self.means,
            &self.log_scales,
            &self.rotations,
            &self.opacities,
            &self.sh_dc,
            &self.sh_rest,
        ])
    }

    /// Appends one isotropic Gaussian with a view-independent colour.
    pub fn push(&mut self, mean: Vec3, scale: f32, opacity: f32, colour: [f32; 3]) {
        self.means.extend(mean.to_array());
        self.log_scales.extend([scale.max(1e-7).ln(); 3]);
        self.rotations.extend([1.0, 0.0, 0.0, 0.0]);
        self.opacities.push(logit(opacity.clamp(1e-6, 1.0 - 1e-6)));
        self.sh_dc.extend(colour.map(|c| (c - 0.5) / C0));
        self.sh_rest.extend([0.0; SH_REST]);
    }

    /// The 3DGS initialisation from a coloured point cloud: one Gaussian per point, isotropic
    /// with the root-mean-square distance to its three nearest neighbours as scale, opacity
    /// 0.1, the point's colour as DC term.
    pub fn from_points(points: &[(Vec3, [f32; 3])]) -> Self {
        let positions: Vec<Vec3> = points.iter().map(|p| p.0).collect();
        let scales = crate::knn::mean_neighbour_distance(&positions, 3);
        let mut cloud = Self::default();
        for ((p, c), s) in points.iter().zip(scales) {
            cloud.push(*p, s, 0.1, *c);
        }
        cloud
    }

    /// `n` points uniformly in the box `lo..hi` with random colours (the fallback when a
    /// dataset has no point cloud), initialised as [`Self::from_points`].
    pub fn random_in_box(n: usize, lo: Vec3, hi: Vec3, seed: u64) -> Self {
        Self::from_points(&Self::random_points_in_box(n, lo, hi, seed))
    }

    /// The points of [`Self::random_in_box`].
    pub fn random_points_in_box(n: usize, lo: Vec3, hi: Vec3, seed: u64) -> Vec<(Vec3, [f32; 3])> {
        let mut rng = Rng::new(seed, 0x5b1a7);
        (0..n)
            .map(|_| {
                let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                (lo + (hi - lo) * u, [rng.uniform(), rng.uniform(), rng.uniform()])
            })
            .collect()
    }

    /// Keeps the Gaussians for which `keep` is true, in order.
    pub fn retain(&mut self, keep: &[bool]) {
        assert_eq!(keep.len(), self.len());
        fn filter(v: &mut Vec<f32>, width: usize, keep: &[bool]) {
            let mut out = Vec::with_capacity(v.len());
            for (row, &k) in v.chunks_exact(width).zip(keep) {
                if k {
                    out.extend_from_slice(row);
                }
            }
            *v = out;
        }
        filter(&mut self.means, 3, keep);
        filter(&mut self.log_scales, 3, keep);
        filter(&mut self.rotations, 4, keep);
        filter(&mut self.opacities, 1, keep);
        filter(&mut self.sh_dc, 3, keep);
        filter(&mut self.sh_rest, SH_REST, keep);
    }

    /// Checks the shapes and that every value is finite.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.len();
        for (name, v, w) in [
            ("means", &self.means, 3),
            ("log_scales", &self.log_scales, 3),
            ("rotations", &self.rotations, 4),
            ("sh_dc", &self.sh_dc, 3),
            ("sh_rest", &self.sh_rest, SH_REST),
        ] {
            if v.len() != n * w {
                return Err(format!("{name} has {} values, expected {}", v.len(), n * w));
            }
        }
        let all = [&self.means, &self.log_scales, &self.rotations, &self.opacities, &self.sh_dc, &self.sh_rest];
        if all.iter().any(|v| v.iter().any(|x| !x.is_finite())) {
            return Err("non-finite parameter".into());
        }
        Ok(())
    }
}
