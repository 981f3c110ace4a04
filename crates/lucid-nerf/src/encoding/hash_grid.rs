//! The multiresolution hash encoding of Müller et al. (instant-ngp), as plain Rust over
//! slices: the layout of the levels in one parameter table, the forward trilinear lookup
//! and the backward scatter-add of gradients into the table.
//!
//! Written by hand because no crate provides it on the CPU; the fused field
//! ([`crate::field`], run as a burn op by [`crate::ops`]) calls these functions.
//!
//! Level `l` has the grid scale `s_l = N_min·b^l − 1` with `b = exp((ln N_max − ln N_min)/(L−1))`;
//! a point `x ∈ [0,1]³` sits at `x·s_l + 0.5` in grid units, and its 8 surrounding vertices
//! are looked up, densely where the level's `(⌈s_l⌉+2)³` vertices fit in the table, else
//! through the spatial hash `(x·1 ⊕ y·2654435761 ⊕ z·805459861) mod T`.

use lucid_scene::simd::wide;
use rayon::prelude::*;

/// Hyper-parameters of the encoding.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HashGridConfig {
    /// Number of levels `L`.
    pub levels: usize,
    /// Features per level `F`.
    pub features_per_level: usize,
    /// `log2` of the table size `T` per level.
    pub log2_table_size: u32,
    /// Resolution of the coarsest level `N_min`.
    pub base_resolution: f32,
    /// Resolution of the finest level `N_max` across the scene box's longest side; 0 lets
    /// the trainer choose it from the training views ([`HashGridConfig::finest_for_views`]),
    /// and stands for [`INSTANT_NGP_FINEST`] where no views chose it.
    pub finest_resolution: f32,
    /// Footprint weighting of the levels (Zip-NeRF's downweighting, scale-aware features):
    /// each level's features are multiplied by `erf(1/(√8·a·σ·s_l))`, where `σ` is the
    /// standard deviation of the sample's pixel footprint in box units, `s_l` the level's
    /// cells per unit and `a` this factor; 0 (the default) leaves every weight at 1.
    pub antialias: f32,
}

/// instant-ngp's finest resolution for NeRF, the stand-in for an unchosen one.
pub const INSTANT_NGP_FINEST: f32 = 2048.0;

/// Cells of the finest level per training pixel's footprint at the scene centre, when the
/// views choose the resolution: instant-ngp's ratio on NeRF-synthetic, whose 2048 cells span
/// the 3-unit box that 800-pixel views (focal length 1111 px) see from 4.03 units away, about
/// 2.5 cells per footprint. A fixed resolution is that many times too fine for views of a
/// quarter the size: on our 200x200 sets 512 cells scored 0.2-0.3 dB above 2048 at 120 s
/// (README, "finest resolution").
pub const FINEST_CELLS_PER_PIXEL: f32 = 2.5;

/// The largest resolution the views may choose: beyond it even 4K views of a distant object
/// would only spread the same table over more collisions.
const MAX_CHOSEN_FINEST: f32 = 8192.0;

impl Default for HashGridConfig {
    /// instant-ngp's NeRF encoding with three changes for the CPU. A 2^15 table instead of
    /// 2^19: the table's Adam step and gradient scatter grow with its size (2^19 halved
    /// training throughput in our measurements), and on the benchmark sets a smaller table
    /// also scored better at an equal number of steps (each entry gets more gradient; toys'
    /// validation views at 27 000 steps: 36.30, 36.36 and 36.47 dB at 2^17, 2^16 and 2^15;
    /// README, "A smaller hash table"). 8 levels of 4 features instead of 16 of 2: the same 32 inputs
    /// to the MLP from half the table lookups, each row one 16-byte load, where a lookup on a
    /// large level is a cache miss; in 10 minutes on the benchmark sets' validation views
    /// 13 % (trophy) and 18 % (toys) more steps, +0.13 and +0.17 dB, views rendered 1.3x and
    /// 1.7x as fast (README, "Eight levels of four features"). And the finest resolution left to
    /// the training views (instant-ngp's 2048 is its ratio to the pixel footprint of
    /// 800-pixel views).
    fn default() -> Self {
        Self {
            levels: 8,
            features_per_level: 4,
            log2_table_size: 15,
            base_resolution: 16.0,
            finest_resolution: 0.0,
            antialias: 0.0,
        }
    }
}

