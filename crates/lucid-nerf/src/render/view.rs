//! Rendering whole views from a model: pixel-centre rays (or rays over a thin lens), marched
//! with the occupancy grid and early termination, in blocks of rays.

use burn::tensor::{Device, Tensor, TensorData};
use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::camera::{Camera, PinholeCamera, ThinLensCamera};
pub use lucid_scene::evaluation::RenderedView;
use lucid_scene::evaluation::ViewModel;
use lucid_scene::sampling::stratified_square;

use rayon::prelude::*;

use super::batch::box_position;
use super::composite::{RAY_OUTPUTS, RayAccumulator};
use super::march::{MarchState, RayMarcher};
use crate::field::FieldConfig;
use crate::model::NerfModel;
use crate::occupancy::OccupancyGrid;

/// Rays per block of a view: a 200×200 view in one, so that the rounds' tails (a few live rays
/// each) come once per view rather than once per block (0.20 → 0.12 s per view with the
/// round size below, measured on a trophy model).
const BLOCK_RAYS: usize = 1 << 16;
/// Samples per round of [`ViewRenderer::render_rays`]: enough for the field's matrix products
/// to run at speed, few enough that rays are not evaluated far past the surface that stops
/// them. A ray gets `ROUND_SAMPLES / live` samples per round, so one sample each while most
/// rays live and more as they stop: of the samples evaluated, 13 % lay past their ray's end
/// (30 % with 2¹⁷ per round and at least 8 per ray).
const ROUND_SAMPLES: usize = 1 << 15;
/// The fewest samples a live ray gets in a round.
const MIN_ROUND_SAMPLES: usize = 1;
/// Live rays per parallel marching task.
const MARCH_CHUNK: usize = 256;

/// What one task marched in a round, ray after ray.
#[derive(Default)]
struct RoundPart {
    counts: Vec<u32>,
    more: Vec<bool>,
    t: Vec<f32>,
    dt: Vec<f32>,
    positions: Vec<f32>,
    directions: Vec<f32>,
}

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
    ///
    /// Rays go in rounds: each round marches every live ray a few samples further, evaluates
    /// the field on all of those at once and composites them onto their rays; a ray stops once
    /// its transmittance falls below the threshold. Marching whole rays first would evaluate
    /// the field behind every surface, most of the work in a scene of opaque objects.
    pub fn render_rays(&self, rays: &[(Vec3, Vec3)]) -> (Vec<f32>, usize) {
        let mut accs = vec![RayAccumulator::default(); rays.len()];
        let mut live: Vec<(usize, MarchState)> = rays
            .iter()
            .enumerate()
            .filter_map(|(i, &(o, d))| self.marcher.start(o, d, self.grid, 0.5).map(|m| (i, m)))
            .collect();
        let (lo, hi) = self.grid.bounds();
        let inv_size = (hi - lo).recip();
        let mut total = 0;
        while !live.is_empty() {
            let per_ray = (ROUND_SAMPLES / live.len()).max(MIN_ROUND_SAMPLES);
            // Per chunk of live rays: sample counts, whether each goes on, t, dt, positions and
            // directions.
            let parts: Vec<RoundPart> = live
                .par_chunks_mut(MARCH_CHUNK)
                .map(|chunk| {
                    let mut part = RoundPart::default();
                    for (ray, state) in chunk.iter_mut() {
                        let (o, d) = rays[*ray];
                        let before = part.t.len();
                        let more = self.marcher.advance(o, d, self.grid, state, per_ray, &mut part.t, &mut part.dt);
                        for &ts in &part.t[before..] {
                            part.positions
                                .extend(box_position(self.marcher.to_model(o + ts * d), lo, inv_size).to_array());
                            part.directions.extend(d.to_array());
                        }
                        part.counts.push((part.t.len() - before) as u32);
                        part.more.push(more);
                    }
                    part
                })
                .collect();
            let s: usize = parts.iter().map(|p| p.t.len()).sum();
            total += s;
            let raw = if s == 0 {
                Vec::new()
            } else {
                let cat = |f: fn(&RoundPart) -> &Vec<f32>| parts.iter().flat_map(|p| f(p).iter().copied()).collect();
                let pos = Tensor::<2>::from_data(TensorData::new(cat(|p| &p.positions), [s, 3]), &self.device);
                let dir = Tensor::<2>::from_data(TensorData::new(cat(|p| &p.directions), [s, 3]), &self.device);
                self.model.field(pos, dir, self.config).into_data().try_to_vec::<f32>().expect("f32 field output")
            };
            // Composite each ray's new samples in order; keep the rays that go on.
            let mut next = Vec::with_capacity(live.len());
            let mut at = 0;
            let mut rank = 0;
            for part in &parts {
                let mut local = 0;
                for (&n, &more) in part.counts.iter().zip(&part.more) {
                    let (ray, state) = live[rank];
                    rank += 1;
                    let n = n as usize;
                    let acc = &mut accs[ray];
                    let mut going = more;
                    for j in 0..n {
                        let g = at + j;
                        if !acc.add(
                            &raw[4 * g..4 * g + 4],
                            part.t[local + j],
                            part.dt[local + j],
                            self.min_transmittance,
                        ) {
                            going = false;
                            break;
                        }
                    }
                    local += n;
                    at += n;
                    if going {
                        next.push((ray, state));
                    }
                }
            }
            live = next;
        }
        (accs.iter().flat_map(|a| a.acc).collect(), total)
    }
}
