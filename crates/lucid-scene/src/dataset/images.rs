//! Training and evaluation images in memory, with their cameras and the scene box (shared by
//! every trainer).

use std::path::PathBuf;

use glam::Vec3;
use lucid_image::color::srgb_encode;

use super::{Dataset, Frame, SceneBounds};
use crate::camera::PinholeCamera;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Images of one split: colours sRGB-encoded in `[0,1]` (the space NeRFs and splats are
/// trained and scored in) with straight alpha.
#[derive(Clone, Debug, Default)]
pub struct ImageSet {
    /// Camera of each image.
    pub cameras: Vec<PinholeCamera>,
    /// Pixels of each image, row-major, `[r, g, b, a]`.
    pub pixels: Vec<Vec<[f32; 4]>>,
    /// Source file of each image.
    pub paths: Vec<PathBuf>,
    /// Thin lens of each view, `(aperture radius, focus distance)`, where the dataset gives
    /// one (e.g. the light-field rig's refocused ground truths).
    pub lenses: Vec<Option<(f32, f32)>>,
    /// Which pixels of each view to learn from and score, where the dataset masks some
    /// (`mask_path`); `None` (or a missing entry): every pixel.
    pub masks: Vec<Option<Vec<bool>>>,
}

impl ImageSet {
    /// Reads the frames' images in parallel. HDR files are clipped to `[0,1]` after encoding.
    pub fn load(frames: &[Frame]) -> Result<Self, lucid_image::ImageError> {
        let images: Vec<_> = frames
            .par_iter()
            .map(|f| {
                let image = lucid_image::read_image(&f.image_path)?;
                let image = match f.resize_to {
                    Some((w, h)) => image.resized(w as usize, h as usize),
                    None => image,
                };
                let mask = f.extras.mask_path.as_deref().map(|p| read_mask(p, image.dimensions())).transpose()?;
                Ok::<_, lucid_image::ImageError>((image, mask))
            })
            .collect();
        let mut set = Self::default();
        for (frame, read) in frames.iter().zip(images) {
            let (image, mask) = read?;
            set.masks.push(mask);
            let pixels = image
                .pixels()
                .iter()
                .map(|p| {
                    let e = |v: f32| srgb_encode(v.max(0.0)).min(1.0);
                    [e(p[0]), e(p[1]), e(p[2]), p[3].clamp(0.0, 1.0)]
                })
                .collect();
            set.cameras.push(frame.camera);
            set.pixels.push(pixels);
            set.paths.push(frame.image_path.clone());
            let lens = frame.extras.aperture_radius.zip(frame.extras.focus_distance);
            set.lenses.push(lens.filter(|(a, f)| *a > 0.0 && *f > 0.0));
        }
        Ok(set)
    }

    /// The same views through pinhole cameras that see only what each image holds, resampled
    /// through the lens: the training images of a rasterizer, which projects through pinholes
    /// only. Borrowed unchanged when every camera already is a pinhole.
    pub fn undistorted(&self) -> std::borrow::Cow<'_, ImageSet> {
        if self.cameras.iter().all(|c| c.intrinsics.distortion.is_pinhole()) {
            return std::borrow::Cow::Borrowed(self);
        }
        // Built afresh rather than cloned and overwritten: a capture's pixels are copied once.
        let (cameras, pixels): (Vec<_>, Vec<_>) = self
            .cameras
            .iter()
            .zip(&self.pixels)
            .map(|(camera, pixels)| {
                let pinhole = crate::undistort::inner_pinhole(&camera.intrinsics);
                let pixels = if camera.intrinsics.distortion.is_pinhole() {
                    pixels.clone()
                } else {
                    crate::undistort::resample(pixels, &camera.intrinsics, &pinhole)
                };
                (PinholeCamera { intrinsics: pinhole, ..*camera }, pixels)
            })
            .unzip();
        let masks = (0..self.masks.len())
            .zip(self.cameras.iter().zip(&cameras))
            .map(|(i, (lens, pinhole))| {
                let values: Vec<[f32; 1]> = self.mask_weights(i)?.into_iter().map(|m| [m]).collect();
                let warped = crate::undistort::resample(&values, &lens.intrinsics, &pinhole.intrinsics);
                Some(warped.iter().map(|v| v[0] > 0.5).collect())
            })
            .collect();
        std::borrow::Cow::Owned(ImageSet {
            cameras,
            pixels,
            paths: self.paths.clone(),
            lenses: self.lenses.clone(),
            masks,
        })
    }

    /// Whether pixel `k` of view `i` is learnt from and scored (not masked out).
    #[inline]
    pub fn keeps(&self, i: usize, k: usize) -> bool {
        self.masks.get(i).and_then(Option::as_ref).is_none_or(|m| m[k])
    }

    /// View `i`'s mask as weights for the metrics (1 kept, 0 ignored), if it has one.
    pub fn mask_weights(&self, i: usize) -> Option<Vec<f32>> {
        let mask = self.masks.get(i)?.as_ref()?;
        Some(mask.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect())
    }

    /// Whether no pixel is transparent: the images see a background that a model must
    /// represent (photographs of unbounded scenes) rather than none (object sets).
    pub fn is_opaque(&self) -> bool {
        self.pixels.iter().flatten().all(|p| p[3] >= 0.999)
    }

    /// Number of images.
    pub fn len(&self) -> usize {
        self.cameras.len()
    }

    /// Whether there are no images.
    pub fn is_empty(&self) -> bool {
        self.cameras.is_empty()
    }

    /// `(width, height)` of image `i`.
    pub fn size(&self, i: usize) -> (usize, usize) {
        let k = &self.cameras[i].intrinsics;
        (k.width as usize, k.height as usize)
    }

    /// The mean angular size of a pixel, `1/f`, over the cameras.
    pub fn pixel_angle(&self) -> f32 {
        let sum: f32 = self.cameras.iter().map(|c| 1.0 / c.intrinsics.fx).sum();
        sum / self.cameras.len().max(1) as f32
    }
}

