//! The tile rasterizer: binning of projected splats into 16×16 tiles in depth order,
//! front-to-back alpha compositing per tile, and the exact backward traversing each tile back
//! to front.
//!
//! Inside a tile the loops run Gaussian-outer, pixel-inner: a splat's kernel constants,
//! prepared once per call, are loaded once (prefetched a few splats ahead) and blended into
//! the tile's pixels, and in the backward its gradient is summed over the tile's pixels in
//! registers and stored once per (tile, splat) pair. Those per-pair gradients are then summed
//! per splat in a fixed order, so results do not depend on the thread count.
//!
//! A splat covers a tile row's span (its blend-threshold ellipse cut by the row) with 8-pixel
//! runs. The forward keeps runs at the rows' halves: a run then reads exactly the lanes an
//! earlier run stored, which the CPU forwards from its store buffer, while a run shifted
//! against the stores before it waits for them. The backward, which stores less per run,
//! places one run over a span at most 8 wide (most splats of a trained cloud are a few pixels
//! across, and one straddling the tile's middle column would otherwise take two mostly idle
//! runs).

use lucid_scene::prefetch::prefetch;
use rayon::prelude::*;

use crate::blend::{BackwardRun, ForwardRun, GradLanes, LANES, SplatLanes, backward_run, forward_run};
use lucid_scene::simd::wide;

use crate::project::{ProjectedGrad, ProjectedSplat};

/// Tile side in pixels.
pub use crate::blend::TILE;
const TILE_PIXELS: usize = TILE * TILE;
/// Opacity cap: no splat fully hides what is behind it (keeps the backward's division safe).
pub const MAX_ALPHA: f32 = 0.99;
/// A pixel stops once its transmittance would fall below this.
pub const MIN_TRANSMITTANCE: f32 = 1e-4;

/// Splats per tile, each tile's list sorted front to back.
#[derive(Clone, Debug, Default)]
pub struct TileBins {
    /// Tiles across.
    pub tiles_x: usize,
    /// Tiles down.
    pub tiles_y: usize,
    /// `offsets[t]..offsets[t+1]` indexes `ids` for tile `t` (row-major tiles).
    pub offsets: Vec<usize>,
    /// Splat index of each (tile, splat) pair.
    pub ids: Vec<u32>,
    /// The binned splats, nearest first.
    pub splats: Vec<u32>,
    /// `splat_offsets[k]..splat_offsets[k+1]` indexes `splat_pairs` for `splats[k]`.
    pub splat_offsets: Vec<usize>,
    /// Positions in `ids` of each binned splat's pairs, in tile order: the backward sums a
    /// splat's per-tile gradients through them, in parallel over splats.
    pub splat_pairs: Vec<u32>,
    /// Per splat index, its position in `splats` ([`NOT_BINNED`] for a splat off screen).
    pub slots: Vec<u32>,
}

/// [`TileBins::slots`] of a splat in no tile.
pub const NOT_BINNED: u32 = u32::MAX;

impl TileBins {
    /// Number of (tile, splat) pairs.
    pub fn pairs(&self) -> usize {
        self.ids.len()
    }
}

/// The pixels a splat can touch along one axis, `[first, last]` (may be empty or off-image):
/// pixel `i` (centre `i + 0.5`) is in reach when `|i + 0.5 − mean| ≤ half`.
#[inline(always)]
fn pixel_span(mean: f32, half: f32) -> (i64, i64) {
    (-floor(half + 0.5 - mean), floor(mean + half - 0.5))
}

/// `⌊x⌋` for finite `x` in the `i64` range: `f32::floor` is a libm call on baseline x86-64,
/// and this runs for every (tile, splat) pair.
#[inline(always)]
fn floor(x: f32) -> i64 {
    let i = x as i64;
    i - ((x < i as f32) as i64)
}

/// The tiles a splat's pixel box touches, as `[x0, x1) × [y0, y1)`; empty if off-screen.
fn tile_rect(s: &ProjectedSplat, tiles_x: usize, tiles_y: usize) -> (usize, usize, usize, usize) {
    if s.radius <= 0.0 {
        return (0, 0, 0, 0);
    }
    let t = TILE as i64;
    let span = |mean: f32, half: f32, tiles: usize| {
        let (a, b) = pixel_span(mean, half);
        if b < a || b < 0 {
            return (0, 0);
        }
        ((a.max(0) / t).min(tiles as i64) as usize, ((b / t) + 1).clamp(0, tiles as i64) as usize)
    };
    let (x0, x1) = span(s.mean.x, s.half_extent.x, tiles_x);
    let (y0, y1) = span(s.mean.y, s.half_extent.y, tiles_y);
    if x0 >= x1 || y0 >= y1 {
        return (0, 0, 0, 0);
    }
    (x0, x1, y0, y1)
}

