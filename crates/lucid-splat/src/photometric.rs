//! The 3DGS photometric loss, `(1 − λ)·L1 + λ·(1 − SSIM)`, and its gradient in one pass over
//! slices: the definitions of [`crate::loss`] (the reference trainer's: 11×11 Gaussian window
//! of σ = 1.5, zero padding, mean over pixels and channels), computed by hand because burn's
//! version of it (five depthwise convolutions and some twenty whole-image temporaries, then
//! their backward through burn's graph) cost more per step than rasterizing the image.
//!
//! The SSIM gradient is closed-form: with `μ = G∗a`, `m₂ = G∗a²` and `m₃ = G∗ab` (b fixed),
//! each pixel's SSIM `S` depends on `a` only through them, so
//! `∂S̄/∂a = (G∗∂S/∂μ + 2a·G∗∂S/∂m₂ + b·G∗∂S/∂m₃) / N`: the window is symmetric, so the
//! adjoint of its zero-padded blur is the same blur.

use rayon::prelude::*;

use crate::loss::{C1, C2, WINDOW, gaussian_window};

/// A rendered image and what it is compared with.
#[derive(Clone, Copy, Debug)]
pub struct LossInputs<'a> {
    /// The render, `H×W×4` (RGB, then alpha, which the loss ignores).
    pub image: &'a [f32],
    /// The target, `H×W×3`.
    pub target: &'a [f32],
    /// Per-pixel weights (`H×W`): both images are multiplied by them first (a mask blacks
    /// pixels out of the comparison).
    pub mask: Option<&'a [f32]>,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// λ, the weight of the SSIM term.
    pub ssim_weight: f32,
}

/// The loss, the image's mean squared error (for logs) and `∂loss/∂image` (`H×W×4`, zero for
/// alpha).
#[derive(Clone, Debug)]
pub struct LossOutput {
    /// The loss.
    pub loss: f32,
    /// Mean squared error over pixels and channels.
    pub mse: f32,
    /// `∂loss/∂image`.
    pub grad: Vec<f32>,
}

/// Zero-padded blur by the window, same size, of one plane: each tap is added over a whole
/// row (rows) or a whole image row of rows (columns) at once, so that the inner loops vectorise.
/// Sequential: the loss runs many of these side by side.
fn blur(src: &[f32], w: usize, h: usize, window: &[f32; WINDOW]) -> Vec<f32> {
    let r = WINDOW / 2;
    let mut rows = vec![0.0f32; w * h];
    for (dst, row) in rows.chunks_mut(w).zip(src.chunks(w)) {
        for (k, &t) in window.iter().enumerate() {
            // dst[x] += t·row[x + k − r] wherever both exist.
            let (d0, s0) = if k < r { (r - k, 0) } else { (0, k - r) };
            let len = w.saturating_sub(d0.max(s0));
            // In a row narrower than the window's radius a tap may reach no pixel at all.
            if len == 0 {
                continue;
            }
            for (d, v) in dst[d0..d0 + len].iter_mut().zip(&row[s0..s0 + len]) {
                *d += t * v;
            }
        }
    }
    let mut out = vec![0.0f32; w * h];
    for (y, dst) in out.chunks_mut(w).enumerate() {
        let lo = y.saturating_sub(r);
        let hi = (y + r).min(h - 1);
        for yy in lo..=hi {
            let t = window[yy + r - y];
            for (d, v) in dst.iter_mut().zip(&rows[yy * w..(yy + 1) * w]) {
                *d += t * v;
            }
        }
    }
    out
}

/// One channel's share: its L1 and squared-error sums, its SSIM sum, and `∂loss/∂a` before the
/// mask (filled in two phases around the second round of blurs).
struct Channel {
    a: Vec<f32>,
    b: Vec<f32>,
    abs_sum: f64,
    sq_sum: f64,
    ssim_sum: f64,
    grad: Vec<f32>,
}

