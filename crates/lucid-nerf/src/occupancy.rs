//! The occupancy grid of instant-ngp: a coarse grid over the scene box holding an
//! exponential moving average of the field's density per cell, and a bitfield of the cells
//! worth sampling, so that ray marching skips empty space.
//!
//! Densities are stored as optical thickness over one reference step (`σ·Δ_ref`), so the
//! threshold is dimensionless: a cell is occupied when its value exceeds
//! `min(threshold, mean)`, the mean keeping a mostly transparent early field from culling
//! everything.
//!
//! Coarser flags mark the aligned regions of 2³, 4³, 8³, … cells holding any occupied cell (a
//! mip pyramid of the bitfield), so that a marching ray crosses the largest empty region
//! around it in one jump rather than cell by cell. Rays crossing a few hundred empty cells
//! were a third of a view's render; with one level of 8³ blocks, the jumps still outnumbered
//! the samples 3.7 to 1 on a trophy view.

use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// Cells per parallel task of the grid's whole-grid passes (a multiple of 64, one bit word).
const CELL_CHUNK: usize = 1 << 15;

/// The grid over an axis-aligned box.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyGrid {
    resolution: u32,
    min: Vec3,
    max: Vec3,
    thickness: Vec<f32>,
    bits: Vec<u64>,
    /// `resolution / (max − min)`.
    cells_per_unit: Vec3,
    /// Derived from `bits`: level `k − 1` holds one flag per aligned region of `2^k` cells a
    /// side (cut at the grid's edge), true where some cell of it is occupied.
    mips: Vec<Vec<bool>>,
}

impl OccupancyGrid {
    /// A `resolution³` grid over `[min, max]` with every cell occupied and no density yet.
    pub fn new(resolution: u32, min: Vec3, max: Vec3) -> Self {
        assert!((1..=1024).contains(&resolution), "grid resolution must be in 1..=1024");
        assert!(max.cmpgt(min).all(), "the box must have positive size");
        let cells = (resolution as usize).pow(3);
        Self::from_parts(resolution, min, max, vec![0.0; cells], vec![u64::MAX; cells.div_ceil(64)])
            .expect("the parts are sized for the resolution")
    }

    /// Regions per axis at mip level `k` (regions of `2^k` cells a side).
    #[inline]
    fn regions_per_axis(&self, k: u32) -> u32 {
        self.resolution.div_ceil(1 << k)
    }

    /// The index at mip level `k` of the region holding the cell at `c`.
    #[inline]
    fn region_index(&self, k: u32, c: UVec3) -> usize {
        let (n, q) = (self.regions_per_axis(k), c >> k);
        ((q.z * n + q.y) * n + q.x) as usize
    }

    /// Levels up to the one whose single region covers the grid.
    fn rebuild_mips(&mut self) {
        let r = self.resolution;
        let mut mips: Vec<Vec<bool>> = Vec::new();
        let mut k = 1;
        while (1u32 << (k - 1)) < r {
            let n = self.regions_per_axis(k) as usize;
            // Each level from the one below it (the first from the cells): up to 8 children a
            // region, fewer at the grid's far edges.
            let below = if k == 1 { r as usize } else { self.regions_per_axis(k - 1) as usize };
            let prev = mips.last();
            let occupied = |child: usize| match prev {
                None => self.is_occupied(child),
                Some(level) => level[child],
            };
            let level: Vec<bool> = (0..n * n * n)
                .into_par_iter()
                .with_min_len(CELL_CHUNK)
                .map(|i| {
                    let (x, y, z) = (2 * (i % n), 2 * (i / n % n), 2 * (i / (n * n)));
                    (z..(z + 2).min(below)).any(|cz| {
                        (y..(y + 2).min(below))
                            .any(|cy| (x..(x + 2).min(below)).any(|cx| occupied((cz * below + cy) * below + cx)))
                    })
                })
                .collect();
            mips.push(level);
            k += 1;
        }
        self.mips = mips;
    }

