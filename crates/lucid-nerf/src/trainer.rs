//! One training step at a time: sample pixels, march their rays through the occupancy grid
//! to a fixed sample budget, evaluate and composite on the autodiff device, take burn's Adam
//! step; every few steps refresh the occupancy grid from the field's density.

use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use glam::{Vec2, Vec3};
use lucid_scene::Dataset;
use lucid_scene::camera::{Camera, PinholeCamera};
use lucid_scene::ray::Ray;
use lucid_scene::sampling::{Rng, grid_cell_point, mix};

use crate::average::{AVERAGE_EVERY, ParameterAverage};
use crate::config::{Background, Loss, NerfConfig};
use crate::data::{ImageSet, ViewInfo, scene_box};
use crate::encoding::hash_grid::FINEST_CELLS_PER_PIXEL;
use crate::error_map::ErrorMap;
use crate::loss;
use crate::model::NerfModel;
use crate::occupancy::OccupancyGrid;
use crate::ops;
use crate::optimizer::optimizer;
use crate::render::batch::march_to_termination;
use crate::render::march::RayMarcher;
use crate::render::view::ViewRenderer;

/// What one step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepStats {
    /// The loss value.
    pub loss: f32,
    /// PSNR of the batch's colours (dB).
    pub psnr: f32,
    /// Rays in the batch.
    pub rays: usize,
    /// Samples in the batch.
    pub samples: usize,
    /// Seconds spent in each phase of the step.
    pub timings: StepTimings,
}

/// Wall time of the phases of one step, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTimings {
    /// Occupancy-grid refresh (only on update steps).
    pub occupancy: f64,
    /// Pixel sampling and ray marching.
    pub march: f64,
    /// The density evaluations that find where each ray stops (in rounds with the marching).
    pub cut: f64,
    /// Field evaluation (encoding + MLPs).
    pub field: f64,
    /// Compositing and loss.
    pub composite: f64,
    /// Backward pass (compositing, MLPs and the grid scatter).
    pub backward: f64,
    /// Adam step.
    pub optimizer: f64,
}

impl StepTimings {
    /// Adds another step's timings.
    pub fn add(&mut self, o: &StepTimings) {
        self.occupancy += o.occupancy;
        self.march += o.march;
        self.cut += o.cut;
        self.field += o.field;
        self.composite += o.composite;
        self.backward += o.backward;
        self.optimizer += o.optimizer;
    }

    /// Timings from named phases (as [`Self::named`] gives them, summed by the training
    /// loop); unknown names are ignored.
    pub fn from_named(phases: &[(&str, f64)]) -> Self {
        let mut t = Self::default();
        for &(name, seconds) in phases {
            let slot = match name {
                "occupancy" => &mut t.occupancy,
                "march" => &mut t.march,
                "cut" => &mut t.cut,
                "field" => &mut t.field,
                "composite+loss" => &mut t.composite,
                "backward" => &mut t.backward,
                "optimizer" => &mut t.optimizer,
                _ => continue,
            };
            *slot += seconds;
        }
        t
    }

    /// The phases with their names.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        [
            ("occupancy", self.occupancy),
            ("march", self.march),
            ("cut", self.cut),
            ("field", self.field),
            ("composite+loss", self.composite),
            ("backward", self.backward),
            ("optimizer", self.optimizer),
        ]
    }
}

