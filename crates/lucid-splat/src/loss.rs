//! The 3DGS photometric loss, `(1 − λ)·L1 + λ·(1 − SSIM)`, in burn tensor operations (so its
//! gradient is burn's): the definition that the trainer's hand-written kernel
//! ([`crate::photometric`]) is tested against, and the SSIM constants both use. SSIM as in
//! the reference trainer: 11×11 Gaussian window (σ = 1.5), zero padding to the same size,
//! averaged over pixels and channels; the window is applied as two separable depthwise
//! convolutions.

use burn::tensor::module::conv2d;
use burn::tensor::ops::ConvOptions;
use burn::tensor::{Device, Tensor, TensorData};

pub(crate) const WINDOW: usize = 11;
const SIGMA: f32 = 1.5;
pub(crate) const C1: f32 = 0.01 * 0.01;
pub(crate) const C2: f32 = 0.03 * 0.03;

/// The normalised 1-D window.
pub(crate) fn gaussian_window() -> [f32; WINDOW] {
    let h = (WINDOW / 2) as f32;
    let w: [f32; WINDOW] = std::array::from_fn(|i| (-((i as f32 - h).powi(2)) / (2.0 * SIGMA * SIGMA)).exp());
    let sum: f32 = w.iter().sum();
    w.map(|v| v / sum)
}

/// Separable Gaussian blur of `x` (`1×C×H×W`), same size, zero padded.
fn blur(x: Tensor<4>, device: &Device) -> Tensor<4> {
    let c = x.dims()[1];
    let w = gaussian_window();
    let row: Vec<f32> = (0..c).flat_map(|_| w.iter().copied()).collect();
    let horizontal = Tensor::<4>::from_data(TensorData::new(row.clone(), [c, 1, 1, WINDOW]), device);
    let vertical = Tensor::<4>::from_data(TensorData::new(row, [c, 1, WINDOW, 1]), device);
    let p = WINDOW / 2;
    let x = conv2d(x, horizontal, None, ConvOptions::new([1, 1], [0, p], [1, 1], c));
    conv2d(x, vertical, None, ConvOptions::new([1, 1], [p, 0], [1, 1], c))
}

/// Mean SSIM of two `H×W×C` images.
pub fn ssim(a: Tensor<3>, b: Tensor<3>) -> Tensor<1> {
    ssim_map(a, b).mean()
}

/// The SSIM of two `H×W×C` images at every pixel and channel, `1×C×H×W` (zero padded: the
/// border's windows reach outside the image).
pub fn ssim_map(a: Tensor<3>, b: Tensor<3>) -> Tensor<4> {
    let device = a.device();
    let to_nchw = |t: Tensor<3>| t.permute([2, 0, 1]).unsqueeze_dim::<4>(0);
    let (a, b) = (to_nchw(a), to_nchw(b));
    let mu_a = blur(a.clone(), &device);
    let mu_b = blur(b.clone(), &device);
    let (mu_a2, mu_b2, mu_ab) = (mu_a.clone().square(), mu_b.clone().square(), mu_a * mu_b);
    let var_a = blur(a.clone().square(), &device) - mu_a2.clone();
    let var_b = blur(b.clone().square(), &device) - mu_b2.clone();
    let cov = blur(a * b, &device) - mu_ab.clone();
    let num = (mu_ab * 2.0 + C1) * (cov * 2.0 + C2);
    let den = (mu_a2 + mu_b2 + C1) * (var_a + var_b + C2);
    num / den
}

/// `(1 − λ)·mean|a − b| + λ·(1 − SSIM(a, b))` and, for logs, the MSE, of `H×W×3` images.
pub fn photometric_loss(pred: Tensor<3>, target: Tensor<3>, ssim_weight: f32) -> (Tensor<1>, Tensor<1>) {
    let diff = pred.clone() - target.clone();
    let mse = diff.clone().square().mean().detach();
    let l1 = diff.abs().mean();
    let loss =
        if ssim_weight > 0.0 { l1 * (1.0 - ssim_weight) + (ssim(pred, target).neg() + 1.0) * ssim_weight } else { l1 };
    (loss, mse)
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Tensor, TensorData};

    use super::*;

    #[test]
    fn ssim_is_one_for_equal_images_and_drops_with_noise() {
        let device = lucid_burn::backend::default_device();
        let v: Vec<f32> = (0..24 * 20 * 3).map(|k| ((k * 37 % 101) as f32) / 101.0).collect();
        let a = Tensor::<3>::from_data(TensorData::new(v.clone(), [24, 20, 3]), &device);
        let s = ssim(a.clone(), a.clone()).into_data().try_to_vec::<f32>().unwrap()[0];
        assert!((s - 1.0).abs() < 1e-5, "{s}");
        let noisy: Vec<f32> = v.iter().enumerate().map(|(k, x)| x + if k % 2 == 0 { 0.1 } else { -0.1 }).collect();
        let b = Tensor::<3>::from_data(TensorData::new(noisy, [24, 20, 3]), &device);
        let s = ssim(a, b).into_data().try_to_vec::<f32>().unwrap()[0];
        assert!(s < 0.95 && s > 0.0, "{s}");
    }

    /// Away from the border, where no window reaches the zero padding, the loss's SSIM map is
    /// the metric's, which matches scikit-image (`lucid_image::metrics`, tested against its
    /// values): same window, constants and formula.
    #[test]
    fn the_loss_ssim_is_the_metric_ssim_inside_the_border() {
        let device = lucid_burn::backend::default_device();
        let (w, h) = (30usize, 26usize);
        let value = |k: usize, salt: usize| ((k * 37 + salt * 11) % 101) as f32 / 101.0;
        let image = |salt: usize| {
            lucid_image::Image::from_fn(w, h, |x, y| {
                let k = 3 * (y * w + x);
                let smooth = 0.5 + 0.4 * ((x as f32 * 0.3).sin() * (y as f32 * 0.2).cos());
                let v = |c: usize| 0.5 * smooth + 0.5 * value(k + c, salt);
                [v(0), v(1), v(2), 1.0]
            })
        };
        let (ia, ib) = (image(1), image(2));
        let tensor = |i: &lucid_image::Image| {
            let v: Vec<f32> = i.pixels().iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
            Tensor::<3>::from_data(TensorData::new(v, [h, w, 3]), &device)
        };
        let map = ssim_map(tensor(&ia), tensor(&ib)).into_data().try_to_vec::<f32>().unwrap();
        let r = WINDOW / 2;
        let mut sum = 0.0f64;
        for c in 0..3 {
            for y in r..h - r {
                for x in r..w - r {
                    sum += map[(c * h + y) * w + x] as f64;
                }
            }
        }
        let inside = sum / (3 * (h - 2 * r) * (w - 2 * r)) as f64;
        let metric = lucid_image::metrics::ssim(&ia, &ib, None).unwrap();
        assert!(metric > 0.2 && metric < 0.9, "a pair neither alike nor unrelated: {metric}");
        assert!((inside - metric).abs() < 1e-5, "loss {inside} vs metric {metric}");
    }
}
