//! Lucid's dataset generator: renders scenes from camera rigs and writes the
//! NeRF-synthetic layout (`transforms_{train,val,test}.json`, sRGB PNG with alpha, linear EXR,
//! and per-frame depth/normal/albedo EXR).
//!
//! Scenes are rendered by a [`ViewRenderer`]; today that is the exact analytic ray caster of
//! [`analytic`], whose images need no sampling noise, and the physically based path tracer
//! plugs in behind the same trait.

pub mod analytic;
pub mod rig;
pub mod writer;

pub use analytic::AnalyticScene;
pub use rig::OrbitRig;
pub use writer::{DatasetSpec, GeneratedDataset, ViewRenderer, generate_dataset};
