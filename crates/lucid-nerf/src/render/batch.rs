//! From camera rays to a packed training batch of samples: marched in rounds up to where
//! each ray stops, packed ray after ray with positions normalised to the scene box.

use super::composite::{PackedSamples, RayAccumulator};
use super::march::{MarchState, RayMarcher};
use super::rounds::{march_round, samples_per_ray};
use crate::occupancy::OccupancyGrid;
use glam::Vec3;

/// Samples of a set of rays, ready for the field and the compositing.
#[derive(Clone, Debug, Default)]
pub struct SampleBatch {
    /// Ray offsets, distances and spacing.
    pub samples: PackedSamples,
    /// Sample positions in `[0,1]³` of the scene box (`S×3`).
    pub positions: Vec<f32>,
    /// Each sample's pixel footprint (standard deviation) in box units (`S`).
    pub footprints: Vec<f32>,
    /// Unit ray direction of each sample (`S×3`).
    pub directions: Vec<f32>,
    /// Where [`march_to_termination`] evaluated each sample's density: its index among all the
    /// positions passed to `density`, call after call.
    pub evaluated: Vec<u32>,
}

/// Samples per round of [`march_to_termination`]: see [`super::rounds`]. A ray gets
/// `ROUND_SAMPLES / live` samples per round, so a few while most rays live and more as they
/// stop.
const ROUND_SAMPLES: usize = 1 << 14;

/// How far a ray of [`march_to_termination`] has got.
#[derive(Default)]
struct RayTrack {
    t: Vec<f32>,
    dt: Vec<f32>,
    positions: Vec<f32>,
    footprints: Vec<f32>,
    evaluated: Vec<u32>,
    ray: RayAccumulator,
}

