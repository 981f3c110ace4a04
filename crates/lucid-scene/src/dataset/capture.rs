//! Captures: a folder of photographs with a COLMAP sparse model (the Mip-NeRF 360, Tanks and
//! Temples and Deep Blending layouts), read into Lucid's frames.
//!
//! - Poses become OpenGL camera-to-world and the scene is normalised
//!   ([`SceneNormalisation`]): centred on the point the cameras look at, turned so that
//!   the cameras' mean up is +Z, and scaled so the farthest camera is 1 from the centre.
//! - Images come from `images/`, or `images_N/` under `--downscale N` (resized in memory when
//!   that folder is absent).
//! - Without split files, every `holdout_every`-th image by sorted name is a test view (the
//!   Mip-NeRF 360 / LLFF convention).

use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DQuat, DVec3};

use super::{Dataset, DatasetError, Frame, FrameExtras, OpenOptions, SparsePoint, Split, SplitFrames};
use crate::PinholeCamera;
use crate::colmap::{ColmapImage, ColmapModel, model_file};

/// How the dataset's own coordinates map to Lucid's: `scene = scale · rotation · (p − centre)`.
/// Renders, camera paths and exports map back through [`Self::to_dataset`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneNormalisation {
    /// The dataset point that becomes the origin.
    pub centre: DVec3,
    /// Turns the cameras' mean up direction to +Z.
    pub rotation: DQuat,
    /// Uniform scale.
    pub scale: f64,
}

impl SceneNormalisation {
    /// A dataset point in scene coordinates.
    pub fn to_scene(&self, p: DVec3) -> DVec3 {
        self.scale * (self.rotation * (p - self.centre))
    }

    /// A scene point in the dataset's coordinates.
    pub fn to_dataset(&self, p: DVec3) -> DVec3 {
        self.rotation.inverse() * (p / self.scale) + self.centre
    }

    /// A camera-to-world pose (rigid) in scene coordinates: rotated and moved, not scaled.
    pub fn pose_to_scene(&self, pose: DMat4) -> DMat4 {
        let r = DMat3::from_quat(self.rotation) * DMat3::from_mat4(pose);
        DMat4::from_mat3_translation(r, self.to_scene(pose.w_axis.truncate()))
    }

    /// A scene camera-to-world pose (rigid) in the dataset's coordinates: the inverse of
    /// [`Self::pose_to_scene`].
    pub fn pose_to_dataset(&self, pose: DMat4) -> DMat4 {
        let r = DMat3::from_quat(self.rotation.inverse()) * DMat3::from_mat4(pose);
        DMat4::from_mat3_translation(r, self.to_dataset(pose.w_axis.truncate()))
    }

    /// Chooses the normalisation of cameras with these poses (OpenGL camera-to-world).
    pub fn from_cameras(poses: &[DMat4]) -> Self {
        let positions: Vec<DVec3> = poses.iter().map(|p| p.w_axis.truncate()).collect();
        let n = positions.len().max(1) as f64;
        let mean = positions.iter().sum::<DVec3>() / n;
        let up = poses.iter().map(|p| p.y_axis.truncate().normalize_or_zero()).sum::<DVec3>();
        let rotation =
            if up.length() > 1e-9 { DQuat::from_rotation_arc(up.normalize(), DVec3::Z) } else { DQuat::IDENTITY };
        let spread = positions.iter().map(|p| p.distance(mean)).fold(0.0, f64::max);
        let centre = match focus_point(poses) {
            Some(f) if f.distance(mean) <= 10.0 * spread.max(1e-9) => f,
            _ => mean,
        };
        let farthest = positions.iter().map(|p| p.distance(centre)).fold(0.0, f64::max);
        let scale = if farthest > 1e-12 { 1.0 / farthest } else { 1.0 };
        Self { centre, rotation, scale }
    }
}

/// The point nearest, in least squares, to every camera's optical axis: what a capture
/// circles around. `None` when the axes are nearly parallel (a forward-facing capture).
fn focus_point(poses: &[DMat4]) -> Option<DVec3> {
    let mut a = DMat3::ZERO;
    let mut b = DVec3::ZERO;
    for pose in poses {
        let d = -pose.z_axis.truncate().normalize_or_zero();
        let c = pose.w_axis.truncate();
        let m = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        a += m;
        b += m * c;
    }
    // Parallel axes leave a direction unconstrained: a nearly singular system.
    let det = a.determinant();
    let size = (poses.len() as f64).powi(3);
    (det.abs() > 1e-4 * size).then(|| a.inverse() * b).filter(|p| p.is_finite())
}