impl HashGridConfig {
    /// The finest level's resolution in use: the configured one, or instant-ngp's where it
    /// was left to the views and none chose it.
    pub fn finest(&self) -> f32 {
        if self.finest_resolution > 0.0 { self.finest_resolution } else { INSTANT_NGP_FINEST.max(self.base_resolution) }
    }

    /// The finest resolution for a box whose longest side is `extent`, seen by views whose
    /// pixels span `pixel_angle` radians from `distance` away from its centre:
    /// [`FINEST_CELLS_PER_PIXEL`] cells per pixel footprint there, within the base resolution
    /// and [`MAX_CHOSEN_FINEST`].
    pub fn finest_for_views(&self, extent: f32, pixel_angle: f32, distance: f32) -> f32 {
        let footprint = pixel_angle * distance;
        if !(footprint > 0.0 && extent > 0.0 && footprint.is_finite() && extent.is_finite()) {
            return self.finest();
        }
        (FINEST_CELLS_PER_PIXEL * extent / footprint)
            .clamp(self.base_resolution, MAX_CHOSEN_FINEST.max(self.base_resolution))
    }

    /// Growth factor `b` between levels.
    pub fn per_level_scale(&self) -> f32 {
        if self.levels <= 1 {
            return 1.0;
        }
        ((self.finest().ln() - self.base_resolution.ln()) / (self.levels - 1) as f32).exp()
    }

    /// Width of the encoded feature vector, `L·F`.
    pub fn output_dim(&self) -> usize {
        self.levels * self.features_per_level
    }

    /// Checks the values; the message says which one is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if self.levels == 0 || self.levels > 64 {
            return Err(format!("levels must be in 1..=64, got {}", self.levels));
        }
        if self.features_per_level == 0 || self.features_per_level > 16 {
            return Err(format!("features_per_level must be in 1..=16, got {}", self.features_per_level));
        }
        if !(4..=26).contains(&self.log2_table_size) {
            return Err(format!("log2_table_size must be in 4..=26, got {}", self.log2_table_size));
        }
        if !(self.base_resolution >= 2.0 && self.base_resolution.is_finite()) {
            return Err(format!("base_resolution must be at least 2, got {}", self.base_resolution));
        }
        let chosen_by_views = self.finest_resolution == 0.0;
        let fixed = self.finest_resolution >= self.base_resolution && self.finest_resolution.is_finite();
        if !(chosen_by_views || fixed) {
            return Err(format!(
                "finest_resolution ({}) must be 0 (chosen from the views) or at least base_resolution ({})",
                self.finest_resolution, self.base_resolution
            ));
        }
        if !(self.antialias >= 0.0 && self.antialias.is_finite()) {
            return Err(format!("antialias must be zero or positive, got {}", self.antialias));
        }
        Ok(())
    }

    /// Where each level lives in the table.
    pub fn layout(&self) -> HashGridLayout {
        let table_size = 1usize << self.log2_table_size;
        let b = self.per_level_scale();
        let mut offset = 0;
        let levels = (0..self.levels)
            .map(|l| {
                let scale = self.base_resolution * b.powi(l as i32) - 1.0;
                let resolution = scale.ceil() as usize + 2;
                let dense_size = resolution.checked_pow(3).unwrap_or(usize::MAX);
                let (size, dense) = if dense_size <= table_size { (dense_size, true) } else { (table_size, false) };
                let level = LevelLayout { scale, resolution: resolution as u32, offset, size, dense };
                offset += size;
                level
            })
            .collect();
        HashGridLayout { levels, entries: offset, features: self.features_per_level, antialias: self.antialias }
    }
}

/// One level's place in the parameter table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelLayout {
    /// Grid scale `s_l`: a point `x` sits at `x·s_l + 0.5` grid units.
    pub scale: f32,
    /// Vertices per axis of the dense grid.
    pub resolution: u32,
    /// First table row of this level.
    pub offset: usize,
    /// Rows of this level.
    pub size: usize,
    /// Dense indexing (no hash collisions) when the grid fits.
    pub dense: bool,
}

impl LevelLayout {
    /// Table row (relative to the level) of grid vertex `v`.
    #[inline]
    pub fn index(&self, v: [u32; 3]) -> usize {
        if self.dense {
            let r = self.resolution as usize;
            v[0] as usize + r * (v[1] as usize + r * v[2] as usize)
        } else {
            let h = v[0] ^ v[1].wrapping_mul(2_654_435_761) ^ v[2].wrapping_mul(805_459_861);
            h as usize & (self.size - 1)
        }
    }

