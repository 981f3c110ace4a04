//! The compositing kernels of one splat over one 8-pixel run of a tile row, forward and
//! backward.
//!
//! Every lane computes the same straight-line arithmetic and the per-pixel decisions (inside
//! the splat's box, below the blend threshold, transmittance exhausted, past the pixel's last
//! contributor) become masks, so the compiler turns each loop into a few SIMD instructions
//! instead of a branch per pixel; this is where a training step spends most of its time. The
//! exponential is a polynomial ([`fast_exp`]) for the same reason: a call to libm's `expf`
//! would keep the loop scalar. Forward and backward use the same function, so the backward
//! reconstructs the forward's transmittances exactly.

use lucid_scene::simd::sign_mask8;

use crate::project::ProjectedSplat;

/// Pixels per run: one AVX register of `f32`, two SSE ones.
pub const LANES: usize = 8;

/// Each lane's x offset as a float: converting the loop index instead would be a 64-bit
/// integer conversion per lane, which keeps SSE2 code scalar.
const LANE_X: [f32; LANES] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];

/// `eˣ` for `x ≤ 0` to about one ulp (Cephes' `expf` polynomial after the reduction
/// `x = n·ln 2 + r`, `|r| ≤ ½ ln 2`); inputs below −87 give `e⁻⁸⁷`, above 0 give 1.
#[inline(always)]
pub fn fast_exp(x: f32) -> f32 {
    let x = x.clamp(-87.0, 0.0);
    // Round x·log₂e to the nearest integer by adding 1.5·2²³: the sum's low mantissa bits
    // then hold n, which avoids a float-to-int conversion the vectoriser handles poorly.
    const SHIFTER: f32 = 12_582_912.0;
    let t = x * std::f32::consts::LOG2_E + SHIFTER;
    let n = t - SHIFTER;
    let r = x - n * 0.693_359_4 + n * 2.121_944_4e-4;
    // The polynomial by Estrin's scheme, not Horner's: a blend kernel is one long chain of
    // dependent operations per run, and this halves the exponential's part of it.
    let r2 = r * r;
    let low = 0.5 + 0.166_666_65 * r;
    let mid = 4.166_579_6e-2 + 8.333_452e-3 * r;
    let high = 1.398_2e-3 + 1.987_569_1e-4 * r;
    let p = low + r2 * (mid + r2 * high);
    let e = p * r2 + r + 1.0;
    let n_int = t.to_bits() as i32 - SHIFTER.to_bits() as i32;
    e * f32::from_bits(((n_int + 127) << 23) as u32)
}

/// One splat's constants for the kernels: its exponent is `pw = qa·dx² + qb·dx·dy + qc·dy²`,
/// and its α before the cap `exp(pw + ln opacity)`.
#[derive(Clone, Copy, Debug, Default)]
pub struct SplatLanes {
    qa: f32,
    qb: f32,
    qc: f32,
    mean_x: f32,
    mean_y: f32,
    log_opacity: f32,
    inv_opacity: f32,
    colour: [f32; 3],
    depth: f32,
    /// The blend-threshold ellipse `A dx² + 2B dx dy + C dy² ≤ R`, `R = 2 ln(opacity / min α)`,
    /// as its rows' spans: centre `mean_x + slope·dy`, half-width `√(ar − k·dy²) / A`.
    slope: f32,
    ar: f32,
    k: f32,
    inv_a: f32,
}

impl SplatLanes {
    /// The kernel constants of a projected splat, for blend threshold `exp(log_min_alpha)`.
    #[inline(always)]
    pub fn new(s: &ProjectedSplat, log_min_alpha: f32) -> Self {
        let [a, b, c] = s.conic;
        let log_opacity = s.opacity.ln();
        let reach2 = 2.0 * (log_opacity - log_min_alpha);
        Self {
            qa: -0.5 * a,
            qb: -b,
            qc: -0.5 * c,
            mean_x: s.mean.x,
            mean_y: s.mean.y,
            log_opacity,
            inv_opacity: 1.0 / s.opacity,
            colour: s.colour,
            depth: s.depth,
            slope: -b / a,
            ar: a * reach2,
            k: a * c - b * b,
            inv_a: 1.0 / a,
        }
    }