    /// Cells per axis.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The box corners.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.min, self.max)
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.thickness.len()
    }

    /// The per-cell optical thickness estimates.
    pub fn thickness(&self) -> &[f32] {
        &self.thickness
    }

    /// The cell containing world point `p`, or `None` outside the box.
    #[inline]
    pub fn cell_at(&self, p: Vec3) -> Option<usize> {
        self.coords_at(p).map(|c| self.index(c))
    }

    /// Integer coordinates of the cell containing world point `p`, or `None` outside the box.
    #[inline]
    pub fn coords_at(&self, p: Vec3) -> Option<UVec3> {
        // A multiplication by the cells per unit length rather than a division by the box's
        // size: this runs for every sample and jump of every marched ray. (Tested in cell
        // units after the subtraction, so that a point rounded a hair past a face, as a ray's
        // first sample at the box's entry can be, is still inside.)
        let r = self.resolution;
        let u = (p - self.min) * self.cells_per_unit;
        if u.cmplt(Vec3::ZERO).any() || u.cmpgt(Vec3::splat(r as f32)).any() {
            return None;
        }
        Some(u.as_uvec3().min(UVec3::splat(r - 1)))
    }

    /// The index of the cell at integer coordinates `c`.
    #[inline]
    pub fn index(&self, c: UVec3) -> usize {
        let r = self.resolution;
        ((c.z * r + c.y) * r + c.x) as usize
    }

    /// World-space position of the lowest corner of the cell at `c` (any `c`, also one past
    /// the grid).
    #[inline]
    fn corner(&self, c: UVec3) -> Vec3 {
        self.min + c.as_vec3() * self.cell_size()
    }

    #[inline]
    fn cell_size(&self) -> Vec3 {
        (self.max - self.min) / self.resolution as f32
    }

    /// World-space corners of the cell at `c`.
    #[inline]
    pub fn bounds_of(&self, c: UVec3) -> (Vec3, Vec3) {
        let lo = self.corner(c);
        (lo, lo + self.cell_size())
    }

    /// The empty space around the empty cell at `c` that a ray may cross in one jump: the
    /// largest aligned region of `2^k` cells a side that holds it and no occupied cell (the
    /// cell itself where its 2³ neighbourhood is occupied), clipped to the grid.
    #[inline]
    pub fn empty_span(&self, c: UVec3) -> (Vec3, Vec3) {
        let mut k = 0;
        while (k as usize) < self.mips.len() && !self.mips[k as usize][self.region_index(k + 1, c)] {
            k += 1;
        }
        if k == 0 {
            return self.bounds_of(c);
        }
        let q = c >> k;
        (self.corner(q << k), self.corner((q + 1) << k).min(self.max))
    }

    /// Integer coordinates of cell `index`.
    pub fn cell_coords(&self, index: usize) -> [u32; 3] {
        let r = self.resolution as usize;
        [(index % r) as u32, ((index / r) % r) as u32, (index / (r * r)) as u32]
    }

    /// World-space corners of cell `index`.
    pub fn cell_bounds(&self, index: usize) -> (Vec3, Vec3) {
        self.bounds_of(UVec3::from_array(self.cell_coords(index)))
    }

    /// Whether cell `index` may hold matter.
    #[inline]
    pub fn is_occupied(&self, index: usize) -> bool {
        self.bits[index / 64] >> (index % 64) & 1 == 1
    }

    /// Fraction of cells marked occupied.
    pub fn occupied_fraction(&self) -> f32 {
        let ones: u64 = self.bits.iter().map(|b| b.count_ones() as u64).sum();
        ones as f32 / self.cells() as f32
    }

    /// Indices of the occupied cells.
    pub fn occupied_cells(&self) -> Vec<u32> {
        (0..self.cells() as u32)
            .into_par_iter()
            .with_min_len(CELL_CHUNK)
            .filter(|&i| self.is_occupied(i as usize))
            .collect()
    }

    /// One update: every cell decays by `decay`, each `(cell, thickness)` observation raises
    /// its cell to at least that value, and the bitfield is rebuilt with the threshold
    /// `min(max_threshold, mean thickness)`. Returns the threshold used.
    pub fn update(&mut self, observations: &[(u32, f32)], decay: f32, max_threshold: f32) -> f32 {
        // Decaying every cell and then raising the observed ones gives max(decayed, largest
        // observation), as thickness is never negative; both cores decay, one observes.
        self.thickness.par_chunks_mut(CELL_CHUNK).for_each(|c| c.iter_mut().for_each(|t| *t *= decay));
        for &(cell, value) in observations {
            let t = &mut self.thickness[cell as usize];
            *t = t.max(value);
        }
        // Sums of fixed chunks, added in order: the same threshold on every run.
        let sums: Vec<f64> =
            self.thickness.par_chunks(CELL_CHUNK).map(|c| c.iter().map(|&t| f64::from(t)).sum()).collect();
        let sum: f64 = sums.iter().sum();
        let threshold = max_threshold.min((sum / self.cells() as f64) as f32);
        self.rebuild_bits(threshold);
        threshold
    }

    fn rebuild_bits(&mut self, threshold: f32) {
        let thickness = &self.thickness;
        self.bits.par_chunks_mut(CELL_CHUNK / 64).enumerate().for_each(|(c, words)| {
            let first = c * CELL_CHUNK;
            for (w, word) in words.iter_mut().enumerate() {
                let start = first + 64 * w;
                let cells = &thickness[start..(start + 64).min(thickness.len())];
                *word = cells.iter().enumerate().filter(|&(_, &t)| t > threshold).fold(0, |b, (i, _)| b | 1 << i);
            }
        });
        self.rebuild_mips();
    }

    /// A grid from its saved state (thickness per cell and bitfield words), or `None` when
    /// their lengths do not match the resolution.
    pub fn from_parts(resolution: u32, min: Vec3, max: Vec3, thickness: Vec<f32>, bits: Vec<u64>) -> Option<Self> {
        let cells = (resolution as usize).checked_pow(3)?;
        (thickness.len() == cells && bits.len() == cells.div_ceil(64)).then(|| {
            let cells_per_unit = resolution as f32 / (max - min);
            let mut grid = Self { resolution, min, max, thickness, bits, cells_per_unit, mips: Vec::new() };
            grid.rebuild_mips();
            grid
        })
    }

    /// The bitfield words.
    pub fn bits(&self) -> &[u64] {
        &self.bits
    }
}

