//! The tile rasterizer: binning of projected splats into 16×16 tiles in depth order,
//! front-to-back alpha compositing per tile, and the exact backward traversing each tile back
//! to front.
//!
//! Inside a tile the loops run Gaussian-outer, pixel-inner: a splat is loaded once and
//! blended into all 256 pixels (a contiguous copy of the tile's splats keeps them in cache),
//! and in the backward its gradient is summed over the tile's pixels in registers and stored
//! once per (tile, splat) pair. Those per-pair gradients are then summed per splat in a
//! fixed order, so results do not depend on the thread count.

use glam::Vec2;
use rayon::prelude::*;

use crate::project::{ProjectedGrad, ProjectedSplat};

/// Tile side in pixels.
pub const TILE: usize = 16;
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
}

impl TileBins {
    /// Number of (tile, splat) pairs.
    pub fn pairs(&self) -> usize {
        self.ids.len()
    }
}

/// The pixels a splat can touch along one axis, `[first, last]` (may be empty or off-image):
/// pixel `i` (centre `i + 0.5`) is in reach when `|i + 0.5 − mean| ≤ half`.
fn pixel_span(mean: f32, half: f32) -> (i64, i64) {
    ((mean - half - 0.5).ceil() as i64, (mean + half - 0.5).floor() as i64)
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

/// The splat's pixel box inside tile `(tx, ty)`, in tile-local coordinates `[x0, x1) × [y0, y1)`.
#[inline]
fn local_rect(s: &ProjectedSplat, tx: usize, ty: usize) -> (usize, usize, usize, usize) {
    let clip = |mean: f32, half: f32, origin: usize| {
        let (a, b) = pixel_span(mean, half);
        let (a, b) = (a - origin as i64, b - origin as i64 + 1);
        (a.clamp(0, TILE as i64) as usize, b.clamp(0, TILE as i64) as usize)
    };
    let (x0, x1) = clip(s.mean.x, s.half_extent.x, tx * TILE);
    let (y0, y1) = clip(s.mean.y, s.half_extent.y, ty * TILE);
    (x0, x1, y0, y1)
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
    let order: Vec<u32> = keys.iter().map(|k| *k as u32).collect();
    let mut counts = vec![0usize; tiles_x * tiles_y + 1];
    for &i in &order {
        let (x0, x1, y0, y1) = tile_rect(&splats[i as usize], tiles_x, tiles_y);
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
    let mut ids = vec![0u32; *offsets.last().unwrap_or(&0)];
    for &i in &order {
        let (x0, x1, y0, y1) = tile_rect(&splats[i as usize], tiles_x, tiles_y);
        for ty in y0..y1 {
            for tx in x0..x1 {
                let t = ty * tiles_x + tx;
                ids[cursor[t]] = i;
                cursor[t] += 1;
            }
        }
    }
    TileBins { tiles_x, tiles_y, offsets, ids }
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
}

/// The weight exponent of splat `s` at pixel centre `p`.
#[inline(always)]
fn power(s: &ProjectedSplat, p: Vec2) -> (f32, f32, f32) {
    let d = p - s.mean;
    let [a, b, c] = s.conic;
    (-0.5 * (a * d.x * d.x + c * d.y * d.y) - b * d.x * d.y, d.x, d.y)
}

fn tile_pixels(t: usize, bins: &TileBins, width: usize, height: usize) -> impl Iterator<Item = Option<(usize, Vec2)>> {
    let (tx, ty) = (t % bins.tiles_x, t / bins.tiles_x);
    (0..TILE_PIXELS).map(move |k| {
        let (x, y) = (tx * TILE + k % TILE, ty * TILE + k / TILE);
        (x < width && y < height).then(|| (y * width + x, Vec2::new(x as f32 + 0.5, y as f32 + 0.5)))
    })
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
    let tiles: Vec<_> = (0..bins.tiles_x * bins.tiles_y)
        .into_par_iter()
        .map(|t| {
            let local: Vec<ProjectedSplat> =
                bins.ids[bins.offsets[t]..bins.offsets[t + 1]].iter().map(|&i| splats[i as usize]).collect();
            let pixels: Vec<Option<(usize, Vec2)>> = tile_pixels(t, bins, width, height).collect();
            let mut trans = [1.0f32; TILE_PIXELS];
            let mut colour = [[0.0f32; 3]; TILE_PIXELS];
            let mut depth = [0.0f32; TILE_PIXELS];
            let mut blends = 0u64;
            let mut last = [0u32; TILE_PIXELS];
            let mut done = [false; TILE_PIXELS];
            let mut n_done = 0;
            for (k, d) in done.iter_mut().enumerate() {
                if pixels[k].is_none() {
                    *d = true;
                    n_done += 1;
                }
            }
            let (tx, ty) = (t % bins.tiles_x, t / bins.tiles_x);
            for (j, s) in local.iter().enumerate() {
                if n_done == TILE_PIXELS {
                    break;
                }
                let (x0, x1, y0, y1) = local_rect(s, tx, ty);
                for ly in y0..y1 {
                    for lx in x0..x1 {
                        let k = ly * TILE + lx;
                        if done[k] {
                            continue;
                        }
                        let p = Vec2::new((tx * TILE + lx) as f32 + 0.5, (ty * TILE + ly) as f32 + 0.5);
                        let (pw, _, _) = power(s, p);
                        if pw > 0.0 || pw < s.log_cutoff {
                            continue;
                        }
                        let alpha = (s.opacity * pw.exp()).min(MAX_ALPHA);
                        if alpha < min_alpha {
                            continue;
                        }
                        let next = trans[k] * (1.0 - alpha);
                        if next < MIN_TRANSMITTANCE {
                            done[k] = true;
                            n_done += 1;
                            continue;
                        }
                        let w = alpha * trans[k];
                        for (acc, c) in colour[k].iter_mut().zip(s.colour) {
                            *acc += c * w;
                        }
                        depth[k] += s.depth * w;
                        blends += 1;
                        trans[k] = next;
                        last[k] = j as u32 + 1;
                    }
                }
            }
            (pixels, trans, colour, last, depth, blends)
        })
        .collect();
    let mut image = vec![0.0f32; width * height * 4];
    let mut state = PixelState {
        final_t: vec![1.0; width * height],
        n_contrib: vec![0; width * height],
        depth: vec![0.0; width * height],
        blends: 0,
    };
    for (pixels, trans, colour, last, depth, blends) in tiles {
        state.blends += blends;
        for (k, px) in pixels.iter().enumerate() {
            let Some((idx, _)) = *px else { continue };
            for c in 0..3 {
                image[4 * idx + c] = colour[k][c] + trans[k] * background[c];
            }
            image[4 * idx + 3] = 1.0 - trans[k];
            state.final_t[idx] = trans[k];
            state.n_contrib[idx] = last[k];
            state.depth[idx] = depth[k];
        }
    }
    (image, state)
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
    let per_tile: Vec<Vec<ProjectedGrad>> = (0..bins.tiles_x * bins.tiles_y)
        .into_par_iter()
        .map(|t| {
            let ids = &bins.ids[bins.offsets[t]..bins.offsets[t + 1]];
            let local: Vec<ProjectedSplat> = ids.iter().map(|&i| splats[i as usize]).collect();
            let mut grads = vec![ProjectedGrad::default(); local.len()];
            let pixels: Vec<Option<(usize, Vec2)>> = tile_pixels(t, bins, width, height).collect();
            let mut trans = [0.0f32; TILE_PIXELS];
            let mut n_contrib = [0u32; TILE_PIXELS];
            let mut dout = [[0.0f32; 4]; TILE_PIXELS];
            // ∂loss/∂α_i collects (S_c + T_final·bg_c)/(1−α_i): S is the colour of everything
            // behind splat i, seeded with the background's share.
            let mut behind = [[0.0f32; 3]; TILE_PIXELS];
            let mut t_final = [0.0f32; TILE_PIXELS];
            let mut max_contrib = 0;
            for (k, px) in pixels.iter().enumerate() {
                let Some((idx, _)) = *px else { continue };
                trans[k] = state.final_t[idx];
                t_final[k] = state.final_t[idx];
                n_contrib[k] = state.n_contrib[idx];
                max_contrib = max_contrib.max(n_contrib[k] as usize);
                dout[k].copy_from_slice(&grad_image[4 * idx..4 * idx + 4]);
                for c in 0..3 {
                    behind[k][c] = t_final[k] * background[c];
                }
            }
            let (tx, ty) = (t % bins.tiles_x, t / bins.tiles_x);
            for j in (0..max_contrib).rev() {
                let s = &local[j];
                let mut acc = ProjectedGrad::default();
                let (x0, x1, y0, y1) = local_rect(s, tx, ty);
                for ly in y0..y1 {
                    for lx in x0..x1 {
                        let k = ly * TILE + lx;
                        if j as u32 >= n_contrib[k] {
                            continue;
                        }
                        let p = Vec2::new((tx * TILE + lx) as f32 + 0.5, (ty * TILE + ly) as f32 + 0.5);
                        let (pw, dx, dy) = power(s, p);
                        if pw > 0.0 || pw < s.log_cutoff {
                            continue;
                        }
                        let g = pw.exp();
                        let raw = s.opacity * g;
                        let alpha = raw.min(MAX_ALPHA);
                        if alpha < min_alpha {
                            continue;
                        }
                        let one_minus = 1.0 - alpha;
                        let t_i = trans[k] / one_minus;
                        let w = alpha * t_i;
                        let d = dout[k];
                        let mut g_alpha = d[3] * t_final[k] / one_minus;
                        for c in 0..3 {
                            acc.colour[c] += d[c] * w;
                            g_alpha += d[c] * (s.colour[c] * t_i - behind[k][c] / one_minus);
                            behind[k][c] += s.colour[c] * w;
                        }
                        trans[k] = t_i;
                        if raw > MAX_ALPHA {
                            continue;
                        }
                        acc.opacity += g_alpha * g;
                        let g_pow = g_alpha * s.opacity * g;
                        let [a, b, c] = s.conic;
                        acc.conic[0] += -0.5 * g_pow * dx * dx;
                        acc.conic[1] += -g_pow * dx * dy;
                        acc.conic[2] += -0.5 * g_pow * dy * dy;
                        acc.mean += g_pow * Vec2::new(a * dx + b * dy, b * dx + c * dy);
                    }
                }
                grads[j] = acc;
            }
            grads
        })
        .collect();
    // Sum the per-(tile, splat) gradients per splat, in tile order.
    let mut out = vec![ProjectedGrad::default(); splats.len()];
    for (t, grads) in per_tile.iter().enumerate() {
        for (g, &i) in grads.iter().zip(&bins.ids[bins.offsets[t]..bins.offsets[t + 1]]) {
            out[i as usize] += *g;
        }
    }
    out
}