    /// A run's constants: the exponent of lane offset `dx` (with the opacity's log folded in)
    /// is `(qa·dx + by)·dx + cy`; returns `(by, cy, dx₀, dy)`.
    #[inline(always)]
    fn run_power(&self, run: &Run) -> (f32, f32, f32, f32) {
        let dy = run.y - self.mean_y;
        let dx0 = run.x - self.mean_x;
        (self.qb * dy, self.qc * dy * dy + self.log_opacity, dx0, dy)
    }

    /// The runs of this splat in the tile whose top-left pixel corner is at `(left, top)`:
    /// each row's span is the columns inside the box `[x0, x1) × [y0, y1)` whose pixel
    /// centres lie in the blend-threshold ellipse (widened by a thousandth of a pixel, so
    /// rounding never drops a pixel that passes the threshold test), and only rows whose bit
    /// is set in `rows` are kept. A trained cloud's splats are small and often elongated:
    /// their rows' spans are a fraction of the box. `placed` puts a span at most 8 wide under
    /// one run (the backward's choice); otherwise runs lie at the row's halves (the forward's:
    /// see [`crate::raster`]). Rows go eight at a time, branch-free, as vector code: one
    /// group for a box at most 8 rows high, which most are.
    #[inline(always)]
    pub fn tile_runs(&self, left: f32, top: f32, rect: [usize; 4], rows: u32, placed: bool) -> TileRuns {
        let [x0, x1, y0, y1] = rect;
        let mut out = TileRuns { mask: 0, start: [0; TILE], first: [0.0; TILE], end: [0.0; TILE], left, top };
        if x0 >= x1 || y0 >= y1 {
            return out;
        }
        let (lo, hi) = (x0 as f32, x1 as f32);
        let window = if y1 - y0 <= LANES { y0.min(TILE - LANES) } else { 0 };
        let groups = if y1 - y0 <= LANES { 1 } else { 2 };
        let mut mask = 0u32;
        for g in 0..groups {
            let r0 = window + g * LANES;
            // Negative where the row has its first (second) run: the masks are the sign bits.
            let (mut one, mut two) = ([0f32; LANES], [0f32; LANES]);
            let first_out: &mut [f32; LANES] = (&mut out.first[r0..r0 + LANES]).try_into().expect("8 rows");
            let end_out: &mut [f32; LANES] = (&mut out.end[r0..r0 + LANES]).try_into().expect("8 rows");
            let start_out: &mut [u32; LANES] = (&mut out.start[r0..r0 + LANES]).try_into().expect("8 rows");
            let row_top = top + r0 as f32 + 0.5 - self.mean_y;
            for l in 0..LANES {
                let dy = row_top + LANE_X[l];
                let d = self.ar - self.k * dy * dy;
                // Outside the ellipse's rows an empty span (first past every column).
                let reach = d.max(0.0).sqrt() * self.inv_a * (1.0 + 1e-4) + 1e-3;
                let half = if d >= 0.0 { reach } else { -100.0 };
                let centre = self.mean_x - left + self.slope * dy - 0.5;
                // max/min rather than clamp, whose bounds check would keep the loop scalar.
                let first = (centre - half).ceil().max(lo);
                let end = ((centre + half).floor() + 1.0).min(hi);
                let half_lanes = LANES as f32;
                let (a, b, start) = if placed {
                    let wide = end - first > half_lanes;
                    (first < end, wide & (first < end), if wide { 0.0 } else { first.min(half_lanes) })
                } else {
                    (first < end.min(half_lanes), first.max(half_lanes) < end, 0.0)
                };
                first_out[l] = first;
                end_out[l] = end;
                // A small whole number to an integer by the same shift as in fast_exp: a
                // float-to-int conversion saturates in Rust, a dozen instructions per value.
                const SHIFTER: f32 = 8_388_608.0;
                start_out[l] = (start + SHIFTER).to_bits() - SHIFTER.to_bits();
                one[l] = 0.0 - a as u32 as f32;
                two[l] = 0.0 - b as u32 as f32;
            }
            mask |= (spread(sign_mask8(&one)) | (spread(sign_mask8(&two)) << 1)) << (2 * r0);
        }
        let row_range = (1u32 << y1).wrapping_sub(1) & !((1u32 << y0) - 1) & rows;
        // Both runs of each row in range.
        let row_runs = spread(row_range) * 3;
        out.mask = mask & row_runs;
        out
    }
}

