//! Rendering whole views of a trained cloud for evaluation and novel-view paths: pinhole, or
//! a thin lens by averaging renders from points on the aperture (each an off-axis pinhole
//! whose principal point is shifted so that the plane of focus stays put).

use glam::{Mat4, Vec3};
use lucid_image::Image;
use lucid_scene::camera::PinholeCamera;
use lucid_scene::evaluation::{RenderedView, ViewModel};
use lucid_scene::sampling::{concentric_disk, stratified_square};
use lucid_scene::undistort::{outer_pinhole, resample};

use crate::camera::SplatCamera;
use crate::cloud::SplatCloud;
use crate::project::RenderSettings;
use crate::render::render;

/// A cloud with the settings to render it.
pub struct SplatRenderer<'a> {
    /// The Gaussians.
    pub cloud: &'a SplatCloud,
    /// Projection, SH degree and background.
    pub settings: RenderSettings,
}

impl SplatRenderer<'_> {
    /// `RGBA` (colour over the background, alpha) and expected depth of one view. A distorted
    /// view is rendered through a pinhole that covers it and warped through the lens.
    fn render_pinhole(&self, camera: &PinholeCamera) -> (Vec<f32>, Vec<f32>) {
        let k = camera.intrinsics;
        let wide = PinholeCamera::new(outer_pinhole(&k), camera.camera_to_world);
        let (image, state) = render(&self.cloud.params(), &SplatCamera::from_pinhole(&wide), &self.settings);
        if k.distortion.is_pinhole() {
            return (image, state.pixels.depth);
        }
        let rgba: Vec<[f32; 4]> = image.chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
        let rgba = resample(&rgba, &wide.intrinsics, &k);
        // Depth along the axis is the same for both cameras (one pose), so it warps as it is.
        let depth: Vec<[f32; 1]> = state.pixels.depth.iter().map(|&d| [d]).collect();
        let depth = resample(&depth, &wide.intrinsics, &k);
        (rgba.into_iter().flatten().collect(), depth.into_iter().map(|d| d[0]).collect())
    }

    /// The mean of `passes` pinhole renders from stratified points on a thin lens's aperture.
    fn render_lens(
        &self,
        camera: &PinholeCamera,
        aperture: f32,
        focus: f32,
        passes: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<(Vec<f32>, Vec<f32>)> {
        let (w, h) = (camera.intrinsics.width as usize, camera.intrinsics.height as usize);
        let mut acc = vec![0.0f32; w * h * 4];
        let mut depth = vec![0.0f32; w * h];
        for k in 0..passes {
            if abandoned() {
                return None;
            }
            let d = concentric_disk(stratified_square(k, passes, seed)) * aperture;
            let (image, z) = self.render_pinhole(&lens_pinhole(camera, d.x, d.y, focus));
            for (a, v) in acc.iter_mut().zip(&image) {
                *a += v / passes as f32;
            }
            for (a, v) in depth.iter_mut().zip(&z) {
                *a += v / passes as f32;
            }
        }
        Some((acc, depth))
    }
}

/// The pinhole through lens point `(ox, oy)` (camera units, +y up) of a thin lens focused at
/// `focus`: moved on the lens plane, principal point shifted to keep the focus plane fixed.
pub fn lens_pinhole(camera: &PinholeCamera, ox: f32, oy: f32, focus: f32) -> PinholeCamera {
    let mut k = camera.intrinsics;
    k.cx += k.fx * ox / focus;
    k.cy -= k.fy * oy / focus;
    let pose = camera.camera_to_world * Mat4::from_translation(Vec3::new(ox, oy, 0.0));
    PinholeCamera::new(k, pose)
}

impl ViewModel for SplatRenderer<'_> {
    fn render_view(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
    ) -> RenderedView {
        self.render_view_unless(camera, lens, lens_rays, seed, &|| false).expect("a render nobody abandons")
    }

    fn render_view_unless(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<RenderedView> {
        let (w, h) = (camera.intrinsics.width as usize, camera.intrinsics.height as usize);
        let (acc, depth) = match lens {
            None => self.render_pinhole(camera),
            Some((aperture, focus)) => self.render_lens(camera, aperture, focus, lens_rays.max(1), seed, abandoned)?,
        };
        let pixels: Vec<[f32; 4]> = acc.chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
        let depth = pixels.iter().zip(&depth).map(|(p, d)| if p[3] > 1e-3 { d / p[3] } else { 0.0 }).collect();
        Some(RenderedView { colour: Image::from_pixels(w, h, pixels), depth, samples: self.cloud.len() })
    }

    fn background(&self) -> [f32; 3] {
        self.settings.background
    }
}
