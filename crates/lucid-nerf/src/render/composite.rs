//! Emission–absorption compositing of packed ray samples, forward and backward.
//!
//! Ray `r` owns samples `offsets[r]..offsets[r+1]`, each with its distance `t` and the
//! length `dt` of the segment it stands for. With `α_i = 1 − exp(−σ_i·dt_i)` and
//! `T_i = Π_{j<i}(1 − α_j)`, the weights are `w_i = T_i·α_i`, and the ray gets colour
//! `Σ w_i c_i`, opacity `Σ w_i` and depth `Σ w_i t_i`. Marching stops once `T` drops below
//! the termination threshold; later samples get no weight and no gradient.
//!
//! The backward uses `∂w_k/∂σ_i = dt_i·T_{i+1}` for `k = i` and `−dt_i·w_k` for `k > i`, so for
//! any `Q = Σ w_k q_k`: `∂Q/∂σ_i = dt_i·(T_{i+1}·q_i − Σ_{k>i} w_k q_k)`, the suffix sum
//! being the total minus the running prefix — one pass per ray, no stored weights.

use rayon::prelude::*;

/// Values per ray in the composited output: `r, g, b, opacity, depth`.
pub const RAY_OUTPUTS: usize = 5;

/// Samples packed ray after ray.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedSamples {
    /// `offsets[r]..offsets[r+1]` are ray `r`'s samples; `offsets.len()` is rays + 1.
    pub offsets: Vec<u32>,
    /// Distance of each sample along its ray.
    pub t: Vec<f32>,
    /// Segment length of each sample.
    pub dt: Vec<f32>,
}

impl PackedSamples {
    /// Number of rays.
    pub fn rays(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of samples.
    pub fn samples(&self) -> usize {
        self.t.len()
    }

    fn range(&self, r: usize) -> std::ops::Range<usize> {
        self.offsets[r] as usize..self.offsets[r + 1] as usize
    }
}

/// Rays per parallel task.
const CHUNK: usize = 64;

/// One ray's compositing so far, front to back: what [`composite_forward`] computes per ray,
/// kept between calls so that a renderer can composite a ray in several rounds of samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayAccumulator {
    /// `r, g, b, opacity, depth` so far.
    pub acc: [f32; RAY_OUTPUTS],
    /// Transmittance in front of the next sample.
    pub transmittance: f32,
}

impl Default for RayAccumulator {
    fn default() -> Self {
        Self { acc: [0.0; RAY_OUTPUTS], transmittance: 1.0 }
    }
}

impl RayAccumulator {
    /// Adds one sample (`raw` = `σ, r, g, b`); false once transmittance has fallen below
    /// `min_transmittance` (the ray is done).
    #[inline]
    pub fn add(&mut self, raw: &[f32], t: f32, dt: f32, min_transmittance: f32) -> bool {
        let alpha = 1.0 - (-raw[0] * dt).exp();
        let w = self.transmittance * alpha;
        for k in 0..3 {
            self.acc[k] += w * raw[1 + k];
        }
        self.acc[3] += w;
        self.acc[4] += w * t;
        self.transmittance *= 1.0 - alpha;
        self.transmittance >= min_transmittance
    }
}

/// Composites `raw` (`S×4`: `σ, r, g, b`) into `out` (`R×5`: `r, g, b, opacity, depth`).
pub fn composite_forward(samples: &PackedSamples, raw: &[f32], min_transmittance: f32, out: &mut [f32]) {
    assert_eq!(raw.len(), samples.samples() * 4, "raw values are S×4");
    assert_eq!(out.len(), samples.rays() * RAY_OUTPUTS, "output is R×5");
    out.par_chunks_mut(CHUNK * RAY_OUTPUTS).enumerate().for_each(|(c, out)| {
        for (i, o) in out.chunks_exact_mut(RAY_OUTPUTS).enumerate() {
            let mut ray = RayAccumulator::default();
            for s in samples.range(c * CHUNK + i) {
                if !ray.add(&raw[4 * s..4 * s + 4], samples.t[s], samples.dt[s], min_transmittance) {
                    break;
                }
            }
            o.copy_from_slice(&ray.acc);
        }
    });
}

