//! Rendering whole views from a model: pixel-centre rays (or rays over a thin lens), marched
//! with the occupancy grid and early termination, in blocks of rays.

use std::sync::Arc;

use burn::tensor::{Device, Tensor, TensorData};
use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::camera::{Camera, PinholeCamera, ThinLensCamera};
pub use lucid_scene::evaluation::RenderedView;
use lucid_scene::evaluation::ViewModel;
use lucid_scene::sampling::stratified_square;

use super::batch::march_rays;
use super::composite::RAY_OUTPUTS;
use super::march::RayMarcher;
use crate::field::FieldConfig;
use crate::field_ops;
use crate::model::NerfModel;
use crate::occupancy::OccupancyGrid;

/// Rays per block: bounds the memory of one field evaluation.
const BLOCK_RAYS: usize = 1 << 14;

/// What renders a view.
pub struct ViewRenderer<'a> {
    /// The model.
    pub model: &'a NerfModel,
    /// Its field configuration.
    pub config: FieldConfig,
    /// The occupancy grid.
    pub grid: &'a OccupancyGrid,
    /// The marcher.
    pub marcher: RayMarcher,
    /// Early-termination threshold.
    pub min_transmittance: f32,
    /// Background colour (encoded).
    pub background: [f32; 3],
    /// Device of the model.
    pub device: Device,
}

impl ViewModel for ViewRenderer<'_> {
    fn render_view(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
    ) -> RenderedView {
        self.render_lens(camera, lens, lens_rays, seed)
    }

    fn background(&self) -> [f32; 3] {
        self.background
    }
}

impl ViewRenderer<'_> {
    /// Renders `camera` with one ray through each pixel centre.
    pub fn render(&self, camera: &PinholeCamera) -> RenderedView {
        self.render_lens(camera, None, 1, 0)
    }

    /// Renders with a thin lens of `aperture` radius focused at `focus`, averaging `rays` rays
    /// per pixel over the lens (stratified on a concentric disk), or a pinhole when `None`.
    pub fn render_lens(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        rays: usize,
        seed: u64,
    ) -> RenderedView {
        let (w, h) = (camera.intrinsics.width as usize, camera.intrinsics.height as usize);
        let n = w * h;
        let thin = lens.map(|(a, f)| ThinLensCamera::new(*camera, a, f));
        let per_pixel = if thin.is_some() { rays.max(1) } else { 1 };
        let mut acc = vec![[0f32; RAY_OUTPUTS]; n];
        let mut samples = 0;
        for k in 0..per_pixel {
            let lens_u = stratified_square(k, per_pixel, seed);
            let rays: Vec<(Vec3, Vec3)> = (0..n)
                .map(|i| {
                    let (px, py) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                    let ray = match &thin {
                        Some(t) => t.generate_ray(px, py, lens_u),
                        None => camera.generate_ray(px, py, Vec2::ZERO),
                    };
                    (ray.origin, ray.direction)
                })
                .collect();
            for (b, block) in rays.chunks(BLOCK_RAYS).enumerate() {
                let out = self.render_rays(block);
                samples += out.1;
                for (i, o) in out.0.chunks_exact(RAY_OUTPUTS).enumerate() {
                    let a = &mut acc[b * BLOCK_RAYS + i];
                    for c in 0..RAY_OUTPUTS {
                        a[c] += o[c] / per_pixel as f32;
                    }
                }
            }
        }
        let bg = self.background;
        let pixels = acc
            .iter()
            .map(|a| {
                let o = a[3];
                [a[0] + (1.0 - o) * bg[0], a[1] + (1.0 - o) * bg[1], a[2] + (1.0 - o) * bg[2], o]
            })
            .collect();
        let depth = acc.iter().map(|a| if a[3] > 1e-3 { a[4] / a[3] } else { 0.0 }).collect();
        RenderedView { colour: Image::from_pixels(w, h, pixels), depth, samples }
    }

    /// Composited `r, g, b, opacity, depth` (no background) of each ray, and the sample count.
    pub fn render_rays(&self, rays: &[(Vec3, Vec3)]) -> (Vec<f32>, usize) {
        let (batch, _) = march_rays(rays, |_| 0.5, &self.marcher, self.grid, None);
        let s = batch.samples.samples();
        if s == 0 {
            return (vec![0.0; rays.len() * RAY_OUTPUTS], 0);
        }
        let pos = Tensor::<2>::from_data(TensorData::new(batch.positions, [s, 3]), &self.device);
        let dir = Tensor::<2>::from_data(TensorData::new(batch.directions, [s, 3]), &self.device);
        let raw = self.model.field(pos, dir, self.config);
        let out = field_ops::composite(raw, Arc::new(batch.samples), self.min_transmittance);
        (out.into_data().try_to_vec::<f32>().expect("f32 output"), s)
    }
}