/// The mask in `path` for an image of `size`: a pixel is kept where the mask's first channel
/// is at least one half. A mask of another size with the image's aspect ratio (a full-size
/// mask beside a downscaled image) is resized to it; any other size is an error naming it.
fn read_mask(path: &std::path::Path, size: (usize, usize)) -> Result<Vec<bool>, lucid_image::ImageError> {
    let mask = lucid_image::read_image(path)?;
    let (mw, mh) = mask.dimensions();
    let (w, h) = size;
    let mask = if (mw, mh) == (w, h) {
        mask
    } else if (mw * h).abs_diff(mh * w) <= mw.max(w) {
        mask.resized(w, h)
    } else {
        return Err(lucid_image::ImageError::Malformed {
            path: path.to_path_buf(),
            format: "mask",
            reason: format!("the mask is {mw}x{mh}, its image {w}x{h}"),
        });
    };
    Ok(mask.pixels().iter().map(|p| p[0] >= 0.5).collect())
}

/// How the training cameras saw the scene: the defaults of novel-view paths.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewInfo {
    /// Mean distance of the cameras from the centre of the scene box.
    pub radius: f32,
    /// Image width of the first camera.
    pub width: u32,
    /// Image height of the first camera.
    pub height: u32,
    /// Horizontal field of view of the first camera (radians).
    pub fov_x: f32,
    /// How the dataset's own coordinates map to the scene's, for a capture: renders, camera
    /// paths and exports are mapped back through it. Absent in checkpoints from before it was
    /// kept, and for datasets used as they are.
    #[serde(default)]
    pub frame: Option<super::SceneNormalisation>,
}

impl Default for ViewInfo {
    fn default() -> Self {
        Self { radius: 4.0, width: 200, height: 200, fov_x: 40f32.to_radians(), frame: None }
    }
}

impl ViewInfo {
    /// From a set of cameras around `centre`.
    pub fn from_cameras(cameras: &[PinholeCamera], centre: Vec3) -> Self {
        let Some(first) = cameras.first() else { return Self::default() };
        let radius = cameras.iter().map(|c| (c.position() - centre).length()).sum::<f32>() / cameras.len() as f32;
        let k = first.intrinsics;
        Self { radius, width: k.width, height: k.height, fov_x: k.fov_x(), frame: None }
    }
}

/// The box the field lives in: the dataset's `aabb`, or instant-ngp's `aabb_scale` (its unit
/// cube spans `[-1.5, 1.5]³` of NeRF-synthetic world space), or that cube when the dataset
/// says nothing.
pub fn scene_box(dataset: &Dataset) -> (Vec3, Vec3) {
    let bounds = dataset.splits.iter().find_map(|s| s.bounds);
    match bounds {
        Some(SceneBounds::Box { min, max }) => (min, max),
        Some(SceneBounds::AabbScale(s)) => (Vec3::splat(-1.5 * s), Vec3::splat(1.5 * s)),
        None => (Vec3::splat(-1.5), Vec3::splat(1.5)),
    }
}
