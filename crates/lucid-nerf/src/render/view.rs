//! Rendering whole views from a model: pixel-centre rays (or rays over a thin lens), marched
//! with the occupancy grid and early termination, in blocks of rays.

use burn::tensor::{Device, Tensor, TensorData};
use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::camera::{Camera, PinholeCamera, ThinLensCamera};
pub use lucid_scene::evaluation::RenderedView;
use lucid_scene::evaluation::ViewModel;
use lucid_scene::sampling::{grid_cell_point, stratified_square};

use super::composite::{RAY_OUTPUTS, RayAccumulator};
use super::march::{MarchState, RayMarcher};
use super::rounds::{march_round, samples_per_ray};
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
    /// Rays per pixel, through the centres of a grid of cells over its area, averaged; 1: its
    /// centre.
    pub pixel_rays: usize,
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

    fn render_view_unless(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        lens_rays: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<RenderedView> {
        self.render_lens_unless(camera, lens, lens_rays, seed, abandoned)
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
        self.render_lens_unless(camera, lens, rays, seed, &|| false).expect("a render nobody abandons")
    }

    /// [`Self::render_lens`], given up between blocks of rays once `abandoned` says so.
    fn render_lens_unless(
        &self,
        camera: &PinholeCamera,
        lens: Option<(f32, f32)>,
        rays: usize,
        seed: u64,
        abandoned: &dyn Fn() -> bool,
    ) -> Option<RenderedView> {
        let (w, h) = (camera.intrinsics.width as usize, camera.intrinsics.height as usize);
        let n = w * h;
        let thin = lens.map(|(a, f)| ThinLensCamera::new(*camera, a, f));
        let lens_rays = if thin.is_some() { rays.max(1) } else { 1 };
        let per_pixel = lens_rays.max(self.pixel_rays);
        // Each ray's footprint is this camera's pixel (or its share of it).
        let marcher = self.marcher.with_pixel_angle(1.0 / camera.intrinsics.fx).with_rays_per_pixel(self.pixel_rays);
        let mut acc = vec![[0f32; RAY_OUTPUTS]; n];
        let mut samples = 0;
        for k in 0..per_pixel {
            let lens_u = stratified_square(k, per_pixel, seed);
            let offset =
                if self.pixel_rays > 1 { grid_cell_point(k, per_pixel, Vec2::splat(0.5)) } else { Vec2::splat(0.5) };
            let rays: Vec<(Vec3, Vec3)> = (0..n)
                .map(|i| {
                    let (px, py) = ((i % w) as f32 + offset.x, (i / w) as f32 + offset.y);
                    let ray = match &thin {
                        Some(t) => t.generate_ray(px, py, lens_u),
                        None => camera.generate_ray(px, py, Vec2::ZERO),
                    };
                    (ray.origin, ray.direction)
                })
                .collect();
            for (b, block) in rays.chunks(BLOCK_RAYS).enumerate() {
                if abandoned() {
                    return None;
                }
                let out = self.render_rays_with(block, &marcher);
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
        Some(RenderedView { colour: Image::from_pixels(w, h, pixels), depth, samples })
    }

    /// Composited `r, g, b, opacity, depth` (no background) of each ray, and the sample count.
    ///
    /// Rays go in rounds (see [`super::rounds`]): each round marches every live ray a few
    /// samples further, evaluates the field on all of those at once and composites them onto
    /// their rays; a ray stops once its transmittance falls below the threshold. (Evaluating
    /// the density first and the colour only where a sample reaches the image took 1.5× the
    /// time: the second pass's gathers cost more than the colour MLP it saved.)
    pub fn render_rays(&self, rays: &[(Vec3, Vec3)]) -> (Vec<f32>, usize) {
        self.render_rays_with(rays, &self.marcher)
    }

    /// [`Self::render_rays`] with another marcher (the same scene, another footprint).
    fn render_rays_with(&self, rays: &[(Vec3, Vec3)], marcher: &RayMarcher) -> (Vec<f32>, usize) {
        let mut accs = vec![RayAccumulator::default(); rays.len()];
        let mut live: Vec<(usize, MarchState)> = rays
            .iter()
            .enumerate()
            .filter_map(|(i, &(o, d))| marcher.start(o, d, self.grid, 0.5).map(|m| (i, m)))
            .collect();
        let mut total = 0;
        while !live.is_empty() {
            let per_ray = samples_per_ray(ROUND_SAMPLES, live.len());
            let round = march_round(rays, &mut live, per_ray, marcher, self.grid);
            let s = round.samples;
            if s == 0 {
                // No ray reached its round's limit: all are done.
                break;
            }
            total += s;
            let pos = Tensor::<2>::from_data(TensorData::new(round.positions(), [s, 3]), &self.device);
            let foot = Tensor::<1>::from_data(TensorData::new(round.footprints(), [s]), &self.device);
            let dir = Tensor::<2>::from_data(TensorData::new(round.directions(rays, &live), [s, 3]), &self.device);
            let raw = self
                .model
                .field(pos, foot, dir, self.config)
                .into_data()
                .try_into_vec::<f32>()
                .expect("f32 field output");
            // Composite each ray's new samples in order; keep the rays that go on.
            let mut going = vec![false; live.len()];
            round.for_each_ray(|rank, t, dt, at, more| {
                let acc = &mut accs[live[rank].0];
                let stopped = (0..t.len())
                    .any(|j| !acc.add(&raw[4 * (at + j)..4 * (at + j) + 4], t[j], dt[j], self.min_transmittance));
                going[rank] = more && !stopped;
            });
            let mut rank = 0;
            live.retain(|_| {
                rank += 1;
                going[rank - 1]
            });
        }
        (accs.iter().flat_map(|a| a.acc).collect(), total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::tests::tiny_config;
    use crate::render::composite::{PackedSamples, composite_forward};
    use crate::render::march::MarchSettings;
    use burn::module::Param;
    use lucid_scene::sampling::Rng;

    /// A model of random weights, occupied in a ball (so rays start, jump and end at
    /// different places), and its marcher.
    fn random_scene() -> (NerfModel, OccupancyGrid, RayMarcher, FieldConfig) {
        // Footprint weights strong enough that this coarse grid's levels feel them.
        let mut config = tiny_config();
        config.grid.antialias = 30.0;
        let layout = config.layout();
        let device = crate::backend::training_device();
        let mut rng = Rng::new(3, 0);
        let mut uniform =
            |n: usize, scale: f32| -> Vec<f32> { (0..n).map(|_| (2.0 * rng.uniform() - 1.0) * scale).collect() };
        let table = uniform(layout.grid.entries * layout.grid.features, 2.0);
        let mlp = uniform(layout.mlp_params(), 0.8);
        let model = NerfModel {
            table: Param::from_tensor(Tensor::from_data(
                TensorData::new(table, [layout.grid.entries, layout.grid.features]),
                &device,
            )),
            mlp: Param::from_tensor(Tensor::from_data(TensorData::new(mlp, [layout.mlp_params()]), &device)),
        };
        let grid = crate::occupancy::grid_occupied_where(16, |c| c.length() < 0.8);
        let marcher = RayMarcher::new(&MarchSettings::default(), 2.0 * 3f32.sqrt(), 0.01, 16);
        (model, grid, marcher, config)
    }

    fn renderer<'a>(
        scene: &'a (NerfModel, OccupancyGrid, RayMarcher, FieldConfig),
        pixel_rays: usize,
    ) -> ViewRenderer<'a> {
        ViewRenderer {
            model: &scene.0,
            config: scene.3,
            grid: &scene.1,
            marcher: scene.2,
            // (A high threshold, so that this small random field stops rays.)
            min_transmittance: 0.5,
            background: [1.0; 3],
            device: crate::backend::training_device(),
            pixel_rays,
        }
    }

    /// With `n²` rays per pixel a view is the mean of the `n²` views whose rays pass through
    /// the centres of the cells of an `n × n` grid over each pixel.
    #[test]
    fn pixel_rays_average_the_centres_of_a_grid_over_each_pixel() {
        let scene = random_scene();
        let pose = lucid_scene::camera::look_at(Vec3::new(0.3, 0.2, 2.5), Vec3::ZERO, Vec3::Y);
        let camera = PinholeCamera::new(lucid_scene::camera::Intrinsics::from_fov_x(24, 16, 0.9), pose);
        let view = renderer(&scene, 4).render(&camera);
        let single = renderer(&scene, 1);
        // Each of the four rays covers a quarter of its pixel: half the footprint's width.
        let quarter = scene.2.with_pixel_angle(1.0 / camera.intrinsics.fx).with_rays_per_pixel(4);
        let (w, h) = (24, 16);
        let mut mean = vec![[0f32; RAY_OUTPUTS]; w * h];
        let mut footprint_matters = false;
        for (dx, dy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
            let rays: Vec<(Vec3, Vec3)> = (0..w * h)
                .map(|i| {
                    let ray = camera.generate_ray((i % w) as f32 + dx, (i / w) as f32 + dy, Vec2::ZERO);
                    (ray.origin, ray.direction)
                })
                .collect();
            let whole_pixel = single.render_rays_with(&rays, &scene.2.with_pixel_angle(1.0 / camera.intrinsics.fx)).0;
            let sub_pixel = single.render_rays_with(&rays, &quarter).0;
            footprint_matters |= whole_pixel.iter().zip(&sub_pixel).any(|(a, b)| (a - b).abs() > 1e-3);
            for (m, o) in mean.iter_mut().zip(sub_pixel.chunks_exact(RAY_OUTPUTS)) {
                for c in 0..RAY_OUTPUTS {
                    m[c] += 0.25 * o[c];
                }
            }
        }
        assert!(footprint_matters, "the scene's footprint weights change what a ray sees");
        let mut differs_from_centre = 0;
        let centre = single.render(&camera);
        for (i, m) in mean.iter().enumerate() {
            let p = view.colour.pixels()[i];
            let expected = [m[0] + 1.0 - m[3], m[1] + 1.0 - m[3], m[2] + 1.0 - m[3], m[3]];
            for c in 0..4 {
                assert!((p[c] - expected[c]).abs() < 1e-5, "pixel {i}: {p:?} vs {expected:?}");
            }
            differs_from_centre += ((p[3] - centre.colour.pixels()[i][3]).abs() > 1e-3) as usize;
        }
        // The scene has edges: somewhere the mean over a pixel is not its centre's ray.
        assert!(differs_from_centre > 10, "{differs_from_centre} pixels differ from the centre ray's");
    }

    /// Rendering in rounds composites exactly what marching each whole ray, evaluating the
    /// field on all its samples and compositing them gives: every ray, including those that
    /// end within a round, gets all its samples up to where it stops.
    #[test]
    fn rays_rendered_in_rounds_composite_as_whole_rays() {
        let scene = random_scene();
        let (model, grid, marcher, config) = (&scene.0, &scene.1, scene.2, scene.3);
        let device = crate::backend::training_device();
        let renderer = renderer(&scene, 1);
        let mut rng = Rng::new(4, 0);
        let rays: Vec<(Vec3, Vec3)> = (0..500)
            .map(|_| {
                let o = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 3.0);
                (o, (Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 1.5 - o).normalize())
            })
            .collect();
        let (rounds, _) = renderer.render_rays(&rays);
        let mut whole = PackedSamples { offsets: vec![0], ..Default::default() };
        let (mut pos, mut foot, mut dir) = (Vec::new(), Vec::new(), Vec::new());
        for &(o, d) in &rays {
            marcher.march(o, d, grid, 0.5, false, &mut whole.t, &mut whole.dt);
            for &t in &whole.t[*whole.offsets.last().unwrap() as usize..] {
                pos.extend(((o + t * d - Vec3::splat(-1.0)) * 0.5).to_array());
                foot.push(marcher.footprint(t, o + t * d) * 0.5);
                dir.extend(d.to_array());
            }
            whole.offsets.push(whole.t.len() as u32);
        }
        let s = whole.t.len();
        let raw = model
            .field(
                Tensor::from_data(TensorData::new(pos, [s, 3]), &device),
                Tensor::from_data(TensorData::new(foot, [s]), &device),
                Tensor::from_data(TensorData::new(dir, [s, 3]), &device),
                config,
            )
            .into_data()
            .try_into_vec::<f32>()
            .unwrap();
        let mut reference = vec![0.0; rays.len() * RAY_OUTPUTS];
        composite_forward(&whole, &raw, 0.5, &mut reference);
        // (A high threshold, so that this small random field stops rays.)
        let stopped = reference.chunks(RAY_OUTPUTS).filter(|r| r[3] > 0.5).count();
        let partial = reference.chunks(RAY_OUTPUTS).filter(|r| r[3] > 0.05 && r[3] < 0.45).count();
        assert!(stopped > 20 && partial > 20, "{stopped} rays stop, {partial} pass through part-opaque");
        for (a, b) in rounds.iter().zip(&reference) {
            assert!((a - b).abs() <= 1e-5 * (1.0 + b.abs()), "{a} vs {b}");
        }
    }
}
