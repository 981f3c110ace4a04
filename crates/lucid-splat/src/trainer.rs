//! The 3DGS training loop: one training view per step, rendered by the splat op, scored by
//! `(1 − λ)·L1 + λ·D-SSIM` against the view composited over the step's background, Adam with a
//! learning rate per parameter kind (positions decaying exponentially), SH degree raised
//! every `sh_degree_every` steps, densification and opacity resets on schedule.
//!
//! The schedule is the reference's, in steps of a `train.steps` run. Under a wall-clock budget
//! that ends the run first, its phases (SH degrees, densification window, opacity resets,
//! position learning rate) are stretched to the fraction of the budget used, so a short run
//! still goes through all of them; densification itself still waits `densify.every` real
//! steps, so its gradient statistics always cover as many views.

use std::time::Instant;

use burn::tensor::{Device, Tensor};
use glam::Vec3;
use lucid_scene::Dataset;
use lucid_scene::dataset::images::{ImageSet, ViewInfo, scene_box};
use lucid_scene::sampling::{Rng, mix};

use crate::camera::SplatCamera;
use crate::cloud::SplatCloud;
use crate::config::{Background, SplatConfig};
use crate::densify::{DensifyReport, DensifyStats, SceneExtent, densify_and_prune, reset_opacity};
use crate::loss_op::{LossArgs, image_loss};
use crate::model::{SplatModel, SplatOptimizer};
use crate::ops::{SplatRenderArgs, render_splats};
use crate::project::RenderSettings;

/// What one step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepStats {
    /// The loss.
    pub loss: f32,
    /// PSNR of the rendered view against its target.
    pub psnr: f32,
    /// Gaussians after the step.
    pub gaussians: usize,
    /// What densification did at this step, if it ran.
    pub densified: Option<DensifyReport>,
    /// Seconds in the forward render, the loss and backward, the optimiser, densification.
    pub timings: [f64; 4],
}

/// A splat cloud in training with everything needed to continue.
pub struct SplatTrainer {
    /// The configuration.
    pub config: SplatConfig,
    /// The parameters.
    pub model: SplatModel,
    /// Adam's state.
    pub optimizer: SplatOptimizer,
    /// Densification statistics since the last densification.
    pub stats: DensifyStats,
    /// Steps taken.
    pub step: usize,
    /// Scene extent: 1.1 × the largest distance of a training camera from their centroid
    /// (the reference's `cameras_extent`); learning rates and size limits scale with it.
    pub extent: f32,
    /// How the training cameras saw the scene.
    pub view: ViewInfo,
    /// Centre of the scene (the target of orbit paths).
    pub centre: Vec3,
    /// Fraction of the run's budget used before the next step, in [0, 1] (set by the training
    /// loop, [`lucid_burn::run`]).
    pub progress: f64,
    /// Position in the reference schedule (the step count, or further on under a time
    /// budget).
    pub schedule: usize,
    /// Steps since the last densification.
    pub since_densify: usize,
    device: Device,
}

/// The SH degree in use at position `schedule` of the reference schedule.
pub fn sh_degree(config: &SplatConfig, schedule: usize) -> usize {
    (schedule / config.train.sh_degree_every).min(config.train.sh_degree)
}

/// Render settings for evaluation (the fixed background, the SH degree at `schedule`) of a
/// cloud trained with `config` in a scene of `extent`.
pub fn eval_settings(config: &SplatConfig, extent: f32, schedule: usize) -> RenderSettings {
    let background = match config.render.eval_background {
        Background::Black => [0.0; 3],
        _ => [1.0; 3],
    };
    render_settings(config, extent, schedule, background)
}

/// Render settings of a cloud trained with `config` in a scene of `extent`, at `schedule`, over
/// `background`.
fn render_settings(config: &SplatConfig, extent: f32, schedule: usize, background: [f32; 3]) -> RenderSettings {
    RenderSettings {
        near: config.render.near * extent,
        low_pass: config.render.low_pass,
        sh_degree: sh_degree(config, schedule),
        background,
        ..RenderSettings::default()
    }
}

/// The reference's scene extent of a set of cameras.
pub fn camera_extent(data: &ImageSet) -> f32 {
    let centres: Vec<Vec3> = data.cameras.iter().map(|c| c.position()).collect();
    let mean = centres.iter().copied().sum::<Vec3>() / centres.len().max(1) as f32;
    let radius = centres.iter().map(|c| (*c - mean).length()).fold(0.0f32, f32::max);
    1.1 * radius.max(1e-3)
}