/// `grad_raw` (`S×4`) split into the contiguous sample ranges of each chunk of [`CHUNK`] rays:
/// `(chunk, first sample, its rows)`, for parallel backward passes.
fn chunk_gradients<'a>(samples: &PackedSamples, grad_raw: &'a mut [f32]) -> Vec<(usize, usize, &'a mut [f32])> {
    let rays = samples.rays();
    let mut parts = Vec::with_capacity(rays.div_ceil(CHUNK));
    let mut rest = grad_raw;
    for c in 0..rays.div_ceil(CHUNK) {
        let (lo, hi) = (samples.offsets[c * CHUNK] as usize, samples.offsets[((c + 1) * CHUNK).min(rays)] as usize);
        let (part, tail) = rest.split_at_mut(4 * (hi - lo));
        parts.push((c, lo, part));
        rest = tail;
    }
    parts
}

/// `∂loss/∂raw` (`S×4`) from `∂loss/∂out` (`R×5`), given the forward's `out`.
pub fn composite_backward(
    samples: &PackedSamples,
    raw: &[f32],
    out: &[f32],
    grad_out: &[f32],
    min_transmittance: f32,
    grad_raw: &mut [f32],
) {
    assert_eq!(raw.len(), samples.samples() * 4, "raw values are S×4");
    assert_eq!(grad_raw.len(), raw.len(), "gradient matches raw");
    assert_eq!(out.len(), samples.rays() * RAY_OUTPUTS, "output is R×5");
    assert_eq!(grad_out.len(), out.len(), "output gradient is R×5");
    let rays = samples.rays();
    let parts = chunk_gradients(samples, grad_raw);
    parts.into_par_iter().for_each(|(c, first, grad)| {
        grad.fill(0.0);
        for r in c * CHUNK..((c + 1) * CHUNK).min(rays) {
            let total = &out[r * RAY_OUTPUTS..(r + 1) * RAY_OUTPUTS];
            let g = &grad_out[r * RAY_OUTPUTS..(r + 1) * RAY_OUTPUTS];
            let mut prefix = [0f32; RAY_OUTPUTS];
            let mut transmittance = 1.0f32;
            for s in samples.range(r) {
                let (sigma, dt, t) = (raw[4 * s], samples.dt[s], samples.t[s]);
                let alpha = 1.0 - (-sigma * dt).exp();
                let w = transmittance * alpha;
                let next = transmittance * (1.0 - alpha);
                let q = [raw[4 * s + 1], raw[4 * s + 2], raw[4 * s + 3], 1.0, t];
                let mut own = 0.0;
                let mut suffix = 0.0;
                for k in 0..RAY_OUTPUTS {
                    prefix[k] += w * q[k];
                    own += g[k] * q[k];
                    suffix += g[k] * (total[k] - prefix[k]);
                }
                let gs = &mut grad[4 * (s - first)..4 * (s - first) + 4];
                gs[0] = dt * (next * own - suffix);
                for k in 0..3 {
                    gs[1 + k] = w * g[k];
                }
                transmittance = next;
                if transmittance < min_transmittance {
                    break;
                }
            }
        }
    });
}

/// The weights `w_i` of one ray's samples (the forward's, up to its termination).
fn ray_weights(samples: &PackedSamples, raw: &[f32], r: usize, min_transmittance: f32, w: &mut Vec<f32>) {
    w.clear();
    let mut transmittance = 1.0f32;
    for s in samples.range(r) {
        let alpha = 1.0 - (-raw[4 * s] * samples.dt[s]).exp();
        w.push(transmittance * alpha);
        transmittance *= 1.0 - alpha;
        if transmittance < min_transmittance {
            break;
        }
    }
}

/// Mip-NeRF 360's distortion loss of each ray, `Σ_ij w_i w_j |t_i − t_j| + ⅓ Σ_i w_i² dt_i`:
/// small when a ray's weight sits in one short stretch (a sharp surface), large when it is
/// spread along the ray (a soft surface or floaters in front of one).
pub fn distortion_loss(samples: &PackedSamples, raw: &[f32], min_transmittance: f32) -> Vec<f32> {
    let mut w = Vec::new();
    (0..samples.rays())
        .map(|r| {
            ray_weights(samples, raw, r, min_transmittance, &mut w);
            let first = samples.offsets[r] as usize;
            let (mut below_w, mut below_wt, mut loss) = (0f32, 0f32, 0f32);
            for (i, &wi) in w.iter().enumerate() {
                let (t, dt) = (samples.t[first + i], samples.dt[first + i]);
                // Samples are in order along the ray: |t_i − t_j| = t_i − t_j for j < i.
                loss += 2.0 * wi * (t * below_w - below_wt) + wi * wi * dt / 3.0;
                below_w += wi;
                below_wt += wi * t;
            }
            loss
        })
        .collect()
}

