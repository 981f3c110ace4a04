//! What the viewer answers to each request that needs the model or the dataset: renders as
//! PNG (encoded as `lucid render` writes its frames, so the pixels are the same), the depth
//! under a pixel, dataset images and scored comparisons. No HTTP here: a request in, a reply
//! out, so the answers are tested without a server.

use std::time::Instant;

use lucid_image::metrics::{psnr, ssim};
use lucid_image::{Image, encode_png, encoded_png, encoded_rgb8};
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::{RenderedView, ViewModel, ground_truth};
use lucid_scene::held_out::error_image;
use lucid_scene::{Dataset, Intrinsics, PinholeCamera};
use serde_json::json;

use super::requests::{FrameFormat, FrameRef, ImageMode, Route, ViewRequest};

/// A reply: status, content type, body and extra headers.
#[derive(Clone, Debug)]
pub struct Reply {
    /// HTTP status.
    pub status: u16,
    /// MIME type of the body.
    pub content_type: &'static str,
    /// The body.
    pub body: Vec<u8>,
    /// Extra headers (render time, scores).
    pub headers: Vec<(&'static str, String)>,
}

impl Reply {
    /// A JSON body.
    pub fn json(value: &serde_json::Value) -> Self {
        Self { status: 200, content_type: "application/json", body: value.to_string().into_bytes(), headers: vec![] }
    }

    /// A refusal or failure, its reason as plain text.
    pub fn text(status: u16, reason: &str) -> Self {
        Self { status, content_type: "text/plain; charset=utf-8", body: reason.as_bytes().to_vec(), headers: vec![] }
    }

    /// A linear image as PNG.
    fn png(image: &Image) -> Self {
        Self::png_bytes(encode_png(image))
    }

    /// An sRGB-encoded image (a render, a dataset image) as PNG, quickly compressed.
    fn encoded_png(image: &Image) -> Self {
        Self::png_bytes(encoded_png(image, true))
    }

    /// An sRGB-encoded image as its raw 8-bit RGB bytes (the pixels of [`Self::encoded_png`]),
    /// its size in `X-Width` and `X-Height`.
    fn rgb(image: &Image) -> Self {
        let body = encoded_rgb8(image);
        Self { status: 200, content_type: "application/octet-stream", body, headers: vec![] }
            .with("X-Width", image.width().to_string())
            .with("X-Height", image.height().to_string())
    }

    fn png_bytes(bytes: Result<Vec<u8>, lucid_image::ImageError>) -> Self {
        match bytes {
            Ok(body) => Self { status: 200, content_type: "image/png", body, headers: vec![] },
            Err(e) => Self::text(500, &e.to_string()),
        }
    }

    /// The reply with one more header.
    pub fn with(mut self, name: &'static str, value: String) -> Self {
        self.headers.push((name, value));
        self
    }
}

/// The model and, optionally, the dataset it is compared with.
pub struct ViewedScene<'a> {
    /// The model's renderer.
    pub renderer: &'a dyn ViewModel,
    /// The dataset (cameras in the model's frame).
    pub dataset: Option<&'a Dataset>,
}