/// The pixel box `[x0, x1) × [y0, y1)` of a splat, kept within a tile of the image's edges
/// (a splat close to the camera can reach far beyond them).
#[inline(always)]
fn pixel_rect(s: &ProjectedSplat, width: usize, height: usize) -> [i32; 4] {
    let clip = |mean: f32, half: f32, size: usize| {
        let (a, b) = pixel_span(mean, half);
        let reach = (size + TILE) as i64;
        (a.clamp(-1, reach) as i32, (b + 1).clamp(-1, reach) as i32)
    };
    let (x0, x1) = clip(s.mean.x, s.half_extent.x, width);
    let (y0, y1) = clip(s.mean.y, s.half_extent.y, height);
    [x0, x1, y0, y1]
}

/// A splat ready for the kernels: its constants and its pixel box.
#[derive(Clone, Copy, Debug, Default)]
pub struct PreparedSplat {
    lanes: SplatLanes,
    rect: [i32; 4],
}

impl PreparedSplat {
    /// The box inside the tile with top-left pixel `origin`, in tile pixels.
    #[inline(always)]
    fn tile_rect(&self, origin: [i32; 2]) -> [usize; 4] {
        let [x0, x1, y0, y1] = self.rect;
        let clip = |v: i32, o: i32| (v - o).clamp(0, TILE as i32) as usize;
        [clip(x0, origin[0]), clip(x1, origin[0]), clip(y0, origin[1]), clip(y1, origin[1])]
    }
}

/// Every splat prepared once per call rather than once per tile it touches, in index order
/// (read in order, where the depth order of the binned splats made each read a cache miss).
/// Collected in parallel: the scalar arithmetic gains nothing from [`wide`], and a vector
/// filled with defaults first was a serial third of this.
fn prepare(splats: &[ProjectedSplat], bins: &TileBins, min_alpha: f32) -> Vec<PreparedSplat> {
    let (width, height) = (bins.tiles_x * TILE, bins.tiles_y * TILE);
    let log_min_alpha = min_alpha.ln();
    splats
        .par_iter()
        .with_min_len(1024)
        .map(|s| {
            if s.radius > 0.0 {
                PreparedSplat { lanes: SplatLanes::new(s, log_min_alpha), rect: pixel_rect(s, width, height) }
            } else {
                PreparedSplat::default()
            }
        })
        .collect()
}

/// Bins the splats of a `width × height` image: each tile lists the splats whose 3σ square
/// overlaps it, nearest first (ties by index, so the order is deterministic).
pub fn bin(splats: &[ProjectedSplat], width: usize, height: usize) -> TileBins {
    let (tiles_x, tiles_y) = (width.div_ceil(TILE), height.div_ceil(TILE));
    // Sort keys: the depth's bits (positive floats order as integers) above the index, so the
    // order is total and deterministic and the sort touches no splat data.
    let mut keys: Vec<u64> = splats
        .iter()
        .enumerate()
        .filter(|(_, s)| s.radius > 0.0)
        .map(|(i, s)| ((s.depth.max(0.0).to_bits() as u64) << 32) | i as u64)
        .collect();
    keys.par_sort_unstable();
    let rects: Vec<(u32, (usize, usize, usize, usize))> =
        keys.par_iter().map(|k| (*k as u32, tile_rect(&splats[*k as u32 as usize], tiles_x, tiles_y))).collect();
    let mut counts = vec![0usize; tiles_x * tiles_y + 1];
    for &(_, (x0, x1, y0, y1)) in &rects {
        for ty in y0..y1 {
            for tx in x0..x1 {
                counts[ty * tiles_x + tx + 1] += 1;
            }
        }
    }
    for t in 1..counts.len() {
        counts[t] += counts[t - 1];
    }
    let offsets = counts.clone();
    let mut cursor = counts;
    let pairs = *offsets.last().unwrap_or(&0);
    let mut ids = vec![0u32; pairs];
    let mut splat_offsets = Vec::with_capacity(rects.len() + 1);
    let mut splat_pairs = Vec::with_capacity(pairs);
    splat_offsets.push(0);
    let mut slots = vec![NOT_BINNED; splats.len()];
    for (k, &(i, (x0, x1, y0, y1))) in rects.iter().enumerate() {
        slots[i as usize] = k as u32;
        for ty in y0..y1 {
            for tx in x0..x1 {
                let t = ty * tiles_x + tx;
                ids[cursor[t]] = i;
                splat_pairs.push(cursor[t] as u32);
                cursor[t] += 1;
            }
        }
        splat_offsets.push(splat_pairs.len());
    }
    let splats = rects.iter().map(|r| r.0).collect();
    TileBins { tiles_x, tiles_y, offsets, ids, splats, splat_offsets, splat_pairs, slots }
}

