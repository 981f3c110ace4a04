//! Ray marching through the scene box: samples only in occupied cells of the
//! [`OccupancyGrid`], with a step that grows with distance (`dt = clamp(t·cone, min, max)`,
//! so that far samples cover about as many pixels as near ones).
//!
//! Unbounded scenes (captures, whose photographs see the sky and far scenery) are marched in
//! Mip-NeRF 360's contracted space: within a ball of radius `r` around the origin points are
//! themselves, beyond it `x ↦ (2 − r/|x|)·r·x/|x|`, so all of space fits a ball of radius
//! `2r` that the grid and the field cover. Contraction was chosen over instant-ngp's cascade
//! of ever larger grids because one grid and one hash table then serve all distances at the
//! resolution each deserves (the far shell is squeezed as the disparity falls), with no
//! per-cascade bookkeeping in the marcher or the occupancy update. Beyond `r` the steps are
//! also at least half a contracted cell long, which makes the samples there even in
//! disparity, as Mip-NeRF 360 spaces them.

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
    /// Steps to evaluate and render, as a fraction of the training steps (every step length:
    /// the bounds, the cone and the contracted far steps). Training shifts each ray's samples
    /// by a random fraction of a step, so the field learns the mean over those shifts, the
    /// continuous volume integral; a view marched at one fixed shift adds the quadrature
    /// error of its steps, which finer steps shrink (measured in the README).
    pub render_step_scale: f32,
    /// Radius of the ball beyond which space is contracted (unbounded scenes); 0: the scene
    /// is the box and nothing lies outside it. Chosen from the dataset when training starts.
    pub contraction: f32,
    /// Whether the scene is unbounded: `auto` (captures, and datasets whose images have no
    /// transparent background), `on` or `off`.
    pub unbounded: Unbounded,
}

/// Whether a scene extends beyond its box.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unbounded {
    /// Captures and opaque images are unbounded, the rest bounded.
    #[default]
    Auto,
    /// Always contract space beyond the cameras.
    On,
    /// Only the scene box.
    Off,
}

impl Default for MarchSettings {
    fn default() -> Self {
        Self {
            min_step: 1.0 / 1024.0,
            max_step: 1.0 / 64.0,
            cone_angle: 0.0,
            max_samples: 1024,
            near: 0.05,
            render_step_scale: 0.5,
            contraction: 0.0,
            unbounded: Unbounded::Auto,
        }
    }
}

/// Empty space an empty-space sample stands for, as a fraction of the box diagonal: about
/// five samples on a ray that crosses the box missing everything (one per empty block made
/// such rays 4× as long as one that stops on a surface, and cut the rays of a batch by 3×).
const EMPTY_SPAN: f32 = 0.125;

/// Rays of an unbounded scene end this many contraction radii away: there the contracted
/// point is within 0.01 % of the ball's edge.
const FAR: f32 = 1e4;

impl MarchSettings {
    /// Whether `scale` is a valid [`Self::render_step_scale`]: in (0, 1].
    pub fn is_render_step_scale(scale: f32) -> bool {
        scale.is_finite() && scale > 0.0 && scale <= 1.0
    }

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
        if !Self::is_render_step_scale(self.render_step_scale) {
            return Err(format!("render_step_scale must be in (0, 1], got {}", self.render_step_scale));
        }
        if !(self.near.is_finite() && self.near >= 0.0) {
            return Err(format!("near must be zero or positive, got {}", self.near));
        }
        if !(self.contraction.is_finite() && self.contraction >= 0.0) {
            return Err(format!("contraction must be zero or positive, got {}", self.contraction));
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
    /// The contraction radius (0: none).
    radius: f32,
    /// Beyond the radius, steps are at least this (in contracted units) times `|x|²/r`.
    far_step: f32,
    /// Length of empty space one empty-space sample stands for (at least).
    empty_span: f32,
    /// Standard deviation of a ray's pixel footprint per unit distance: a pixel's angle over
    /// √12 (a box filter's), over √n for rays that each cover `1/n` of a pixel.
    footprint_angle: f32,
}

impl RayMarcher {
    /// Marcher for a box of diagonal `diagonal` (a grid of `resolution` cells per axis);
    /// `pixel_angle` replaces a zero `cone_angle`.
    pub fn new(settings: &MarchSettings, diagonal: f32, pixel_angle: f32, resolution: u32) -> Self {
        let cone_angle = if settings.cone_angle > 0.0 { settings.cone_angle } else { pixel_angle };
        let radius = settings.contraction;
        Self {
            min_step: settings.min_step * diagonal,
            max_step: settings.max_step * diagonal,
            cone_angle,
            max_samples: settings.max_samples,
            near: settings.near,
            radius,
            // Half a cell of the grid over the contracted ball's cube (side 4r).
            far_step: 0.5 * 4.0 * radius / resolution.max(1) as f32,
            empty_span: EMPTY_SPAN * diagonal,
            footprint_angle: 0.0,
        }
        .with_pixel_angle(pixel_angle)
    }