/// A grid of `resolution`³ cells over `[-1,1]³`, occupied exactly where `inside` holds at
/// the cell's centre: the marching and rendering tests' scenes.
#[cfg(test)]
pub(crate) fn grid_occupied_where(resolution: u32, inside: impl Fn(Vec3) -> bool) -> OccupancyGrid {
    let mut grid = OccupancyGrid::new(resolution, Vec3::splat(-1.0), Vec3::splat(1.0));
    let obs: Vec<(u32, f32)> = (0..grid.cells())
        .map(|i| {
            let (lo, hi) = grid.cell_bounds(i);
            (i as u32, if inside((lo + hi) * 0.5) { 1.0 } else { 0.0 })
        })
        .collect();
    grid.update(&obs, 0.0, 0.01);
    grid
}

#[cfg(test)]
mod tests {
    use super::*;
    use lucid_scene::sampling::Rng;

    #[test]
    fn cells_map_to_their_bounds() {
        let g = OccupancyGrid::new(8, Vec3::splat(-1.0), Vec3::splat(1.0));
        for i in [0, 7, 63, 100, 511] {
            let (lo, hi) = g.cell_bounds(i);
            assert_eq!(g.cell_at((lo + hi) * 0.5), Some(i));
        }
        assert_eq!(g.cell_at(Vec3::new(1.5, 0.0, 0.0)), None);
        assert_eq!(g.cell_at(Vec3::splat(1.0)), Some(511), "the far faces belong to the last cells");
        // A ray's first sample at the box's entry, rounded a hair past the face, is inside.
        assert_eq!(g.cell_at(Vec3::new(1.000_000_1, 0.0, 0.0)), Some(7 + 8 * 4 + 64 * 4));
    }

    /// An empty cell spans the largest aligned empty region of 2^k cells around it (cut at the
    /// grid's edge); one next to an occupied cell spans only itself.
    #[test]
    fn an_empty_span_is_the_largest_aligned_empty_region() {
        let mut g = OccupancyGrid::new(20, Vec3::splat(-1.0), Vec3::splat(1.0));
        let occupied = UVec3::new(3, 4, 5);
        let obs = [(g.index(occupied) as u32, 1.0)];
        g.update(&obs, 0.0, 0.5);
        assert!(g.is_occupied(g.index(occupied)) && g.occupied_fraction() * 8000.0 == 1.0);
        let cell = 0.1;
        let corner = |c: [u32; 3]| Vec3::from_array(c.map(|v| -1.0 + v as f32 * cell).map(|v| v.min(1.0)));
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
        // In the occupied cell's 2³ region: the cell alone.
        let c = UVec3::new(2, 5, 4);
        assert_eq!(g.empty_span(c), g.bounds_of(c));
        // In its 4³ region but not its 2³ one: the 2³ region (cells 0..2, 4..6, 4..6).
        let (lo, hi) = g.empty_span(UVec3::new(1, 5, 4));
        assert!(close(lo, corner([0, 4, 4])) && close(hi, corner([2, 6, 6])), "{lo} {hi}");
        // In its 8³ region but not its 4³ one: the 4³ region (cells 4..8, 0..4, 4..8).
        let (lo, hi) = g.empty_span(UVec3::new(7, 1, 6));
        assert!(close(lo, corner([4, 0, 4])) && close(hi, corner([8, 4, 8])), "{lo} {hi}");
        // Outside its 16³ region: the largest empty one, a 16³ region cut at the edge (cells
        // 16..20 on x, 0..16 on y and z); past x = 16 the whole 32³ region is not empty.
        let (lo, hi) = g.empty_span(UVec3::new(17, 9, 2));
        assert!(close(lo, corner([16, 0, 0])) && close(hi, corner([20, 16, 16])), "{lo} {hi}");
        // An empty grid: every cell spans the whole grid.
        let empty = OccupancyGrid::from_parts(20, g.min, g.max, vec![0.0; 8000], vec![0; 125]).unwrap();
        let (lo, hi) = empty.empty_span(UVec3::new(3, 4, 5));
        assert!(close(lo, Vec3::splat(-1.0)) && close(hi, Vec3::splat(1.0)), "{lo} {hi}");
        // Saved and restored, the levels are derived again.
        let back = OccupancyGrid::from_parts(20, g.min, g.max, g.thickness.clone(), g.bits.clone()).unwrap();
        assert_eq!(back, g);
    }