impl ViewedScene<'_> {
    /// The reply to a request that needs the model or the dataset; `None` when `abandoned`
    /// said the client had gone before the render was done.
    pub fn answer(&self, route: &Route, abandoned: &dyn Fn() -> bool) -> Option<Reply> {
        Some(match route {
            Route::Render(view) => self.render(view, abandoned)?,
            Route::Depth { view, x, y } => self.depth_at(view, *x, *y),
            Route::Truth(frame) => match self.truth(*frame) {
                Ok((_, truth)) => Reply::encoded_png(&truth),
                Err(reply) => reply,
            },
            Route::Compare { frame, error } => self.compare(*frame, *error, abandoned)?,
            Route::Page | Route::Script | Route::Info | Route::Status => Reply::text(500, "answered without the model"),
        })
    }

    fn render(&self, view: &ViewRequest, abandoned: &dyn Fn() -> bool) -> Option<Reply> {
        let started = Instant::now();
        let out = self.renderer.render_view_unless(&view.camera, view.lens, view.lens_rays, 0, abandoned)?;
        let seconds = started.elapsed().as_secs_f64();
        let image = match view.mode {
            ImageMode::Colour => out.colour,
            ImageMode::Depth => depth_colours(&out),
        };
        let reply = match view.format {
            FrameFormat::Png => Reply::encoded_png(&image),
            FrameFormat::Rgb => Reply::rgb(&image),
        };
        Some(reply.with("X-Render-Seconds", format!("{seconds:.4}")).with("X-Samples", out.samples.to_string()))
    }

    /// Renders the one ray through pixel `(x, y)`: a 1×1 camera whose principal point is
    /// moved so its pixel centre is the clicked one.
    fn depth_at(&self, view: &ViewRequest, x: u32, y: u32) -> Reply {
        let k = view.camera.intrinsics;
        let one = Intrinsics { width: 1, height: 1, cx: k.cx - x as f32, cy: k.cy - y as f32, ..k };
        let camera = PinholeCamera::new(one, view.camera.camera_to_world);
        let out = self.renderer.render_view(&camera, None, 1, 0);
        let depth = out.depth[0];
        let opacity = out.colour.pixels()[0][3];
        // The focus distance is measured along the optical axis, the depth along the ray.
        let direction = k.camera_direction(x as f32 + 0.5, y as f32 + 0.5);
        let focus = depth / direction.length();
        Reply::json(&json!({ "hit": depth > 0.0 && opacity > 0.5, "depth": depth, "focus": focus, "opacity": opacity }))
    }

    fn truth(&self, frame: FrameRef) -> Result<(ImageSet, Image), Reply> {
        let Some(dataset) = self.dataset else {
            return Err(Reply::text(404, "no dataset was given (lucid view CHECKPOINT --dataset DIR)"));
        };
        let frames = dataset.frames(frame.split);
        let Some(one) = frames.get(frame.index) else {
            return Err(Reply::text(
                404,
                &format!(
                    "the {} split has {} images; there is no index {}",
                    frame.split.name(),
                    frames.len(),
                    frame.index
                ),
            ));
        };
        let set = ImageSet::load(std::slice::from_ref(one)).map_err(|e| Reply::text(500, &e.to_string()))?;
        let truth = ground_truth(&set, 0, self.renderer.background());
        Ok((set, truth))
    }

    fn compare(&self, frame: FrameRef, error: bool, abandoned: &dyn Fn() -> bool) -> Option<Reply> {
        let (set, truth) = match self.truth(frame) {
            Ok(read) => read,
            Err(reply) => return Some(reply),
        };
        let started = Instant::now();
        let lens_rays = lucid_scene::evaluation::LENS_RAYS;
        let view = self.renderer.render_view_unless(&set.cameras[0], set.lenses[0], lens_rays, 0, abandoned)?;
        let seconds = started.elapsed().as_secs_f64();
        let opaque = view.colour.map(|p| [p[0], p[1], p[2], 1.0]);
        let mask = set.mask_weights(0);
        let score = |s: Result<f64, _>| s.map_or("nan".to_string(), |v: f64| format!("{v:.3}"));
        let reply =
            if error { Reply::png(&error_image(&view.colour, &truth)) } else { Reply::encoded_png(&view.colour) };
        Some(
            reply
                .with("X-Render-Seconds", format!("{seconds:.4}"))
                .with("X-PSNR", score(psnr(&opaque, &truth, mask.as_deref())))
                .with("X-SSIM", score(ssim(&opaque, &truth, mask.as_deref()))),
        )
    }
}

/// Depth in false colour (turbo, display-encoded), near to far over the depths this view saw; black where the
/// rays hit nothing.
fn depth_colours(view: &RenderedView) -> Image {
    let (w, h) = view.colour.dimensions();
    let hits = view.depth.iter().zip(view.colour.pixels()).filter(|(d, p)| **d > 0.0 && p[3] > 0.5).map(|(d, _)| *d);
    let (near, far) = hits.fold((f32::INFINITY, 0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
    let span = (far - near).max(1e-6);
    let pixels = view
        .depth
        .iter()
        .zip(view.colour.pixels())
        .map(|(&d, p)| {
            if d > 0.0 && p[3] > 0.5 {
                let [r, g, b] = turbo(1.0 - (d - near) / span);
                [r, g, b, 1.0]
            } else {
                [0.0, 0.0, 0.0, 1.0]
            }
        })
        .collect();
    Image::from_pixels(w, h, pixels)
}

/// Google's turbo colour map (Mikhailov's polynomial fit), display-encoded RGB of `t ∈ [0,1]`.
fn turbo(t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    let poly = |c: [f32; 6]| (c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))))).clamp(0.0, 1.0);
    [
        poly([0.135_721_4, 4.615_392_6, -42.660_324, 132.131_08, -152.942_4, 59.286_38]),
        poly([0.091_402_61, 2.194_188_4, 4.842_966_6, -14.185_033, 4.277_298_6, 2.829_566]),
        poly([0.106_673_3, 12.641_946, -60.582_05, 110.362_77, -89.903_11, 27.348_25]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turbo_runs_from_blue_through_green_to_dark_red() {
        let [r, g, b] = turbo(0.1);
        assert!(b > 0.8 && r < 0.4 && g < 0.4, "{:?}", turbo(0.1));
        let [r, g, b] = turbo(0.5);
        assert!(g > 0.9 && r < g && b < 0.4, "{:?}", turbo(0.5));
        let [r, g, b] = turbo(1.0);
        assert!(r > 0.5 && r < 0.6 && g < 0.1 && b == 0.0, "{:?}", turbo(1.0));
    }
}