    /// This marcher for the rays of cameras whose pixels span `pixel_angle` radians (a view
    /// rendered at another resolution than the training views'): the footprints follow the
    /// pixels; the steps stay the training views' ([`Self::with_step_scale`] changes them).
    pub fn with_pixel_angle(mut self, pixel_angle: f32) -> Self {
        self.footprint_angle = pixel_angle / 12f32.sqrt();
        self
    }

    /// This marcher with every step length `scale` times as long (the rendering marcher:
    /// [`MarchSettings::render_step_scale`]) and `1/scale` times the samples a ray may take,
    /// so that a ray reaches as far; the footprints stay.
    pub fn with_step_scale(mut self, scale: f32) -> Self {
        self.min_step *= scale;
        self.max_step *= scale;
        self.cone_angle *= scale;
        self.far_step *= scale;
        self.max_samples = (self.max_samples as f32 / scale).ceil() as usize;
        self
    }

    /// This marcher for rays that each cover `1/rays` of a pixel (a grid of rays per pixel):
    /// their footprints are `√rays` times narrower.
    pub fn with_rays_per_pixel(mut self, rays: usize) -> Self {
        self.footprint_angle /= (rays.max(1) as f32).sqrt();
        self
    }

    /// Standard deviation, in the field's space, of the pixel footprint of a ray that reaches
    /// world point `p` at distance `t`: `t` times the footprint angle, shrunk beyond the
    /// contraction radius as the contraction shrinks lengths across the ray there
    /// (`(2 − r/|x|)·r/|x|`, the tangential scale of `x ↦ (2 − r/|x|)·r·x/|x|`).
    #[inline]
    pub fn footprint(&self, t: f32, p: Vec3) -> f32 {
        let sigma = t * self.footprint_angle;
        let r = self.radius;
        if r <= 0.0 {
            return sigma;
        }
        let len = p.length();
        if len <= r { sigma } else { sigma * (2.0 - r / len) * r / len }
    }

    /// Whether space beyond a ball is contracted.
    pub fn is_unbounded(&self) -> bool {
        self.radius > 0.0
    }

    /// Where the grid and the field see world point `p`: itself, or contracted.
    #[inline]
    pub fn to_model(&self, p: Vec3) -> Vec3 {
        let r = self.radius;
        if r <= 0.0 {
            return p;
        }
        let len = p.length();
        if len <= r { p } else { p * ((2.0 - r / len) * r / len) }
    }