/// A model in training with everything needed to continue: optimiser state, occupancy grid,
/// step counter and the batch-size adaptation.
pub struct NerfTrainer {
    /// The configuration.
    pub config: NerfConfig,
    /// The model (on the autodiff device).
    pub model: NerfModel,
    /// burn's Adam, with weight decay on the MLP group only.
    pub optimizer: ModuleOptimizer,
    /// The occupancy grid.
    pub grid: OccupancyGrid,
    /// Steps taken.
    pub step: usize,
    /// Rays for the next batch (adapted to the sample budget).
    pub rays_per_batch: f32,
    /// Angular size of a training pixel (sets the step growth).
    pub pixel_angle: f32,
    /// How the training cameras saw the scene (defaults for rendering paths).
    pub view: ViewInfo,
    /// Fraction of the run's budget used before the next step, in [0, 1] (set by the training
    /// loop, [`lucid_burn::run`]): the position of the learning-rate decay.
    pub progress: f64,
    /// Per-block loss estimates of the training images, when `train.error_sampling` is on
    /// (made at the first step, kept in checkpoints).
    pub error_map: Option<ErrorMap>,
    /// The running average of the parameters over the end of the budget, when
    /// `train.average_window` is on and the run has reached it: what is evaluated and
    /// rendered.
    pub average: Option<ParameterAverage>,
    device: Device,
}

/// The rows `indices` (counted over all rounds) of the row-major `width`-column matrices
/// `rounds`, one after the other.
fn gather_round_rows(rounds: &[Vec<f32>], width: usize, indices: &[u32]) -> Vec<f32> {
    use rayon::prelude::*;
    let mut starts = vec![0usize];
    for r in rounds {
        starts.push(starts.last().unwrap() + r.len() / width);
    }
    let mut out = vec![0.0; indices.len() * width];
    out.par_chunks_mut(width * 1024).zip(indices.par_chunks(1024)).for_each(|(out, idx)| {
        for (o, &i) in out.chunks_exact_mut(width).zip(idx) {
            let i = i as usize;
            let r = starts.partition_point(|&s| s <= i) - 1;
            let row = i - starts[r];
            o.copy_from_slice(&rounds[r][row * width..(row + 1) * width]);
        }
    });
    out
}

/// Training ray `j` of the `n` cast through pixel `(x, y)`: through the centre of the `j`-th
/// of `n` cells tiling the pixel (its centre for `n = 1`), or, when `jitter`, through a random
/// point of that cell, so that `n` rays spread over the pixel's area as the truth's pixel
/// filter does.
fn training_ray(
    camera: &PinholeCamera,
    x: usize,
    y: usize,
    (j, n): (usize, usize),
    jitter: bool,
    rng: &mut Rng,
) -> Ray {
    let offset = if jitter { Vec2::new(rng.uniform(), rng.uniform()) } else { Vec2::splat(0.5) };
    let p = grid_cell_point(j, n, offset);
    camera.generate_ray(x as f32 + p.x, y as f32 + p.y, Vec2::ZERO)
}

/// Draws of another pixel before a ray whose pixel is masked out is given up.
const MASK_REDRAWS: usize = 32;

/// Truth alpha below which a pixel counts as seeing nothing (half an 8-bit step).
const TRANSPARENT: f32 = 0.5 / 255.0;

impl NerfTrainer {
    /// A fresh model over the scene box `(min, max)`.
    pub fn new(config: NerfConfig, bounds: (Vec3, Vec3), pixel_angle: f32, device: Device) -> Self {
        let model = NerfModel::init(&config.field, &device, config.train.seed);
        let grid = OccupancyGrid::new(config.occupancy.resolution, bounds.0, bounds.1);
        Self::resume(config, model, None, grid, 0, pixel_angle, device)
    }

