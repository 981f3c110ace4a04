//! Lucid's neural relighting head on 3D Gaussian splatting.
//!
//! A splat cloud is trained on a multi-view OLAT set lit uniformly (the solid-angle-weighted
//! sum of each view's OLAT frames); its geometry is then frozen and every Gaussian gets a
//! feature vector that a small MLP decodes, with the light and viewing directions, into the
//! Gaussian's radiance under that light ([`head`]). A novel view under a novel light is one
//! render; under an environment map, each Gaussian's radiance is integrated over light
//! directions first, which for fixed geometry equals integrating the renders ([`render`]).
//!
//! - [`config`]: the `configs/relight/*.toml` settings.
//! - [`data`]: the OLAT frames of a split grouped by view, and the uniformly lit images.
//! - [`trainer`]: the two stages.
//! - [`eval`]: scores on held-out views under single lights and environment maps.
//! - [`checkpoint`]: the `"relight"` checkpoint kind.

pub mod checkpoint;
pub mod config;
pub mod data;
pub mod eval;
pub mod head;
pub mod render;
pub mod run;
pub mod trainer;

pub use lucid_relight::RelightError;
