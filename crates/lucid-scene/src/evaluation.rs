//! Held-out evaluation shared by every model kind: render each view, composite its ground
//! truth on the same background, and score both in sRGB-encoded space (the NeRF literature's
//! convention, see DESIGN.md).

use std::time::Instant;

use lucid_image::Image;
use lucid_image::metrics::{psnr, ssim};
use serde::Serialize;

use crate::camera::PinholeCamera;
use crate::dataset::images::ImageSet;

/// A rendered view: colour composited on the background, and expected depth and opacity.
#[derive(Clone, Debug)]
pub struct RenderedView {
    /// Colour (sRGB-encoded, as trained) over the background; alpha is the opacity.
    pub colour: Image,
    /// Expected depth along the ray, divided by opacity (0 where nothing was hit).
    pub depth: Vec<f32>,
    /// Samples evaluated.
    pub samples: usize,
}

impl RenderedView {
    /// The colour as opaque linear RGB, for the image writers (which encode sRGB themselves).
    pub fn linear_colour(&self) -> Image {
        use lucid_image::color::srgb_decode;
        self.colour.map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), 1.0])
    }

    /// The expected depth as an image, in the dataset's own units where `frame` maps the
    /// dataset to the scene the model was trained in.
    pub fn depth_image(&self, frame: Option<&crate::dataset::SceneNormalisation>) -> Image {
        let (w, h) = self.colour.dimensions();
        let to_dataset = frame.map_or(1.0, |n| (1.0 / n.scale) as f32);
        Image::from_pixels(w, h, self.depth.iter().map(|&d| d * to_dataset).map(|d| [d, d, d, 1.0]).collect())
    }
}

/// A trained scene model that renders views (NeRF, splats, ...).
pub trait ViewModel {
    /// Renders `camera`; with `lens = Some((aperture radius, focus distance))` through a thin
    /// lens, averaging `lens_rays` samples over the aperture (seeded by `seed`).
    fn render_view(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
    ) -> RenderedView;

    /// [`Self::render_view`], given up (`None`) once `abandoned` says so: a viewer's client
    /// that has gone. A model that renders in parts asks between them.
    fn render_view_unless(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<RenderedView> {
        (!abandoned()).then(|| self.render_view(camera, lens, lens_rays, seed))
    }

    /// The background the renders are composited on (encoded).
    fn background(&self) -> [f32; 3];
}

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
    renderer: &dyn ViewModel,
    set: &ImageSet,
    limit: Option<usize>,
    mut each: impl FnMut(usize, &RenderedView, &Image, &ViewScore),
) -> (Vec<ViewScore>, EvalSummary) {
    let n = limit.unwrap_or(set.len()).min(set.len());
    let mut scores = Vec::with_capacity(n);
    for i in 0..n {
        let start = Instant::now();
        // Views with a thin lens (refocused ground truths) are rendered through the same lens.
        let view = renderer.render_view(&set.cameras[i], set.lenses[i], LENS_RAYS, i as u64);
        let seconds = start.elapsed().as_secs_f64();
        let truth = ground_truth(set, i, renderer.background());
        let opaque = view.colour.map(|p| [p[0], p[1], p[2], 1.0]);
        // Masked pixels (a person walking through a capture) are not scored.
        let mask = set.mask_weights(i);
        let score = ViewScore {
            image: set.paths[i].display().to_string(),
            // A view masked out entirely has no score.
            psnr: psnr(&opaque, &truth, mask.as_deref()).unwrap_or(f64::NAN),
            // SSIM's 11-pixel window does not fit images smaller than it: no score there.
            ssim: ssim(&opaque, &truth, mask.as_deref()).unwrap_or(f64::NAN),
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
        background: renderer.background(),
    };
    (scores, summary)
}

/// The floor every trained model must clear: each test view predicted by the training image
/// taken nearest to it (by camera position), both composited on `background`. The mean PSNR
/// over the test views whose nearest training image has their size (dB), or `None` if none
/// has.
pub fn nearest_view_psnr(train: &ImageSet, test: &ImageSet, background: [f32; 3]) -> Option<f64> {
    let scores: Vec<f64> = (0..test.len())
        .filter_map(|i| {
            let p = test.cameras[i].position();
            let nearest = (0..train.len()).min_by(|&a, &b| {
                train.cameras[a].position().distance(p).total_cmp(&train.cameras[b].position().distance(p))
            })?;
            let (guess, truth) = (ground_truth(train, nearest, background), ground_truth(test, i, background));
            psnr(&guess, &truth, test.mask_weights(i).as_deref()).ok()
        })
        .collect();
    (!scores.is_empty()).then(|| scores.iter().sum::<f64>() / scores.len() as f64)
}
