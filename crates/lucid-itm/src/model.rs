//! The network: a two-level U-Net (Ronneberger et al. 2015) small enough to train on a CPU.
//!
//! `3 → w → w` at full resolution, `w → 2w → 2w` at half, `2w → 4w` at a quarter, then back up
//! by nearest-neighbour upsampling and concatenation with the skip features, `3w → 2w`,
//! `3w → w`, and a final `w → 3` convolution giving the log gain. ReLU between layers; 3×3
//! convolutions with zero padding, so any image size works (pooling floors, upsampling goes
//! back to the skip's exact size).

use burn::module::Module;
use burn::nn::PaddingConfig2d;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::tensor::activation::relu;
use burn::tensor::module::{avg_pool2d, interpolate};
use burn::tensor::ops::{AvgPoolOptions, InterpolateMode, InterpolateOptions};
use burn::tensor::{Device, Tensor};

/// The ITM network.
#[derive(Module, Debug)]
pub struct ItmNet {
    enc1a: Conv2d,
    enc1b: Conv2d,
    enc2a: Conv2d,
    enc2b: Conv2d,
    bottom: Conv2d,
    dec2: Conv2d,
    dec1: Conv2d,
    out: Conv2d,
}

fn conv(cin: usize, cout: usize, device: &Device) -> Conv2d {
    Conv2dConfig::new([cin, cout], [3, 3]).with_padding(PaddingConfig2d::Same).init(device)
}

fn down(x: Tensor<4>) -> Tensor<4> {
    avg_pool2d(x, AvgPoolOptions::new([2, 2]))
}

fn up_to(x: Tensor<4>, like: &Tensor<4>) -> Tensor<4> {
    let [_, _, h, w] = like.dims();
    interpolate(x, InterpolateOptions::new(InterpolateMode::Nearest).with_output_size([h, w]))
}

impl ItmNet {
    /// A freshly initialised network with `width` channels at the first level.
    pub fn new(width: usize, device: &Device) -> Self {
        let w = width;
        Self {
            enc1a: conv(3, w, device),
            enc1b: conv(w, w, device),
            enc2a: conv(w, 2 * w, device),
            enc2b: conv(2 * w, 2 * w, device),
            bottom: conv(2 * w, 4 * w, device),
            dec2: conv(6 * w, 2 * w, device),
            dec1: conv(3 * w, w, device),
            out: conv(w, 3, device),
        }
    }

    /// Log gains `N×3×H×W` from display values `N×3×H×W` in `[0, 1]` (centred on 0 inside).
    pub fn forward(&self, display: Tensor<4>) -> Tensor<4> {
        let x = display - 0.5;
        let e1 = relu(self.enc1b.forward(relu(self.enc1a.forward(x))));
        let e2 = relu(self.enc2b.forward(relu(self.enc2a.forward(down(e1.clone())))));
        let b = relu(self.bottom.forward(down(e2.clone())));
        let d2 = relu(self.dec2.forward(Tensor::cat(vec![up_to(b, &e2), e2], 1)));
        let d1 = relu(self.dec1.forward(Tensor::cat(vec![up_to(d2, &e1), e1], 1)));
        self.out.forward(d1)
    }

    /// HDR exposure `f⁻¹(y)·(1 + α(eʳ − 1))` from the display values, their linearisation and
    /// the clipping mask (`N×1×H×W`).
    pub fn predict(&self, display: Tensor<4>, linear: Tensor<4>, mask: Tensor<4>) -> Tensor<4> {
        let gain = self.forward(display).exp() - 1.0;
        linear.clone() + linear * gain * mask
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Tensor, TensorData};

    use super::*;

    /// Whatever the weights, the prediction is the linearised input exactly where the mask
    /// is 0, and differs from it where the mask is on.
    #[test]
    fn prediction_is_the_linear_input_where_the_mask_is_off() {
        let device = lucid_burn::backend::default_device();
        device.seed(3);
        let net = ItmNet::new(4, &device);
        let (h, w) = (6, 10);
        let display: Vec<f32> = (0..3 * h * w).map(|k| (k % 17) as f32 / 16.0).collect();
        let linear: Vec<f32> = display.iter().map(|&y| lucid_hdr::itm::linearise(y)).collect();
        let mask: Vec<f32> = (0..h * w).map(|i| if i % 3 == 0 { 0.7 } else { 0.0 }).collect();
        let t = |v: &[f32], c: usize| Tensor::<4>::from_data(TensorData::new(v.to_vec(), [1, c, h, w]), &device);
        let out = lucid_burn::to_host_tensor(net.predict(t(&display, 3), t(&linear, 3), t(&mask, 1)));
        let mut changed = 0;
        for c in 0..3 {
            for (i, &m) in mask.iter().enumerate() {
                let k = c * h * w + i;
                if m == 0.0 {
                    assert_eq!(out[k], linear[k], "pixel {i} channel {c}");
                } else if (out[k] - linear[k]).abs() > 1e-6 {
                    changed += 1;
                }
            }
        }
        assert!(changed > 0, "the network acts where the mask is on");
    }
}
