//! Held-out evaluation: render each view, composite its ground truth on the same background,
//! and score both in sRGB-encoded space (the NeRF literature's convention, see DESIGN.md).

use std::time::Instant;

use lucid_image::Image;
use lucid_image::metrics::{psnr, ssim};
use serde::Serialize;

use crate::data::ImageSet;
use crate::render::view::{RenderedView, ViewRenderer};

/// Rays per pixel over the lens for thin-lens views.
pub const LENS_RAYS: usize = 32;

/// The scores of one view.
#[derive(Clone, Debug, Serialize)]
pub struct ViewScore {
    /// The ground-truth file.
    pub image: String,
    /// PSNR in dB.
    pub psnr: f64,
    /// SSIM.
    pub ssim: f64,
    /// Render time in seconds.
    pub seconds: f64,
    /// Field samples evaluated.
    pub samples: usize,
}

/// Averages over the views.
#[derive(Clone, Debug, Serialize)]
pub struct EvalSummary {
    /// Views scored.
    pub views: usize,
    /// Mean PSNR (dB).
    pub psnr: f64,
    /// Mean SSIM.
    pub ssim: f64,
    /// Mean render time per view (s).
    pub seconds_per_view: f64,
    /// The background both images were composited on.
    pub background: [f32; 3],
}

/// The ground truth of view `i` composited on `background` (encoded space, opaque).
pub fn ground_truth(set: &ImageSet, i: usize, background: [f32; 3]) -> Image {
    let (w, h) = set.size(i);
    let pixels = set.pixels[i]
        .iter()
        .map(|p| {
            let a = p[3];
            [
                p[0] * a + background[0] * (1.0 - a),
                p[1] * a + background[1] * (1.0 - a),
                p[2] * a + background[2] * (1.0 - a),
                1.0,
            ]
        })
        .collect();
    Image::from_pixels(w, h, pixels)
}

/// Renders and scores every view of `set` (or the first `limit`), calling `each` with the
/// index, the render, the ground truth and the score (to write files or report progress).
pub fn evaluate(
    renderer: &ViewRenderer,
    set: &ImageSet,
    limit: Option<usize>,
    mut each: impl FnMut(usize, &RenderedView, &Image, &ViewScore),
) -> (Vec<ViewScore>, EvalSummary) {
    let n = limit.unwrap_or(set.len()).min(set.len());
    let mut scores = Vec::with_capacity(n);
    for i in 0..n {
        let start = Instant::now();
        // Views with a thin lens (refocused ground truths) are rendered through the same lens.
        let view = match set.lenses[i] {
            Some(lens) => renderer.render_lens(&set.cameras[i], Some(lens), LENS_RAYS, i as u64),
            None => renderer.render(&set.cameras[i]),
        };
        let seconds = start.elapsed().as_secs_f64();
        let truth = ground_truth(set, i, renderer.background);
        let opaque = view.colour.map(|p| [p[0], p[1], p[2], 1.0]);
        let score = ViewScore {
            image: set.paths[i].display().to_string(),
            psnr: psnr(&opaque, &truth, None).expect("same size"),
            ssim: ssim(&opaque, &truth, None).expect("same size"),
            seconds,
            samples: view.samples,
        };
        each(i, &view, &truth, &score);
        scores.push(score);
    }
    let mean = |f: &dyn Fn(&ViewScore) -> f64| scores.iter().map(f).sum::<f64>() / scores.len().max(1) as f64;
    let summary = EvalSummary {
        views: scores.len(),
        psnr: mean(&|s| s.psnr),
        ssim: mean(&|s| s.ssim),
        seconds_per_view: mean(&|s| s.seconds),
        background: renderer.background,
    };
    (scores, summary)
}
