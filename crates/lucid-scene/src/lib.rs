//! Rays, cameras and the dataset format.
//!
//! Conventions (shared by every Lucid crate):
//! - World space is right-handed; the NeRF-synthetic data is +Z up.
//! - A camera pose is a camera-to-world 4×4 matrix in the OpenGL convention: the camera
//!   looks down its local −Z axis, +Y is up and +X is right.
//! - Pixel `(i, j)` (column, row from the top) has its centre at `(i + 0.5, j + 0.5)`, and
//!   the focal length in pixels is `f = 0.5·W / tan(0.5·camera_angle_x)`.
//!
//! The [`dataset`] module reads and writes the NeRF-synthetic / instant-ngp
//! `transforms_*.json` layout; [`evaluation`] scores any trained model on its held-out views.

pub mod camera;
pub mod camera_path;
pub mod colmap;
pub mod dataset;
pub mod evaluation;
pub mod held_out;
pub mod lens;
pub mod point_cloud;
pub mod prefetch;
pub mod ray;
pub mod sampling;
pub mod scene_model;
pub mod simd;
pub mod text_file;
pub mod undistort;

pub use camera::{Camera, Intrinsics, PinholeCamera, ThinLensCamera, look_at};
pub use dataset::{Dataset, DatasetError, Frame, FrameExtras, Split, SplitFrames};
pub use lens::LensDistortion;
pub use ray::Ray;
