//! Camera rigs: where the cameras of a dataset stand.

use glam::{Mat4, Vec3};
use lucid_scene::look_at;

/// Cameras on a sphere (or its upper half, +Z up) around a target, looking at it.
///
/// Positions follow a Fibonacci spiral, which spreads any number of points almost
/// uniformly; each split uses its own spiral, rotated about Z by an angle drawn from the
/// seed, so train and test views never coincide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitRig {
    /// Distance from the target.
    pub radius: f32,
    /// Point the cameras look at.
    pub target: Vec3,
    /// Only the upper hemisphere (z ≥ target.z), as in the Blender set.
    pub upper_hemisphere: bool,
    /// Seed for the per-split rotations.
    pub seed: u64,
}

impl OrbitRig {
    /// `count` camera-to-world poses for split number `split_index` (0 = train, 1 = val, …).
    pub fn poses(&self, count: usize, split_index: u64) -> Vec<Mat4> {
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let phase = unit_float(splitmix64(self.seed ^ (split_index.wrapping_mul(0x9E37_79B9_7F4A_7C15))))
            * std::f32::consts::TAU;
        (0..count)
            .map(|i| {
                // z in (0, 1) for the hemisphere, (−1, 1) for the sphere, at cell centres;
                // keep clear of the pole where look_at's up vector degenerates.
                let t = (i as f32 + 0.5) / count as f32;
                let z = if self.upper_hemisphere { 0.05 + 0.85 * t } else { (1.0 - 2.0 * t) * 0.95 };
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f32 + phase;
                let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                look_at(self.target + self.radius * dir, self.target, Vec3::Z)
            })
            .collect()
    }
}

/// SplitMix64: a tiny, well-mixed hash used to derive independent streams from one seed.
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The top 24 bits of `x` as a float in `[0, 1)`.
pub fn unit_float(x: u64) -> f32 {
    (x >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4Swizzles;

    #[test]
    fn cameras_sit_on_the_sphere_and_look_at_the_target() {
        let rig = OrbitRig { radius: 4.0, target: Vec3::new(0.0, 0.0, 0.5), upper_hemisphere: true, seed: 1 };
        for pose in rig.poses(50, 0) {
            let eye = pose.w_axis.xyz();
            assert!(((eye - rig.target).length() - 4.0).abs() < 1e-4);
            assert!(eye.z >= rig.target.z);
            let forward = -pose.z_axis.xyz();
            assert!(forward.dot((rig.target - eye).normalize()) > 1.0 - 1e-5);
        }
    }

    #[test]
    fn splits_are_disjoint_and_seeded() {
        let rig = OrbitRig { radius: 3.0, target: Vec3::ZERO, upper_hemisphere: false, seed: 7 };
        let train = rig.poses(20, 0);
        let test = rig.poses(20, 2);
        for a in &train {
            for b in &test {
                assert!((a.w_axis - b.w_axis).length() > 1e-3);
            }
        }
        assert_eq!(rig.poses(20, 0), train, "same seed, same poses");
        let other = OrbitRig { seed: 8, ..rig }.poses(20, 0);
        assert_ne!(other, train);
    }
}

/// How a dataset's views are laid out and lit: one kind of rig at a time, so a dataset
/// cannot be asked to be both a light field and an OLAT set.
#[derive(Clone, Debug, PartialEq)]
pub enum Rig {
    /// Views on an orbit.
    Orbit(OrbitRig),
    /// Orbit views, each also recorded as LDR frames at several exposure times (the
    /// transforms list one frame per view and exposure, with its `exposure_time`).
    Brackets(OrbitRig, crate::brackets::BracketSpec),
    /// A light-field grid instead of an orbit: its sub-aperture views form the training split
    /// and its thin-lens ground truths the test split (the split counts are unused).
    LightField(crate::lightfield::LightFieldRig),
    /// Orbit views, each rendered once per light (`light_direction` per frame); the test
    /// views also under held-out lights and each environment map (`environment_file_path`,
    /// maps written to `envmaps/`).
    Olat(OrbitRig, crate::olat::OlatSpec),
}

impl Rig {
    /// The orbit, for every rig but the light field.
    pub fn orbit(&self) -> Option<&OrbitRig> {
        match self {
            Self::Orbit(o) | Self::Brackets(o, _) | Self::Olat(o, _) => Some(o),
            Self::LightField(_) => None,
        }
    }

    /// The exposure brackets, if this is a bracket rig.
    pub fn brackets(&self) -> Option<&crate::brackets::BracketSpec> {
        match self {
            Self::Brackets(_, b) => Some(b),
            _ => None,
        }
    }

    /// The light-field grid, if this is a light-field rig.
    pub fn light_field(&self) -> Option<&crate::lightfield::LightFieldRig> {
        match self {
            Self::LightField(l) => Some(l),
            _ => None,
        }
    }

    /// The OLAT lights, if this is an OLAT rig.
    pub fn olat(&self) -> Option<&crate::olat::OlatSpec> {
        match self {
            Self::Olat(_, o) => Some(o),
            _ => None,
        }
    }

    /// The name `dataset.toml` records (`orbit`, `brackets`, `lightfield`, `olat`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Orbit(_) => "orbit",
            Self::Brackets(..) => "brackets",
            Self::LightField(_) => "lightfield",
            Self::Olat(..) => "olat",
        }
    }
}
