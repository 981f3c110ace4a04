//! Scoring an ITM method on held-out pairs: log-domain PSNR over the clipped pixels (where
//! the methods differ) and over all pixels, and PSNR after a fixed tone map
//! (`x/(1+x)`, sRGB-encoded) — for the network, the strongest analytic baseline and the plain
//! inverse response.

use burn::tensor::{Device, Tensor, TensorData};
use lucid_hdr::itm::{highlight_gain, log_difference, log_psnr};
use lucid_image::color::srgb_encode;
use serde::Serialize;

use crate::data::ItmImage;
use crate::model::ItmNet;

/// The analytic baselines' highlight boosts, in stops at full clipping (0: the inverse response
/// alone). The report's analytic row uses the best of them on training pairs
/// ([`best_boost`]), so that the network is compared with the strongest baseline of the
/// family, tuned as the network is, on data other than the scored views.
pub const BASELINE_BOOSTS: [f32; 7] = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0];

/// The boost of [`BASELINE_BOOSTS`] with the best clipped log-PSNR on `images`.
pub fn best_boost(images: &[ItmImage]) -> f32 {
    let peak = peak(images);
    let scores: Vec<f64> = BASELINE_BOOSTS
        .iter()
        .map(|&boost| {
            let mut sums = Sums::default();
            images.iter().for_each(|img| sums.add(&analytic(img, boost), img));
            sums.score(peak).log_psnr_clipped
        })
        .collect();
    let best = (0..scores.len()).max_by(|&a, &b| scores[a].total_cmp(&scores[b])).expect("baselines");
    BASELINE_BOOSTS[best]
}

fn peak(images: &[ItmImage]) -> f32 {
    images.iter().flat_map(|i| i.truth.iter().copied()).fold(1.0f32, f32::max)
}

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
    /// The analytic baseline: inverse response + highlight expansion by
    /// `analytic_boost_stops`, the best of [`BASELINE_BOOSTS`] on training pairs.
    pub analytic: MethodScore,
    /// The analytic baseline's boost, in stops.
    pub analytic_boost_stops: f32,
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

/// The analytic baseline's prediction (planar): the inverse response, with highlights boosted
/// by up to `boost_stops` where the input clips.
pub fn analytic(img: &ItmImage, boost_stops: f32) -> Vec<f32> {
    let n = img.width * img.height;
    let mut out = img.linear.clone();
    for i in 0..n {
        let gain = highlight_gain(img.mask[i], boost_stops);
        for c in 0..3 {
            out[c * n + i] *= gain;
        }
    }
    out
}

/// Scores the network, the analytic baseline with `boost_stops` (choose it with
/// [`best_boost`] on training pairs) and the inverse response on `images`.
pub fn evaluate(net: &ItmNet, images: &[ItmImage], device: &Device, boost_stops: f32) -> ItmReport {
    let peak = peak(images);
    let (mut network, mut baseline, mut plain) = (Sums::default(), Sums::default(), Sums::default());
    let (mut clipped, mut pixels) = (0usize, 0usize);
    for img in images {
        network.add(&predict(net, img, device), img);
        baseline.add(&analytic(img, boost_stops), img);
        plain.add(&img.linear, img);
        clipped += img.clipped.len();
        pixels += img.width * img.height;
    }
    ItmReport {
        images: images.len(),
        clipped_fraction: clipped as f64 / pixels.max(1) as f64,
        network: network.score(peak),
        analytic: baseline.score(peak),
        analytic_boost_stops: boost_stops,
        inverse_response: plain.score(peak),
    }
}

impl ItmReport {
    /// The report as a table, one line each.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![
            format!(
                "ITM on {} held-out exposures ({:.2} % of pixels clipped)",
                self.images,
                100.0 * self.clipped_fraction
            ),
            format!("{:<18} {:>18} {:>14} {:>20}", "method", "log-PSNR clipped", "log-PSNR all", "tone-mapped PSNR"),
        ];
        let analytic = format!("analytic ({} EV)", self.analytic_boost_stops);
        for (name, s) in [
            ("network", &self.network),
            (analytic.as_str(), &self.analytic),
            ("inverse response", &self.inverse_response),
        ] {
            lines.push(format!(
                "{name:<18} {:>18.2} {:>14.2} {:>20.2}",
                s.log_psnr_clipped, s.log_psnr, s.tonemapped_psnr
            ));
        }
        lines
    }
}

fn planar_image(v: &[f32], w: usize, h: usize) -> lucid_image::Image {
    let n = w * h;
    lucid_image::Image::from_fn(w, h, |x, y| {
        let i = y * w + x;
        [v[i], v[n + i], v[2 * n + i], 1.0]
    })
}

/// Evaluates `net` on `images` and writes into `out`: per exposure the network's prediction,
/// the analytic baseline's and the truth (`NNN_network.exr`, `NNN_analytic.exr`,
/// `NNN_truth.exr`), and `metrics.json`.
pub fn evaluate_into(
    net: &ItmNet,
    images: &[ItmImage],
    device: &Device,
    boost_stops: f32,
    out: &std::path::Path,
) -> Result<ItmReport, lucid_image::ImageError> {
    use lucid_image::write_image;
    let report = evaluate(net, images, device, boost_stops);
    let folder = lucid_image::owned_folder::OwnedFolder::claim(out, "the evaluation", &[])?;
    for (k, img) in images.iter().enumerate() {
        let (w, h) = (img.width, img.height);
        write_image(out.join(format!("{k:03}_network.exr")), &planar_image(&predict(net, img, device), w, h))?;
        let baseline = analytic(img, report.analytic_boost_stops);
        write_image(out.join(format!("{k:03}_analytic.exr")), &planar_image(&baseline, w, h))?;
        write_image(out.join(format!("{k:03}_truth.exr")), &planar_image(&img.truth, w, h))?;
    }
    let json = serde_json::to_string_pretty(&report).expect("serialises");
    lucid_image::output::write_text(&out.join("metrics.json"), &json)?;
    folder.finish()?;
    Ok(report)
}
