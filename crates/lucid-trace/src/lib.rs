//! Lucid's physically based path tracer: it renders all training data and every ground
//! truth, so its correctness is checked against closed forms (white furnace, solid angles,
//! Fresnel values, pdf normalisation) and against a reference render of the Cornell box.

pub mod assets;
mod bdpt;
pub mod bsdf;
pub mod distribution;
pub mod environment;
pub mod geometry;
pub mod integrator;
pub mod irradiance_cache;
pub mod light;
pub mod light_grid;
pub mod manylight;
pub mod material;
pub mod medium;
pub mod packet;
pub mod projector;
pub mod pssmlt;
pub mod render;
pub mod sample_scenes;
pub mod sampling;
pub mod scene;
pub mod scene_file;
mod scene_integrator;
pub mod sppm;
pub mod subsurface;
pub mod tabulate;
pub mod texture_set;
mod visible;

pub use integrator::{LightStrategy, PathTracer};
pub use material::{Material, Texture};
pub use render::{Integrator, RenderCamera, RenderOutput, RenderSettings, Unsupported, render};
pub use scene::{Emission, Scene, SceneBuilder};
pub use scene_file::{LoadedScene, SceneFileError, load_scene, parse_scene};