/// How many entries of a tile's list ahead the kernels prefetch.
const PREFETCH_AHEAD: usize = 8;

/// Before `splats[ids[k]]` is read, asks the cache for the record [`PREFETCH_AHEAD`] entries
/// further down the list (and, at the first entry, for the ones before that): a tile's list is
/// in depth order and jumps through the array, which the hardware prefetcher cannot follow.
#[inline(always)]
fn prefetch_ahead<T>(splats: &[T], ids: &[u32], k: usize) {
    if k == 0 {
        for &i in &ids[..ids.len().min(PREFETCH_AHEAD)] {
            prefetch(splats, i as usize);
        }
    }
    if let Some(&ahead) = ids.get(k + PREFETCH_AHEAD) {
        prefetch(splats, ahead as usize);
    }
}

/// What the backward needs from the forward, per pixel.
#[derive(Clone, Debug, Default)]
pub struct PixelState {
    /// Transmittance left after the last blended splat.
    pub final_t: Vec<f32>,
    /// Number of leading splats of the pixel's tile list that were considered (the last
    /// blended one is at `n_contrib − 1`).
    pub n_contrib: Vec<u32>,
    /// `Σ wᵢ·depthᵢ` over the blended splats (divide by the alpha for the expected depth;
    /// not differentiated).
    pub depth: Vec<f32>,
    /// Splat-pixel blends performed (the rasterizer's unit of work, for benchmarks).
    pub blends: u64,
    /// Per (tile, splat) pair, in the order of [`TileBins::ids`], whether the splat blended
    /// into any pixel of the tile. The others (a box corner the footprint does not reach,
    /// pixels already stopped) have a zero gradient, and the backward skips them.
    pub blended_pairs: Vec<bool>,
    /// The splats as the kernels read them (built by the forward, reused by the backward).
    pub prepared: Vec<PreparedSplat>,
}

/// The image rows of tile `t`: `(tile index, image index)` of each row's first pixel, and
/// the row's length (a tile at the image's right edge is cut short). Loops over a row's pixels
/// then index both arrays contiguously, with no per-pixel bounds test.
fn tile_rows(t: usize, bins: &TileBins, width: usize, height: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    let (x0, y0) = ((t % bins.tiles_x) * TILE, (t / bins.tiles_x) * TILE);
    let len = width.saturating_sub(x0).min(TILE);
    (0..TILE.min(height.saturating_sub(y0))).map(move |ly| (ly * TILE, (y0 + ly) * width + x0, len))
}