/// Marches `rays` (`(origin, unit direction)`, jittered by `jitter(i)`, with samples over
/// empty space where `sample_empty(i)`, see [`super::march::MarchState`]) in rounds, and cuts
/// each after the sample where its transmittance, from `density` (positions `S×3` in the box
/// and their footprints `S` → `σ` per sample), falls below `min_transmittance`: compositing
/// gives the samples behind it no weight and no gradient, yet the field would be evaluated and
/// differentiated on them (over half of a trophy batch once the surfaces are learned). Keeps
/// whole rays, first to last, while their samples fit `budget`; a ray that can no longer fit
/// is not marched on. Returns the batch and the number of rays kept; the batch says where each
/// of its samples was evaluated, so that whatever `density` computed on the way can be reused.
#[allow(clippy::too_many_arguments)]
pub fn march_to_termination(
    rays: &[(Vec3, Vec3)],
    jitter: impl Fn(usize) -> f32,
    sample_empty: impl Fn(usize) -> bool,
    marcher: &RayMarcher,
    grid: &OccupancyGrid,
    mut density: impl FnMut(&[f32], &[f32]) -> Vec<f32>,
    min_transmittance: f32,
    budget: usize,
) -> (SampleBatch, usize) {
    let mut tracks: Vec<RayTrack> = rays.iter().map(|_| RayTrack::default()).collect();
    let mut live: Vec<(usize, MarchState)> = rays
        .iter()
        .enumerate()
        .filter_map(|(i, &(o, d))| {
            let mut state = marcher.start(o, d, grid, jitter(i))?;
            state.sample_empty = sample_empty(i);
            Some((i, state))
        })
        .collect();
    // Rays from `end` on do not fit the budget.
    let mut end = rays.len();
    let mut evaluated = 0;
    while !live.is_empty() {
        let per_ray = samples_per_ray(ROUND_SAMPLES, live.len());
        let round = march_round(rays, &mut live, per_ray, marcher, grid);
        let (positions, footprints) = (round.positions(), round.footprints());
        let sigma = if round.samples == 0 { Vec::new() } else { density(&positions, &footprints) };
        assert_eq!(sigma.len(), round.samples, "one density per sample");
        let mut going = vec![false; live.len()];
        round.for_each_ray(|rank, t, dt, at, more| {
            let track = &mut tracks[live[rank].0];
            let mut stop = t.len();
            going[rank] = more;
            for j in 0..t.len() {
                // Colour does not change where the ray stops.
                if !track.ray.add(&[sigma[at + j], 0.0, 0.0, 0.0], t[j], dt[j], min_transmittance) {
                    (stop, going[rank]) = (j + 1, false);
                    break;
                }
            }
            track.t.extend_from_slice(&t[..stop]);
            track.dt.extend_from_slice(&dt[..stop]);
            track.positions.extend_from_slice(&positions[3 * at..3 * (at + stop)]);
            track.footprints.extend_from_slice(&footprints[at..at + stop]);
            track.evaluated.extend((evaluated + at..evaluated + at + stop).map(|i| i as u32));
        });
        evaluated += round.samples;
        let mut total = 0;
        end = tracks[..end]
            .iter()
            .position(|r| {
                total += r.t.len();
                total > budget
            })
            .unwrap_or(end);
        let mut rank = 0;
        live.retain(|&(ray, _)| {
            rank += 1;
            going[rank - 1] && ray < end
        });
    }
    let mut batch =
        SampleBatch { samples: PackedSamples { offsets: vec![0], ..Default::default() }, ..Default::default() };
    for (track, &(_, d)) in tracks[..end].iter().zip(rays) {
        batch.samples.t.extend_from_slice(&track.t);
        batch.samples.dt.extend_from_slice(&track.dt);
        batch.positions.extend_from_slice(&track.positions);
        batch.footprints.extend_from_slice(&track.footprints);
        batch.evaluated.extend_from_slice(&track.evaluated);
        for _ in &track.t {
            batch.directions.extend(d.to_array());
        }
        batch.samples.offsets.push(batch.samples.t.len() as u32);
    }
    (batch, end)
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
    use crate::render::march::MarchSettings;
    use lucid_scene::sampling::Rng;

    /// A 40³ grid over `[-1,1]³` occupied in a ball of radius 0.5, a marcher over it, and a
    /// density in box coordinates: a hard shell (σ = 400) between radii 0.3 and 0.35 around
    /// the centre, thin haze (σ = 0.5) elsewhere.
    fn scene() -> (OccupancyGrid, RayMarcher, impl Fn(&[f32]) -> Vec<f32>) {
        let grid = crate::occupancy::grid_occupied_where(40, |c| c.length() < 0.5);
        let marcher = RayMarcher::new(&MarchSettings::default(), 2.0 * 3f32.sqrt(), 0.002, 40);
        let density = |p: &[f32]| {
            p.chunks_exact(3)
                .map(|q| {
                    let r = (2.0 * Vec3::from_slice(q) - Vec3::ONE).length();
                    if (0.3..0.35).contains(&r) { 400.0 } else { 0.5 }
                })
                .collect()
        };
        (grid, marcher, density)
    }

    fn rays(n: usize) -> Vec<(Vec3, Vec3)> {
        let mut rng = Rng::new(5, 0);
        (0..n)
            .map(|_| {
                let o = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 3.0);
                (o, (Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 0.8 - o).normalize())
            })
            .collect()
    }

    /// Whole rays marched at once, then cut where the density stops them: the reference.
    fn whole_rays(rays: &[(Vec3, Vec3)], grid: &OccupancyGrid, marcher: &RayMarcher, min_t: f32) -> Vec<Vec<f32>> {
        let (_, _, density) = scene();
        let (lo, hi) = grid.bounds();
        rays.iter()
            .enumerate()
            .map(|(i, &(o, d))| {
                let (mut t, mut dt) = (Vec::new(), Vec::new());
                marcher.march(o, d, grid, 0.1 * (i % 10) as f32, i % 3 == 0, &mut t, &mut dt);
                let pos: Vec<f32> =
                    t.iter().flat_map(|&s| box_position(o + s * d, lo, (hi - lo).recip()).to_array()).collect();
                let sigma = density(&pos);
                let mut acc = RayAccumulator::default();
                let stop = (0..t.len()).position(|j| !acc.add(&[sigma[j], 0.0, 0.0, 0.0], t[j], dt[j], min_t));
                t.truncate(stop.map_or(t.len(), |j| j + 1));
                t
            })
            .collect()
    }

    /// The rays marched to termination with the jitter and empty-space choices of
    /// [`whole_rays`].
    fn march(
        rays: &[(Vec3, Vec3)],
        grid: &OccupancyGrid,
        marcher: &RayMarcher,
        mut density: impl FnMut(&[f32]) -> Vec<f32>,
        min_t: f32,
        budget: usize,
    ) -> (SampleBatch, usize) {
        let density = |p: &[f32], _: &[f32]| density(p);
        march_to_termination(rays, |i| 0.1 * (i % 10) as f32, |i| i % 3 == 0, marcher, grid, density, min_t, budget)
    }

    #[test]
    fn rays_marched_in_rounds_stop_where_whole_rays_are_cut_and_composite_the_same() {
        let (grid, marcher, density) = scene();
        let rays = rays(300);
        let min_t = 1e-4;
        let reference = whole_rays(&rays, &grid, &marcher, min_t);
        let (batch, kept) = march(&rays, &grid, &marcher, &density, min_t, usize::MAX);
        assert_eq!(kept, rays.len());
        let mut all_positions = Vec::new();
        let record = |p: &[f32]| {
            all_positions.extend_from_slice(p);
            density(p)
        };
        march(&rays, &grid, &marcher, record, min_t, usize::MAX);
        for (s, &e) in batch.evaluated.iter().enumerate() {
            assert_eq!(batch.positions[3 * s..3 * s + 3], all_positions[3 * e as usize..3 * e as usize + 3]);
        }
        let mut cut_short = 0;
        for (r, want) in reference.iter().enumerate() {
            let (a, b) = (batch.samples.offsets[r] as usize, batch.samples.offsets[r + 1] as usize);
            assert_eq!(&batch.samples.t[a..b], &want[..], "ray {r}");
            assert!(batch.directions[3 * a..3 * b].chunks(3).all(|d| d == rays[r].1.to_array()));
            let mut full = (Vec::new(), Vec::new());
            let (o, d) = rays[r];
            marcher.march(o, d, &grid, 0.1 * (r % 10) as f32, r % 3 == 0, &mut full.0, &mut full.1);
            cut_short += (full.0.len() > want.len()) as usize;
        }
        assert!(cut_short > 100, "the shell stops many rays ({cut_short} of 300)");
        // Each sample's footprint: its distance times the pixel angle (0.002) over √12, in
        // units of the box (side 2).
        let per_distance = 0.002 / 12f32.sqrt() / 2.0;
        assert_eq!(batch.footprints.len(), batch.samples.samples());
        for (&f, &t) in batch.footprints.iter().zip(&batch.samples.t) {
            assert!((f - t * per_distance).abs() <= 1e-6 * t, "footprint {f} at t = {t}");
        }
        // The samples cut away had no weight: compositing the cut rays gives the whole rays'
        // colour, opacity and depth.
        let raw = |positions: &[f32]| -> Vec<f32> {
            let sigma = density(positions);
            sigma.iter().zip(positions.chunks(3)).flat_map(|(&s, p)| [s, p[0], p[1], p[2]]).collect()
        };
        let mut whole =
            SampleBatch { samples: PackedSamples { offsets: vec![0], ..Default::default() }, ..Default::default() };
        let (lo, hi) = grid.bounds();
        for (r, &(o, d)) in rays.iter().enumerate() {
            let (mut t, mut dt) = (Vec::new(), Vec::new());
            marcher.march(o, d, &grid, 0.1 * (r % 10) as f32, r % 3 == 0, &mut t, &mut dt);
            whole.positions.extend(t.iter().flat_map(|&s| box_position(o + s * d, lo, (hi - lo).recip()).to_array()));
            whole.samples.t.extend(t);
            whole.samples.dt.extend(dt);
            whole.samples.offsets.push(whole.samples.t.len() as u32);
        }
        let mut full = vec![0.0; rays.len() * RAY_OUTPUTS];
        let mut short = vec![0.0; rays.len() * RAY_OUTPUTS];
        composite_forward(&whole.samples, &raw(&whole.positions), min_t, &mut full);
        composite_forward(&batch.samples, &raw(&batch.positions), min_t, &mut short);
        assert_eq!(full, short);
    }

    #[test]
    fn whole_rays_are_kept_first_to_last_while_they_fit_the_budget() {
        let (grid, marcher, density) = scene();
        let rays = rays(50);
        let reference = whole_rays(&rays, &grid, &marcher, 1e-4);
        let budget = reference[..20].iter().map(Vec::len).sum::<usize>() + reference[20].len() - 1;
        let (batch, kept) = march(&rays, &grid, &marcher, &density, 1e-4, budget);
        assert!(reference[20].len() > 1, "ray 20 has samples");
        assert_eq!(kept, 20, "ray 20 is one sample over the budget");
        assert_eq!(batch.samples.rays(), 20);
        assert_eq!(batch.samples.t, reference[..20].concat());
        assert_eq!(batch.positions.len(), 3 * batch.samples.samples());
    }
}