/// The initial cloud for `dataset`: a capture's SfM points or the set's `points3d.ply` if
/// present and enabled, otherwise random points in the scene box; where the training images
/// `data` have no transparent background, also a far sphere of background points
/// ([`crate::background`]).
pub fn initial_cloud(config: &SplatConfig, dataset: &Dataset, data: &ImageSet) -> Result<SplatCloud, String> {
    let ply = dataset.root.join("points3d.ply");
    let (lo, hi) = scene_box(dataset);
    let mut points: Vec<(Vec3, [f32; 3])> = if config.init.use_points && !dataset.points.is_empty() {
        dataset.points.iter().map(|p| (p.position, p.colour.map(|c| f32::from(c) / 255.0))).collect()
    } else if config.init.use_points && ply.exists() {
        lucid_scene::point_cloud::read_point_cloud(&ply).map_err(|e| e.to_string())?
    } else {
        SplatCloud::random_points_in_box(config.init.random_points, lo, hi, config.train.seed)
    };
    if config.init.background_points > 0 && data.is_opaque() {
        // Around the box's centre, the scene's centre for every trainer (a capture's origin).
        let centre = 0.5 * (lo + hi);
        points.extend(crate::background::background_points(data, centre, config.init.background_points));
    }
    let mut cloud = SplatCloud::from_points(&points);
    let o = crate::cloud::logit(config.init.opacity);
    cloud.opacities.iter_mut().for_each(|v| *v = o);
    Ok(cloud)
}

impl SplatTrainer {
    /// A trainer for `data` (training images) of a scene around `centre`, starting from
    /// `cloud`.
    pub fn new(config: SplatConfig, cloud: &SplatCloud, data: &ImageSet, centre: Vec3, device: Device) -> Self {
        let extent = camera_extent(data);
        let t = &config.train;
        let optimizer = SplatOptimizer::new(t.beta1, t.beta2, t.epsilon);
        Self {
            model: SplatModel::from_cloud(cloud, &device),
            stats: DensifyStats::new(cloud.len()),
            optimizer,
            config,
            step: 0,
            extent,
            view: ViewInfo::from_cameras(&data.cameras, centre),
            centre,
            progress: 0.0,
            schedule: 0,
            since_densify: 0,
            device,
        }
    }

    /// A trainer for `dataset`, trained on `data` (its training images) from `cloud`: the
    /// scene box's centre is the target of novel-view paths, and a capture's normalisation is
    /// kept so that exports and renders come out in the dataset's own frame.
    pub fn for_dataset(
        config: SplatConfig,
        cloud: &SplatCloud,
        dataset: &Dataset,
        data: &ImageSet,
        device: Device,
    ) -> Self {
        let (lo, hi) = scene_box(dataset);
        let mut trainer = Self::new(config, cloud, data, (lo + hi) * 0.5, device);
        trainer.view.frame = dataset.normalisation;
        trainer
    }