    /// A fresh model for `dataset` trained on `data` (its training images): the dataset's
    /// scene box, the cameras' pixel angle for the step growth, and their view for rendering.
    /// An unbounded scene (a capture, or images without transparency) contracts the space
    /// beyond the ball around the origin that holds the cameras, and the box is the contracted
    /// ball's cube.
    pub fn for_dataset(mut config: NerfConfig, dataset: &Dataset, data: &ImageSet, device: Device) -> Self {
        use crate::render::march::Unbounded;
        let unbounded = match config.march.unbounded {
            Unbounded::Auto => dataset.normalisation.is_some() || data.is_opaque(),
            Unbounded::On => true,
            Unbounded::Off => false,
        };
        let bounds = if unbounded {
            if config.march.contraction <= 0.0 {
                let reach = data.cameras.iter().map(|c| c.position().length()).fold(0.0f32, f32::max);
                config.march.contraction = reach.max(1e-3);
            }
            let r = config.march.contraction;
            (Vec3::splat(-2.0 * r), Vec3::splat(2.0 * r))
        } else {
            config.march.contraction = 0.0;
            scene_box(dataset)
        };
        let centre = if unbounded { Vec3::ZERO } else { (bounds.0 + bounds.1) * 0.5 };
        let view = ViewInfo { frame: dataset.normalisation, ..ViewInfo::from_cameras(&data.cameras, centre) };
        let pixel_angle = data.pixel_angle();
        let grid = &mut config.field.grid;
        if grid.finest_resolution == 0.0 {
            // A contracted scene's cells grow with distance, so no one footprint fits it; it
            // keeps instant-ngp's resolution.
            grid.finest_resolution = if unbounded {
                grid.finest()
            } else {
                grid.finest_for_views((bounds.1 - bounds.0).max_element(), pixel_angle, view.radius)
            };
            let why = if unbounded {
                "instant-ngp's, for an unbounded scene".to_string()
            } else {
                format!("{FINEST_CELLS_PER_PIXEL} cells per training pixel")
            };
            tracing::info!(
                "hash grid: finest resolution {:.0} ({why}; field.grid.finest_resolution overrides it)",
                grid.finest_resolution
            );
        }
        let mut trainer = Self::new(config, bounds, pixel_angle, device);
        trainer.view = view;
        trainer
    }

    /// Continues from saved state.
    pub fn resume(
        config: NerfConfig,
        model: NerfModel,
        optimizer: Option<ModuleOptimizer>,
        grid: OccupancyGrid,
        step: usize,
        pixel_angle: f32,
        device: Device,
    ) -> Self {
        let optimizer = optimizer.unwrap_or_else(|| self::optimizer(&config));
        let rays_per_batch = config.train.initial_rays as f32;
        Self {
            config,
            model,
            optimizer,
            grid,
            step,
            rays_per_batch,
            pixel_angle,
            view: ViewInfo::default(),
            progress: 0.0,
            error_map: None,
            average: None,
            device,
        }
    }

    /// The marcher for this scene.
    pub fn marcher(&self) -> RayMarcher {
        crate::trained::marcher(&self.config, &self.grid, self.pixel_angle)
    }

    /// The learning rate at the current schedule position (exponential decay to the final
    /// fraction over the run's budget).
    pub fn learning_rate(&self) -> f64 {
        let t = &self.config.train;
        t.learning_rate * t.final_learning_rate.powf(self.progress.clamp(0.0, 1.0))
    }

    /// Samples per batch at the current schedule position: geometric from `batch_samples` to
    /// `batch_growth` times it over the run's budget.
    pub fn batch_samples(&self) -> usize {
        let t = &self.config.train;
        (t.batch_samples as f64 * t.batch_growth.powf(self.progress.clamp(0.0, 1.0))).round() as usize
    }

