//! Ray marching through the scene box: samples only in occupied cells of the
//! [`OccupancyGrid`], with a step that grows with distance (`dt = clamp(t·cone, min, max)`,
//! so that far samples cover about as many pixels as near ones).

use glam::Vec3;

use crate::occupancy::OccupancyGrid;

/// How samples are placed along a ray.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MarchSettings {
    /// Smallest step, as a fraction of the box diagonal.
    pub min_step: f32,
    /// Largest step, as a fraction of the box diagonal.
    pub max_step: f32,
    /// Growth of the step with distance: `dt = t·cone_angle` between the two bounds. `0`
    /// takes the angular size of one pixel of the training cameras.
    pub cone_angle: f32,
    /// At most this many samples per ray.
    pub max_samples: usize,
    /// Samples start at least this far from the camera.
    pub near: f32,
}

impl Default for MarchSettings {
    fn default() -> Self {
        Self { min_step: 1.0 / 1024.0, max_step: 1.0 / 64.0, cone_angle: 0.0, max_samples: 1024, near: 0.05 }
    }
}

impl MarchSettings {
    /// Checks the values; the message names the wrong one.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, v: f32| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(format!("{name} must be a positive number, got {v}")) }
        };
        positive("min_step", self.min_step)?;
        positive("max_step", self.max_step)?;
        if self.max_step < self.min_step {
            return Err(format!("max_step ({}) must be at least min_step ({})", self.max_step, self.min_step));
        }
        if !(self.cone_angle.is_finite() && self.cone_angle >= 0.0) {
            return Err(format!("cone_angle must be zero or positive, got {}", self.cone_angle));
        }
        if !(1..=16384).contains(&self.max_samples) {
            return Err(format!("max_samples must be in 1..=16384, got {}", self.max_samples));
        }
        if !(self.near.is_finite() && self.near >= 0.0) {
            return Err(format!("near must be zero or positive, got {}", self.near));
        }
        Ok(())
    }
}

/// The marcher for one scene box: step bounds in world units.
#[derive(Clone, Copy, Debug)]
pub struct RayMarcher {
    min_step: f32,
    max_step: f32,
    cone_angle: f32,
    max_samples: usize,
    near: f32,
}

impl RayMarcher {
    /// Marcher for a box of diagonal `diagonal`; `pixel_angle` replaces a zero `cone_angle`.
    pub fn new(settings: &MarchSettings, diagonal: f32, pixel_angle: f32) -> Self {
        let cone_angle = if settings.cone_angle > 0.0 { settings.cone_angle } else { pixel_angle };
        Self {
            min_step: settings.min_step * diagonal,
            max_step: settings.max_step * diagonal,
            cone_angle,
            max_samples: settings.max_samples,
            near: settings.near,
        }
    }

    /// The smallest step in world units (the occupancy grid's reference step).
    pub fn min_step(&self) -> f32 {
        self.min_step
    }

    /// Step at distance `t`.
    #[inline]
    pub fn step(&self, t: f32) -> f32 {
        (t * self.cone_angle).clamp(self.min_step, self.max_step)
    }

    /// Appends the samples of one ray to `t` and `dt`. `jitter ∈ [0,1)` shifts the first
    /// sample by a fraction of a step (random in training, `0.5` to render).
    pub fn march(
        &self,
        origin: Vec3,
        dir: Vec3,
        grid: &OccupancyGrid,
        jitter: f32,
        t_out: &mut Vec<f32>,
        dt_out: &mut Vec<f32>,
    ) {
        if let Some(mut state) = self.start(origin, dir, grid, jitter) {
            self.advance(origin, dir, grid, &mut state, usize::MAX, t_out, dt_out);
        }
    }

    /// Where the marching of a ray starts, or `None` if it misses the box.
    pub fn start(&self, origin: Vec3, dir: Vec3, grid: &OccupancyGrid, jitter: f32) -> Option<MarchState> {
        let (lo, hi) = grid.bounds();
        let (t0, t1) = intersect_box(origin, dir, lo, hi)?;
        let t = t0.max(self.near);
        Some(MarchState { t: t + jitter * self.step(t), exit: t1, samples: 0 })
    }

