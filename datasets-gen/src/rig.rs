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