    /// Step at distance `t` where the ray is at world point `p`.
    #[inline]
    fn step_at(&self, t: f32, p: Vec3) -> f32 {
        let dt = self.step(t);
        let r = self.radius;
        if r <= 0.0 {
            return dt;
        }
        let len2 = p.length_squared();
        if len2 <= r * r { dt } else { dt.max(self.far_step * len2 / r) }
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
    /// sample by a fraction of a step (random in training, `0.5` to render). With
    /// `sample_empty`, the empty space crossed also gets samples, one per stretch of at least
    /// [`EMPTY_SPAN`] of the diagonal (see [`MarchState::sample_empty`]).
    #[allow(clippy::too_many_arguments)]
    pub fn march(
        &self,
        origin: Vec3,
        dir: Vec3,
        grid: &OccupancyGrid,
        jitter: f32,
        sample_empty: bool,
        t_out: &mut Vec<f32>,
        dt_out: &mut Vec<f32>,
    ) {
        if let Some(mut state) = self.start(origin, dir, grid, jitter) {
            state.sample_empty = sample_empty;
            self.advance(origin, dir, grid, &mut state, usize::MAX, t_out, dt_out);
        }
    }

    /// Where the marching of a ray starts, or `None` if it misses the box.
    pub fn start(&self, origin: Vec3, dir: Vec3, grid: &OccupancyGrid, jitter: f32) -> Option<MarchState> {
        if self.is_unbounded() {
            // Every ray crosses all of (contracted) space, out to the far sphere.
            let far = FAR * self.radius;
            let b = origin.dot(dir);
            let exit = -b + (b * b - origin.length_squared() + far * far).max(0.0).sqrt();
            let t = self.near;
            return Some(MarchState::new(t + jitter * self.step_at(t, origin + t * dir), exit, jitter));
        }
        let (lo, hi) = grid.bounds();
        let (t0, t1) = intersect_box(origin, dir, lo, hi)?;
        let t = t0.max(self.near);
        Some(MarchState::new(t + jitter * self.step(t), t1, jitter))
    }

    /// Appends up to `limit` more samples of the ray to `t` and `dt` (the same ones a single
    /// [`RayMarcher::march`] places, so rendering in rounds changes nothing); false once the
    /// ray has left the box or has all its samples.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
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
            let Some(coords) = grid.coords_at(self.to_model(p)) else { break };
            let dt = self.step_at(t, p);
            if grid.is_occupied(grid.index(coords)) {
                added += state.flush_empty(t, t_out, dt_out);
                t_out.push(t);
                dt_out.push(dt);
                state.samples += 1;
                added += 1;
                t += dt;
            } else if !self.is_unbounded() || p.length_squared() <= self.radius * self.radius {
                // Jump to where the ray leaves the largest empty region around this cell,
                // keeping a whole number of steps so the samples stay on one lattice.
                // (Within the contraction's ball, cells are where they are in the world; a
                // region reaching beyond it is longer in the world than in the grid, so the
                // jump falls short of its exit, never past.)
                let (clo, chi) = grid.empty_span(coords);
                let exit = cell_exit(origin, inv, clo, chi);
                let next = t + ceil((exit - t) / dt).max(1.0) * dt;
                if state.sample_empty {
                    let from = *state.empty_from.get_or_insert(t);
                    if next - from >= self.empty_span {
                        // (A jump may land past the box, a step at most.)
                        added += state.flush_empty(next.min(state.exit), t_out, dt_out);
                    }
                }
                t = next;
            } else {
                t += dt;
            }
        }
        state.flush_empty(t.min(state.exit), t_out, dt_out);
        state.t = t;
        false
    }
}

/// `⌈x⌉` for finite `x` in the `i64` range: `f32::ceil` is a libm call on baseline x86-64,
/// and this runs for every empty cell a ray crosses.
#[inline(always)]
fn ceil(x: f32) -> f32 {
    let i = x as i64;
    (i + (x > i as f32) as i64) as f32
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
    /// Whether the empty space the ray jumps over gets samples: one per stretch of at least
    /// [`EMPTY_SPAN`] of the diagonal (cut short by an occupied sample or the ray's end),
    /// standing for all of it. For training rays whose truth is transparent, every point they
    /// cross must be empty, also in cells the grid has culled. There the field is never
    /// sampled otherwise, so its density drifts as hash entries it shares with the surfaces
    /// are trained, until the grid's refresh finds the drift and rays that rarely cross the
    /// cell must undo it: the floaters that grew with training time on toys.
    pub sample_empty: bool,
    /// Where the empty space not yet sampled began.
    empty_from: Option<f32>,
    /// Empty-space samples placed so far.
    empty_samples: u32,
    /// The ray's jitter, which places the empty-space samples.
    jitter: f32,
}

impl MarchState {
    fn new(t: f32, exit: f32, jitter: f32) -> Self {
        Self { t, exit, samples: 0, sample_empty: false, empty_from: None, empty_samples: 0, jitter }
    }

    /// Places the pending empty-space sample, standing for `[empty_from, to)`, at a point of
    /// it that varies from ray to ray and sample to sample; returns the samples added.
    fn flush_empty(&mut self, to: f32, t_out: &mut Vec<f32>, dt_out: &mut Vec<f32>) -> usize {
        let Some(from) = self.empty_from.take() else { return 0 };
        if to <= from {
            return 0;
        }
        // A golden-ratio sequence offset by the ray's jitter: even over the span, not the same
        // point on every ray.
        let u = (self.jitter + 0.618_034 * self.empty_samples as f32).fract();
        self.empty_samples += 1;
        t_out.push(from + u * (to - from));
        dt_out.push(to - from);
        self.samples += 1;
        1
    }
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
    use crate::occupancy::grid_occupied_where;
    use lucid_scene::sampling::Rng;

