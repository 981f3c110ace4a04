//! Marching many rays a few samples at a time: each round advances every live ray, in
//! parallel chunks, by up to a given number of samples, so that the field can be evaluated on
//! all of a round's samples at once and rays dropped once they stop. Both the view renderer
//! and the trainer's cut at termination march this way: marching whole rays first would
//! evaluate the field behind every surface, most of the work in a scene of opaque objects.

use glam::Vec3;
use lucid_scene::simd::wide;
use rayon::prelude::*;

use super::batch::box_position;
use super::march::{MarchState, RayMarcher};
use crate::occupancy::OccupancyGrid;

/// Live rays per parallel marching task.
const MARCH_CHUNK: usize = 256;

/// What one task marched in a round, ray after ray.
#[derive(Default)]
pub struct RoundPart {
    /// Samples each ray got.
    pub counts: Vec<u32>,
    /// Whether each ray has samples left.
    pub more: Vec<bool>,
    /// Distance of each sample along its ray.
    pub t: Vec<f32>,
    /// Segment length of each sample.
    pub dt: Vec<f32>,
    /// Each sample's position in `[0,1]³` of the grid's box (`×3`).
    pub positions: Vec<f32>,
    /// Each sample's pixel footprint (standard deviation) in the box's units.
    pub footprints: Vec<f32>,
}

/// A round's samples, task after task (ray order is `live`'s).
pub struct Round {
    /// The tasks' parts.
    pub parts: Vec<RoundPart>,
    /// Samples in all parts.
    pub samples: usize,
}

impl Round {
    /// All positions, packed (`samples×3`).
    pub fn positions(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(3 * self.samples);
        for p in &self.parts {
            out.extend_from_slice(&p.positions);
        }
        out
    }

    /// All footprints, packed (`samples`).
    pub fn footprints(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.samples);
        for p in &self.parts {
            out.extend_from_slice(&p.footprints);
        }
        out
    }

    /// Each sample's unit ray direction, packed (`samples×3`); `live` is the round's.
    pub fn directions(&self, rays: &[(Vec3, Vec3)], live: &[(usize, MarchState)]) -> Vec<f32> {
        let mut out = Vec::with_capacity(3 * self.samples);
        self.for_each_ray(|rank, t, _, _, _| {
            let d = rays[live[rank].0].1.to_array();
            for _ in t {
                out.extend_from_slice(&d);
            }
        });
        out
    }

    /// Visits every live ray in order with its slot in `live`, its samples' `t`, `dt`, their
    /// index in the packed round, and whether the ray has samples left.
    pub fn for_each_ray(&self, mut visit: impl FnMut(usize, &[f32], &[f32], usize, bool)) {
        let (mut rank, mut at) = (0, 0);
        for part in &self.parts {
            let mut local = 0;
            for (&n, &more) in part.counts.iter().zip(&part.more) {
                let n = n as usize;
                visit(rank, &part.t[local..local + n], &part.dt[local..local + n], at, more);
                rank += 1;
                local += n;
                at += n;
            }
        }
    }
}

/// Samples per live ray in a round of about `round_samples`, at least one.
pub fn samples_per_ray(round_samples: usize, live: usize) -> usize {
    (round_samples / live.max(1)).max(1)
}

/// Advances each `(ray, state)` of `live` by up to `per_ray` samples of `rays[ray]`.
pub fn march_round(
    rays: &[(Vec3, Vec3)],
    live: &mut [(usize, MarchState)],
    per_ray: usize,
    marcher: &RayMarcher,
    grid: &OccupancyGrid,
) -> Round {
    let (lo, hi) = grid.bounds();
    let inv_size = (hi - lo).recip();
    // Footprints in box units: a box that is not a cube has cells of different widths per
    // axis, and its mean inverse side stands for all three.
    let box_scale = (inv_size.x + inv_size.y + inv_size.z) / 3.0;
    let parts: Vec<RoundPart> = live
        .par_chunks_mut(MARCH_CHUNK)
        .map(|chunk| {
            wide(
                #[inline(always)]
                || {
                    let mut part = RoundPart::default();
                    for (ray, state) in chunk.iter_mut() {
                        let (o, d) = rays[*ray];
                        let before = part.t.len();
                        let more = marcher.advance(o, d, grid, state, per_ray, &mut part.t, &mut part.dt);
                        for &ts in &part.t[before..] {
                            let p = o + ts * d;
                            part.positions.extend(box_position(marcher.to_model(p), lo, inv_size).to_array());
                            part.footprints.push(marcher.footprint(ts, p) * box_scale);
                        }
                        part.counts.push((part.t.len() - before) as u32);
                        part.more.push(more);
                    }
                    part
                },
            )
        })
        .collect();
    let samples = parts.iter().map(|p| p.t.len()).sum();
    Round { parts, samples }
}
