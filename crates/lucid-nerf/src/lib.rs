//! Lucid's NeRF on burn.
//!
//! The hot loops — the radiance field (hash encoding and both MLPs fused, [`field`]) and the
//! ray compositing ([`render::composite`]) — are plain Rust over slices, parallel with rayon,
//! exposed to burn as custom autodiff operations that work directly on the CPU backend's
//! storage ([`ops`]). Parameters, optimisers and checkpoints are burn's; the training
//! loop is Lucid's one loop ([`run`], over [`lucid_burn::run`]).
//! Which backend runs is chosen by cargo feature ([`backend`]); trainer code only sees
//! `burn::tensor::Device`.

pub use lucid_burn::backend;

pub mod average;
pub mod checkpoint;
pub mod config;
pub mod data;
pub mod encoding;
pub mod error_map;
pub mod eval;
pub mod field;
pub mod loss;
pub mod model;
pub mod occupancy;
pub mod ops;
pub mod optimizer;
pub mod profile;
pub mod render;
pub mod run;
pub mod trained;
pub mod trainer;

pub use encoding::hash_grid::{HashGridConfig, HashGridLayout, LevelLayout};
