//! Lucid's NeRF on burn.
//!
//! The hot loops — here the multiresolution hash encoding — are plain Rust over slices,
//! parallel with rayon, exposed to burn as custom autodiff operations that work directly on
//! the CPU backend's storage ([`kernels`]). Parameters, optimisers and checkpoints are burn's.
//! Which backend runs is chosen by cargo feature ([`backend`]); trainer code only sees
//! `burn::tensor::Device`.

pub mod backend;
pub mod encoding;
pub mod field;
pub mod field_ops;
pub mod kernels;
pub mod occupancy;
pub mod render;

pub use encoding::hash_grid::{HashGridConfig, HashGridLayout, LevelLayout};
pub use kernels::hash_grid_encode;
