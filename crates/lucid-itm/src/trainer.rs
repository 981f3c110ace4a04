//! Training: Adam on the `α`-weighted squared error of log exposure,
//! `Σ α·(ln(H + ε) − ln(T + ε))² / Σ α`, over patches drawn mostly where the input clips.

use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use lucid_scene::sampling::Rng;

use crate::config::ItmConfig;
use crate::data::{Batch, ItmImage, sample_batch};
use crate::model::ItmNet;

/// Offset inside the logarithms: 10⁻³ of the clipping exposure.
pub const LOG_EPSILON: f32 = 1e-3;

/// A network being trained.
pub struct ItmTrainer {
    /// Configuration.
    pub config: ItmConfig,
    /// The network (on the autodiff device).
    pub net: ItmNet,
    /// Adam.
    pub optimizer: ModuleOptimizer,
    /// Steps taken.
    pub step: usize,
    /// Fraction of the run's budget used before the next step, in [0, 1] (set by the training
    /// loop, [`lucid_burn::run`]).
    pub progress: f64,
    /// The device.
    pub device: Device,
}

fn tensor(values: Vec<f32>, shape: [usize; 4], device: &Device) -> Tensor<4> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

/// The loss of a prediction against the truth under the mask (all `N×C×H×W`, mask `N×1×H×W`).
pub fn masked_log_loss(pred: Tensor<4>, truth: Tensor<4>, mask: Tensor<4>) -> Tensor<1> {
    let d = (pred + LOG_EPSILON).log() - (truth + LOG_EPSILON).log();
    let weighted = d.square() * mask.clone();
    weighted.sum() / (mask.sum() * 3.0 + 1e-6)
}

impl ItmTrainer {
    /// A fresh network.
    pub fn new(config: ItmConfig, device: Device) -> Self {
        // burn draws the initial weights from the device's generator: seed it so that the same
        // configuration gives the same network.
        device.seed(config.train.seed);
        let net = ItmNet::new(config.model.width, &device);
        let optimizer = AdamConfig::new().init();
        Self { config, net, optimizer, step: 0, progress: 0.0, device }
    }

    /// From saved parts.
    pub fn from_parts(config: ItmConfig, net: ItmNet, optimizer: ModuleOptimizer, step: usize, device: Device) -> Self {
        Self { config, net, optimizer, step, progress: 0.0, device }
    }

    /// Learning rate at the current schedule position: exponential decay by 10× over the run.
    pub fn learning_rate(&self) -> f64 {
        self.config.train.learning_rate * 0.1f64.powf(self.progress.clamp(0.0, 1.0))
    }

    /// The batch of a step: drawn from a generator seeded by the seed and the step, so a
    /// resumed run draws what the uninterrupted one would have.
    pub fn batch(&self, images: &[ItmImage]) -> Batch {
        let t = &self.config.train;
        let mut rng = Rng::new(t.seed, self.step as u64);
        sample_batch(images, t.batch, t.patch, t.clipped_patches, &mut rng)
    }

    /// One optimiser step; returns the loss.
    pub fn step(&mut self, images: &[ItmImage]) -> f32 {
        let b = self.batch(images);
        let (n, p) = (b.n, b.patch);
        let dev = &self.device;
        let display = tensor(b.display, [n, 3, p, p], dev);
        let linear = tensor(b.linear, [n, 3, p, p], dev);
        let mask = tensor(b.mask, [n, 1, p, p], dev);
        let truth = tensor(b.truth, [n, 3, p, p], dev);
        let pred = self.net.predict(display, linear, mask.clone());
        let loss = masked_log_loss(pred, truth, mask);
        let value = loss.clone().into_data().try_to_vec::<f32>().map(|v| v[0]).unwrap_or(f32::NAN);
        let grads = GradientsParams::from_grads(loss.backward(), &self.net);
        let lr = self.learning_rate();
        self.net = self.optimizer.step(lr, self.net.clone(), grads);
        self.step += 1;
        value
    }
}
