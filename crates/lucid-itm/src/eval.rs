//! Scoring an ITM method on held-out pairs: log-domain PSNR over the clipped pixels (where
//! the methods differ) and over all pixels, and PSNR after a fixed tone map
//! (`x/(1+x)`, sRGB-encoded) — for the network, the analytic baseline and the plain inverse
//! response.

use burn::tensor::{Device, Tensor, TensorData};
use lucid_hdr::itm::{highlight_gain, log_difference, log_psnr};
use lucid_image::color::srgb_encode;
use serde::Serialize;

use crate::data::ItmImage;
use crate::model::ItmNet;

/// Highlight boost of the analytic baseline, in stops at full clipping.
pub const BASELINE_BOOST_STOPS: f32 = 2.0;

/// Scores of one method.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct MethodScore {
    /// Log-PSNR over pixels with `α > 0`.
    pub log_psnr_clipped: f64,
    /// Log-PSNR over all pixels.
    pub log_psnr: f64,
    /// PSNR of `x/(1+x)` in sRGB over all pixels.
    pub tonemapped_psnr: f64,
}

/// Scores of the network against the baselines.
#[derive(Clone, Debug, Serialize)]
pub struct ItmReport {
    /// Images scored.
    pub images: usize,
    /// Share of pixels with `α > 0`.
    pub clipped_fraction: f64,
    /// The network.
    pub network: MethodScore,
    /// The analytic baseline (inverse response + highlight expansion).
    pub analytic: MethodScore,
    /// The inverse response alone.
    pub inverse_response: MethodScore,
}

#[derive(Default)]
struct Sums {
    clipped: (f64, usize),
    all: (f64, usize),
    tonemapped: (f64, usize),
}

impl Sums {
    fn add(&mut self, pred: &[f32], img: &ItmImage) {
        let n = img.width * img.height;
        for c in 0..3 {
            for i in 0..n {
                let (p, t) = (pred[c * n + i], img.truth[c * n + i]);
                let d = log_difference(p, t) as f64;
                self.all.0 += d * d;
                self.all.1 += 1;
                if img.mask[i] > 0.0 {
                    self.clipped.0 += d * d;
                    self.clipped.1 += 1;
                }
                let tm = |x: f32| srgb_encode(x.max(0.0) / (1.0 + x.max(0.0)));
                let e = (tm(p) - tm(t)) as f64;
                self.tonemapped.0 += e * e;
                self.tonemapped.1 += 1;
            }
        }
    }

    fn score(&self, peak: f32) -> MethodScore {
        let mse = self.tonemapped.0 / self.tonemapped.1.max(1) as f64;
        MethodScore {
            log_psnr_clipped: log_psnr(self.clipped.0, self.clipped.1, peak),
            log_psnr: log_psnr(self.all.0, self.all.1, peak),
            tonemapped_psnr: 10.0 * (1.0 / mse.max(1e-20)).log10(),
        }
    }
}

/// The network's HDR prediction for one image (planar `3×H×W`).
pub fn predict(net: &ItmNet, img: &ItmImage, device: &Device) -> Vec<f32> {
    let (w, h) = (img.width, img.height);
    let t = |v: &[f32], c: usize| Tensor::<4>::from_data(TensorData::new(v.to_vec(), [1, c, h, w]), device);
    let out = net.predict(t(&img.display, 3), t(&img.linear, 3), t(&img.mask, 1));
    lucid_burn::to_host_tensor(out)
}

/// The analytic baseline's prediction (planar).
pub fn analytic(img: &ItmImage) -> Vec<f32> {
    let n = img.width * img.height;
    let mut out = img.linear.clone();
    for i in 0..n {
        let gain = highlight_gain(img.mask[i], BASELINE_BOOST_STOPS);
        for c in 0..3 {
            out[c * n + i] *= gain;
        }
    }
    out
}

/// Scores the network and the baselines on `images`.
pub fn evaluate(net: &ItmNet, images: &[ItmImage], device: &Device) -> ItmReport {
    let peak = images.iter().flat_map(|i| i.truth.iter().copied()).fold(1.0f32, f32::max);
    let (mut network, mut baseline, mut plain) = (Sums::default(), Sums::default(), Sums::default());
    let (mut clipped, mut pixels) = (0usize, 0usize);
    for img in images {
        network.add(&predict(net, img, device), img);
        baseline.add(&analytic(img), img);
        plain.add(&img.linear, img);
        clipped += img.clipped.len();
        pixels += img.width * img.height;
    }
    ItmReport {
        images: images.len(),
        clipped_fraction: clipped as f64 / pixels.max(1) as f64,
        network: network.score(peak),
        analytic: baseline.score(peak),
        inverse_response: plain.score(peak),
    }
}
