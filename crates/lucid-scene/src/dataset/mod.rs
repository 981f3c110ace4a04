//! The NeRF-synthetic / instant-ngp dataset layout.
//!
//! A dataset is a folder with `transforms_train.json`, `transforms_val.json` and
//! `transforms_test.json` (or a single instant-ngp style `transforms.json`, read as the
//! training split). Each file holds intrinsics and a list of frames:
//!
//! ```json
//! { "camera_angle_x": 0.6911,                     // and/or fl_x, fl_y, cx, cy, w, h
//!   "aabb": [[-1.5,-1.5,-1.5],[1.5,1.5,1.5]],      // optional scene bounds (ours)
//!   "frames": [ { "file_path": "./train/r_0",      // with or without extension
//!                 "transform_matrix": [[...4 rows of 4...]],
//!                 "hdr_file_path": "train/r_0.exr",   // the rest are optional extras
//!                 "depth_file_path": "train/r_0_depth.exr",
//!                 "normal_file_path": "train/r_0_normal.exr",
//!                 "albedo_file_path": "train/r_0_albedo.exr",
//!                 "environment_file_path": "envmaps/env_0.exr",
//!                 "exposure_time": 0.25, "light_direction": [0,0,1], "held_out_light": true,
//!                 "aperture_radius": 0.05, "focus_distance": 4.0 } ] }
//! ```
//!
//! Intrinsics may also be given per frame (nerfstudio writes them so), overriding the
//! file-level ones, and so may nerfstudio's lens (`camera_model`, `k1…k4`, `p1`, `p2`). Other
//! tools ignore our extra keys; we ignore theirs, except lens keys, which are honoured or
//! refused.
//!
//! A folder without transforms files but with a COLMAP model (`sparse/0/`) and `images/` is a
//! capture ([`capture`]), and so is a lone nerfstudio `transforms.json` (one that names its
//! `camera_model`, `applied_transform` or `ply_file_path`), normalised the same way. A dataset
//! without split files (a lone `transforms.json`, or a capture) holds out every 8th image by
//! sorted name as its test split.

pub mod capture;
mod fingerprint;
pub mod images;
mod nerfstudio;
mod read;
pub use read::MAX_POSE_ENTRY;
pub mod summary;
mod write;

use std::path::{Path, PathBuf};

use glam::{Vec3, Vec4Swizzles};

use crate::PinholeCamera;

pub use capture::SceneNormalisation;
pub use write::{FrameRecord, write_transforms};

/// Choices made when opening a dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OpenOptions {
    /// Without split files, every this-many-th image (by sorted name) is a test view; 0 holds
    /// none out.
    pub holdout_every: usize,
    /// Read captures at 1/N of their size: from `images_N/` where it exists, else resized.
    pub downscale: Option<u32>,
    /// Which description to read where a folder holds several (nerfstudio's layout keeps both
    /// a `transforms.json` and a COLMAP model); `None`: transforms files first.
    pub format: Option<DatasetFormat>,
}

/// The description of a dataset's cameras.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DatasetFormat {
    /// `transforms_*.json` or a lone `transforms.json` (Blender, instant-ngp, nerfstudio).
    Transforms,
    /// A COLMAP sparse model with `images/`.
    Colmap,
}

impl Default for OpenOptions {
    /// The Mip-NeRF 360 / LLFF convention: every 8th image held out, full size.
    fn default() -> Self {
        Self { holdout_every: 8, downscale: None, format: None }
    }
}

/// A point of a capture's sparse reconstruction, in scene coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SparsePoint {
    /// Position.
    pub position: Vec3,
    /// Colour, 8-bit sRGB.
    pub colour: [u8; 3],
}

/// The three splits of the Blender layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Split {
    /// Training views.
    Train,
    /// Validation views.
    Val,
    /// Held-out test views.
    Test,
}

impl Split {
    /// All splits in file order.
    pub const ALL: [Split; 3] = [Split::Train, Split::Val, Split::Test];

    /// `train`, `val` or `test`.
    pub fn name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }

    /// `transforms_<name>.json`.
    pub fn file_name(self) -> String {
        format!("transforms_{}.json", self.name())
    }
}