    /// The 8 (row, weight) pairs of trilinear interpolation at `x ∈ [0,1]³` (clamped),
    /// rows absolute in the table. Corner `c` is offset by `(c&1, c>>1&1, c>>2)`.
    #[inline(always)]
    pub fn corners(&self, x: [f32; 3]) -> [(usize, f32); 8] {
        let max_vertex = self.resolution - 2;
        let mut base = [0u32; 3];
        let mut w = [[0f32; 2]; 3];
        for a in 0..3 {
            // p ≥ 0.5, so truncation is the floor (and avoids a libm call without SSE4.1).
            let p = x[a].clamp(0.0, 1.0) * self.scale + 0.5;
            base[a] = (p as u32).min(max_vertex);
            let f = p - base[a] as f32;
            w[a] = [1.0 - f, f];
        }
        let rows: [usize; 8] = if self.dense {
            let r = self.resolution as usize;
            let i0 = base[0] as usize + r * (base[1] as usize + r * base[2] as usize);
            let (dy, dz) = (r, r * r);
            [i0, i0 + 1, i0 + dy, i0 + dy + 1, i0 + dz, i0 + dz + 1, i0 + dz + dy, i0 + dz + dy + 1]
        } else {
            let mask = self.size - 1;
            let hx = [base[0], base[0] + 1];
            let hy = [base[1].wrapping_mul(2_654_435_761), (base[1] + 1).wrapping_mul(2_654_435_761)];
            let hz = [base[2].wrapping_mul(805_459_861), (base[2] + 1).wrapping_mul(805_459_861)];
            std::array::from_fn(|c| (hx[c & 1] ^ hy[(c >> 1) & 1] ^ hz[c >> 2]) as usize & mask)
        };
        let wxy = [w[0][0] * w[1][0], w[0][1] * w[1][0], w[0][0] * w[1][1], w[0][1] * w[1][1]];
        std::array::from_fn(|c| (self.offset + rows[c], wxy[c & 3] * w[2][c >> 2]))
    }
}

impl LevelLayout {
    /// [`LevelLayout::corners`] of point `i` of `positions`, rows less `base`.
    #[inline(always)]
    fn corners_of(&self, positions: &[f32], i: usize, base: usize) -> [(usize, f32); 8] {
        self.corners([positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]]).map(|(r, w)| (r - base, w))
    }

    /// Calls `visit(i, corners, rows)` for each point `i` of `positions` (`n×3`) in order, with its
    /// corners' rows less `base` (a level's segment of a table starts at `base`). On a large
    /// level each point's rows in `rows` are prefetched [`AHEAD`] points before `visit` gets
    /// them, so the cache misses of consecutive points overlap.
    #[inline(always)]
    fn for_each_prefetched<R: AsRef<[f32]>>(
        &self,
        positions: &[f32],
        rows: &mut R,
        features: usize,
        base: usize,
        mut visit: impl FnMut(usize, [(usize, f32); 8], &mut R),
    ) {
        let n = positions.len() / 3;
        let far = self.size * features * std::mem::size_of::<f32>() > PREFETCH_ABOVE_BYTES;
        let mut ring = [[(0usize, 0f32); 8]; AHEAD];
        for (i, slot) in ring.iter_mut().enumerate().take(n) {
            *slot = self.corners_of(positions, i, base);
            if far {
                prefetch_rows(rows.as_ref(), features, slot);
            }
        }
        for i in 0..n {
            let current = ring[i % AHEAD];
            if i + AHEAD < n {
                // (A method, not a closure: closures were left out of `wide`'s AVX2 build.)
                let next = self.corners_of(positions, i + AHEAD, base);
                if far {
                    prefetch_rows(rows.as_ref(), features, &next);
                }
                ring[i % AHEAD] = next;
            }
            visit(i, current, rows);
        }
    }
}

/// The levels of a configured encoding and the table they share.
#[derive(Clone, Debug, PartialEq)]
pub struct HashGridLayout {
    /// Per-level placement.
    pub levels: Vec<LevelLayout>,
    /// Total rows of the table.
    pub entries: usize,
    /// Features per row.
    pub features: usize,
    /// The footprint weighting's factor ([`HashGridConfig::antialias`]; 0: off).
    pub antialias: f32,
}

/// Points per parallel task: large enough to amortise scheduling, small enough to balance.
const CHUNK: usize = 512;

