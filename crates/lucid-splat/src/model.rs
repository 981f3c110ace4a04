//! The splat cloud as a burn module, and its optimiser: one [`FusedAdam`] (burn's `Optimizer`
//! trait) per parameter kind with its own learning rate, whose per-Gaussian moments
//! densification can gather, extend and reset (burn's `ModuleOptimizer` keeps its state
//! private, so the states are held here).

use burn::module::{Module, Param};
use burn::optim::{AdamState, AdaptiveMomentumState, Optimizer};
use burn::tensor::{Device, Gradients, Tensor, TensorData};
use lucid_burn::{FusedAdam, to_host_tensor};

use crate::cloud::SplatCloud;
use crate::ops::SplatTensors;

/// Values per Gaussian of each parameter kind, in [`KINDS`] order.
pub const WIDTHS: [usize; 6] = [3, 3, 4, 1, 3, 45];
/// The parameter kinds.
pub const KINDS: [&str; 6] = ["means", "log_scales", "rotations", "opacities", "sh_dc", "sh_rest"];

/// A splat cloud's parameters.
#[derive(Module, Debug)]
pub struct SplatModel {
    /// `N×3` centres.
    pub means: Param<Tensor<2>>,
    /// `N×3` log standard deviations.
    pub log_scales: Param<Tensor<2>>,
    /// `N×4` quaternions `(w, x, y, z)`.
    pub rotations: Param<Tensor<2>>,
    /// `N×1` opacity logits.
    pub opacities: Param<Tensor<2>>,
    /// `N×3` DC SH coefficients.
    pub sh_dc: Param<Tensor<2>>,
    /// `N×45` rest SH coefficients.
    pub sh_rest: Param<Tensor<2>>,
}

fn tensor(values: Vec<f32>, width: usize, device: &Device) -> Tensor<2> {
    let n = values.len() / width;
    Tensor::from_data(TensorData::new(values, [n, width]), device)
}

impl SplatModel {
    /// Parameters from a host cloud.
    pub fn from_cloud(cloud: &SplatCloud, device: &Device) -> Self {
        let [a, b, c, d, e, f] = cloud_fields(cloud).map(|v| v.clone());
        let p = |v: Vec<f32>, w: usize| Param::from_tensor(tensor(v, w, device));
        Self {
            means: p(a, 3),
            log_scales: p(b, 3),
            rotations: p(c, 4),
            opacities: p(d, 1),
            sh_dc: p(e, 3),
            sh_rest: p(f, 45),
        }
    }

    /// The parameters on the host.
    pub fn to_cloud(&self) -> SplatCloud {
        let [a, b, c, d, e, f] = self.values().map(to_host_tensor);
        SplatCloud { means: a, log_scales: b, rotations: c, opacities: d, sh_dc: e, sh_rest: f }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.opacities.val().dims()[0]
    }

    /// Whether the cloud is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The current values, in [`KINDS`] order.
    pub fn values(&self) -> [Tensor<2>; 6] {
        [
            self.means.val(),
            self.log_scales.val(),
            self.rotations.val(),
            self.opacities.val(),
            self.sh_dc.val(),
            self.sh_rest.val(),
        ]
    }

    /// The values for the render op.
    pub fn tensors(&self) -> SplatTensors {
        let [means, log_scales, rotations, opacities, sh_dc, sh_rest] = self.values();
        SplatTensors { means, log_scales, rotations, opacities, sh_dc, sh_rest }
    }
}

/// The six arrays of a cloud in [`KINDS`] order.
pub fn cloud_fields(c: &SplatCloud) -> [&Vec<f32>; 6] {
    [&c.means, &c.log_scales, &c.rotations, &c.opacities, &c.sh_dc, &c.sh_rest]
}

/// The six arrays of a cloud in [`KINDS`] order, mutable.
pub fn cloud_fields_mut(c: &mut SplatCloud) -> [&mut Vec<f32>; 6] {
    [&mut c.means, &mut c.log_scales, &mut c.rotations, &mut c.opacities, &mut c.sh_dc, &mut c.sh_rest]
}

/// Adam's moments of one parameter kind on the host (`time` steps taken).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HostMoments {
    /// Steps taken.
    pub time: usize,
    /// First moments, row-major like the parameter.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
}

/// Adam over the splat parameters, a learning rate per kind.
#[derive(Clone)]
pub struct SplatOptimizer {
    adam: FusedAdam,
    states: [Option<AdamState<2>>; 6],
}

impl SplatOptimizer {
    /// Fresh state.
    pub fn new(beta1: f32, beta2: f32, epsilon: f32) -> Self {
        Self {
            adam: FusedAdam { beta1, beta2, epsilon, weight_decay: 0.0, lr_scale: 1.0, segments: None },
            states: Default::default(),
        }
    }

    /// One step of every parameter kind that has a gradient in `grads`, with learning rates
    /// `lrs` (in [`KINDS`] order).
    pub fn step(&mut self, model: SplatModel, grads: &mut Gradients, lrs: [f64; 6]) -> SplatModel {
        let params = [model.means, model.log_scales, model.rotations, model.opacities, model.sh_dc, model.sh_rest];
        let mut out = Vec::with_capacity(6);
        for (k, param) in params.into_iter().enumerate() {
            // Taken out of the parameter rather than cloned from it: a second owner of the
            // storage made the in-place update copy the whole tensor first.
            let (id, value, _) = param.consume();
            let Some(grad) = value.grad_remove(grads) else {
                out.push(Param::initialized(id, value));
                continue;
            };
            let (next, state) = self.adam.step(lrs[k], value.inner(), grad, self.states[k].take());
            self.states[k] = state;
            out.push(Param::initialized(id, Tensor::from_inner(next).require_grad()));
        }
        let [means, log_scales, rotations, opacities, sh_dc, sh_rest]: [Param<Tensor<2>>; 6] =
            out.try_into().expect("six parameter kinds");
        SplatModel { means, log_scales, rotations, opacities, sh_dc, sh_rest }
    }

    /// The moments on the host (`None` for kinds not stepped yet).
    pub fn to_host(&self) -> [Option<HostMoments>; 6] {
        self.states.clone().map(|s| {
            s.map(|s| HostMoments {
                time: s.momentum.time,
                m: to_host_tensor(s.momentum.moment_1),
                v: to_host_tensor(s.momentum.moment_2),
            })
        })
    }

    /// Replaces the moments (after densification edited them on the host).
    pub fn set_from_host(&mut self, moments: [Option<HostMoments>; 6], device: &Device) {
        for (k, m) in moments.into_iter().enumerate() {
            self.states[k] = m.map(|h| {
                let (m1, m2) = (tensor(h.m, WIDTHS[k], device), tensor(h.v, WIDTHS[k], device));
                AdamState::new(AdaptiveMomentumState::new(h.time, m1, m2))
            });
        }
    }
}