    /// On a grid of many parallel chunks whose cell count is not a whole number of bit words,
    /// an update keeps max(decayed, largest observation) per cell, marks exactly the cells
    /// above the threshold, and each mip level flags exactly the regions holding one.
    #[test]
    fn updates_and_levels_match_the_cell_by_cell_definition() {
        let r = 70u32;
        let mut g = OccupancyGrid::new(r, Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut rng = Rng::new(9, 1);
        let mut expected = vec![0f32; g.cells()];
        for _ in 0..2 {
            let obs: Vec<(u32, f32)> = (0..20_000)
                .map(|_| (rng.below(g.cells()) as u32, if rng.uniform() < 0.5 { 0.02 * rng.uniform() } else { 0.005 }))
                .collect();
            expected.iter_mut().for_each(|t| *t *= 0.9);
            for &(c, v) in &obs {
                expected[c as usize] = expected[c as usize].max(v);
            }
            let threshold = g.update(&obs, 0.9, 0.01);
            let mean = expected.iter().map(|&t| f64::from(t)).sum::<f64>() / expected.len() as f64;
            assert!((f64::from(threshold) - mean.min(0.01)).abs() < 1e-9, "{threshold} against {mean}");
            assert_eq!(g.thickness, expected);
            for (i, &t) in expected.iter().enumerate() {
                assert_eq!(g.is_occupied(i), t > threshold, "cell {i}");
            }
            assert!(g.bits.last().is_some_and(|w| w >> (g.cells() % 64) == 0), "bits past the last cell stay clear");
            for k in 1..=g.mips.len() as u32 {
                let n = g.regions_per_axis(k);
                for (i, &flag) in g.mips[k as usize - 1].iter().enumerate() {
                    let q = UVec3::new(i as u32 % n, i as u32 / n % n, i as u32 / (n * n));
                    let lo = q << k;
                    let hi = ((q + UVec3::ONE) << k).min(UVec3::splat(r));
                    let any = (lo.z..hi.z).any(|z| {
                        (lo.y..hi.y).any(|y| (lo.x..hi.x).any(|x| g.is_occupied(g.index(UVec3::new(x, y, z)))))
                    });
                    assert_eq!(flag, any, "level {k} region {i}");
                }
            }
        }
    }

    /// A sphere of dense matter in an empty box: after updates with one random sample per
    /// cell, no cell whose sample was above threshold is culled, and most empty cells are.
    #[test]
    fn never_culls_a_cell_with_a_sample_above_threshold() {
        let mut g = OccupancyGrid::new(16, Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut rng = Rng::new(5, 0);
        let density = |p: Vec3| if p.length() < 0.5 { 50.0 } else { 1e-4 * (1.0 + p.x) };
        let step = 2.0 * 3f32.sqrt() / 1024.0;
        for _ in 0..4 {
            let obs: Vec<(u32, f32)> = (0..g.cells())
                .map(|i| {
                    let (lo, hi) = g.cell_bounds(i);
                    let p = lo + (hi - lo) * Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                    (i as u32, density(p) * step)
                })
                .collect();
            let threshold = g.update(&obs, 0.95, 0.01);
            for &(cell, value) in &obs {
                if value > threshold {
                    assert!(g.is_occupied(cell as usize), "cell {cell} with {value} > {threshold} was culled");
                }
            }
        }
        let frac = g.occupied_fraction();
        let sphere_frac = 4.0 / 3.0 * std::f32::consts::PI * 0.125 / 8.0;
        assert!(frac > sphere_frac * 0.8 && frac < sphere_frac * 2.0, "occupied {frac} vs sphere {sphere_frac}");
    }
}