/// Reads the COLMAP model in `model_dir` and the photographs beside it.
pub(super) fn open(root: &Path, model_dir: &Path, options: &OpenOptions) -> Result<Dataset, DatasetError> {
    let model = ColmapModel::read(model_dir)?;
    let (images_file, cameras_file) = (model_file(model_dir, "images"), model_file(model_dir, "cameras"));
    let invalid =
        |path: &Path, key: String, reason: String| DatasetError::Invalid { path: path.to_path_buf(), key, reason };
    if model.images.is_empty() {
        return Err(invalid(&images_file, "images".into(), "no registered images".into()));
    }
    let folder = ImageFolder::choose(root, options.downscale)?;
    let mut images: Vec<&ColmapImage> = model.images.iter().collect();
    images.sort_by(|a, b| a.name.cmp(&b.name));
    let poses: Vec<DMat4> = images.iter().map(|im| im.camera_to_world()).collect();
    let normalisation = SceneNormalisation::from_cameras(&poses);

    let mut frames = Vec::with_capacity(images.len());
    for (image, pose) in images.iter().zip(&poses) {
        let key = format!("image {} ({})", image.id, image.name);
        let camera = &model.cameras[&image.camera_id];
        let intrinsics =
            camera.intrinsics().map_err(|reason| invalid(&cameras_file, format!("camera {}", camera.id), reason))?;
        let image_path = folder.path.join(&image.name);
        if !image_path.is_file() {
            return Err(invalid(&images_file, key, format!("image {} not found", image_path.display())));
        }
        let (w, h) = lucid_image::image_dimensions(&image_path).map_err(|source| DatasetError::Image {
            path: images_file.clone(),
            key: key.clone(),
            source,
        })?;
        let (intrinsics, resize_to) = folder.fit(intrinsics, (w as u32, h as u32)).map_err(|reason| {
            let camera_file = cameras_file.file_name().unwrap_or_default().to_string_lossy();
            invalid(&images_file, key.clone(), format!("{reason} (camera {} of {camera_file})", camera.id))
        })?;
        let pose = normalisation.pose_to_scene(*pose).as_mat4();
        frames.push(Frame {
            file_path: image.name.clone(),
            image_path,
            camera: PinholeCamera::new(intrinsics, pose),
            extras: FrameExtras::default(),
            resize_to,
        });
    }
    let splits = held_out_splits(frames, options.holdout_every, &images_file);
    super::read::check_camera_centres(&splits)?;
    let points = model
        .points
        .iter()
        .map(|p| SparsePoint { position: normalisation.to_scene(p.position).as_vec3(), colour: p.colour })
        .collect();
    Ok(Dataset { root: root.to_path_buf(), splits, normalisation: Some(normalisation), points })
}

/// Frames (sorted by name) split into training and every `every`-th as test, from `source`.
/// `every = 0` holds nothing out, nor does a split that would leave no training view.
pub(super) fn held_out_splits(frames: Vec<Frame>, every: usize, source: &Path) -> Vec<SplitFrames> {
    let count = frames.len();
    let held_out = |i: usize| every > 0 && count > 1 && i.is_multiple_of(every);
    let (mut train, mut test) = (Vec::new(), Vec::new());
    for (i, frame) in frames.into_iter().enumerate() {
        if held_out(i) { test.push(frame) } else { train.push(frame) }
    }
    let split = |split, frames: Vec<Frame>| SplitFrames { split, source: source.to_path_buf(), frames, bounds: None };
    let mut splits = vec![split(Split::Train, train)];
    if !test.is_empty() {
        splits.push(split(Split::Test, test));
    }
    splits
}

/// Where the photographs are read from, and at what scale.
struct ImageFolder {
    path: PathBuf,
    /// `--downscale N`.
    factor: u32,
    /// The folder holds full-size images that are resized in memory.
    resize: bool,
}

impl ImageFolder {
    fn choose(root: &Path, downscale: Option<u32>) -> Result<Self, DatasetError> {
        let full = root.join("images");
        let factor = downscale.unwrap_or(1);
        if factor > 1 {
            let scaled = root.join(format!("images_{factor}"));
            if scaled.is_dir() {
                return Ok(Self { path: scaled, factor, resize: false });
            }
        }
        if !full.is_dir() {
            return Err(DatasetError::Io {
                path: full,
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no images folder beside the COLMAP model"),
            });
        }
        Ok(Self { path: full, factor, resize: factor > 1 })
    }

    /// The intrinsics of an image of `size` (on disk) taken by a camera of `k`, and the size
    /// it is resized to on reading, if any.
    fn fit(&self, k: crate::Intrinsics, size: (u32, u32)) -> Result<(crate::Intrinsics, Option<(u32, u32)>), String> {
        let expected = |n: u32| downscaled(n, self.factor);
        let at_scale = |n: u32, from: u32| is_downscaled(n, from, self.factor);
        if self.resize || self.factor == 1 {
            if size != (k.width, k.height) {
                return Err(format!(
                    "the photograph is {}x{}, the camera {}x{} (a downscaled folder under the name images/?)",
                    size.0, size.1, k.width, k.height
                ));
            }
            if self.resize {
                let target = (expected(k.width), expected(k.height));
                return Ok((k.resized(target.0, target.1), Some(target)));
            }
            return Ok((k, None));
        }
        if !at_scale(size.0, k.width) || !at_scale(size.1, k.height) {
            return Err(format!(
                "the photograph is {}x{}, but a camera of {}x{} downscaled {} times is {}x{}",
                size.0,
                size.1,
                k.width,
                k.height,
                self.factor,
                expected(k.width),
                expected(k.height)
            ));
        }
        Ok((k.resized(size.0, size.1), None))
    }
}

/// A side of `n` pixels read at 1/`factor`, as downscaling scripts leave it: rounded, and at
/// least one pixel.
pub(super) fn downscaled(n: u32, factor: u32) -> u32 {
    ((n as f64 / factor as f64).round() as u32).max(1)
}

/// Whether a side of `n` pixels on disk is one of `full` pixels downscaled `factor` times:
/// scripts round either way, so one pixel of slack.
pub(super) fn is_downscaled(n: u32, full: u32, factor: u32) -> bool {
    n.abs_diff(downscaled(full, factor)) <= 1
}
