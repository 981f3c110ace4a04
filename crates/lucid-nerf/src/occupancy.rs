//! The occupancy grid of instant-ngp: a coarse grid over the scene box holding an
//! exponential moving average of the field's density per cell, and a bitfield of the cells
//! worth sampling, so that ray marching skips empty space.
//!
//! Densities are stored as optical thickness over one reference step (`σ·Δ_ref`), so the
//! threshold is dimensionless: a cell is occupied when its value exceeds
//! `min(threshold, mean)`, the mean keeping a mostly transparent early field from culling
//! everything.
//!
//! A second, coarse bitfield marks blocks of [`BLOCK`]³ cells holding any occupied cell, so
//! that a marching ray crosses an empty block in one jump rather than cell by cell (rays that
//! miss the object crossed up to a few hundred empty cells, a third of a view's render).

use glam::{UVec3, Vec3};

/// Cells per side of a block of the coarse bitfield.
pub const BLOCK: u32 = 8;

/// The grid over an axis-aligned box.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyGrid {
    resolution: u32,
    min: Vec3,
    max: Vec3,
    thickness: Vec<f32>,
    bits: Vec<u64>,
    /// Derived from `bits`: one flag per block, true where some cell of it is occupied.
    blocks: Vec<bool>,
}

impl OccupancyGrid {
    /// A `resolution³` grid over `[min, max]` with every cell occupied and no density yet.
    pub fn new(resolution: u32, min: Vec3, max: Vec3) -> Self {
        assert!((1..=1024).contains(&resolution), "grid resolution must be in 1..=1024");
        assert!(max.cmpgt(min).all(), "the box must have positive size");
        let cells = (resolution as usize).pow(3);
        let bits = vec![u64::MAX; cells.div_ceil(64)];
        let mut grid = Self { resolution, min, max, thickness: vec![0.0; cells], bits, blocks: Vec::new() };
        grid.rebuild_blocks();
        grid
    }

    /// Blocks per axis.
    fn blocks_per_axis(&self) -> u32 {
        self.resolution.div_ceil(BLOCK)
    }

    /// The index of the block holding the cell at `c`.
    #[inline]
    fn block_index(&self, c: UVec3) -> usize {
        let (b, k) = (self.blocks_per_axis(), c / BLOCK);
        ((k.z * b + k.y) * b + k.x) as usize
    }

    fn rebuild_blocks(&mut self) {
        let r = self.resolution;
        let mut blocks = vec![false; (self.blocks_per_axis() as usize).pow(3)];
        for z in 0..r {
            for y in 0..r {
                for x in 0..r {
                    let c = UVec3::new(x, y, z);
                    if self.is_occupied(self.index(c)) {
                        blocks[self.block_index(c)] = true;
                    }
                }
            }
        }
        self.blocks = blocks;
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
        let u = (p - self.min) / (self.max - self.min);
        if u.cmplt(Vec3::ZERO).any() || u.cmpgt(Vec3::ONE).any() {
            return None;
        }
        let r = self.resolution;
        Some((u * r as f32).as_uvec3().min(UVec3::splat(r - 1)))
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

    /// The empty space around the empty cell at `c` that a ray may cross in one jump: its
    /// whole block where no cell of that is occupied, else the cell. The block is clipped to
    /// the grid.
    #[inline]
    pub fn empty_span(&self, c: UVec3) -> (Vec3, Vec3) {
        if self.blocks[self.block_index(c)] {
            return self.bounds_of(c);
        }
        let k = c / BLOCK;
        (self.corner(k * BLOCK), self.corner((k + 1) * BLOCK).min(self.max))
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
        (0..self.cells()).filter(|&i| self.is_occupied(i)).map(|i| i as u32).collect()
    }

    /// One update: every cell decays by `decay`, each `(cell, thickness)` observation raises
    /// its cell to at least that value, and the bitfield is rebuilt with the threshold
    /// `min(max_threshold, mean thickness)`. Returns the threshold used.
    pub fn update(&mut self, observations: &[(u32, f32)], decay: f32, max_threshold: f32) -> f32 {
        let mut fresh = vec![0f32; self.cells()];
        for &(cell, value) in observations {
            let slot = &mut fresh[cell as usize];
            *slot = slot.max(value);
        }
        let mut sum = 0.0f64;
        for (t, f) in self.thickness.iter_mut().zip(&fresh) {
            *t = (*t * decay).max(*f);
            sum += *t as f64;
        }
        let threshold = max_threshold.min((sum / self.cells() as f64) as f32);
        self.rebuild_bits(threshold);
        threshold
    }

    fn rebuild_bits(&mut self, threshold: f32) {
        self.bits.iter_mut().for_each(|b| *b = 0);
        for (i, &t) in self.thickness.iter().enumerate() {
            if t > threshold {
                self.bits[i / 64] |= 1 << (i % 64);
            }
        }
        self.rebuild_blocks();
    }

    /// A grid from its saved state (thickness per cell and bitfield words), or `None` when
    /// their lengths do not match the resolution.
    pub fn from_parts(resolution: u32, min: Vec3, max: Vec3, thickness: Vec<f32>, bits: Vec<u64>) -> Option<Self> {
        let cells = (resolution as usize).checked_pow(3)?;
        (thickness.len() == cells && bits.len() == cells.div_ceil(64)).then(|| {
            let mut grid = Self { resolution, min, max, thickness, bits, blocks: Vec::new() };
            grid.rebuild_blocks();
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
    }

    /// An empty cell in an all-empty block spans the block (cut at the grid's edge); one in a
    /// block holding an occupied cell spans only itself.
    #[test]
    fn an_empty_span_is_the_block_only_where_all_of_it_is_empty() {
        let mut g = OccupancyGrid::new(20, Vec3::splat(-1.0), Vec3::splat(1.0));
        let occupied = UVec3::new(3, 4, 5);
        let obs = [(g.index(occupied) as u32, 1.0)];
        g.update(&obs, 0.0, 0.5);
        assert!(g.is_occupied(g.index(occupied)) && g.occupied_fraction() * 8000.0 == 1.0);
        // The same block as the occupied cell: the cell alone.
        let c = UVec3::new(7, 0, 1);
        assert_eq!(g.empty_span(c), g.bounds_of(c));
        // Another block: all of it, cells 8..16 on x, 16..20 on y (the edge), 0..8 on z.
        let (lo, hi) = g.empty_span(UVec3::new(9, 17, 2));
        let cell = 0.1;
        assert!((lo - Vec3::new(-1.0 + 8.0 * cell, -1.0 + 16.0 * cell, -1.0)).abs().max_element() < 1e-6);
        assert!((hi - Vec3::new(-1.0 + 16.0 * cell, 1.0, -1.0 + 8.0 * cell)).abs().max_element() < 1e-6);
        // Saved and restored, the blocks are derived again.
        let back = OccupancyGrid::from_parts(20, g.min, g.max, g.thickness.clone(), g.bits.clone()).unwrap();
        assert_eq!(back, g);
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