/// Bit `i` of `bits` (16 at most) moved to bit `2i`: row bits to the bits of their first runs.
#[inline(always)]
fn spread(bits: u32) -> u32 {
    SPREAD[(bits & 0xff) as usize] as u32 | (SPREAD[(bits >> 8 & 0xff) as usize] as u32) << 16
}

/// Each byte's bits spread to the even bits of a 16-bit word.
const SPREAD: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut b = 0;
        while b < 8 {
            t[i] |= (((i >> b) & 1) as u16) << (2 * b);
            b += 1;
        }
        i += 1;
    }
    t
};

/// One splat's runs in one tile: bit `2·ly` of `mask` is row `ly`'s first run, starting at
/// column `start[ly]`, bit `2·ly + 1` its second, at column 8; the row's span is
/// `[first, end)` (tile columns).
#[derive(Clone, Copy, Debug)]
pub struct TileRuns {
    /// The runs present.
    pub mask: u32,
    start: [u32; TILE],
    first: [f32; TILE],
    end: [f32; TILE],
    left: f32,
    top: f32,
}

impl TileRuns {
    /// Run `bit` of the mask: its offset in the tile's arrays and where it lies.
    #[inline(always)]
    pub fn run(&self, bit: u32) -> (usize, Run) {
        let ly = (bit / 2) as usize;
        // A row with a second run has its first at column 0.
        let start = self.start[ly] | ((bit & 1) * LANES as u32);
        let s = start as f32;
        let run =
            Run { x: self.left + s + 0.5, y: self.top + ROW_Y[ly], first: self.first[ly] - s, end: self.end[ly] - s };
        (ly * TILE + start as usize, run)
    }
}

/// Rows of a tile.
pub const TILE: usize = 16;

/// Each tile row's pixel-centre y offset.
const ROW_Y: [f32; TILE] = [0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5, 9.5, 10.5, 11.5, 12.5, 13.5, 14.5, 15.5];

/// Where a run lies: pixel centre coordinates of its first lane and which lanes the splat's
/// box covers (`first..end`).
#[derive(Clone, Copy, Debug)]
pub struct Run {
    /// Pixel-centre x of lane 0.
    pub x: f32,
    /// Pixel-centre y of the row.
    pub y: f32,
    /// First covered lane (as a float, compared with [`LANE_X`]).
    pub first: f32,
    /// One past the last covered lane.
    pub end: f32,
}

/// Per-pixel forward state of one run, as slices of the tile's arrays.
pub struct ForwardRun<'a> {
    /// Transmittance so far.
    pub trans: &'a mut [f32; LANES],
    /// Accumulated colour, per channel.
    pub rgb: [&'a mut [f32; LANES]; 3],
    /// Accumulated weighted depth.
    pub depth: &'a mut [f32; LANES],
    /// Index + 1 of the last splat blended, as a float (exact below 2²⁴): as an integer the
    /// compiler turns its update into a masked store, which AMD CPUs run as slow microcode.
    pub last: &'a mut [f32; LANES],
    /// −1 once the pixel has stopped (or lies outside the image), else +0: the sign bit is
    /// the flag, which a move-mask reads for eight lanes at once. A float, updated by a
    /// subtraction: as integer flags the compiler turned the update into a masked store.
    pub done: &'a mut [f32; LANES],
}