/// The loss and its gradient with respect to the image. The work runs as a few parallel
/// phases of whole-plane tasks (15 blurs, 3 channels, 9 blurs) rather than many small parallel
/// loops, each of which would wait for both cores.
pub fn photometric_loss(inputs: &LossInputs) -> LossOutput {
    let (w, h) = (inputs.width, inputs.height);
    let n = w * h;
    assert_eq!(inputs.image.len(), 4 * n, "image is not {h}×{w}×4");
    assert_eq!(inputs.target.len(), 3 * n, "target is not {h}×{w}×3");
    let weight = |i: usize| inputs.mask.map_or(1.0, |m| m[i]);
    let count = (3 * n) as f32;
    let lambda = inputs.ssim_weight;
    let window = gaussian_window();
    let mut channels: Vec<Channel> = (0..3)
        .into_par_iter()
        .map(|c| {
            let a: Vec<f32> = (0..n).map(|i| inputs.image[4 * i + c] * weight(i)).collect();
            let b: Vec<f32> = (0..n).map(|i| inputs.target[3 * i + c] * weight(i)).collect();
            let (mut abs_sum, mut sq_sum) = (0.0f64, 0.0f64);
            // L1's subgradient: 0 where the images agree, as burn's `abs`.
            let grad = a
                .iter()
                .zip(&b)
                .map(|(x, y)| {
                    let d = x - y;
                    abs_sum += d.abs() as f64;
                    sq_sum += (d * d) as f64;
                    (1.0 - lambda)
                        * if d > 0.0 {
                            1.0
                        } else if d < 0.0 {
                            -1.0
                        } else {
                            0.0
                        }
                        / count
                })
                .collect();
            Channel { a, b, abs_sum, sq_sum, ssim_sum: 0.0, grad }
        })
        .collect();
    if lambda > 0.0 {
        // μ_a, μ_b, G∗a², G∗b², G∗ab of every channel.
        let moments: Vec<Vec<f32>> = (0..15)
            .into_par_iter()
            .map(|task| {
                let ch = &channels[task / 5];
                let product =
                    |f: fn(f32, f32) -> f32| -> Vec<f32> { ch.a.iter().zip(&ch.b).map(|(x, y)| f(*x, *y)).collect() };
                match task % 5 {
                    0 => blur(&ch.a, w, h, &window),
                    1 => blur(&ch.b, w, h, &window),
                    2 => blur(&product(|x, _| x * x), w, h, &window),
                    3 => blur(&product(|_, y| y * y), w, h, &window),
                    _ => blur(&product(|x, y| x * y), w, h, &window),
                }
            })
            .collect();
        // Per pixel: S and its partials with respect to μ_a, G∗a² and G∗ab.
        let partials: Vec<(f64, [Vec<f32>; 3])> = moments
            .par_chunks(5)
            .map(|m| {
                let [mu_a, mu_b, s_aa, s_bb, s_ab] = [&m[0], &m[1], &m[2], &m[3], &m[4]];
                let mut d: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0f32; n]);
                let mut sum = 0.0f64;
                for i in 0..n {
                    let (ma, mb) = (mu_a[i], mu_b[i]);
                    let (va, vb, cov) = (s_aa[i] - ma * ma, s_bb[i] - mb * mb, s_ab[i] - ma * mb);
                    let (a1, a2) = (2.0 * ma * mb + C1, 2.0 * cov + C2);
                    let (b1, b2) = (ma * ma + mb * mb + C1, va + vb + C2);
                    let den = b1 * b2;
                    let s = a1 * a2 / den;
                    sum += s as f64;
                    d[0][i] = 2.0 * mb * (a2 - a1) / den - 2.0 * ma * s * (1.0 / b1 - 1.0 / b2);
                    d[1][i] = -s / b2;
                    d[2][i] = 2.0 * a1 / den;
                }
                (sum, d)
            })
            .collect();
        let blurred: Vec<Vec<f32>> =
            (0..9).into_par_iter().map(|task| blur(&partials[task / 3].1[task % 3], w, h, &window)).collect();
        let scale = -lambda / count;
        channels.par_iter_mut().zip(blurred.par_chunks(3)).zip(&partials).for_each(|((ch, g), p)| {
            ch.ssim_sum = p.0;
            let terms = g[0].iter().zip(&g[1]).zip(&g[2]).zip(ch.a.iter().zip(&ch.b));
            for (v, (((g_mu, g_aa), g_ab), (x, y))) in ch.grad.iter_mut().zip(terms) {
                *v += scale * (g_mu + 2.0 * x * g_aa + y * g_ab);
            }
        });
    }
    let mut grad = vec![0.0f32; 4 * n];
    grad.par_chunks_mut(4).enumerate().for_each(|(i, px)| {
        let m = weight(i);
        for (c, ch) in channels.iter().enumerate() {
            px[c] = ch.grad[i] * m;
        }
    });
    let (l1, sse, ssim_sum) =
        channels.iter().fold((0.0, 0.0, 0.0), |t, ch| (t.0 + ch.abs_sum, t.1 + ch.sq_sum, t.2 + ch.ssim_sum));
    let mut loss = (1.0 - lambda as f64) * l1 / count as f64;
    if lambda > 0.0 {
        loss += lambda as f64 * (1.0 - ssim_sum / count as f64);
    }
    LossOutput { loss: loss as f32, mse: (sse / count as f64) as f32, grad }
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Tensor, TensorData};

    use super::*;

    /// An image and a target that differ in smooth and rough ways, with some pixels equal.
    fn pair(w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
        let value = |k: usize, salt: usize| ((k * 37 + salt * 11) % 101) as f32 / 101.0;
        let image: Vec<f32> = (0..w * h)
            .flat_map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let smooth = 0.5 + 0.4 * (x * 0.3).sin() * (y * 0.2).cos();
                [0, 1, 2].map(|c| 0.6 * smooth + 0.4 * value(3 * i + c, 1)).into_iter().chain([0.9])
            })
            .collect();
        let target: Vec<f32> = (0..w * h)
            .flat_map(|i| {
                [0, 1, 2]
                    .map(|c| if i % 7 == 0 { image[4 * i + c] } else { 0.7 * image[4 * i + c] + 0.3 * value(i + c, 2) })
            })
            .collect();
        (image, target)
    }

    /// The kernel is the burn implementation of the same loss (itself tested against the SSIM
    /// metric): equal loss, and a gradient equal to burn's autodiff of it, with and without a
    /// mask, for several weights.
    #[test]
    fn loss_and_gradient_are_burns() {
        // Images narrower than the window's radius too (a 4-pixel render once read past a row).
        for (w, h) in [(23, 17), (4, 4), (3, 9)] {
            loss_and_gradient_are_burns_at(w, h);
        }
    }

    fn loss_and_gradient_are_burns_at(w: usize, h: usize) {
        let (image, target) = pair(w, h);
        let mask: Vec<f32> = (0..w * h).map(|i| if i % 5 == 0 { 0.0 } else { 1.0 }).collect();
        let device = lucid_burn::backend::training_device();
        for (lambda, masked) in [(0.2, false), (0.2, true), (0.0, false), (1.0, false)] {
            let inputs = LossInputs {
                image: &image,
                target: &target,
                mask: masked.then_some(&mask[..]),
                width: w,
                height: h,
                ssim_weight: lambda,
            };
            let out = photometric_loss(&inputs);
            let img = Tensor::<3>::from_data(TensorData::new(image.clone(), [h, w, 4]), &device).require_grad();
            let rgb = img.clone().slice([0..h, 0..w, 0..3]);
            let tgt = Tensor::<3>::from_data(TensorData::new(target.clone(), [h, w, 3]), &device);
            let (loss, mse) = if masked {
                let m: Vec<f32> = mask.iter().flat_map(|&m| [m; 3]).collect();
                let m = Tensor::<3>::from_data(TensorData::new(m, [h, w, 3]), &device);
                crate::loss::photometric_loss(rgb * m.clone(), tgt * m, lambda)
            } else {
                crate::loss::photometric_loss(rgb, tgt, lambda)
            };
            let grads = loss.backward();
            let want = loss.into_data().try_to_vec::<f32>().unwrap()[0];
            let want_mse = mse.into_data().try_to_vec::<f32>().unwrap()[0];
            let want_grad = img.grad(&grads).unwrap().into_data().try_to_vec::<f32>().unwrap();
            assert!((out.loss - want).abs() < 1e-5 * want.abs().max(1.0), "λ {lambda}: loss {} vs {want}", out.loss);
            assert!((out.mse - want_mse).abs() < 1e-6, "λ {lambda}: mse {} vs {want_mse}", out.mse);
            let scale = want_grad.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let worst = out.grad.iter().zip(&want_grad).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-4 * scale, "λ {lambda}, masked {masked}: gradient off by {worst} (largest {scale})");
        }
    }

    /// The gradient against central differences of the loss itself.
    #[test]
    fn gradient_matches_finite_differences() {
        let (w, h) = (15, 12);
        let (image, target) = pair(w, h);
        let loss_at = |img: &[f32]| {
            let inputs = LossInputs { image: img, target: &target, mask: None, width: w, height: h, ssim_weight: 0.2 };
            photometric_loss(&inputs).loss as f64
        };
        let inputs = LossInputs { image: &image, target: &target, mask: None, width: w, height: h, ssim_weight: 0.2 };
        let grad = photometric_loss(&inputs).grad;
        let eps = 1e-3f32;
        for k in [0, 5, 4 * 37 + 1, 4 * 90 + 2, 4 * (w * h - 1), 4 * 50 + 3] {
            let (mut up, mut down) = (image.clone(), image.clone());
            up[k] += eps;
            down[k] -= eps;
            let fd = (loss_at(&up) - loss_at(&down)) / (2.0 * eps as f64);
            assert!((fd - grad[k] as f64).abs() < 2e-5 + 1e-2 * fd.abs(), "element {k}: {} vs {fd}", grad[k]);
        }
    }
}
