//! From camera rays to a packed batch of samples: marching in parallel, then packing ray
//! after ray with positions normalised to the scene box.

use glam::Vec3;
use rayon::prelude::*;

use super::composite::PackedSamples;
use super::march::RayMarcher;
use crate::occupancy::OccupancyGrid;

/// Samples of a set of rays, ready for the field and the compositing.
#[derive(Clone, Debug, Default)]
pub struct SampleBatch {
    /// Ray offsets, distances and spacing.
    pub samples: PackedSamples,
    /// Sample positions in `[0,1]³` of the scene box (`S×3`).
    pub positions: Vec<f32>,
    /// Unit ray direction of each sample (`S×3`).
    pub directions: Vec<f32>,
}

/// Rays per parallel task.
const CHUNK: usize = 256;

/// Marches `rays` (`(origin, unit direction)`) with the jitter `jitter(i)` for ray `i`.
/// With `budget`, rays are dropped from the end until the samples fit; returns the batch and
/// the number of rays kept.
pub fn march_rays(
    rays: &[(Vec3, Vec3)],
    jitter: impl Fn(usize) -> f32 + Sync,
    marcher: &RayMarcher,
    grid: &OccupancyGrid,
    budget: Option<usize>,
) -> (SampleBatch, usize) {
    let parts: Vec<(Vec<u32>, Vec<f32>, Vec<f32>)> = rays
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let (mut counts, mut t, mut dt) = (Vec::with_capacity(chunk.len()), Vec::new(), Vec::new());
            for (i, &(o, d)) in chunk.iter().enumerate() {
                let before = t.len();
                marcher.march(o, d, grid, jitter(c * CHUNK + i), &mut t, &mut dt);
                counts.push((t.len() - before) as u32);
            }
            (counts, t, dt)
        })
        .collect();
    let (lo, hi) = grid.bounds();
    let inv_size = (hi - lo).recip();
    let mut batch =
        SampleBatch { samples: PackedSamples { offsets: vec![0], ..Default::default() }, ..Default::default() };
    let mut kept = 0;
    'outer: for (c, (counts, t, dt)) in parts.into_iter().enumerate() {
        let mut at = 0;
        for (i, &n) in counts.iter().enumerate() {
            let n = n as usize;
            if budget.is_some_and(|b| batch.samples.t.len() + n > b) {
                break 'outer;
            }
            let (o, d) = rays[c * CHUNK + i];
            for &ts in &t[at..at + n] {
                batch.positions.extend(box_position(marcher.to_model(o + ts * d), lo, inv_size).to_array());
                batch.directions.extend(d.to_array());
            }
            batch.samples.t.extend_from_slice(&t[at..at + n]);
            batch.samples.dt.extend_from_slice(&dt[at..at + n]);
            batch.samples.offsets.push(batch.samples.t.len() as u32);
            at += n;
            kept += 1;
        }
    }
    (batch, kept)
}

/// A point of the grid's space (the world, or contracted) in `[0,1]³` coordinates of the box
/// whose minimum corner is `lo` and whose inverse size is `inv_size` (the field's input).
#[inline]
pub fn box_position(model: Vec3, lo: Vec3, inv_size: Vec3) -> Vec3 {
    ((model - lo) * inv_size).clamp(Vec3::ZERO, Vec3::ONE)
}