/// Composites the binned splats front to back over `background`: returns the `H×W×4` image
/// (RGB, then alpha = 1 − final transmittance) and the state for the backward.
pub fn rasterize(
    splats: &[ProjectedSplat],
    bins: &TileBins,
    width: usize,
    height: usize,
    background: [f32; 3],
    min_alpha: f32,
) -> (Vec<f32>, PixelState) {
    let prepared = prepare(splats, bins, min_alpha);
    let tiles: Vec<_> = heaviest_first(bins)
        .into_par_iter()
        .map(|t| {
            let tile = wide(
                #[inline(always)]
                || {
                    let (tx, ty) = (t % bins.tiles_x, t / bins.tiles_x);
                    let mut trans = TileArray([1.0f32; TILE_PIXELS]);
                    let mut rgb = [TileArray([0.0f32; TILE_PIXELS]); 3];
                    let mut depth = TileArray([0.0f32; TILE_PIXELS]);
                    let mut last = TileArray([0f32; TILE_PIXELS]);
                    let mut done = TileArray([0f32; TILE_PIXELS]);
                    // Runs with a pixel still blending, one bit each (forward runs lie at the
                    // rows' halves: bit `k` is the run at offset `8k`): runs whose pixels have
                    // all stopped are skipped (behind an opaque surface most of a tile's list
                    // is), and the tile ends when none is left.
                    let mut live_runs = u32::MAX;
                    for (k, d) in done.iter_mut().enumerate() {
                        if tx * TILE + k % TILE >= width || ty * TILE + k / TILE >= height {
                            *d = -1.0;
                        }
                    }
                    for (k, run) in done.chunks_exact(LANES).enumerate() {
                        live_runs &= !((run.iter().all(|&d| d < 0.0) as u32) << k);
                    }
                    let (left, top) = ((tx * TILE) as f32, (ty * TILE) as f32);
                    let origin = [(tx * TILE) as i32, (ty * TILE) as i32];
                    let mut blends = 0u64;
                    let list = &bins.ids[bins.offsets[t]..bins.offsets[t + 1]];
                    let mut blended_pairs = vec![false; list.len()];
                    for (j, &i) in list.iter().enumerate() {
                        if live_runs == 0 {
                            break;
                        }
                        prefetch_ahead(&prepared, list, j);
                        let ps = &prepared[i as usize];
                        let lanes_of = &ps.lanes;
                        let runs = lanes_of.tile_runs(left, top, ps.tile_rect(origin), u32::MAX, false);
                        // One bit per run, found by bit scan: a loop over rows and runs
                        // mispredicted about once per row.
                        let mut pending = runs.mask & live_runs;
                        while pending != 0 {
                            let bit = pending.trailing_zeros();
                            pending &= pending - 1;
                            let (o, run) = runs.run(bit);
                            let [r, g, b] = &mut rgb;
                            let (blended, stopped) = forward_run(
                                lanes_of,
                                j as u32 + 1,
                                run,
                                min_alpha,
                                ForwardRun {
                                    trans: lanes_mut(&mut trans, o),
                                    rgb: [lanes_mut(r, o), lanes_mut(g, o), lanes_mut(b, o)],
                                    depth: lanes_mut(&mut depth, o),
                                    last: lanes_mut(&mut last, o),
                                    done: lanes_mut(&mut done, o),
                                },
                            );
                            blends += blended.count_ones() as u64;
                            blended_pairs[j] |= blended != 0;
                            live_runs &= !((stopped as u32) << bit);
                        }
                    }
                    (trans, rgb, last, depth, blends, blended_pairs)
                },
            );
            (t, tile)
        })
        .collect();
    let mut at = vec![0; tiles.len()];
    for (k, (t, _)) in tiles.iter().enumerate() {
        at[*t] = k;
    }
    let mut image = vec![0.0f32; width * height * 4];
    let mut state = PixelState {
        final_t: vec![1.0; width * height],
        n_contrib: vec![0; width * height],
        depth: vec![0.0; width * height],
        blends: 0,
        blended_pairs: Vec::with_capacity(bins.pairs()),
        prepared: Vec::new(),
    };
    for &k in &at {
        let (_, (.., blends, blended_pairs)) = &tiles[k];
        state.blends += blends;
        state.blended_pairs.extend_from_slice(blended_pairs);
    }
    // The pixels, in parallel over rows of tiles (each a block of image rows).
    let rows = TILE * width;
    image
        .par_chunks_mut(4 * rows)
        .zip(state.final_t.par_chunks_mut(rows))
        .zip(state.n_contrib.par_chunks_mut(rows).zip(state.depth.par_chunks_mut(rows)))
        .enumerate()
        .for_each(|(ty, ((image, final_t), (n_contrib, depth_out)))| {
            for tx in 0..bins.tiles_x {
                let (_, (trans, rgb, last, depth, ..)) = &tiles[at[ty * bins.tiles_x + tx]];
                for (k0, idx0, len) in tile_rows(ty * bins.tiles_x + tx, bins, width, height) {
                    let idx0 = idx0 - ty * rows;
                    let pixels = &mut image[4 * idx0..4 * (idx0 + len)];
                    for (i, px) in pixels.chunks_exact_mut(4).enumerate() {
                        let (k, t) = (k0 + i, trans[k0 + i]);
                        px.copy_from_slice(&[
                            rgb[0][k] + t * background[0],
                            rgb[1][k] + t * background[1],
                            rgb[2][k] + t * background[2],
                            1.0 - t,
                        ]);
                    }
                    final_t[idx0..idx0 + len].copy_from_slice(&trans[k0..k0 + len]);
                    for (n, &l) in n_contrib[idx0..idx0 + len].iter_mut().zip(&last[k0..k0 + len]) {
                        *n = l as u32;
                    }
                    depth_out[idx0..idx0 + len].copy_from_slice(&depth[k0..k0 + len]);
                }
            }
        });
    state.prepared = prepared;
    (image, state)
}

