//! COLMAP sparse reconstructions (`sparse/0/{cameras,images,points3D}.{bin,txt}`), binary and
//! text, read as COLMAP writes them: cameras with their model and parameters, registered
//! images with world-to-camera poses (OpenCV convention), and the triangulated points.
//!
//! Both encodings are parsed by hand: the format is a few fixed records (COLMAP's
//! `src/colmap/scene/reconstruction_io.cc`), and no maintained Rust crate reads it.

pub mod binary;
mod text;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3, Mat4};

use crate::camera::Intrinsics;
use crate::lens::LensDistortion;

/// A camera model of COLMAP's, with its id in the binary format, name and parameter count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CameraModel {
    /// The id in `cameras.bin`.
    pub id: i32,
    /// The name in `cameras.txt`.
    pub name: &'static str,
    /// Parameters stored.
    pub params: usize,
}

/// Every model COLMAP defines (`src/colmap/sensor/models.h`), honoured or not, so that files
/// with any of them parse and the error can name the model.
pub const CAMERA_MODELS: [CameraModel; 12] = [
    CameraModel { id: 0, name: "SIMPLE_PINHOLE", params: 3 },
    CameraModel { id: 1, name: "PINHOLE", params: 4 },
    CameraModel { id: 2, name: "SIMPLE_RADIAL", params: 4 },
    CameraModel { id: 3, name: "RADIAL", params: 5 },
    CameraModel { id: 4, name: "OPENCV", params: 8 },
    CameraModel { id: 5, name: "OPENCV_FISHEYE", params: 8 },
    CameraModel { id: 6, name: "FULL_OPENCV", params: 12 },
    CameraModel { id: 7, name: "FOV", params: 5 },
    CameraModel { id: 8, name: "SIMPLE_RADIAL_FISHEYE", params: 4 },
    CameraModel { id: 9, name: "RADIAL_FISHEYE", params: 5 },
    CameraModel { id: 10, name: "THIN_PRISM_FISHEYE", params: 12 },
    CameraModel { id: 11, name: "RAD_TAN_THIN_PRISM_FISHEYE", params: 16 },
];

impl CameraModel {
    fn by_id(id: i32) -> Option<Self> {
        CAMERA_MODELS.iter().copied().find(|m| m.id == id)
    }

    fn by_name(name: &str) -> Option<Self> {
        CAMERA_MODELS.iter().copied().find(|m| m.name == name)
    }
}

/// One camera of `cameras.{bin,txt}`.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// The camera's id.
    pub id: u32,
    /// Its model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u64,
    /// Image height in pixels.
    pub height: u64,
    /// The model's parameters in COLMAP's order.
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// The COLMAP camera that describes `k`: the simplest model holding its lens (SIMPLE_*
    /// where the pixels are square).
    pub fn from_intrinsics(id: u32, k: &Intrinsics) -> Result<Self, String> {
        let (fx, fy, cx, cy) = (f64::from(k.fx), f64::from(k.fy), f64::from(k.cx), f64::from(k.cy));
        let square = k.fx == k.fy;
        let (name, params) = match k.distortion {
            LensDistortion::None if square => ("SIMPLE_PINHOLE", vec![fx, cx, cy]),
            LensDistortion::None => ("PINHOLE", vec![fx, fy, cx, cy]),
            LensDistortion::OpenCv {
                radial: [k1, 0.0, 0.0, 0.0],
                rational: [0.0, 0.0, 0.0],
                tangential: [0.0, 0.0],
            } if square => ("SIMPLE_RADIAL", vec![fx, cx, cy, f64::from(k1)]),
            LensDistortion::OpenCv { radial: [k1, k2, 0.0, 0.0], rational: [0.0, 0.0, 0.0], tangential: [p1, p2] } => {
                ("OPENCV", [fx, fy, cx, cy].into_iter().chain([k1, k2, p1, p2].map(f64::from)).collect())
            }
            LensDistortion::OpenCv { radial: [k1, k2, k3, 0.0], rational: [k4, k5, k6], tangential: [p1, p2] } => (
                "FULL_OPENCV",
                [fx, fy, cx, cy].into_iter().chain([k1, k2, p1, p2, k3, k4, k5, k6].map(f64::from)).collect(),
            ),
            LensDistortion::OpenCv { .. } => return Err("COLMAP has no model with an r⁸ radial term".into()),
            LensDistortion::Fisheye { k } => {
                ("OPENCV_FISHEYE", [fx, fy, cx, cy].into_iter().chain(k.map(f64::from)).collect())
            }
        };
        let model = CameraModel::by_name(name).expect("a COLMAP model");
        Ok(Self { id, model, width: u64::from(k.width), height: u64::from(k.height), params })
    }

    /// Lucid's intrinsics for this camera, or why its model cannot be honoured. COLMAP puts the
    /// centre of the top-left pixel at (0.5, 0.5), as Lucid does, so the principal point
    /// carries over unchanged.
    pub fn intrinsics(&self) -> Result<Intrinsics, String> {
        let p: Vec<f32> = self.params.iter().map(|&v| v as f32).collect();
        let (fx, fy, cx, cy, distortion) = match self.model.name {
            "SIMPLE_PINHOLE" => (p[0], p[0], p[1], p[2], LensDistortion::None),
            "PINHOLE" => (p[0], p[1], p[2], p[3], LensDistortion::None),
            "SIMPLE_RADIAL" => (p[0], p[0], p[1], p[2], LensDistortion::opencv(p[3], 0.0, 0.0, 0.0)),
            "RADIAL" => (p[0], p[0], p[1], p[2], LensDistortion::opencv(p[3], p[4], 0.0, 0.0)),
            "OPENCV" => (p[0], p[1], p[2], p[3], LensDistortion::opencv(p[4], p[5], p[6], p[7])),
            "OPENCV_FISHEYE" => (p[0], p[1], p[2], p[3], LensDistortion::Fisheye { k: [p[4], p[5], p[6], p[7]] }),
            "FULL_OPENCV" => (
                p[0],
                p[1],
                p[2],
                p[3],
                // k1, k2, p1, p2, k3, k4, k5, k6: k4..k6 divide.
                LensDistortion::OpenCv {
                    radial: [p[4], p[5], p[8], 0.0],
                    rational: [p[9], p[10], p[11]],
                    tangential: [p[6], p[7]],
                }
                .simplified(),
            ),
            other => {
                return Err(format!(
                    "camera model {other} is not supported (Lucid honours SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, OPENCV_FISHEYE and FULL_OPENCV)"
                ));
            }
        };
        if !p.iter().all(|v| v.is_finite()) {
            return Err("a parameter is not finite".into());
        }
        if fx <= 0.0 || fy <= 0.0 {
            return Err(format!("focal lengths must be positive, got {fx}, {fy}"));
        }
        if self.width == 0 || self.height == 0 || self.width > 1 << 20 || self.height > 1 << 20 {
            return Err(format!("image size {}x{} is not a camera's", self.width, self.height));
        }
        Ok(Intrinsics { distortion, ..Intrinsics::pinhole(self.width as u32, self.height as u32, fx, fy, cx, cy) })
    }
}