    /// Rebuilds a trainer from saved parts.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        config: SplatConfig,
        model: SplatModel,
        optimizer: SplatOptimizer,
        step: usize,
        extent: f32,
        view: ViewInfo,
        centre: Vec3,
        device: Device,
    ) -> Self {
        let stats = DensifyStats::new(model.len());
        Self {
            config,
            model,
            optimizer,
            stats,
            step,
            extent,
            view,
            centre,
            progress: 0.0,
            schedule: step,
            since_densify: 0,
            device,
        }
    }

    /// Progress through the run's budget, in [0, 1].
    pub fn progress(&self) -> f64 {
        self.progress.clamp(0.0, 1.0)
    }

    /// The SH degree in use at this step.
    pub fn sh_degree(&self) -> usize {
        sh_degree(&self.config, self.schedule)
    }

    /// Render settings for evaluation (fixed background, current SH degree).
    pub fn eval_settings(&self) -> RenderSettings {
        eval_settings(&self.config, self.extent, self.schedule)
    }

    fn settings(&self, background: [f32; 3]) -> RenderSettings {
        render_settings(&self.config, self.extent, self.schedule, background)
    }

    /// Learning rates in the model's kind order: positions decay exponentially from
    /// `position_lr` to `position_lr_final` (both × extent), the rest are constant.
    pub fn learning_rates(&self) -> [f64; 6] {
        let t = &self.config.train;
        let p = self.progress();
        let position = (t.position_lr.ln() * (1.0 - p) + t.position_lr_final.ln() * p).exp() * self.extent as f64;
        [position, t.scale_lr, t.rotation_lr, t.opacity_lr, t.sh_dc_lr, t.sh_rest_lr]
    }

    /// One step on a training view of `data`.
    pub fn step(&mut self, data: &ImageSet) -> StepStats {
        let mut timings = [0.0; 4];
        let mut clock = Instant::now();
        let mut lap = |slot: &mut f64| {
            let now = Instant::now();
            *slot = (now - clock).as_secs_f64();
            clock = now;
        };
        let cfg = self.config.train;
        // Views in a fresh random order every epoch (as the reference's shuffled stack).
        let epoch = self.step / data.len();
        let mut order: Vec<usize> = (0..data.len()).collect();
        let mut rng = Rng::new(cfg.seed, mix(0x5e1a7 ^ epoch as u64));
        for i in (1..order.len()).rev() {
            order.swap(i, rng.below(i + 1));
        }
        let view = order[self.step % data.len()];
        let mut rng = Rng::new(cfg.seed, mix(self.step as u64 + 1));
        let background = match self.config.render.background {
            Background::White => [1.0; 3],
            Background::Black => [0.0; 3],
            Background::Random => [rng.uniform(), rng.uniform(), rng.uniform()],
        };
        let camera = SplatCamera::from_pinhole(&data.cameras[view]);
        let (w, h) = (camera.width as usize, camera.height as usize);
        let args = SplatRenderArgs::new(camera, self.settings(background));
        let n = self.model.len();
        let means_2d = Tensor::<2>::zeros([n, 2], &self.device).require_grad();
        let image = render_splats(&self.model.tensors(), means_2d.clone(), args.clone());
        lap(&mut timings[0]);

        let target: Vec<f32> = data.pixels[view]
            .iter()
            .flat_map(|p| (0..3).map(move |c| p[c] * p[3] + background[c] * (1.0 - p[3])))
            .collect();
        // Masked pixels are blacked out in both images: no error, so no gradient, there.
        let mask = data.mask_weights(view);
        let loss_args = LossArgs::new(target, mask, w, h, cfg.ssim_weight);
        let loss = image_loss(image, loss_args.clone());
        let mut grads = loss.backward();
        let mse = loss_args.mse();
        let loss = loss.into_data().try_to_vec::<f32>().expect("f32")[0];
        let g2d = means_2d.grad(&grads).map(lucid_burn::to_host_tensor).unwrap_or_else(|| vec![0.0; 2 * n]);
        let state = args.take_state();
        self.stats.record(&g2d, state.projected.iter().map(|p| p.radius));
        lap(&mut timings[1]);

        let lrs = self.learning_rates();
        let model = std::mem::replace(&mut self.model, SplatModel::from_cloud(&SplatCloud::default(), &self.device));
        self.model = self.optimizer.step(model, &mut grads, lrs);
        lap(&mut timings[2]);

        self.step += 1;
        self.since_densify += 1;
        let before = self.schedule;
        // The reference schedule's position after this step: under a step budget the step
        // count, under a time budget stretched over the seconds (and at least one further
        // per step). Rounded down, the position never runs ahead of the budget used.
        let position = (self.progress() * cfg.steps as f64) as usize;
        self.schedule = position.max(before + 1);
        let d = self.config.densify;
        let mut densified = None;
        let in_window = self.schedule < d.until;
        if self.since_densify >= d.every {
            if in_window && self.schedule > d.from {
                densified = Some(self.densify(&mut rng));
            }
            self.since_densify = 0;
        }
        if in_window && self.schedule / d.opacity_reset_every > before / d.opacity_reset_every {
            self.edit_on_host(reset_opacity);
        }
        lap(&mut timings[3]);
        StepStats { loss, psnr: -10.0 * mse.max(1e-10).log10(), gaussians: self.model.len(), densified, timings }
    }

    fn densify(&mut self, rng: &mut Rng) -> DensifyReport {
        let stats = std::mem::take(&mut self.stats);
        let prune_oversized = self.schedule > self.config.densify.opacity_reset_every;
        let (config, extent, centre) = (self.config.densify, self.extent, self.centre);
        let report = self.edit_on_host(|cloud, moments| {
            densify_and_prune(cloud, moments, &stats, &config, SceneExtent { extent, centre }, prune_oversized, rng)
        });
        self.stats = DensifyStats::new(self.model.len());
        report
    }

    /// Runs `edit` on the host copy of the parameters and Adam's moments, then uploads both.
    fn edit_on_host<R>(
        &mut self,
        edit: impl FnOnce(&mut SplatCloud, &mut [Option<crate::model::HostMoments>; 6]) -> R,
    ) -> R {
        let mut cloud = self.model.to_cloud();
        let mut moments = self.optimizer.to_host();
        let out = edit(&mut cloud, &mut moments);
        // The optimiser keys its state by parameter kind, not by burn's parameter ids, so fresh
        // parameters carry on with the edited moments.
        self.model = SplatModel::from_cloud(&cloud, &self.device);
        self.optimizer.set_from_host(moments, &self.device);
        out
    }
}
