//! Lucid's 3D Gaussian splatting.
//!
//! A splat cloud is projected to screen-space ellipses ([`project`]), binned into 16×16 tiles
//! and composited front to back ([`raster`]); both have exact hand-written backward passes,
//! checked against finite differences (`tests/finite_diff.rs`). [`render`] chains them for
//! one view. The kernels are plain Rust over slices, parallel over splats and tiles with rayon.

pub mod background;
pub mod blend;
pub mod camera;
pub mod checkpoint;
pub mod cloud;
pub mod config;
pub mod densify;
pub mod frame;
pub mod knn;
pub mod loss;
pub mod loss_op;
pub mod model;
pub mod ops;
pub mod photometric;
pub mod ply;
pub mod project;
pub mod raster;
pub mod render;
pub mod run;
pub mod sh;
pub mod trained;
pub mod trainer;
pub mod view;

pub use camera::SplatCamera;
pub use cloud::SplatCloud;
pub use project::{RenderSettings, SplatParams};
pub use render::{RenderState, SplatGrads, render, render_backward};
