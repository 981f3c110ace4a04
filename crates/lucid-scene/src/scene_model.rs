//! A trained scene model apart from whatever trained it: what `eval`, `render`, `view` and
//! `export` need of a NeRF, a splat cloud or a model another tool wrote.

use std::any::Any;

use glam::Vec3;

use crate::dataset::images::ViewInfo;
use crate::evaluation::ViewModel;

/// A model that renders views and knows how its training cameras saw the scene.
pub trait SceneModel: ViewModel + Send + Sync {
    /// The kind its checkpoints name (`nerf`, `splat`).
    fn kind(&self) -> &'static str;

    /// Training steps taken.
    fn step(&self) -> usize;

    /// How the training cameras saw the scene (the defaults of novel-view paths).
    fn view(&self) -> ViewInfo;

    /// The centre of the scene (the target of orbit paths).
    fn centre(&self) -> Vec3;

    /// Casts its rays as `options` say where it has rays to cast; what they leave out stays as
    /// trained. An error names the option that does not apply or is out of range.
    fn set_render_options(&mut self, options: &RenderOptions) -> Result<(), String> {
        match options.first_set() {
            None => Ok(()),
            Some(name) => Err(format!("{name} applies to NeRF models; this one is a '{}' model", self.kind())),
        }
    }

    /// The model as [`Any`], for exports that write one kind's own parameters.
    fn as_any(&self) -> &dyn Any;
}

/// How a ray-marched model is rendered, where it differs from how it was trained.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderOptions {
    /// Rays per pixel, on a regular grid over its area, averaged.
    pub pixel_rays: Option<usize>,
    /// The fraction of the training step length the rays march at, in (0, 1].
    pub step_scale: Option<f32>,
}

impl RenderOptions {
    /// The name of the first option given (as the command line spells it), if any.
    pub fn first_set(&self) -> Option<&'static str> {
        match (self.pixel_rays, self.step_scale) {
            (Some(_), _) => Some("--pixel-rays"),
            (None, Some(_)) => Some("--step-scale"),
            (None, None) => None,
        }
    }
}

/// A model that renders through a renderer it lends (its parameters with their settings):
/// every such model is a [`ViewModel`] by its renderer's rendering.
pub trait RendersThrough {
    /// The renderer, borrowing the model.
    type Renderer<'a>: ViewModel
    where
        Self: 'a;

    /// A renderer of the model as it is.
    fn renderer(&self) -> Self::Renderer<'_>;
}

impl<T: RendersThrough> ViewModel for T {
    fn render_view(
        &self,
        camera: &crate::camera::PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
    ) -> crate::evaluation::RenderedView {
        self.renderer().render_view(camera, lens, lens_rays, seed)
    }

    fn render_view_unless(
        &self,
        camera: &crate::camera::PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<crate::evaluation::RenderedView> {
        self.renderer().render_view_unless(camera, lens, lens_rays, seed, abandoned)
    }

    fn background(&self) -> [f32; 3] {
        self.renderer().background()
    }
}