impl std::fmt::Display for Split {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Optional per-frame data beyond the image and pose (Lucid's extra keys).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameExtras {
    /// Linear HDR image (`hdr_file_path`).
    pub hdr_path: Option<PathBuf>,
    /// Depth along the camera axis (`depth_file_path`).
    pub depth_path: Option<PathBuf>,
    /// World-space normals (`normal_file_path`).
    pub normal_path: Option<PathBuf>,
    /// Surface albedo (`albedo_file_path`).
    pub albedo_path: Option<PathBuf>,
    /// The lat-long environment map the frame is lit by (`environment_file_path`).
    pub environment_path: Option<PathBuf>,
    /// Which pixels to learn from and score (`mask_path`, nerfstudio's): where the mask is
    /// dark (below one half) the pixel is ignored, e.g. a person walking through a capture.
    pub mask_path: Option<PathBuf>,
    /// Exposure time in seconds (`exposure_time`).
    pub exposure_time: Option<f32>,
    /// Direction towards a directional light, world space (`light_direction`).
    pub light_direction: Option<Vec3>,
    /// The light is not among the training lights (`held_out_light`; OLAT test views).
    pub held_out_light: bool,
    /// Thin-lens aperture radius in world units (`aperture_radius`).
    pub aperture_radius: Option<f32>,
    /// Thin-lens focus distance in world units (`focus_distance`).
    pub focus_distance: Option<f32>,
}

/// One view: an image, the camera that took it, and optional extras. Paths are resolved
/// against the dataset folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// `file_path` as written in the JSON.
    pub file_path: String,
    /// The image file, resolved (extension found if the JSON omitted it).
    pub image_path: PathBuf,
    /// Intrinsics and pose.
    pub camera: PinholeCamera,
    /// Optional extra data.
    pub extras: FrameExtras,
    /// The size the image is resized to on reading (a capture read with `--downscale` and no
    /// downscaled folder); the intrinsics already describe it.
    pub resize_to: Option<(u32, u32)>,
}

/// The frames of one split, with the file they came from.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitFrames {
    /// Which split.
    pub split: Split,
    /// The JSON file read.
    pub source: PathBuf,
    /// The frames in file order.
    pub frames: Vec<Frame>,
    /// Scene bounds, if the file gives them (see [`SceneBounds`]).
    pub bounds: Option<SceneBounds>,
}

/// How a transforms file bounds the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneBounds {
    /// An explicit axis-aligned box (`aabb`: `[[min], [max]]`).
    Box {
        /// Minimum corner.
        min: Vec3,
        /// Maximum corner.
        max: Vec3,
    },
    /// instant-ngp's `aabb_scale`: a power of two scaling its unit cube.
    AabbScale(f32),
}

/// A dataset folder: the splits that exist in it.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// The folder.
    pub root: PathBuf,
    /// The splits found, in train/val/test order.
    pub splits: Vec<SplitFrames>,
    /// How a capture's coordinates were normalised (`None`: the files' coordinates are used
    /// as they are).
    pub normalisation: Option<SceneNormalisation>,
    /// A capture's sparse points (empty for rendered sets).
    pub points: Vec<SparsePoint>,
}

impl Dataset {
    /// Reads every `transforms_*.json` in `root` (or `transforms.json` as the training split)
    /// and checks each frame: the pose is a finite 4×4 (or 3×4) matrix, the image exists and
    /// has the size the intrinsics say.
    pub fn open(root: impl AsRef<Path>) -> Result<Self, DatasetError> {
        read::open(root.as_ref(), &OpenOptions::default())
    }

    /// [`Dataset::open`] with choices for split-less datasets and captures.
    pub fn open_with(root: impl AsRef<Path>, options: &OpenOptions) -> Result<Self, DatasetError> {
        read::open(root.as_ref(), options)
    }

    /// Reads one transforms file as the given split.
    pub fn read_split(json: impl AsRef<Path>, split: Split) -> Result<SplitFrames, DatasetError> {
        read::read_split(json.as_ref(), split)
    }

    /// The frames of one split (empty if the split is absent).
    pub fn frames(&self, split: Split) -> &[Frame] {
        self.splits.iter().find(|s| s.split == split).map(|s| s.frames.as_slice()).unwrap_or(&[])
    }

    /// All frames of all splits.
    pub fn all_frames(&self) -> impl Iterator<Item = &Frame> {
        self.splits.iter().flat_map(|s| s.frames.iter())
    }

    /// The axis-aligned box of all camera centres, or `None` without frames.
    pub fn camera_bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.all_frames().map(|f| f.camera.camera_to_world.w_axis.xyz());
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }
}

/// Why a dataset could not be read or written. Each message names the file and, inside
/// a JSON file, the key (e.g. `frames[3].transform_matrix`).
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The OS refused (missing file, permissions…).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The JSON does not parse.
    #[error("{}: malformed JSON: {source}", path.display())]
    Json {
        /// The file involved.
        path: PathBuf,
        /// Parser error with line and column.
        source: serde_json::Error,
    },
    /// A key is missing or has a wrong value.
    #[error("{}: {key}: {reason}", path.display())]
    Invalid {
        /// The JSON file.
        path: PathBuf,
        /// Where in the file, e.g. `frames[2].file_path`.
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// A COLMAP model could not be read.
    #[error(transparent)]
    Colmap(#[from] crate::colmap::ColmapError),
    /// No transforms file in the folder.
    #[error("{}: not a dataset: no transforms_train.json, transforms_val.json, transforms_test.json or transforms.json, and no COLMAP model (sparse/0/cameras.bin or .txt)", path.display())]
    NotADataset {
        /// The folder.
        path: PathBuf,
    },
    /// An image named by a frame could not be read.
    #[error("{}: {key}: {source}", path.display())]
    Image {
        /// The JSON file.
        path: PathBuf,
        /// The frame key.
        key: String,
        /// The image error (names the image file).
        source: lucid_image::ImageError,
    },
}
