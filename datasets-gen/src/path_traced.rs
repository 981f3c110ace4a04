//! Views rendered by the path tracer, for datasets of scene files.

use lucid_scene::{PinholeCamera, ThinLensCamera};
use lucid_trace::light::Light;
use lucid_trace::{RenderCamera, RenderSettings, Scene, render};

use crate::writer::{Lens, RenderedView, ViewRenderer};

/// A scene and its render settings; each view gets its own seed derived from the base seed.
pub struct PathTracedScene {
    /// The scene.
    pub scene: Scene,
    /// Samples per pixel, base seed and integrator.
    pub settings: RenderSettings,
}

impl PathTracedScene {
    fn seed(&self, view: u64) -> u64 {
        lucid_trace::sampling::mix(self.settings.seed ^ view.wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }
}

impl ViewRenderer for PathTracedScene {
    fn can_relight(&self) -> Result<(), String> {
        self.scene.relit(Vec::new()).map(|_| ())
    }

    fn render_lit(&self, camera: &PinholeCamera, lights: &[Light], view: u64) -> Result<RenderedView, String> {
        let scene = self.scene.relit(lights.to_vec())?;
        let settings = RenderSettings { seed: self.seed(view), ..self.settings };
        let out = render(&scene, &RenderCamera::Pinhole(*camera), &settings, &|_| {}).map_err(|e| e.to_string())?;
        Ok(RenderedView { colour: out.colour, depth: out.depth, normal: out.normal, albedo: out.albedo })
    }

    fn render(&self, camera: &PinholeCamera, lens: Option<Lens>, view: u64) -> Result<RenderedView, String> {
        let settings = RenderSettings { seed: self.seed(view), ..self.settings };
        let camera = match lens {
            None => RenderCamera::Pinhole(*camera),
            Some(l) => RenderCamera::ThinLens(ThinLensCamera::new(*camera, l.aperture_radius, l.focus_distance)),
        };
        let out = render(&self.scene, &camera, &settings, &|_| {}).map_err(|e| e.to_string())?;
        Ok(RenderedView { colour: out.colour, depth: out.depth, normal: out.normal, albedo: out.albedo })
    }
}