/// How many points ahead [`HashGridLayout::encode_chunk`] prefetches a level's rows.
const AHEAD: usize = 16;
/// Levels larger than this are prefetched (smaller ones stay in the cache anyway).
const PREFETCH_ABOVE_BYTES: usize = 256 << 10;

/// Asks the cache for the table rows of 8 corners.
#[inline(always)]
fn prefetch_rows(table: &[f32], features: usize, corners: &[(usize, f32); 8]) {
    for &(row, _) in corners {
        lucid_scene::prefetch::prefetch(table, row * features);
    }
}

impl HashGridLayout {
    /// Width of the output per point.
    pub fn output_dim(&self) -> usize {
        self.levels.len() * self.features
    }

    /// Encodes `positions` (`N×3`, in `[0,1]`) with `table` (`entries×F`) into `out` (`N×L·F`).
    pub fn forward(&self, positions: &[f32], table: &[f32], out: &mut [f32]) {
        let (f, width) = (self.features, self.output_dim());
        assert_eq!(table.len(), self.entries * f, "table has the wrong size");
        assert_eq!(out.len(), positions.len() / 3 * width, "output has the wrong size");
        out.par_chunks_mut(CHUNK * width)
            .zip(positions.par_chunks(CHUNK * 3))
            .for_each(|(out, pos)| self.encode_chunk(pos, table, out, width));
    }

    /// Encodes one point into `out` (`L·F` values), serially: for callers that already run
    /// in a parallel task (the fused field kernel).
    #[inline]
    pub fn encode_point(&self, p: [f32; 3], table: &[f32], out: &mut [f32]) {
        let f = self.features;
        if f == 2 {
            // The common case, unrolled: two features per row.
            for (l, level) in self.levels.iter().enumerate() {
                let (mut a0, mut a1) = (0.0, 0.0);
                for (row, w) in level.corners(p) {
                    let t = &table[2 * row..2 * row + 2];
                    a0 += w * t[0];
                    a1 += w * t[1];
                }
                out[2 * l] = a0;
                out[2 * l + 1] = a1;
            }
            return;
        }
        for (l, level) in self.levels.iter().enumerate() {
            let acc = &mut out[l * f..(l + 1) * f];
            acc.fill(0.0);
            for (row, w) in level.corners(p) {
                for (a, t) in acc.iter_mut().zip(&table[row * f..(row + 1) * f]) {
                    *a += w * t;
                }
            }
        }
    }

    /// Encodes a chunk of points (`positions`, `n×3`) into the first `L·F` columns of the
    /// rows of `act` (row `i` at `i·stride`), serially, for callers already in a parallel
    /// task. The same numbers as [`Self::encode_point`] per point, computed level by level:
    /// consecutive samples along a ray share coarse cells (cache hits), and each point's rows
    /// on the large levels are prefetched [`AHEAD`] points before they are read, so the
    /// table's cache misses overlap instead of stalling one after another (the lookups of a
    /// large level are ~all misses, and they were ~60 % of a view's render time).
    pub fn encode_chunk(&self, positions: &[f32], table: &[f32], act: &mut [f32], stride: usize) {
        wide(
            #[inline(always)]
            || self.encode_chunk_in(positions, table, act, stride),
        )
    }

    #[inline(always)]
    fn encode_chunk_in(&self, positions: &[f32], table: &[f32], act: &mut [f32], stride: usize) {
        let n = positions.len() / 3;
        assert!(n == 0 || act.len() >= (n - 1) * stride + self.output_dim(), "activation rows too short");
        // The common row widths with the width known to the compiler, so that a row is
        // loaded and blended as one vector (the table's misses set the pace, not these).
        match self.features {
            2 => self.encode_rows::<2>(positions, table, act, stride),
            4 => self.encode_rows::<4>(positions, table, act, stride),
            f => {
                for (l, level) in self.levels.iter().enumerate() {
                    level.for_each_prefetched(positions, &mut { table }, f, 0, |i, corners, table| {
                        let out = &mut act[i * stride + l * f..i * stride + (l + 1) * f];
                        out.fill(0.0);
                        for (row, w) in corners {
                            for (a, t) in out.iter_mut().zip(&table[row * f..(row + 1) * f]) {
                                *a += w * t;
                            }
                        }
                    });
                }
            }
        }
    }