/// Adds `scale · ∂(Σ_rays distortion)/∂σ` to the density column of `grad_raw` (`S×4`), in
/// O(samples) per ray: `∂L/∂w_i = 2 Σ_j w_j |t_i − t_j| + ⅔ w_i dt_i` from prefix sums, then
/// through the weights as in [`composite_backward`].
pub fn add_distortion_gradient(
    samples: &PackedSamples,
    raw: &[f32],
    scale: f32,
    min_transmittance: f32,
    grad_raw: &mut [f32],
) {
    assert_eq!(grad_raw.len(), raw.len(), "gradient matches raw");
    let rays = samples.rays();
    let parts = chunk_gradients(samples, grad_raw);
    parts.into_par_iter().for_each(|(c, first, grad)| {
        let (mut w, mut gw) = (Vec::new(), Vec::new());
        for r in c * CHUNK..((c + 1) * CHUNK).min(rays) {
            ray_weights(samples, raw, r, min_transmittance, &mut w);
            let start = samples.offsets[r] as usize;
            let t = |i: usize| samples.t[start + i];
            let (total_w, total_wt) =
                w.iter().enumerate().fold((0f32, 0f32), |(a, b), (i, &wi)| (a + wi, b + wi * t(i)));
            gw.clear();
            let (mut below_w, mut below_wt) = (0f32, 0f32);
            for (i, &wi) in w.iter().enumerate() {
                let (ti, dt) = (t(i), samples.dt[start + i]);
                let (above_w, above_wt) = (total_w - below_w - wi, total_wt - below_wt - wi * ti);
                let spread = ti * below_w - below_wt + above_wt - ti * above_w;
                gw.push(2.0 * spread + 2.0 * wi * dt / 3.0);
                below_w += wi;
                below_wt += wi * ti;
            }
            let total: f32 = w.iter().zip(&gw).map(|(a, b)| a * b).sum();
            let (mut prefix, mut transmittance) = (0f32, 1.0f32);
            for (i, (&wi, &g)) in w.iter().zip(&gw).enumerate() {
                let dt = samples.dt[start + i];
                let next = transmittance - wi;
                prefix += wi * g;
                grad[4 * (start + i - first)] += scale * dt * (next * g - (total - prefix));
                transmittance = next;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use lucid_scene::sampling::Rng;

    fn random_rays(rng: &mut Rng, counts: &[usize]) -> (PackedSamples, Vec<f32>) {
        let mut p = PackedSamples { offsets: vec![0], ..Default::default() };
        let mut raw = Vec::new();
        for &n in counts {
            let mut t = 0.5 + rng.uniform();
            for _ in 0..n {
                let dt = 0.05 + 0.2 * rng.uniform();
                p.t.push(t);
                p.dt.push(dt);
                t += dt;
                raw.extend([4.0 * rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform()]);
            }
            p.offsets.push(p.t.len() as u32);
        }
        (p, raw)
    }

    #[test]
    fn a_single_opaque_sample_gives_its_colour_and_depth() {
        let p = PackedSamples { offsets: vec![0, 1], t: vec![2.0], dt: vec![1.0] };
        let raw = [1e4, 0.2, 0.4, 0.6];
        let mut out = [0.0; 5];
        composite_forward(&p, &raw, 1e-4, &mut out);
        for (a, b) in out.iter().zip([0.2, 0.4, 0.6, 1.0, 2.0]) {
            assert!((a - b).abs() < 1e-6, "{out:?}");
        }
    }

    #[test]
    fn homogeneous_medium_opacity_follows_beer_lambert() {
        // σ = 0.7 over 10 segments of 0.1: opacity 1 − e^{−0.7}, whatever the split.
        let n = 10;
        let p =
            PackedSamples { offsets: vec![0, n as u32], t: (0..n).map(|i| i as f32 * 0.1).collect(), dt: vec![0.1; n] };
        let raw: Vec<f32> = (0..n).flat_map(|_| [0.7, 1.0, 1.0, 1.0]).collect();
        let mut out = [0.0; 5];
        composite_forward(&p, &raw, 0.0, &mut out);
        assert!((out[3] - (1.0 - (-0.7f32).exp())).abs() < 1e-6);
        assert!((out[0] - out[3]).abs() < 1e-6, "white samples: colour equals opacity");
    }

    #[test]
    fn backward_matches_finite_differences() {
        let mut rng = Rng::new(3, 0);
        let (p, raw) = random_rays(&mut rng, &[5, 0, 1, 7, 3]);
        let g: Vec<f32> = (0..p.rays() * RAY_OUTPUTS).map(|_| rng.uniform() - 0.5).collect();
        let loss = |raw: &[f32]| {
            let mut out = vec![0.0; p.rays() * RAY_OUTPUTS];
            composite_forward(&p, raw, 0.0, &mut out);
            out.iter().zip(&g).map(|(a, b)| *a as f64 * *b as f64).sum::<f64>()
        };
        let mut out = vec![0.0; p.rays() * RAY_OUTPUTS];
        composite_forward(&p, &raw, 0.0, &mut out);
        let mut grad = vec![0.0; raw.len()];
        composite_backward(&p, &raw, &out, &g, 0.0, &mut grad);
        let eps = 1e-3;
        for i in 0..raw.len() {
            let mut plus = raw.clone();
            plus[i] += eps;
            let mut minus = raw.clone();
            minus[i] -= eps;
            let fd = (loss(&plus) - loss(&minus)) / (2.0 * eps as f64);
            assert!((fd - grad[i] as f64).abs() < 2e-3 * (1.0 + fd.abs()), "raw[{i}]: fd {fd} vs {}", grad[i]);
        }
    }

    #[test]
    fn distortion_gradient_matches_finite_differences() {
        let mut rng = Rng::new(5, 1);
        let (p, raw) = random_rays(&mut rng, &[6, 0, 1, 9, 3]);
        let total = |raw: &[f32]| distortion_loss(&p, raw, 0.0).iter().map(|&l| l as f64).sum::<f64>();
        let mut grad = vec![0.0; raw.len()];
        add_distortion_gradient(&p, &raw, 1.0, 0.0, &mut grad);
        let eps = 1e-3;
        for s in 0..p.samples() {
            let mut plus = raw.clone();
            plus[4 * s] += eps;
            let mut minus = raw.clone();
            minus[4 * s] -= eps;
            let fd = (total(&plus) - total(&minus)) / (2.0 * eps as f64);
            assert!(
                (fd - grad[4 * s] as f64).abs() < 2e-3 * (1.0 + fd.abs()),
                "sigma[{s}]: fd {fd} vs {}",
                grad[4 * s]
            );
            assert!(grad[4 * s + 1..4 * s + 4].iter().all(|&g| g == 0.0), "colours get no gradient");
        }
    }

    #[test]
    fn distortion_of_one_opaque_sample_is_a_third_of_its_length_and_spread_weight_costs_more() {
        let one = PackedSamples { offsets: vec![0, 1], t: vec![2.0], dt: vec![0.3] };
        let l = distortion_loss(&one, &[1e4, 0.0, 0.0, 0.0], 1e-4)[0];
        assert!((l - 0.1).abs() < 1e-6, "{l}");
        // Half the weight at t = 1 and half at t = 2 (dt → 0): 2·¼·1 = ½.
        let two = PackedSamples { offsets: vec![0, 2], t: vec![1.0, 2.0], dt: vec![1e-6, 1e-6] };
        let s0 = std::f32::consts::LN_2 / 1e-6;
        let l = distortion_loss(&two, &[s0, 0.0, 0.0, 0.0, 1e12, 0.0, 0.0, 0.0], 0.0)[0];
        assert!((l - 0.5).abs() < 1e-3, "{l}");
    }

    #[test]
    fn early_termination_drops_later_samples_from_value_and_gradient() {
        let p = PackedSamples { offsets: vec![0, 3], t: vec![1.0, 2.0, 3.0], dt: vec![1.0; 3] };
        let raw = [20.0, 1.0, 0.0, 0.0, 5.0, 0.0, 1.0, 0.0, 5.0, 0.0, 0.0, 1.0];
        let mut out = [0.0; 5];
        composite_forward(&p, &raw, 1e-4, &mut out);
        let mut grad = [1.0; 12];
        composite_backward(&p, &raw, &out, &[1.0; 5], 1e-4, &mut grad);
        assert_eq!(out[1], 0.0, "the second sample is never reached");
        assert!(grad[4..].iter().all(|&g| g == 0.0), "{grad:?}");
    }
}