    /// One optimisation step on random pixels of `data`.
    pub fn step(&mut self, data: &ImageSet) -> StepStats {
        let cfg = self.config.train;
        let mut timings = StepTimings::default();
        let mut clock = Instant::now();
        let mut lap = |slot: &mut f64| {
            let now = Instant::now();
            *slot = (now - clock).as_secs_f64();
            clock = now;
        };
        if self.step >= self.config.occupancy.warmup_steps
            && self.step.is_multiple_of(self.config.occupancy.update_every)
        {
            self.update_occupancy();
        }
        lap(&mut timings.occupancy);
        let mut rng = Rng::new(cfg.seed, mix(self.step as u64 + 1));
        let batch_samples = self.batch_samples();
        let n_rays = (self.rays_per_batch as usize).clamp(64, 1 << 20);
        // Pixels uniformly over all training pixels (or, for a fraction of them, by the error
        // map), each at a random point of its area.
        let sizes: Vec<usize> = (0..data.len()).map(|i| data.size(i).0 * data.size(i).1).collect();
        let total: usize = sizes.iter().sum();
        if cfg.error_sampling > 0.0 {
            let dims: Vec<(usize, usize)> = (0..data.len()).map(|i| data.size(i)).collect();
            if !self.error_map.as_ref().is_some_and(|m| m.fits(&dims)) {
                self.error_map = Some(ErrorMap::new(&dims, 1.0));
            }
        }
        let mut rays = Vec::with_capacity(n_rays);
        let mut targets = Vec::with_capacity(n_rays);
        let mut picked = Vec::with_capacity(n_rays);
        let error_map = self.error_map.as_ref();
        let pick = |rng: &mut Rng| match error_map {
            Some(map) if rng.uniform() < cfg.error_sampling => map.sample(rng),
            _ => {
                let mut k = rng.below(total);
                let mut img = 0;
                while k >= sizes[img] {
                    k -= sizes[img];
                    img += 1;
                }
                (img, k)
            }
        };
        // Each pixel's rays (`train.pixel_rays` of them) are averaged before the loss.
        let per_pixel = cfg.pixel_rays;
        for _ in 0..(n_rays / per_pixel).max(1) {
            let (mut img, mut k) = pick(&mut rng);
            // A masked pixel teaches nothing: draw again, a bounded number of times so that
            // views masked almost entirely cannot stall the step (unmasked sets draw once).
            for _ in 0..MASK_REDRAWS {
                if data.keeps(img, k) {
                    break;
                }
                (img, k) = pick(&mut rng);
            }
            if !data.keeps(img, k) {
                continue;
            }
            let w = data.size(img).0;
            let (x, y) = (k % w, k / w);
            for j in 0..per_pixel {
                let ray = training_ray(&data.cameras[img], x, y, (j, per_pixel), cfg.pixel_jitter, &mut rng);
                rays.push((ray.origin, ray.direction));
                targets.push(data.pixels[img][k]);
            }
            picked.push((img, k));
        }
        let seed = mix(cfg.seed ^ mix(self.step as u64));
        let marcher = self.marcher().with_rays_per_pixel(per_pixel);
        let mut density_seconds = 0.0;
        // The density's activations at every sample evaluated, round after round, for the
        // field to go on from.
        let mut activations: Vec<Vec<f32>> = Vec::new();
        let (batch, kept) = march_to_termination(
            &rays,
            |i| Rng::new(seed, i as u64).uniform(),
            |i| targets[i][3] < TRANSPARENT,
            &marcher,
            &self.grid,
            |positions, footprints| {
                let start = Instant::now();
                let n = footprints.len();
                let pos = Tensor::<2>::from_data(TensorData::new(positions.to_vec(), [n, 3]), &self.device);
                let foot = Tensor::<1>::from_data(TensorData::new(footprints.to_vec(), [n]), &self.device);
                let (sigma, act) = self.model.density_saving(pos, foot, self.config.field);
                activations.push(act.into_data().try_into_vec::<f32>().expect("f32"));
                density_seconds += start.elapsed().as_secs_f64();
                sigma.into_data().try_into_vec::<f32>().expect("f32")
            },
            cfg.min_transmittance,
            batch_samples,
        );
        lap(&mut timings.march);
        timings.cut = density_seconds;
        timings.march -= density_seconds;
        let s = batch.samples.samples();
        // Adapt the ray count so the next batch fills the sample budget after the cut.
        let per_ray = s.max(1) as f32 / kept.max(1) as f32;
        let wanted = batch_samples as f32 / per_ray;
        self.rays_per_batch = 0.8 * self.rays_per_batch + 0.2 * wanted.min(4.0 * n_rays as f32);

        // Only whole pixels enter the loss: the rays of a pixel the cut split get no gradient.
        let pixels = kept / per_pixel;
        let kept_rays = pixels * per_pixel;
        // A random background under the squared error has a closed-form expectation: no
        // background is drawn and its noise leaves the gradient.
        let expected = cfg.background == Background::Random && cfg.loss == Loss::L2;
        let backgrounds: Vec<[f32; 3]> = (0..pixels)
            .map(|_| match cfg.background {
                _ if expected => [0.5; 3],
                Background::White => [1.0; 3],
                Background::Black => [0.0; 3],
                Background::Random => [rng.uniform(), rng.uniform(), rng.uniform()],
            })
            .collect();
        let target: Vec<f32> = backgrounds
            .iter()
            .enumerate()
            .flat_map(|(i, bg)| {
                let p = targets[i * per_pixel];
                (0..3).map(move |c| p[c] * p[3] + bg[c] * (1.0 - p[3]))
            })
            .collect();
        let bg: Vec<f32> =
            backgrounds.iter().flat_map(|b| std::iter::repeat_n(b, per_pixel)).flatten().copied().collect();
        let device = &self.device;
        let pos = Tensor::<2>::from_data(TensorData::new(batch.positions, [s, 3]), device);
        let foot = Tensor::<1>::from_data(TensorData::new(batch.footprints, [s]), device);
        let dir = Tensor::<2>::from_data(TensorData::new(batch.directions, [s, 3]), device);
        let width = self.config.field.layout().density_width();
        let density = Tensor::<2>::from_data(
            TensorData::new(gather_round_rows(&activations, width, &batch.evaluated), [s, width]),
            device,
        );
        let raw = self.model.field_from_density(pos, foot, dir, density, self.config.field);
        lap(&mut timings.field);
        // The distortion loss's mean over the rays, its distances in box diagonals.
        let (lo, hi) = self.grid.bounds();
        let distortion = cfg.distortion / (kept.max(1) as f32 * (hi - lo).length());
        let out = ops::composite(raw, Arc::new(batch.samples), cfg.min_transmittance, distortion);
        let rgb = out.clone().slice([0..kept_rays, 0..3]);
        let opacity = out.slice([0..kept_rays, 3..4]);
        let bg = Tensor::<2>::from_data(TensorData::new(bg, [kept_rays, 3]), device);
        let target = Tensor::<2>::from_data(TensorData::new(target, [pixels, 3]), device);
        let mut pred = rgb + (opacity.clone().neg() + 1.0) * bg;
        if per_pixel > 1 {
            pred = pred.reshape([pixels, per_pixel, 3]).mean_dim(1).reshape([pixels, 3]);
        }
        let diff = pred - target;
        let squared = if expected {
            let opacity = match per_pixel {
                1 => opacity,
                n => opacity.reshape([pixels, n, 1]).mean_dim(1).reshape([pixels, 1]),
            };
            let target_alpha: Vec<f32> = (0..pixels).map(|i| targets[i * per_pixel][3]).collect();
            let target_alpha = Tensor::<2>::from_data(TensorData::new(target_alpha, [pixels, 1]), device);
            loss::squared_error_over_random_background(diff.clone(), target_alpha - opacity)
        } else {
            diff.clone().square()
        };
        let mse = squared.clone().mean().into_data().try_to_vec::<f32>().expect("f32")[0];
        if let Some(map) = &mut self.error_map {
            let per_ray = squared.clone().sum_dim(1).into_data().try_to_vec::<f32>().expect("f32");
            for (&(img, k), &e) in picked.iter().zip(&per_ray) {
                map.record(map.block_of(img, k), e);
            }
            map.rebuild();
        }
        let loss = match cfg.loss {
            Loss::L2 => squared.mean(),
            Loss::Huber => loss::huber(diff),
        };
        let loss_value = loss.clone().into_data().try_to_vec::<f32>().expect("f32")[0];
        lap(&mut timings.composite);
        let grads = loss.backward();
        let grads = GradientsParams::from_grads(grads, &self.model);
        lap(&mut timings.backward);
        let lr = self.learning_rate();
        // Moved, not cloned, into the optimiser: a second owner of the table made its in-place
        // update copy all of it first.
        let model = std::mem::replace(&mut self.model, NerfModel::stand_in(&self.device));
        self.model = self.optimizer.step(lr, model, grads);
        // burn's ops run eagerly on the CPU backends; a read makes that explicit on others.
        let _ = self.model.table.val().slice([0..1, 0..1]).into_data();
        if ParameterAverage::active(cfg.average_window, self.progress) {
            if self.step.is_multiple_of(AVERAGE_EVERY) {
                self.update_average();
            }
        } else {
            // A run resumed with a larger budget is back before the average's start.
            self.average = None;
        }
        lap(&mut timings.optimizer);
        self.step += 1;
        StepStats { loss: loss_value, psnr: -10.0 * mse.max(1e-10).log10(), rays: kept, samples: s, timings }
    }