/// Blends splat number `index` of the tile into a run; returns the lanes it blended into, one
/// bit each, and whether every pixel of the run has now stopped.
#[inline(always)]
pub fn forward_run(s: &SplatLanes, index: u32, run: Run, min_alpha: f32, px: ForwardRun<'_>) -> (u32, bool) {
    let (by, cy, dx0, _) = s.run_power(&run);
    let index = index as f32;
    // Negative where blended, +0 elsewhere: the lanes' sign bits make the blend mask.
    let mut blend_sign = [0f32; LANES];
    // Local copies: the compiler cannot prove that references held in a struct do not alias,
    // and would not vectorise the loop over them.
    let [pr, pg, pb] = px.rgb;
    let (mut r, mut g, mut b) = (*pr, *pg, *pb);
    let (mut trans, mut depth, mut last, mut done) = (*px.trans, *px.depth, *px.last, *px.done);
    for l in 0..LANES {
        let dx = dx0 + LANE_X[l];
        let alpha = fast_exp((s.qa * dx + by) * dx + cy).min(crate::raster::MAX_ALPHA);
        let covered = (LANE_X[l] >= run.first) & (LANE_X[l] < run.end);
        let ok = covered & (done[l] == 0.0) & (alpha >= min_alpha);
        let t = trans[l];
        let next = t * (1.0 - alpha);
        let stop = ok & (next < crate::raster::MIN_TRANSMITTANCE);
        let blend = ok & !stop;
        // Every update is unconditional arithmetic with a 0/1 factor (exact either way): a
        // conditional store, or a select the compiler turns into a branch, would stop the
        // vectoriser.
        let on = blend as u32 as f32;
        let w = alpha * t * on;
        r[l] += s.colour[0] * w;
        g[l] += s.colour[1] * w;
        b[l] += s.colour[2] * w;
        depth[l] += s.depth * w;
        trans[l] = t * (1.0 - alpha * on);
        // Indices only grow along the tile's list. A compare-and-pick is one max instruction;
        // `f32::max` adds a NaN check.
        let candidate = on * index;
        last[l] = if candidate > last[l] { candidate } else { last[l] };
        done[l] -= stop as u32 as f32;
        blend_sign[l] = 0.0 - on;
    }
    (*pr, *pg, *pb) = (r, g, b);
    (*px.trans, *px.depth, *px.last, *px.done) = (trans, depth, last, done);
    // Sign bits as masks (move-mask instructions): flags shifted by lane and ORed compiled to
    // two dozen shuffles per run, an eighth of the kernel.
    (sign_mask8(&blend_sign), sign_mask8(&done) == (1 << LANES) - 1)
}

/// Per-pixel backward state of one run.
pub struct BackwardRun<'a> {
    /// Transmittance in front of the splat being visited (walked back from the final one).
    pub trans: &'a mut [f32; LANES],
    /// `∂loss/∂alpha` times the final transmittance.
    pub alpha_final: &'a [f32; LANES],
    /// Contributors of the pixel (splats at or past it are skipped).
    pub n_contrib: &'a [u32; LANES],
    /// `∂loss/∂` RGB.
    pub dout: [&'a [f32; LANES]; 3],
    /// `Σ_c ∂loss/∂c · behind_c`, where `behind` is the colour of everything behind the splat
    /// being visited, background share included (the colours themselves are not needed).
    pub behind: &'a mut [f32; LANES],
}

/// Per-lane sums of one splat's screen-space gradient over the runs it covers. With
/// `gᵢ = ∂loss/∂powerᵢ = ∂loss/∂αᵢ · αᵢ` at pixel offset `dᵢ`, the opacity's gradient is
/// `Σ gᵢ / opacity`, and the conic's and the mean's follow from the moments `Σ gᵢ dᵢ` and
/// `Σ gᵢ dᵢ dᵢᵀ`, which take fewer operations per lane than the gradients themselves.
#[derive(Clone, Copy, Debug, Default)]
pub struct GradLanes {
    colour: [[f32; LANES]; 3],
    weight: [f32; LANES],
    x: [f32; LANES],
    y: [f32; LANES],
    xx: [f32; LANES],
    xy: [f32; LANES],
    yy: [f32; LANES],
}

