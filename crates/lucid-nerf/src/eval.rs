//! Held-out evaluation (shared with the other model kinds, see [`lucid_scene::evaluation`]).

pub use lucid_scene::evaluation::{EvalSummary, LENS_RAYS, RenderedView, ViewModel, ViewScore, evaluate, ground_truth};