    /// Refreshes the occupancy grid: a fraction of the cells at random and up to as many
    /// occupied ones (all cells at the first update), one random point each.
    pub fn update_occupancy(&mut self) {
        let occ = self.config.occupancy;
        let cells = self.grid.cells();
        let mut rng = Rng::new(self.config.train.seed ^ 0x6f63_6375, mix(self.step as u64));
        let mut chosen: Vec<u32> = if self.step <= occ.warmup_steps {
            (0..cells as u32).collect()
        } else {
            let occupied = self.grid.occupied_cells();
            let m = ((cells as f32 * occ.sample_fraction) as usize).max(1);
            let mut v: Vec<u32> = (0..m).map(|_| rng.below(cells) as u32).collect();
            if !occupied.is_empty() {
                v.extend((0..m.min(occupied.len())).map(|_| occupied[rng.below(occupied.len())]));
            }
            v
        };
        chosen.par_sort_unstable();
        let res = self.grid.resolution() as f32;
        let positions: Vec<f32> = chosen
            .iter()
            .flat_map(|&c| {
                let [x, y, z] = self.grid.cell_coords(c as usize);
                let j = [rng.uniform(), rng.uniform(), rng.uniform()];
                [(x as f32 + j[0]) / res, (y as f32 + j[1]) / res, (z as f32 + j[2]) / res]
            })
            .collect();
        let n = chosen.len();
        let pos = Tensor::<2>::from_data(TensorData::new(positions, [n, 3]), &self.device);
        // The grid judges a cell by the density at the scale of its own width (a box of one
        // cell, in box units), not at one pixel's: views from near and far both cross it.
        let foot = Tensor::<1>::from_data(TensorData::new(vec![1.0 / (res * 12f32.sqrt()); n], [n]), &self.device);
        let sigma = self.model.density(pos, foot, self.config.field).into_data().try_to_vec::<f32>().expect("f32");
        let step = self.marcher().min_step();
        let obs: Vec<(u32, f32)> = chosen.iter().zip(&sigma).map(|(&c, &s)| (c, s * step)).collect();
        self.grid.update(&obs, occ.decay, occ.threshold);
    }

    /// Takes the current parameters into the running average (starting it if need be).
    fn update_average(&mut self) {
        let table = self.model.table.val().into_data().try_into_vec::<f32>().expect("f32");
        let mlp = self.model.mlp.val().into_data().try_into_vec::<f32>().expect("f32");
        match &mut self.average {
            Some(average) => average.update(&table, &mlp, self.progress, self.config.train.average_window),
            None => {
                self.average = Some(ParameterAverage::start(self.progress, table, mlp));
            }
        }
    }

    /// The model to evaluate and render, without autodiff tracking, on the inner device:
    /// the parameters' running average once there is one, else the parameters.
    pub fn eval_model(&self) -> NerfModel {
        crate::trained::eval_model(&self.config, &self.model, self.average.as_ref())
    }

    /// A renderer of `model` (from [`Self::eval_model`]) with this run's settings.
    pub fn renderer<'a>(&'a self, model: &'a NerfModel) -> ViewRenderer<'a> {
        crate::trained::renderer(&self.config, model, &self.grid, self.pixel_angle)
    }

    /// The device the model lives on.
    pub fn device(&self) -> &Device {
        &self.device
    }
}

#[cfg(test)]
mod tests;