/// One registered image of `images.{bin,txt}` (its 2D observations are skipped).
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    /// The image's id.
    pub id: u32,
    /// World-to-camera rotation (`qw, qx, qy, qz` as stored, normalised).
    pub rotation: DQuat,
    /// World-to-camera translation.
    pub translation: DVec3,
    /// The camera that took it.
    pub camera_id: u32,
    /// The file name under the images folder.
    pub name: String,
}

impl ColmapImage {
    /// The camera-to-world pose in Lucid's (OpenGL) convention: COLMAP's camera looks down
    /// +Z with +Y down, ours down −Z with +Y up, so the pose's Y and Z axes flip.
    pub fn camera_to_world(&self) -> glam::DMat4 {
        let r = DMat3::from_quat(self.rotation).transpose();
        let centre = -(r * self.translation);
        let flip = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
        glam::DMat4::from_mat3_translation(r * flip, centre)
    }

    /// The image of a camera with an OpenGL camera-to-world `pose` (the inverse of
    /// [`Self::camera_to_world`]).
    pub fn from_pose(id: u32, camera_id: u32, name: String, pose: glam::DMat4) -> Self {
        let flip = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
        let world_to_camera = (DMat3::from_mat4(pose) * flip).transpose();
        let translation = -(world_to_camera * pose.w_axis.truncate());
        Self { id, rotation: DQuat::from_mat3(&world_to_camera).normalize(), translation, camera_id, name }
    }

    /// [`Self::camera_to_world`] in `f32`.
    pub fn pose(&self) -> Mat4 {
        self.camera_to_world().as_mat4()
    }
}

/// One point of `points3D.{bin,txt}` (its track is skipped, only its length kept).
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapPoint {
    /// World position.
    pub position: DVec3,
    /// Colour, 8-bit sRGB.
    pub colour: [u8; 3],
    /// Mean reprojection error in pixels.
    pub error: f64,
    /// How many images observe it.
    pub track_length: usize,
}

/// A sparse reconstruction.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColmapModel {
    /// Cameras by id.
    pub cameras: BTreeMap<u32, ColmapCamera>,
    /// Registered images in file order.
    pub images: Vec<ColmapImage>,
    /// Triangulated points (empty when `points3D` is absent).
    pub points: Vec<ColmapPoint>,
}

/// Why a COLMAP model could not be read; each message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ColmapError {
    /// The OS refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The contents are not a COLMAP model.
    #[error("{}: {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong (with the record or line).
        reason: String,
    },
}

fn invalid(path: &Path, reason: impl Into<String>) -> ColmapError {
    ColmapError::Invalid { path: path.to_path_buf(), reason: reason.into() }
}

