//! Random numbers and low-level warps from the unit square, shared by the cameras, the
//! renderer and the trainers.

use glam::Vec2;

/// PCG32 (O'Neill): small state, good statistics, and cheap to seed per pixel, which is
/// how renders stay identical whatever the thread count.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    increment: u64,
}

impl Rng {
    /// A generator for stream `stream` of `seed` (e.g. the pixel index).
    #[inline]
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self { state: 0, increment: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(mix(seed));
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.increment);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in `[0, 1)`.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        // 24 bits fill an f32 mantissa exactly, so the result is never 1.
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform integer in `0..n` (Lemire's multiply-shift; `n` up to 2³²).
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u32() as u64 * n as u64) >> 32) as usize
    }

    /// Two uniforms.
    #[inline]
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }

    /// Standard normal (Box–Muller; one of the pair is used, keeping the stream simple).
    pub fn normal(&mut self) -> f32 {
        let u1 = 1.0 - self.uniform(); // (0, 1]: the log stays finite
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    }
}

/// Sample `k` of `n` stratified over the unit square: one jittered point (drawn from
/// `Rng::new(seed, k)`) in cell `k` of a ⌈√n⌉×⌈√n⌉ grid, row by row. Thin-lens renderers use it
/// for the lens position of each pass.
pub fn stratified_square(k: usize, n: usize, seed: u64) -> Vec2 {
    let side = (n as f32).sqrt().ceil() as usize;
    let mut rng = Rng::new(seed, k as u64);
    let offset = Vec2::new(rng.uniform(), rng.uniform());
    let cell = Vec2::new((k % side) as f32, (k / side) as f32);
    (cell + offset) / side as f32
}

/// The point at `offset ∈ [0,1)²` within cell `k` of a grid over the unit square with ⌈√n⌉
/// columns and ⌈n / columns⌉ rows, row by row (two cells: the left and right halves): where
/// a pixel's `k`-th of `n` rays passes, `offset` `(½, ½)` for the cell's centre. The `n`
/// cells tile the square when they fill the rows (n = 1, 2, 4, 6, 9, 12, 16, ...).
pub fn grid_cell_point(k: usize, n: usize, offset: Vec2) -> Vec2 {
    let columns = (n.max(1) as f32).sqrt().ceil() as usize;
    let rows = n.max(1).div_ceil(columns);
    let cell = Vec2::new((k % columns) as f32, (k / columns) as f32);
    (cell + offset) / Vec2::new(columns as f32, rows as f32)
}

/// SplitMix64 finaliser: spreads nearby seeds far apart.
pub fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Shirley–Chiu concentric map from `[0,1)²` to the unit disk: area-preserving and with
/// low distortion, so stratified samples stay stratified on the lens.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let p = 2.0 * u - Vec2::ONE;
    if p == Vec2::ZERO {
        return Vec2::ZERO;
    }
    // Both wedges need cos and sin of an angle a in [-π/4, π/4] (the second wedge's angle is
    // π/2 − a): short Taylor polynomials are exact to f32 there and several times cheaper
    // than a library sincos, which every diffuse bounce of the path tracer pays for. The wedge
    // is chosen by selects, not a branch: it is a coin flip per sample, so a branch would be
    // mispredicted half the time.
    if p.x.abs() > p.y.abs() {
        let (s, c) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * (p.y / p.x));
        p.x * Vec2::new(c, s)
    } else {
        let (s, c) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * (p.x / p.y));
        p.y * Vec2::new(s, c)
    }
}

/// `(sin a, cos a)` for `|a| ≤ π/4`: the Taylor series to degree 9 and 10, whose remainders
/// there are below 2·10⁻⁹, under half an f32 ulp of the results.
#[inline]
fn sin_cos_quarter(a: f32) -> (f32, f32) {
    let a2 = a * a;
    let sin = a * (1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 * (1.0 / 362_880.0)))));
    let cos =
        1.0 + a2 * (-0.5 + a2 * (1.0 / 24.0 + a2 * (-1.0 / 720.0 + a2 * (1.0 / 40_320.0 + a2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_cells_tile_the_square_each_once() {
        for n in [1, 2, 4, 6, 9, 16] {
            // Each cell's centre, blurred by a quarter cell either way, lands in that cell only:
            // count how many cells cover each point of a fine lattice.
            let centres: Vec<Vec2> = (0..n).map(|k| grid_cell_point(k, n, Vec2::splat(0.5))).collect();
            let lo: Vec<Vec2> = (0..n).map(|k| grid_cell_point(k, n, Vec2::ZERO)).collect();
            let hi: Vec<Vec2> = (0..n).map(|k| grid_cell_point(k, n, Vec2::ONE)).collect();
            for c in &centres {
                assert!(c.min_element() > 0.0 && c.max_element() < 1.0, "{n}: {c}");
            }
            for i in 0..40 {
                for j in 0..40 {
                    let p = (Vec2::new(i as f32, j as f32) + 0.5) / 40.0;
                    let covering = (0..n).filter(|&k| p.cmpge(lo[k]).all() && p.cmplt(hi[k]).all()).count();
                    assert_eq!(covering, 1, "{n} cells: {p} is covered {covering} times");
                }
            }
        }
    }

    #[test]
    fn rng_is_uniform_and_streams_differ() {
        let mut rng = Rng::new(42, 7);
        let n = 200_000;
        let mut sum = 0.0f64;
        let mut buckets = [0u32; 10];
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
            buckets[(u * 10.0) as usize] += 1;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.003);
        for b in buckets {
            assert!((b as f64 / n as f64 - 0.1).abs() < 0.003, "{buckets:?}");
        }
        let a: Vec<u32> = (0..4).map(|_| Rng::new(1, 0).next_u32()).collect();
        assert_eq!(a[0], a[1], "same seed and stream, same numbers");
        assert_ne!(Rng::new(1, 0).next_u32(), Rng::new(1, 1).next_u32());
    }

    #[test]
    fn quarter_sin_cos_matches_the_library() {
        for k in -1000..=1000 {
            let a = std::f32::consts::FRAC_PI_4 * k as f32 / 1000.0;
            let (s, c) = sin_cos_quarter(a);
            assert!((s - a.sin()).abs() < 2e-7 && (c - a.cos()).abs() < 2e-7, "{a}: {s} {c}");
        }
        // The disk map agrees with its textbook form (angle through the library's sin/cos).
        let textbook = |u: Vec2| {
            let p = 2.0 * u - Vec2::ONE;
            let (r, theta) = if p.x.abs() > p.y.abs() {
                (p.x, std::f32::consts::FRAC_PI_4 * (p.y / p.x))
            } else {
                (p.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (p.x / p.y))
            };
            r * Vec2::new(theta.cos(), theta.sin())
        };
        let mut rng = Rng::new(5, 5);
        for _ in 0..10_000 {
            let u = rng.uniform2();
            assert!((concentric_disk(u) - textbook(u)).length() < 1e-6, "{u}");
        }
    }

    #[test]
    fn concentric_disk_stays_inside_and_preserves_area() {
        // A regular grid on the square maps inside the disk, and the fraction inside the
        // half-radius disk equals its area fraction 1/4 (the map preserves area).
        let n = 200;
        let mut inner = 0;
        for i in 0..n {
            for j in 0..n {
                let p = concentric_disk(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                assert!(p.length() <= 1.0 + 1e-6);
                if p.length() < 0.5 {
                    inner += 1;
                }
            }
        }
        let fraction = inner as f64 / (n * n) as f64;
        assert!((fraction - 0.25).abs() < 0.01, "{fraction}");
    }
}
