//! Lucid's dataset generator: renders scenes from camera rigs and writes the
//! NeRF-synthetic layout (`transforms_{train,val,test}.json`, sRGB PNG with alpha, linear EXR,
//! and per-frame depth/normal/albedo EXR).
//!
//! Scenes are rendered by a [`ViewRenderer`]: the physically based path tracer for scene files
//! ([`PathTracedScene`]), or the exact analytic ray caster of [`analytic`], whose noise-free
//! images make quick fixtures.

pub mod analytic;
pub mod brackets;
pub mod builtin;
pub mod capture;
pub mod dual;
pub mod lightfield;
pub mod olat;
pub mod path_traced;
pub mod point_cloud;
pub mod reference_spheres;
pub mod rig;
pub mod writer;

pub use analytic::AnalyticScene;
pub use lightfield::{LightFieldRig, refocus};
pub use path_traced::PathTracedScene;
pub use rig::{OrbitRig, Rig};
pub use writer::{
    DatasetSpec, GeneratedDataset, Shard, ViewRenderer, finish_dataset, generate_dataset, missing_frames,
};