    /// [`Self::encode_chunk_in`] for rows of `F` features.
    #[inline(always)]
    fn encode_rows<const F: usize>(&self, positions: &[f32], table: &[f32], act: &mut [f32], stride: usize) {
        for (l, level) in self.levels.iter().enumerate() {
            level.for_each_prefetched(positions, &mut { table }, F, 0, |i, corners, table| {
                let mut acc = [0f32; F];
                for (row, w) in corners {
                    let t: &[f32; F] = table[F * row..F * row + F].try_into().expect("a row");
                    for (a, t) in acc.iter_mut().zip(t) {
                        *a += w * t;
                    }
                }
                act[i * stride + l * F..i * stride + (l + 1) * F].copy_from_slice(&acc);
            });
        }
    }

    /// Level `l`'s weight for a sample whose footprint has standard deviation `footprint` (box
    /// units): Zip-NeRF's `erf(1/√(8·σ²·s_l²))` with `σ = a·footprint`, the mean of a level's
    /// trilinear features over a Gaussian of that width falls off about so once its cells are
    /// finer than the footprint. 1 where weighting is off or the footprint is zero.
    #[inline]
    pub fn footprint_weight(&self, l: usize, footprint: f32) -> f32 {
        let x = self.antialias * footprint * self.levels[l].scale * std::f32::consts::SQRT_2 * 2.0;
        // erf(1/x) = 1 to 2.3·10⁻⁵ once 1/x ≥ 3: coarse levels skip the call.
        if x <= 1.0 / 3.0 { 1.0 } else { libm::erff(1.0 / x) }
    }

    /// Multiplies each level's features in the first `L·F` columns of the rows of `rows`
    /// (row `i` at `i·stride`) by [`Self::footprint_weight`] of footprint `footprints[i]`:
    /// after the forward's encoding, and on its gradient before the scatter.
    pub fn weigh_by_footprint(&self, rows: &mut [f32], stride: usize, footprints: &[f32]) {
        if self.antialias == 0.0 {
            return;
        }
        let f = self.features;
        for (i, &sigma) in footprints.iter().enumerate() {
            for l in 0..self.levels.len() {
                let w = self.footprint_weight(l, sigma);
                if w != 1.0 {
                    rows[i * stride + l * f..i * stride + (l + 1) * f].iter_mut().for_each(|v| *v *= w);
                }
            }
        }
    }

    /// Scatters one level's gradients for rows of `F` features (`F = 0`: the configured width,
    /// unknown to the compiler).
    #[inline(always)]
    fn scatter_level<const F: usize>(
        &self,
        l: usize,
        level: &LevelLayout,
        positions: &[f32],
        grad_out: &[f32],
        seg: &mut [f32],
    ) {
        let (f, width) = (if F == 0 { self.features } else { F }, self.output_dim());
        level.for_each_prefetched(positions, &mut { seg }, f, level.offset, |i, corners, seg| {
            let g = &grad_out[i * width + l * f..i * width + (l + 1) * f];
            for (row, w) in corners {
                for (dst, gv) in seg[row * f..(row + 1) * f].iter_mut().zip(g) {
                    *dst += w * gv;
                }
            }
        })
    }

    /// Accumulates `∂loss/∂table` into `grad_table` (`entries×F`, zeroed by the caller) from
    /// `∂loss/∂out` (`N×L·F`). Parallel over levels: their rows are disjoint, so no two tasks
    /// write the same row and no atomics or per-thread copies of the table are needed.
    pub fn backward(&self, positions: &[f32], grad_out: &[f32], grad_table: &mut [f32]) {
        let f = self.features;
        assert_eq!(grad_table.len(), self.entries * f, "gradient table has the wrong size");
        let mut segments = Vec::with_capacity(self.levels.len());
        let mut rest = grad_table;
        for level in &self.levels {
            let (seg, tail) = rest.split_at_mut(level.size * f);
            segments.push(seg);
            rest = tail;
        }
        segments.into_par_iter().zip(self.levels.par_iter().enumerate()).for_each(|(seg, (l, level))| {
            // Rows relative to the level's segment.
            wide(
                #[inline(always)]
                || match f {
                    2 => self.scatter_level::<2>(l, level, positions, grad_out, seg),
                    4 => self.scatter_level::<4>(l, level, positions, grad_out, seg),
                    _ => self.scatter_level::<0>(l, level, positions, grad_out, seg),
                },
            );
        });
    }
}

#[cfg(test)]
mod tests;