impl GradLanes {
    /// The lane sums of splat `s` as one gradient, added in a fixed order.
    pub fn total(&self, s: &SplatLanes) -> crate::project::ProjectedGrad {
        // Halves added as vectors, then the four sums: a fixed order, so still deterministic.
        // Summed lane by lane, the compiler paired the x and y sums into two-lane vectors and
        // carried their accumulators shuffled through the run loop (a store-forwarding stall
        // per run).
        let sum = |v: &[f32; LANES]| {
            (glam::Vec4::from_slice(&v[..LANES / 2]) + glam::Vec4::from_slice(&v[LANES / 2..])).element_sum()
        };
        // The conic from the exponent's coefficients (halving and doubling are exact).
        let (a, b, c) = (-2.0 * s.qa, -s.qb, -2.0 * s.qc);
        let (x, y) = (sum(&self.x), sum(&self.y));
        crate::project::ProjectedGrad {
            mean: glam::Vec2::new(a * x + b * y, b * x + c * y),
            conic: [-0.5 * sum(&self.xx), -sum(&self.xy), -0.5 * sum(&self.yy)],
            opacity: sum(&self.weight) * s.inv_opacity,
            colour: self.colour.each_ref().map(sum),
        }
    }
}

/// Undoes splat number `index` (0-based) of the tile in a run, back to front, adding its
/// gradient into `acc`.
#[inline(always)]
pub fn backward_run(s: &SplatLanes, index: u32, run: Run, min_alpha: f32, px: BackwardRun<'_>, acc: &mut GradLanes) {
    let (by, cy, dx0, dy) = s.run_power(&run);
    // Local copies, as in the forward.
    let mut behind = *px.behind;
    let mut trans = *px.trans;
    let (alpha_final, n_contrib) = (*px.alpha_final, *px.n_contrib);
    let dout = px.dout.map(|d| *d);
    let mut sums = *acc;
    for l in 0..LANES {
        // ∂loss/∂α = (T_final·∂loss/∂alpha − Σ ∂loss/∂c·behind_c + T·Σ ∂loss/∂c·colour_c)/(1 − α):
        // both sums do not depend on α, so they run alongside the exponential, not after it.
        let shade = dout[0][l] * s.colour[0] + dout[1][l] * s.colour[1] + dout[2][l] * s.colour[2];
        let ahead = alpha_final[l] - behind[l] + trans[l] * shade;
        let dx = dx0 + LANE_X[l];
        let raw = fast_exp((s.qa * dx + by) * dx + cy);
        let alpha = raw.min(crate::raster::MAX_ALPHA);
        let covered = (LANE_X[l] >= run.first) & (LANE_X[l] < run.end);
        let ok = covered & (index < n_contrib[l]) & (alpha >= min_alpha);
        let inv = 1.0 / (1.0 - alpha);
        let t_i = trans[l] * inv;
        let unblend = if ok { inv } else { 1.0 };
        let w = if ok { alpha * t_i } else { 0.0 };
        let g_alpha = inv * ahead;
        for (sum, d) in sums.colour.iter_mut().zip(&dout) {
            sum[l] += d[l] * w;
        }
        behind[l] += shade * w;
        // Unconditional, as in the forward, so that the loop vectorises.
        trans[l] *= unblend;
        // Where the opacity cap binds, α no longer depends on the splat's parameters.
        let slope = ok & (raw <= crate::raster::MAX_ALPHA);
        // ∂loss/∂power: the opacity's gradient is this over the opacity.
        let weight = if slope { g_alpha * raw } else { 0.0 };
        let (gx, gy) = (weight * dx, weight * dy);
        sums.weight[l] += weight;
        sums.x[l] += gx;
        sums.y[l] += gy;
        sums.xx[l] += gx * dx;
        sums.xy[l] += gx * dy;
        sums.yy[l] += gy * dy;
    }
    *px.behind = behind;
    *px.trans = trans;
    *acc = sums;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_matches_std_to_a_few_ulps() {
        let mut worst = 0.0f32;
        let mut x = -87.0f32;
        while x <= 0.0 {
            let (got, want) = (fast_exp(x), x.exp());
            worst = worst.max(((got - want) / want).abs());
            x += 0.001;
        }
        assert!(worst < 4e-7, "relative error {worst}");
        assert_eq!(fast_exp(0.0), 1.0);
        assert_eq!(fast_exp(5.0), 1.0, "clamped above at 0");
        assert!(fast_exp(-1000.0) > 0.0 && fast_exp(-1000.0) < 1e-37);
    }
}