/// The folder of a dataset that holds the sparse model: of `sparse/0`, `sparse/1`, … the one
/// with the most registered images (COLMAP numbers the models it could not join in the order
/// it started them, so `sparse/0` is not always the main one; the images file's size stands in
/// for its count), else `sparse` or the folder itself, whichever has `cameras.bin` or
/// `cameras.txt`.
pub fn find_model(root: &Path) -> Option<PathBuf> {
    let has_model = |d: &Path| d.join("cameras.bin").is_file() || d.join("cameras.txt").is_file();
    let images_size = |d: &Path| {
        ["images.bin", "images.txt"].iter().filter_map(|f| std::fs::metadata(d.join(f)).ok()).map(|m| m.len()).max()
    };
    let mut numbered: Vec<PathBuf> = std::fs::read_dir(root.join("sparse"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|d| d.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.parse::<u32>().is_ok()) && has_model(d))
        .collect();
    // By size, then by number: deterministic whatever order the folder lists them in.
    numbered.sort_by_key(|d| {
        let n: u32 = d.file_name().and_then(|n| n.to_str()).and_then(|n| n.parse().ok()).unwrap_or(0);
        (std::cmp::Reverse(images_size(d).unwrap_or(0)), n)
    });
    if let Some(best) = numbered.first() {
        if numbered.len() > 1 {
            tracing::info!(
                "{} sparse models; reading {}, the one with the most images",
                numbered.len(),
                best.display()
            );
        }
        return Some(best.clone());
    }
    [root.join("sparse"), root.to_path_buf()].into_iter().find(|d| has_model(d))
}

/// The file `name` (`cameras`, `images`, `points3D`) of the model in `dir`: `.bin` where
/// `cameras.bin` exists, else `.txt`.
pub fn model_file(dir: &Path, name: &str) -> PathBuf {
    let binary = dir.join("cameras.bin").is_file();
    dir.join(format!("{name}.{}", if binary { "bin" } else { "txt" }))
}

impl ColmapModel {
    /// Reads `cameras`, `images` and (if present) `points3D` from `dir`, binary where
    /// `cameras.bin` exists, else text ([`model_file`]), and checks that every image's camera
    /// exists.
    pub fn read(dir: &Path) -> Result<Self, ColmapError> {
        let (cameras, images, points) =
            (model_file(dir, "cameras"), model_file(dir, "images"), model_file(dir, "points3D"));
        let model = if cameras.extension().is_some_and(|e| e == "bin") {
            ColmapModel {
                cameras: binary::cameras(&cameras)?,
                images: binary::images(&images)?,
                points: if points.is_file() { binary::points(&points)? } else { Vec::new() },
            }
        } else {
            ColmapModel {
                cameras: text::cameras(&cameras)?,
                images: text::images(&images)?,
                points: if points.is_file() { text::points(&points)? } else { Vec::new() },
            }
        };
        let cameras_name = cameras.file_name().unwrap_or_default().to_string_lossy();
        for image in &model.images {
            if !model.cameras.contains_key(&image.camera_id) {
                return Err(invalid(
                    &images,
                    format!(
                        "image {} ({}) names camera {}, which {cameras_name} lacks",
                        image.id, image.name, image.camera_id
                    ),
                ));
            }
        }
        Ok(model)
    }
}

/// Largest translation component accepted: beyond it `f32` poses lose their precision, and
/// no reconstruction's coordinates reach it.
const MAX_TRANSLATION: f64 = 1e7;

/// A translation, finite and within [`MAX_TRANSLATION`], or why not.
fn translation(t: [f64; 3]) -> Result<DVec3, String> {
    if !t.iter().all(|v| v.is_finite() && v.abs() <= MAX_TRANSLATION) {
        return Err(format!("translation {t:?} is not finite or beyond ±{MAX_TRANSLATION:e}"));
    }
    Ok(DVec3::from(t))
}

/// A rotation from stored `qw, qx, qy, qz`, or why it is not one.
fn quaternion(q: [f64; 4]) -> Result<DQuat, String> {
    let quat = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
    let norm = quat.length();
    if !norm.is_finite() || (norm - 1.0).abs() > 1e-3 {
        return Err(format!("rotation quaternion {q:?} is not of unit length"));
    }
    Ok(quat / norm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_maps_the_camera_centre_and_axis_as_colmap_defines_them() {
        // A camera at (1, 2, 3) looking along world +X, image "down" along world −Z.
        // COLMAP: x_cam = R·x_world + t with camera axes x right, y down, z forward.
        let r_c2w = DMat3::from_cols(DVec3::new(0.0, -1.0, 0.0), DVec3::new(0.0, 0.0, -1.0), DVec3::X);
        let r = r_c2w.transpose();
        let centre = DVec3::new(1.0, 2.0, 3.0);
        let image = ColmapImage {
            id: 1,
            rotation: DQuat::from_mat3(&r),
            translation: -(r * centre),
            camera_id: 1,
            name: "a.jpg".into(),
        };
        let pose = image.camera_to_world();
        assert!((pose.w_axis.truncate() - centre).length() < 1e-12);
        // OpenGL: the camera looks down its −Z and +Y is up.
        assert!((-pose.z_axis.truncate() - DVec3::X).length() < 1e-12);
        assert!((pose.y_axis.truncate() - DVec3::Z).length() < 1e-12);
    }
}
