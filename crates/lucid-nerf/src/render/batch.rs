//! From camera rays to a packed batch of samples: marching in parallel, then packing ray
//! after ray with positions normalised to the scene box.

use glam::Vec3;
use rayon::prelude::*;

use super::composite::{PackedSamples, RayAccumulator};
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

/// Marches `rays` (`(origin, unit direction)`) with the jitter `jitter(i)` for ray `i`, with
/// samples over empty space where `sample_empty(i)` (see [`super::march::MarchState`]).
/// With `budget`, rays are dropped from the end until the samples fit; returns the batch and
/// the number of rays kept.
pub fn march_rays(
    rays: &[(Vec3, Vec3)],
    jitter: impl Fn(usize) -> f32 + Sync,
    sample_empty: impl Fn(usize) -> bool + Sync,
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
                let k = c * CHUNK + i;
                marcher.march(o, d, grid, jitter(k), sample_empty(k), &mut t, &mut dt);
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

/// Cuts each ray of `batch` after the sample where its transmittance, from the densities
/// `sigma` (one per sample), falls below `min_transmittance`: compositing gives the samples
/// behind it no weight and no gradient, yet the field would be evaluated and differentiated
/// on them (over half of a trophy batch once the surfaces are learned). Then keeps whole rays,
/// first to last, while their samples fit `budget`. Returns the cut batch and its ray count.
pub fn cut_at_termination(
    batch: SampleBatch,
    sigma: &[f32],
    min_transmittance: f32,
    budget: usize,
) -> (SampleBatch, usize) {
    let samples = &batch.samples;
    assert_eq!(sigma.len(), samples.samples(), "one density per sample");
    let mut cut =
        SampleBatch { samples: PackedSamples { offsets: vec![0], ..Default::default() }, ..Default::default() };
    let mut kept = 0;
    for r in 0..samples.rays() {
        let (start, end) = (samples.offsets[r] as usize, samples.offsets[r + 1] as usize);
        let mut ray = RayAccumulator::default();
        let mut stop = end;
        for (s, &density) in sigma.iter().enumerate().take(end).skip(start) {
            // Colour does not change where the ray stops.
            if !ray.add(&[density, 0.0, 0.0, 0.0], samples.t[s], samples.dt[s], min_transmittance) {
                stop = s + 1;
                break;
            }
        }
        if cut.samples.t.len() + (stop - start) > budget {
            break;
        }
        cut.samples.t.extend_from_slice(&samples.t[start..stop]);
        cut.samples.dt.extend_from_slice(&samples.dt[start..stop]);
        cut.positions.extend_from_slice(&batch.positions[3 * start..3 * stop]);
        cut.directions.extend_from_slice(&batch.directions[3 * start..3 * stop]);
        cut.samples.offsets.push(cut.samples.t.len() as u32);
        kept += 1;
    }
    (cut, kept)
}

/// A point of the grid's space (the world, or contracted) in `[0,1]³` coordinates of the box
/// whose minimum corner is `lo` and whose inverse size is `inv_size` (the field's input).
#[inline]
pub fn box_position(model: Vec3, lo: Vec3, inv_size: Vec3) -> Vec3 {
    ((model - lo) * inv_size).clamp(Vec3::ZERO, Vec3::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::composite::{RAY_OUTPUTS, composite_forward};

    /// Three rays: one through an opaque wall at its third sample, one through thin haze that
    /// never stops it, one stopped at its first sample.
    fn batch() -> (SampleBatch, Vec<f32>) {
        let counts = [6, 4, 3];
        let sigma = [vec![0.0, 1.0, 500.0, 500.0, 3.0, 0.0], vec![0.5; 4], vec![1e4, 2.0, 2.0]].concat();
        let mut b =
            SampleBatch { samples: PackedSamples { offsets: vec![0], ..Default::default() }, ..Default::default() };
        for (r, &n) in counts.iter().enumerate() {
            for i in 0..n {
                b.samples.t.push(0.1 * (i + 1) as f32);
                b.samples.dt.push(0.1);
                b.positions.extend([r as f32, i as f32, 0.5]);
                b.directions.extend([0.0, 0.0, 1.0]);
            }
            b.samples.offsets.push(b.samples.t.len() as u32);
        }
        (b, sigma)
    }

    #[test]
    fn rays_are_cut_after_the_sample_that_stops_them_and_composite_the_same() {
        let (b, sigma) = batch();
        let min_t = 1e-4;
        let (cut, kept) = cut_at_termination(b.clone(), &sigma, min_t, usize::MAX);
        assert_eq!(kept, 3);
        // exp(-500·0.1) < 1e-4 at the third sample; the haze ray keeps all 4; exp(-1e3) at once.
        assert_eq!(cut.samples.offsets, vec![0, 3, 7, 8]);
        assert_eq!(cut.positions[..9], b.positions[..9]);
        assert_eq!(cut.positions[9..21], b.positions[18..30]);
        assert_eq!(cut.positions[21..24], b.positions[30..33]);
        let raw = |batch: &SampleBatch, sigma: &[f32]| -> Vec<f32> {
            (0..batch.samples.samples()).flat_map(|s| [sigma[s], 0.2, batch.positions[3 * s + 1] * 0.1, 0.7]).collect()
        };
        let cut_sigma: Vec<f32> = [&sigma[..3], &sigma[6..10], &sigma[10..11]].concat();
        let mut full = vec![0.0; 3 * RAY_OUTPUTS];
        let mut short = vec![0.0; 3 * RAY_OUTPUTS];
        composite_forward(&b.samples, &raw(&b, &sigma), min_t, &mut full);
        composite_forward(&cut.samples, &raw(&cut, &cut_sigma), min_t, &mut short);
        assert_eq!(full, short, "the cut samples had no weight");
    }

    #[test]
    fn whole_rays_are_kept_while_they_fit_the_budget() {
        let (b, sigma) = batch();
        // 3 + 4 samples fit 7; the third ray's one sample would not.
        let (cut, kept) = cut_at_termination(b.clone(), &sigma, 1e-4, 7);
        assert_eq!((kept, cut.samples.offsets.clone()), (2, vec![0, 3, 7]));
        let (cut, kept) = cut_at_termination(b, &sigma, 1e-4, 2);
        assert_eq!((kept, cut.samples.samples(), cut.positions.len()), (0, 0, 0));
    }
}
