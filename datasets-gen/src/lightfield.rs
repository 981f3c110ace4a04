//! Light fields: a U×V grid of parallel cameras on a plane (the sub-aperture views), thin-lens
//! ground truth from the grid centre, and synthetic refocusing by shift-and-add.
//!
//! A point at depth `D` (along the common optical axis) seen by the sub-camera displaced by
//! `(dx, dy)` (along the cameras' right and up axes) appears at `x − f·dx/D`, `y + f·dy/D`
//! relative to the centre view. Averaging the sub-aperture images shifted back by those
//! amounts aligns everything at depth `D` and blurs the rest: over the cameras inside a disk
//! of radius `R` this approximates a thin lens of aperture radius `R` focused at `D`, sampled
//! at the grid's discrete positions.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};
use lucid_image::Image;
use lucid_scene::{Dataset, Split, look_at};

/// A planar grid of cameras sharing one orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct LightFieldRig {
    /// Centre of the camera plane.
    pub centre: Vec3,
    /// Point the (parallel) cameras face: fixes the shared orientation.
    pub target: Vec3,
    /// Approximate up direction.
    pub up: Vec3,
    /// Cameras along the right (U) and up (V) axes.
    pub grid: [usize; 2],
    /// Distance between neighbouring cameras.
    pub spacing: f32,
    /// Thin-lens ground truths to render from the centre: `(focus distance, aperture radius)`.
    pub ground_truth: Vec<(f32, f32)>,
}

impl LightFieldRig {
    /// Pose of the grid centre.
    pub fn centre_pose(&self) -> Mat4 {
        look_at(self.centre, self.target, self.up)
    }

    /// Sub-aperture poses in row-major order (`v` outer, `u` inner), with their offsets.
    pub fn poses(&self) -> Vec<(Vec2, Mat4)> {
        let centre = self.centre_pose();
        let (right, up) = (centre.x_axis.xyz(), centre.y_axis.xyz());
        let mut out = Vec::with_capacity(self.grid[0] * self.grid[1]);
        for v in 0..self.grid[1] {
            for u in 0..self.grid[0] {
                let offset = Vec2::new(
                    (u as f32 - 0.5 * (self.grid[0] - 1) as f32) * self.spacing,
                    (0.5 * (self.grid[1] - 1) as f32 - v as f32) * self.spacing,
                );
                let position = self.centre + offset.x * right + offset.y * up;
                let mut pose = centre;
                pose.w_axis = position.extend(1.0);
                out.push((offset, pose));
            }
        }
        out
    }
}

/// Why refocusing failed.
#[derive(Debug, thiserror::Error)]
pub enum RefocusError {
    /// Reading the dataset or an image failed.
    #[error(transparent)]
    Dataset(#[from] lucid_scene::DatasetError),
    /// Reading an image failed.
    #[error(transparent)]
    Image(#[from] lucid_image::ImageError),
    /// The dataset is not a usable light field.
    #[error("{0}")]
    NotALightField(String),
}

/// Refocuses the light field in `dataset` (its training views) at `focus` (depth along the
/// optical axis) with a synthetic aperture of radius `aperture`, using the linear HDR images
/// where the frames have them. The result has the centre view's intrinsics.
pub fn refocus(dataset: &Dataset, focus: f32, aperture: f32) -> Result<Image, RefocusError> {
    if !(focus.is_finite() && focus > 0.0 && aperture.is_finite() && aperture >= 0.0) {
        return Err(RefocusError::NotALightField(format!(
            "focus {focus} must be positive and aperture {aperture} non-negative"
        )));
    }
    let frames = dataset.frames(Split::Train);
    if frames.is_empty() {
        return Err(RefocusError::NotALightField(format!("{}: no training views", dataset.root.display())));
    }
    let first = &frames[0].camera;
    let k = first.intrinsics;
    let rotation = Mat4::from_cols(
        first.camera_to_world.x_axis,
        first.camera_to_world.y_axis,
        first.camera_to_world.z_axis,
        glam::Vec4::W,
    );
    for f in frames {
        let r = &f.camera.camera_to_world;
        let same_axes = (r.z_axis.xyz() - rotation.z_axis.xyz()).length() < 1e-3
            && (r.x_axis.xyz() - rotation.x_axis.xyz()).length() < 1e-3;
        if !same_axes || f.camera.intrinsics != k {
            return Err(RefocusError::NotALightField(format!(
                "{}: the training cameras are not a parallel grid with shared intrinsics",
                dataset.root.display()
            )));
        }
    }
    let centre = frames.iter().map(|f| f.camera.position()).sum::<Vec3>() / frames.len() as f32;
    let (right, up) = (rotation.x_axis.xyz(), rotation.y_axis.xyz());
    let (w, h) = (k.width as usize, k.height as usize);
    let mut sum = vec![[0.0f32; 4]; w * h];
    let mut used = 0;
    for f in frames {
        let d = f.camera.position() - centre;
        let offset = Vec2::new(d.dot(right), d.dot(up));
        if offset.length() > aperture + 1e-5 {
            continue;
        }
        let path = f.extras.hdr_path.as_ref().unwrap_or(&f.image_path);
        let img = lucid_image::read_image(path)?;
        let (sx, sy) = (-k.fx * offset.x / focus, k.fy * offset.y / focus);
        for y in 0..h {
            for x in 0..w {
                let p = bilinear(&img, x as f32 + 0.5 + sx, y as f32 + 0.5 + sy);
                for c in 0..4 {
                    sum[y * w + x][c] += p[c];
                }
            }
        }
        used += 1;
    }
    if used == 0 {
        return Err(RefocusError::NotALightField(format!("no camera within the aperture radius {aperture}")));
    }
    Ok(Image::from_pixels(w, h, sum.into_iter().map(|p| p.map(|v| v / used as f32)).collect()))
}

/// Bilinear sample at continuous image coordinates (pixel centres at half-integers), clamped
/// at the borders.
fn bilinear(img: &Image, x: f32, y: f32) -> [f32; 4] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (fx, fy) = (x - 0.5, y - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let at = |xi: i64, yi: i64| img.get(xi.clamp(0, w - 1) as usize, yi.clamp(0, h - 1) as usize);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let (a, b, c, d) = (at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1));
    std::array::from_fn(|i| {
        let top = a[i] * (1.0 - tx) + b[i] * tx;
        let bottom = c[i] * (1.0 - tx) + d[i] * tx;
        top * (1.0 - ty) + bottom * ty
    })
}