    /// Appends up to `limit` more samples of the ray to `t` and `dt` (the same ones a single
    /// [`RayMarcher::march`] places, so rendering in rounds changes nothing); false once the
    /// ray has left the box or has all its samples.
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        &self,
        origin: Vec3,
        dir: Vec3,
        grid: &OccupancyGrid,
        state: &mut MarchState,
        limit: usize,
        t_out: &mut Vec<f32>,
        dt_out: &mut Vec<f32>,
    ) -> bool {
        let inv = dir.recip();
        let mut t = state.t;
        let mut added = 0;
        while t < state.exit && state.samples < self.max_samples {
            if added == limit {
                state.t = t;
                return true;
            }
            let p = origin + t * dir;
            let Some(cell) = grid.cell_at(p) else { break };
            if grid.is_occupied(cell) {
                let dt = self.step(t);
                t_out.push(t);
                dt_out.push(dt);
                state.samples += 1;
                added += 1;
                t += dt;
            } else {
                // Jump to where the ray leaves this cell, keeping a whole number of steps so
                // the samples stay on one lattice.
                let (clo, chi) = grid.cell_bounds(cell);
                let exit = cell_exit(origin, inv, clo, chi);
                let dt = self.step(t);
                t += ((exit - t) / dt).ceil().max(1.0) * dt;
            }
        }
        state.t = t;
        false
    }
}

/// How far the marching of one ray has got.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchState {
    /// Where the next sample may be.
    t: f32,
    /// Where the ray leaves the scene box.
    exit: f32,
    /// Samples placed so far.
    samples: usize,
}

/// Entry and exit distances of a ray through a box, or `None` on a miss.
pub fn intersect_box(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let inv = dir.recip();
    let a = (lo - origin) * inv;
    let b = (hi - origin) * inv;
    let t0 = a.min(b).max_element().max(0.0);
    let t1 = a.max(b).min_element();
    (t1 > t0).then_some((t0, t1))
}

fn cell_exit(origin: Vec3, inv: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let a = (lo - origin) * inv;
    let b = (hi - origin) * inv;
    a.max(b).min_element()
}

#[cfg(test)]
mod tests {
    use super::*;
    use lucid_scene::sampling::Rng;

    #[test]
    fn samples_cover_occupied_cells_and_skip_empty_ones() {
        let mut grid = OccupancyGrid::new(8, Vec3::splat(-1.0), Vec3::splat(1.0));
        // Occupy only the cells whose centre is within 0.5 of the origin.
        let obs: Vec<(u32, f32)> = (0..grid.cells())
            .map(|i| {
                let (lo, hi) = grid.cell_bounds(i);
                (i as u32, if ((lo + hi) * 0.5).length() < 0.5 { 1.0 } else { 0.0 })
            })
            .collect();
        grid.update(&obs, 0.0, 0.01);
        let marcher =
            RayMarcher::new(&MarchSettings { cone_angle: 0.0, ..Default::default() }, 2.0 * 3f32.sqrt(), 0.002);
        let mut rng = Rng::new(9, 0);
        for _ in 0..200 {
            let origin = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 4.0);
            let dir = (Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 0.3 - origin).normalize();
            let (mut t, mut dt) = (Vec::new(), Vec::new());
            marcher.march(origin, dir, &grid, rng.uniform(), &mut t, &mut dt);
            for (&ti, &di) in t.iter().zip(&dt) {
                let cell = grid.cell_at(origin + ti * dir).expect("inside the box");
                assert!(grid.is_occupied(cell), "sample in an empty cell");
                assert!(di >= marcher.min_step() * 0.999);
            }
            // Dense reference: every point on a fine lattice inside an occupied cell is
            // within one step of some sample.
            if let Some((t0, t1)) = intersect_box(origin, dir, Vec3::splat(-1.0), Vec3::splat(1.0)) {
                let mut s = t0;
                while s < t1 {
                    if grid.cell_at(origin + s * dir).is_some_and(|c| grid.is_occupied(c)) {
                        let near = t.iter().zip(&dt).any(|(&ti, &di)| (s - ti).abs() <= di * 1.01);
                        assert!(near, "occupied point at t={s} has no sample near it");
                    }
                    s += 0.001;
                }
            }
        }
    }

    #[test]
    fn the_step_grows_with_distance_between_its_bounds() {
        let m = RayMarcher::new(&MarchSettings { cone_angle: 0.01, ..Default::default() }, 1.0, 0.0);
        assert_eq!(m.step(0.0), 1.0 / 1024.0);
        assert!((m.step(1.0) - 0.01).abs() < 1e-7);
        assert_eq!(m.step(100.0), 1.0 / 64.0);
    }
}