    /// At 8³ the grid is one block; at 40³ most blocks around the ball are empty and crossed
    /// in one jump (and the last block is cut by the grid's edge).
    #[test]
    fn samples_cover_occupied_cells_and_skip_empty_ones() {
        for (resolution, radius) in [(8, 0.5), (40, 0.3)] {
            samples_cover_occupied_cells(resolution, radius);
        }
    }

    fn samples_cover_occupied_cells(resolution: u32, radius: f32) {
        // Occupy only the cells whose centre is within `radius` of the origin.
        let grid = grid_occupied_where(resolution, |c| c.length() < radius);
        let marcher = RayMarcher::new(
            &MarchSettings { cone_angle: 0.0, ..Default::default() },
            2.0 * 3f32.sqrt(),
            0.002,
            resolution,
        );
        let mut rng = Rng::new(9, 0);
        for _ in 0..200 {
            let origin = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 4.0);
            let dir = (Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 0.3 - origin).normalize();
            let (mut t, mut dt) = (Vec::new(), Vec::new());
            marcher.march(origin, dir, &grid, rng.uniform(), false, &mut t, &mut dt);
            for (&ti, &di) in t.iter().zip(&dt) {
                let cell = grid.cell_at(origin + ti * dir).expect("inside the box");
                assert!(grid.is_occupied(cell), "sample in an empty cell");
                assert!(di >= marcher.min_step() * 0.999);
            }
            // Dense reference: every point on a fine lattice inside occupied space, a step or
            // more from its edge, is within one step of some sample. (The lattice of samples
            // can miss a sliver of an occupied cell's corner shorter than a step.)
            if let Some((t0, t1)) = intersect_box(origin, dir, Vec3::splat(-1.0), Vec3::splat(1.0)) {
                let occupied = |s: f32| grid.cell_at(origin + s * dir).is_some_and(|c| grid.is_occupied(c));
                let mut s = t0;
                while s < t1 {
                    let step = marcher.step(s);
                    if occupied(s) && occupied(s - step) && occupied(s + step) {
                        let near = t.iter().zip(&dt).any(|(&ti, &di)| (s - ti).abs() <= di * 1.01);
                        assert!(near, "occupied point at t={s} has no sample near it ({resolution}³)");
                    }
                    s += 0.001;
                }
            }
        }
    }

    /// With empty-space samples, a ray keeps its samples in occupied cells and gains a few
    /// that stand for the empty stretches between them: sorted, in empty space, each at least
    /// the span long unless an occupied sample or the box's exit cut it short, and together
    /// covering the ray's whole chord through the box.
    #[test]
    fn empty_space_samples_cover_the_stretches_between_occupied_ones() {
        let grid = grid_occupied_where(40, |c| {
            (c - Vec3::new(0.3, 0.0, 0.0)).length() < 0.25 || (c + Vec3::splat(0.4)).length() < 0.2
        });
        let diagonal = 2.0 * 3f32.sqrt();
        let marcher = RayMarcher::new(&MarchSettings::default(), diagonal, 0.002, 40);
        let span = EMPTY_SPAN * diagonal;
        let mut rng = Rng::new(3, 1);
        let mut empty_total = 0;
        for _ in 0..300 {
            let origin = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 4.0);
            let dir = (Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 1.5 - origin).normalize();
            let jitter = rng.uniform();
            let (mut t0, mut dt0) = (Vec::new(), Vec::new());
            marcher.march(origin, dir, &grid, jitter, false, &mut t0, &mut dt0);
            let (mut t, mut dt) = (Vec::new(), Vec::new());
            marcher.march(origin, dir, &grid, jitter, true, &mut t, &mut dt);
            let Some((entry, exit)) = intersect_box(origin, dir, Vec3::splat(-1.0), Vec3::splat(1.0)) else {
                assert!(t.is_empty());
                continue;
            };
            assert!(t.windows(2).all(|w| w[0] < w[1]), "samples out of order");
            let occupied = t.iter().filter(|ti| t0.contains(ti)).count();
            assert_eq!(occupied, t0.len(), "the occupied-cell samples are unchanged");
            let mut covered = 0.0;
            for (i, (&ti, &di)) in t.iter().zip(&dt).enumerate() {
                covered += di;
                if t0.contains(&ti) {
                    continue;
                }
                empty_total += 1;
                let cell = grid.cell_at(origin + ti * dir).expect("inside the box");
                // A jump lands a whole number of steps on, so up to a step past its cells.
                let near_occupied = t0.iter().any(|&o| (o - ti).abs() <= 1.01 * marcher.step(o));
                assert!(!grid.is_occupied(cell) || near_occupied, "an empty-space sample in an occupied cell");
                let cut_short = t.get(i + 1).is_some_and(|n| t0.contains(n)) || ti + di >= exit - 0.05;
                assert!(di >= span || cut_short, "empty sample standing for {di} < {span}");
            }
            let chord = exit - entry;
            assert!((covered - chord).abs() < 0.1, "samples cover {covered} of a chord of {chord}");
        }
        assert!(empty_total > 300, "rays crossing empty space got empty-space samples");
    }

    #[test]
    fn the_step_grows_with_distance_between_its_bounds() {
        let m = RayMarcher::new(&MarchSettings { cone_angle: 0.01, ..Default::default() }, 1.0, 0.0, 128);
        assert_eq!(m.step(0.0), 1.0 / 1024.0);
        assert!((m.step(1.0) - 0.01).abs() < 1e-7);
        assert_eq!(m.step(100.0), 1.0 / 64.0);
    }

    /// A view marches each ray at one fixed shift of its steps, so a surface is met anywhere
    /// up to a step after it begins, and the composited depth (or a colour that changes with
    /// depth) strays from ray to ray by up to a step; training's random shifts average this
    /// out. Halving every step (the rendering marcher, [`RayMarcher::with_step_scale`])
    /// halves the stray, and the step clamps and cone all shrink with it.
    #[test]
    fn finer_render_steps_shrink_the_quadrature_error_of_a_surface() {
        let grid = grid_occupied_where(8, |_| true);
        // One ray straight down the box's axis, at the rendering shift.
        let march = |marcher: &RayMarcher| {
            let (mut t, mut dt) = (Vec::new(), Vec::new());
            marcher.march(Vec3::new(0.01, 0.02, 5.0), -Vec3::Z, &grid, 0.5, false, &mut t, &mut dt);
            (t, dt)
        };
        let base = RayMarcher::new(&MarchSettings::default(), 2.0 * 3f32.sqrt(), 0.01, 8);
        let density = 2000.0;
        let spread = |marcher: &RayMarcher| -> (f64, f32) {
            let mut rng = Rng::new(5, 0);
            let errors: Vec<f64> = (0..2000)
                .map(|_| {
                    // A surface across the ray at a random depth in [4.2, 5), dense behind it.
                    let surface = 4.2 + 0.8 * rng.uniform();
                    let (t, dt) = march(marcher);
                    let (mut transmittance, mut depth) = (1.0f64, 0.0f64);
                    for (&ti, &di) in t.iter().zip(&dt) {
                        let sigma = if ti >= surface { density } else { 0.0 };
                        let alpha = 1.0 - (-sigma * di as f64).exp();
                        depth += transmittance * alpha * ti as f64;
                        transmittance *= 1.0 - alpha;
                    }
                    assert!(transmittance < 1e-6, "the ray passes the surface");
                    depth - surface as f64
                })
                .collect();
            let mean = errors.iter().sum::<f64>() / errors.len() as f64;
            let sd = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errors.len() as f64).sqrt();
            (sd, marcher.step(4.5))
        };
        let (coarse, coarse_step) = spread(&base);
        let (fine, fine_step) = spread(&base.with_step_scale(0.5));
        assert!((fine_step - 0.5 * coarse_step).abs() < 1e-6, "{fine_step} against {coarse_step}");
        // A stray uniform over a step has the standard deviation step/√12.
        let uniform = coarse_step as f64 / 12f64.sqrt();
        assert!((coarse / uniform - 1.0).abs() < 0.1, "coarse {coarse} against {uniform}");
        assert!((fine / coarse - 0.5).abs() < 0.05, "fine {fine} against coarse {coarse}");

        // A ray capped by the samples it may take reaches as far with the finer steps.
        let capped =
            RayMarcher::new(&MarchSettings { max_samples: 16, ..Default::default() }, 2.0 * 3f32.sqrt(), 0.01, 8);
        let reach = |marcher: &RayMarcher| {
            let (t, dt) = march(marcher);
            (t.len(), t.last().copied().unwrap_or(0.0) + dt.last().copied().unwrap_or(0.0))
        };
        let ((n1, far1), (n2, far2)) = (reach(&capped), reach(&capped.with_step_scale(0.5)));
        assert_eq!((n1, n2), (16, 32));
        assert!((far2 - far1).abs() < 0.02 * far1, "{far2} against {far1}");
    }
}
