//! Training in two stages.
//!
//! 1. Geometry: 3DGS ([`lucid_splat::trainer::SplatTrainer`], unchanged) on each view under
//!    uniform white light, made from its OLAT frames ([`OlatSet::uniformly_lit`]). Shadows
//!    and highlights move with the light, so no single OLAT frame is a consistent target;
//!    their sum is.
//! 2. Head: the geometry frozen, the per-Gaussian features and the decoder learn the OLAT
//!    frames themselves, one view under `lights_per_step` lights per step. The targets are
//!    Monte Carlo renders whose noise is strongly skewed where light arrives indirectly (a
//!    few bright paths), so the loss must seek the mean, not the median: an L1 loss on gamma
//!    values learned dim frames up to 75 % too dark, which environment integration summed
//!    into a uniform 15–20 % deficit. The default is the squared error in gamma space
//!    linearised at the prediction, `(p − t)²·g'(sg(p))²`: mean-seeking like the relative L2
//!    of Noise2Noise (Lehtinen et al. 2018), `(p − t)²/(sg(p) + ε)²`, but weighted like the
//!    sRGB-space error PSNR measures, where the relative L2 over-weights dark pixels (its
//!    renders came out 5–18 % too bright). Measured on a 40-view, 64-light, 64 px studio set
//!    (6000 steps, 6 held-out views): held-out environments 26.4 / 27.7 / 28.6 dB and single
//!    lights 28.3 / 26.2 / 25.6 dB for gamma L1 / relative L2 / gamma L2 (single OLAT truths
//!    are noisy themselves, and PSNR against skewed noise favours the median).

use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use lucid_scene::sampling::{Rng, mix};
use lucid_splat::cloud::SplatCloud;
use lucid_splat::project::RenderSettings;

use crate::config::{LossKind, RelightConfig};
use crate::data::OlatSet;
use crate::head::RelightHead;
use crate::render::Geometry;

/// Offset inside the loss's gamma and the relative L2's denominator: keeps both finite at
/// black.
pub const LOSS_EPSILON: f32 = 0.01;

/// What one step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct HeadStepStats {
    /// The loss.
    pub loss: f32,
    /// PSNR of the step's renders in the loss's gamma space.
    pub psnr: f32,
}

/// The head in training over a frozen geometry.
pub struct RelightTrainer {
    /// The configuration.
    pub config: RelightConfig,
    /// The geometry stage's result.
    pub geometry: Geometry,
    /// The head (on the autodiff device).
    pub head: RelightHead,
    /// Adam.
    pub optimizer: ModuleOptimizer,
    /// Head steps taken.
    pub step: usize,
    /// Fraction of a wall-clock budget used so far (set by time-limited loops).
    pub progress: f64,
    device: Device,
}

fn scalar(t: Tensor<1>) -> f32 {
    t.into_data().try_to_vec::<f32>().map(|v| v[0]).unwrap_or(f32::NAN)
}

/// `(x + ε)^(1/2.2)`.
fn gamma(x: Tensor<3>) -> Tensor<3> {
    (x + LOSS_EPSILON).powf_scalar(1.0 / 2.2)
}

/// The loss of a render against its target (both linear, premultiplied).
fn loss(kind: LossKind, render: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    match kind {
        LossKind::RelativeL2 => {
            let scale = (render.clone().detach() + LOSS_EPSILON).square();
            ((render - target).square() / scale).mean()
        }
        LossKind::GammaL2 => {
            // g'(p)² for g(x) = (x + ε)^(1/2.2): the squared error in gamma space to first
            // order, with the weight taken at the prediction so that the minimum is the
            // targets' mean.
            let weight = (render.clone().detach() + LOSS_EPSILON).powf_scalar(2.0 / 2.2 - 2.0);
            ((render - target).square() * weight).mean()
        }
        LossKind::GammaL1 => (gamma(render) - gamma(target)).abs().mean(),
    }
}

impl RelightTrainer {
    /// A fresh head on `cloud`, rendered with `settings`.
    pub fn new(config: RelightConfig, cloud: SplatCloud, settings: RenderSettings, device: Device) -> Self {
        // burn draws the initial weights from the device's generator.
        device.seed(config.train.seed);
        let head = RelightHead::new(&config, cloud.len(), &device);
        let geometry = Geometry::new(cloud, settings, &device);
        Self::from_parts(config, geometry, head, AdamConfig::new().init(), 0, device)
    }

    /// From saved parts.
    pub fn from_parts(
        config: RelightConfig,
        geometry: Geometry,
        head: RelightHead,
        optimizer: ModuleOptimizer,
        step: usize,
        device: Device,
    ) -> Self {
        Self { config, geometry, head, optimizer, step, progress: 0.0, device }
    }

    /// Progress through the run's budget, in [0, 1].
    pub fn progress(&self) -> f64 {
        self.progress.clamp(0.0, 1.0)
    }

    /// The decoder's learning rate now: exponential decay by 10× over the run.
    pub fn learning_rate(&self) -> f64 {
        self.config.train.learning_rate * 0.1f64.powf(self.progress())
    }

    /// One optimiser step: a view drawn at random and `lights_per_step` of its lights, from a
    /// generator seeded by the seed and the step (a resumed run draws what an uninterrupted
    /// one would have).
    pub fn step(&mut self, data: &OlatSet) -> HeadStepStats {
        let t = self.config.train;
        let mut rng = Rng::new(t.seed, mix(0x4e11 ^ self.step as u64));
        let view = &data.views[rng.below(data.views.len())];
        let (w, h) = (view.camera.intrinsics.width as usize, view.camera.intrinsics.height as usize);
        let dirs = self.geometry.view_directions(&view.camera);
        let encode = |d: &[glam::Vec3], degree| crate::head::encoding_tensor(d, degree, &self.device);
        let free = self.head.light_free(encode(&dirs, self.config.head.view_degree), self.config.feature_scale());
        let mut total = Tensor::<1>::zeros([1], &self.device);
        let mut squared = 0.0f64;
        for _ in 0..t.lights_per_step {
            let lit = &view.lights[rng.below(view.lights.len())];
            let colours = self.head.decode(free.clone(), encode(&[lit.direction], self.config.head.light_degree));
            let image = self.geometry.render(colours, &view.camera).slice([0..h, 0..w, 0..3]);
            let target = Tensor::<3>::from_data(TensorData::new(lit.rgb.clone(), [h, w, 3]), &self.device);
            squared += scalar((gamma(image.clone().detach()) - gamma(target.clone())).square().mean()) as f64;
            total = total + loss(t.loss, image, target);
        }
        let total = total / t.lights_per_step as f32;
        let value = scalar(total.clone());
        let grads = GradientsParams::from_grads(total.backward(), &self.head);
        let lr = self.learning_rate();
        self.head = self.optimizer.step(lr, self.head.clone(), grads);
        self.step += 1;
        let mse = squared / t.lights_per_step as f64;
        HeadStepStats { loss: value, psnr: (-10.0 * mse.max(1e-12).log10()) as f32 }
    }

    /// The device the head trains on.
    pub fn device(&self) -> &Device {
        &self.device
    }
}
