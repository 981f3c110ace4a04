//! Thousands of point lights declared at once: a grid of them over a parallelogram, with
//! optional jitter and colour variation drawn from a seed (the `many-lights` scene, for
//! many-light methods such as lightcuts).

use glam::Vec3;

use crate::light::Light;
use crate::sampling::Rng;

/// The most lights one grid may declare.
pub const MAX_GRID_LIGHTS: u64 = 1_000_000;

/// A grid of `count[0] × count[1]` point lights, one per cell of the parallelogram
/// `corner + s·edge_u + t·edge_v` (s, t ∈ [0, 1]).
#[derive(Clone, Debug, PartialEq)]
pub struct PointLightGrid {
    /// A corner of the parallelogram.
    pub corner: Vec3,
    /// Its first edge.
    pub edge_u: Vec3,
    /// Its second edge.
    pub edge_v: Vec3,
    /// Lights along each edge.
    pub count: [u32; 2],
    /// Intensity of each light (W/sr) before tinting.
    pub intensity: Vec3,
    /// How far a light may move from its cell's centre, as a fraction of the cell (0..=1).
    pub jitter: f32,
    /// Colour variation: each channel scaled by 1 + tint·(2ξ − 1), ξ uniform (0..=1).
    pub tint: f32,
    /// Seed of the jitter and tint.
    pub seed: u64,
}

impl PointLightGrid {
    /// The lights, row by row.
    pub fn lights(&self) -> Vec<Light> {
        let [nu, nv] = self.count;
        let mut rng = Rng::new(self.seed, 0x6c69_6768_7473);
        let mut out = Vec::with_capacity(nu as usize * nv as usize);
        for j in 0..nv {
            for i in 0..nu {
                let offset = (rng.uniform2() - 0.5) * self.jitter;
                let s = (i as f32 + 0.5 + offset.x) / nu as f32;
                let t = (j as f32 + 0.5 + offset.y) / nv as f32;
                let tint = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
                out.push(Light::Point {
                    position: self.corner + s * self.edge_u + t * self.edge_v,
                    intensity: self.intensity * (Vec3::ONE + self.tint * tint),
                });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_places_one_light_per_cell_and_keeps_the_mean_intensity() {
        let grid = PointLightGrid {
            corner: Vec3::new(-1.0, 2.0, -1.0),
            edge_u: Vec3::new(2.0, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.0, 2.0),
            count: [40, 30],
            intensity: Vec3::splat(0.5),
            jitter: 0.9,
            tint: 0.5,
            seed: 3,
        };
        let lights = grid.lights();
        assert_eq!(lights.len(), 1200);
        let mut mean = Vec3::ZERO;
        for (k, light) in lights.iter().enumerate() {
            let Light::Point { position, intensity } = light else { panic!("point lights only") };
            // Inside its own cell (jitter < 1 keeps it there), on the plane y = 2.
            let (i, j) = (k % 40, k / 40);
            let (s, t) = ((position.x + 1.0) / 2.0 * 40.0, (position.z + 1.0) / 2.0 * 30.0);
            assert!(s >= i as f32 && s < i as f32 + 1.0 && t >= j as f32 && t < j as f32 + 1.0, "{k}: {position}");
            assert!((position.y - 2.0).abs() < 1e-6);
            assert!(intensity.min_element() >= 0.25 - 1e-6 && intensity.max_element() <= 0.75 + 1e-6);
            mean += *intensity;
        }
        mean /= 1200.0;
        assert!((mean - Vec3::splat(0.5)).abs().max_element() < 0.01, "{mean}");
        assert_eq!(lights, grid.lights(), "deterministic per seed");
    }
}
