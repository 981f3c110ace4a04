//! Training and evaluation images in memory (shared with the other trainers).

pub use lucid_scene::dataset::images::{ImageSet, ViewInfo, scene_box};