/// The tiles, those with the longest lists first: the parallel loops then end on short tiles,
/// and a thread left alone with the heaviest one does not hold up the rest.
fn heaviest_first(bins: &TileBins) -> Vec<usize> {
    let mut order: Vec<usize> = (0..bins.tiles_x * bins.tiles_y).collect();
    order.sort_by_key(|&t| std::cmp::Reverse(bins.offsets[t + 1] - bins.offsets[t]));
    order
}

/// A tile's values of one kind, aligned to a cache line: a tile row is then one line, so no
/// run's loads or stores are split across two (a split store is not forwarded to the loads
/// after it, and the next splat's run waits for it to reach the cache).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct TileArray<T>([T; TILE_PIXELS]);

impl<T> std::ops::Deref for TileArray<T> {
    type Target = [T; TILE_PIXELS];
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl<T> std::ops::DerefMut for TileArray<T> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

#[inline(always)]
fn lanes_mut<T>(a: &mut [T; TILE_PIXELS], o: usize) -> &mut [T; LANES] {
    (&mut a[o..o + LANES]).try_into().expect("runs lie inside the tile")
}

#[inline(always)]
fn lanes<T>(a: &[T; TILE_PIXELS], o: usize) -> &[T; LANES] {
    (&a[o..o + LANES]).try_into().expect("runs lie inside the tile")
}

/// `∂loss/∂` every splat's screen quantities from `∂loss/∂image` (`H×W×4`, as
/// [`rasterize`] returns).
#[allow(clippy::too_many_arguments)]
pub fn rasterize_backward(
    splats: &[ProjectedSplat],
    bins: &TileBins,
    state: &PixelState,
    width: usize,
    height: usize,
    background: [f32; 3],
    min_alpha: f32,
    grad_image: &[f32],
) -> Vec<ProjectedGrad> {
    assert_eq!(grad_image.len(), width * height * 4, "image gradient must be H×W×4");
    // The forward's prepared splats, unless the state came from elsewhere.
    let own;
    let prepared = if state.prepared.len() == splats.len() {
        &state.prepared
    } else {
        own = prepare(splats, bins, min_alpha);
        &own
    };
    // One gradient per (tile, splat) pair, each tile writing its own slice.
    // Filled in parallel: as one `vec!` it was a serial memset of megabytes per call.
    let mut flat = Vec::with_capacity(bins.pairs());
    flat.par_extend(rayon::iter::repeat_n(ProjectedGrad::default(), bins.pairs()));
    let mut slices: Vec<&mut [ProjectedGrad]> = Vec::with_capacity(bins.tiles_x * bins.tiles_y);
    let mut rest = flat.as_mut_slice();
    for t in 0..bins.tiles_x * bins.tiles_y {
        let (head, tail) = rest.split_at_mut(bins.offsets[t + 1] - bins.offsets[t]);
        slices.push(head);
        rest = tail;
    }
    let order = heaviest_first(bins);
    let mut work: Vec<Option<&mut [ProjectedGrad]>> = slices.into_iter().map(Some).collect();
    let work: Vec<(usize, &mut [ProjectedGrad])> =
        order.iter().map(|&t| (t, work[t].take().expect("each tile once"))).collect();
    work.into_par_iter().for_each(|(t, grads)| {
        wide(
            #[inline(always)]
            || {
                let ids = &bins.ids[bins.offsets[t]..bins.offsets[t + 1]];
                let blended_pairs = &state.blended_pairs[bins.offsets[t]..bins.offsets[t + 1]];
                let mut trans = TileArray([0.0f32; TILE_PIXELS]);
                let mut n_contrib = TileArray([0u32; TILE_PIXELS]);
                let mut dout = [TileArray([0.0f32; TILE_PIXELS]); 3];
                // ∂loss/∂alpha times the final transmittance.
                let mut alpha_final = TileArray([0.0f32; TILE_PIXELS]);
                // ∂loss/∂α_i collects Σ_c ∂loss/∂c·(S_c + T_final·bg_c)/(1−α_i): S is the colour
                // of everything behind splat i; this is the sum, seeded with the background's
                // share, which is all the backward needs of those colours.
                let mut behind = TileArray([0.0f32; TILE_PIXELS]);
                // Per tile row, the most contributors of its pixels: a splat at or past it
                // touches none of them (every lane would be masked off), so the row is skipped.
                let mut row_contrib = [0u32; TILE];
                for (k0, idx0, len) in tile_rows(t, bins, width, height) {
                    trans[k0..k0 + len].copy_from_slice(&state.final_t[idx0..idx0 + len]);
                    n_contrib[k0..k0 + len].copy_from_slice(&state.n_contrib[idx0..idx0 + len]);
                    row_contrib[k0 / TILE] = n_contrib[k0..k0 + len].iter().copied().max().unwrap_or(0);
                    let pixels = &grad_image[4 * idx0..4 * (idx0 + len)];
                    for (i, g) in pixels.chunks_exact(4).enumerate() {
                        let (k, t_final) = (k0 + i, trans[k0 + i]);
                        for c in 0..3 {
                            dout[c][k] = g[c];
                        }
                        behind[k] = (g[0] * background[0] + g[1] * background[1] + g[2] * background[2]) * t_final;
                        alpha_final[k] = g[3] * t_final;
                    }
                }
                let max_contrib = row_contrib.iter().copied().max().unwrap_or(0) as usize;
                let (tx, ty) = (t % bins.tiles_x, t / bins.tiles_x);
                let (left, top) = ((tx * TILE) as f32, (ty * TILE) as f32);
                let origin = [(tx * TILE) as i32, (ty * TILE) as i32];
                {
                    for j in (0..max_contrib).rev() {
                        if j >= PREFETCH_AHEAD {
                            prefetch(prepared, ids[j - PREFETCH_AHEAD] as usize);
                        }
                        if !blended_pairs[j] {
                            continue;
                        }
                        let ps = &prepared[ids[j] as usize];
                        let lanes_of = &ps.lanes;
                        let mut acc = GradLanes::default();
                        let rows = row_contrib
                            .iter()
                            .enumerate()
                            .fold(0u32, |m, (ly, &c)| m | (((j as u32) < c) as u32) << ly);
                        let runs = lanes_of.tile_runs(left, top, ps.tile_rect(origin), rows, true);
                        let mut pending = runs.mask;
                        while pending != 0 {
                            let bit = pending.trailing_zeros();
                            pending &= pending - 1;
                            let (o, run) = runs.run(bit);
                            let [d0, d1, d2] = &dout;
                            backward_run(
                                lanes_of,
                                j as u32,
                                run,
                                min_alpha,
                                BackwardRun {
                                    trans: lanes_mut(&mut trans, o),
                                    alpha_final: lanes(&alpha_final, o),
                                    n_contrib: lanes(&n_contrib, o),
                                    dout: [lanes(d0, o), lanes(d1, o), lanes(d2, o)],
                                    behind: lanes_mut(&mut behind, o),
                                },
                                &mut acc,
                            );
                        }
                        grads[j] = acc.total(lanes_of);
                    }
                }
            },
        )
    });
    // Sum each splat's per-tile gradients, in tile order (so the result does not depend on
    // the thread count), in parallel over splats.
    let sums: Vec<ProjectedGrad> = (0..bins.splats.len())
        .into_par_iter()
        .map(|k| {
            let mut g = ProjectedGrad::default();
            // A splat's pairs lie in different tiles' slices, a cache miss each: prefetched
            // along the next splats' pairs.
            let pairs = &bins.splat_pairs[bins.splat_offsets[k]..bins.splat_offsets[k + 1]];
            let ahead =
                &bins.splat_pairs[bins.splat_offsets[k + 1]..bins.splat_offsets[(k + 3).min(bins.splats.len())]];
            for &p in ahead {
                prefetch(&flat, p as usize);
            }
            for &p in pairs {
                g += flat[p as usize];
            }
            g
        })
        .collect();
    // From depth order to index order, gathered in parallel (scattered, it was a serial
    // twentieth of the backward).
    bins.slots
        .par_iter()
        .with_min_len(1024)
        .map(|&k| if k == NOT_BINNED { ProjectedGrad::default() } else { sums[k as usize] })
        .collect()
}
