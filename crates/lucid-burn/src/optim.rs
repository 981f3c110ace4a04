//! Adam as one fused pass per parameter, plugged into burn's optimiser framework.
//!
//! burn's `Adam` is eight tensor operations per parameter (each a full pass over memory and a
//! fresh allocation); on a 4-million-entry hash table that was a fifth of a NeRF step on the
//! CPU. [`FusedAdam`] implements burn's [`Optimizer`] trait with the same update, the same
//! state type ([`AdamState`], so burn's `ModuleOptimizer` records and reloads it as before)
//! and the same arithmetic, but runs the whole update as one backend operation: on flex one
//! parallel pass that rewrites the parameter and both moments in place. Other backends use a
//! host round trip in the default body until they get a kernel of their own.

#![cfg_attr(feature = "ndarray", allow(deprecated))]

use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::{Autodiff, Backend, Dispatch, TensorMetadata, backend_extension, tensor::FloatTensor};
use burn::optim::{AdamState, AdaptiveMomentumState, LearningRate, Optimizer};
use burn::tensor::{Device, Tensor, TensorData};
use std::sync::Arc;

use rayon::prelude::*;

use crate::{constant, to_host};

/// Learning-rate factors over consecutive stretches of a parameter's elements, as `(end,
/// factor)` pairs in order, the last `end` the parameter's length: e.g. one factor per level of
/// a hash table.
pub type RateSegments = Arc<[(usize, f32)]>;

/// The scalars of one Adam step.
#[derive(Clone, Debug, PartialEq)]
pub struct AdamStep {
    /// Learning rate.
    pub lr: f32,
    /// First-moment decay.
    pub beta1: f32,
    /// Second-moment decay.
    pub beta2: f32,
    /// Denominator guard (scaled like burn's by the second bias correction).
    pub epsilon: f32,
    /// L2 penalty added to the gradient (burn's `WeightDecay`), 0 for none.
    pub weight_decay: f32,
    /// 1-based step count of this parameter, for the bias corrections.
    pub time: usize,
    /// Factors on `lr` per stretch of the elements (`None`: `lr` for all).
    pub segments: Option<RateSegments>,
}

/// Elements per parallel task: large enough to amortise scheduling, small enough to balance.
const CHUNK: usize = 1 << 14;

/// Updates `param`, `m` and `v` in place with gradient `grad` (all the same length).
pub fn adam_update_slices(param: &mut [f32], grad: &[f32], m: &mut [f32], v: &mut [f32], s: AdamStep) {
    assert!(param.len() == grad.len() && m.len() == grad.len() && v.len() == grad.len());
    let Some(segments) = &s.segments else {
        return update_stretch(param, grad, m, v, &s, 1.0);
    };
    assert_eq!(
        segments.last().map(|&(end, _)| end),
        Some(param.len()),
        "learning-rate segments must cover the parameter"
    );
    let mut start = 0;
    for &(end, factor) in segments.iter() {
        let r = start..end;
        update_stretch(&mut param[r.clone()], &grad[r.clone()], &mut m[r.clone()], &mut v[r], &s, factor);
        start = end;
    }
}

/// [`adam_update_slices`] over one stretch, with `lr·factor`.
fn update_stretch(param: &mut [f32], grad: &[f32], m: &mut [f32], v: &mut [f32], s: &AdamStep, factor: f32) {
    let t = s.time as i32;
    let bc2_sqrt = (1.0 - s.beta2.powi(t)).sqrt();
    let step = s.lr * factor * bc2_sqrt / (1.0 - s.beta1.powi(t));
    let eps = s.epsilon * bc2_sqrt;
    let (b1, b2, wd) = (s.beta1, s.beta2, s.weight_decay);
    param
        .par_chunks_mut(CHUNK)
        .zip(grad.par_chunks(CHUNK))
        .zip(m.par_chunks_mut(CHUNK).zip(v.par_chunks_mut(CHUNK)))
        .for_each(|((p, g), (m, v))| {
            for i in 0..p.len() {
                let g = g[i] + wd * p[i];
                m[i] = b1 * m[i] + (1.0 - b1) * g;
                v[i] = b2 * v[i] + (1.0 - b2) * g * g;
                p[i] -= step * m[i] / (v[i].sqrt() + eps);
            }
        });
}

/// The Adam update as a backend operation.
#[backend_extension(
    Flex: cfg(feature = "flex"),
    NdArray: cfg(feature = "ndarray"),
    Cube: cfg(feature = "wgpu"),
    Autodiff,
)]
pub trait AdamOps: Backend {
    /// `(param, m, v)` after one step with gradient `grad`.
    fn adam_update(
        param: FloatTensor<Self>,
        grad: FloatTensor<Self>,
        m: FloatTensor<Self>,
        v: FloatTensor<Self>,
        step: AdamStep,
    ) -> (FloatTensor<Self>, FloatTensor<Self>, FloatTensor<Self>) {
        let device = param.device();
        let shape = param.shape();
        let (mut p, g, mut m, mut v) =
            (to_host::<Self>(param), to_host::<Self>(grad), to_host::<Self>(m), to_host::<Self>(v));
        adam_update_slices(&mut p, &g, &mut m, &mut v, step);
        let up = |x: Vec<f32>| Self::float_from_data(TensorData::new(x, shape.clone()), &device);
        (up(p), up(m), up(v))
    }
}

#[cfg(feature = "flex")]
mod flex_impl {
    use burn::backend::Flex;
    use burn::backend::flex::FlexTensor;

    use super::{AdamOps, AdamStep, adam_update_slices};
    use crate::values;

    /// A contiguous tensor this update may write: shared or strided storage is copied first.
    fn owned(t: FlexTensor) -> FlexTensor {
        let n = t.layout().num_elements();
        if t.layout().contiguous_offsets() == Some((0, n)) && t.bytes().len() == n * size_of::<f32>() {
            t
        } else {
            t.to_contiguous()
        }
    }

    impl AdamOps for Flex {
        fn adam_update(
            param: FlexTensor,
            grad: FlexTensor,
            m: FlexTensor,
            v: FlexTensor,
            step: AdamStep,
        ) -> (FlexTensor, FlexTensor, FlexTensor) {
            let (mut param, mut m, mut v) = (owned(param), owned(m), owned(v));
            let g = values(&grad);
            // storage_mut copies only when another tensor still shares the buffer.
            adam_update_slices(param.storage_mut::<f32>(), &g, m.storage_mut::<f32>(), v.storage_mut::<f32>(), step);
            (param, m, v)
        }
    }
}

#[cfg(feature = "ndarray")]
impl AdamOps for burn::backend::NdArray {}

#[cfg(feature = "wgpu")]
impl AdamOps for burn::backend::Cube {}

impl<B: Backend + AdamOps, C: CheckpointStrategy> AdamOps for Autodiff<B, C> {
    fn adam_update(
        param: FloatTensor<Self>,
        grad: FloatTensor<Self>,
        m: FloatTensor<Self>,
        v: FloatTensor<Self>,
        step: AdamStep,
    ) -> (FloatTensor<Self>, FloatTensor<Self>, FloatTensor<Self>) {
        // Optimiser updates are not differentiated through.
        let (p, m, v) =
            B::adam_update(param.into_primitive(), grad.into_primitive(), m.into_primitive(), v.into_primitive(), step);
        (constant::<B, C>(p), constant::<B, C>(m), constant::<B, C>(v))
    }
}

/// Adam (with optional L2 weight decay, as burn's `AdamConfig::with_weight_decay`) whose
/// per-parameter update is one fused backend operation.
#[derive(Clone, Debug)]
pub struct FusedAdam {
    /// First-moment decay.
    pub beta1: f32,
    /// Second-moment decay.
    pub beta2: f32,
    /// Denominator guard.
    pub epsilon: f32,
    /// L2 penalty on the parameters, 0 for none.
    pub weight_decay: f32,
    /// Factor on the learning rate the module optimiser passes in: one parameter group can
    /// learn faster or slower than the others on one schedule.
    pub lr_scale: f32,
    /// Further factors per stretch of the elements, for a parameter of exactly the segments'
    /// length (other parameters of the group get `lr_scale` alone).
    pub segments: Option<RateSegments>,
}

impl Optimizer for FusedAdam {
    type State<const D: usize> = AdamState<D>;

    fn step<const D: usize>(
        &self,
        lr: LearningRate,
        tensor: Tensor<D>,
        grad: Tensor<D>,
        state: Option<Self::State<D>>,
    ) -> (Tensor<D>, Option<Self::State<D>>) {
        let (m, v, time) = match state {
            Some(s) => (s.momentum.moment_1, s.momentum.moment_2, s.momentum.time + 1),
            None => (tensor.zeros_like(), tensor.zeros_like(), 1),
        };
        let step = AdamStep {
            lr: lr as f32 * self.lr_scale,
            beta1: self.beta1,
            beta2: self.beta2,
            epsilon: self.epsilon,
            weight_decay: self.weight_decay,
            time,
            segments: self
                .segments
                .clone()
                .filter(|s| s.last().map(|&(end, _)| end) == Some(tensor.shape().num_elements())),
        };
        let (p, m, v) = <Dispatch as AdamOps>::adam_update(
            tensor.into_dispatch(),
            grad.into_dispatch(),
            m.into_dispatch(),
            v.into_dispatch(),
            step,
        );
        let (p, m, v) = (Tensor::from_dispatch(p), Tensor::from_dispatch(m), Tensor::from_dispatch(v));
        (p, Some(AdamState::new(AdaptiveMomentumState::new(time, m, v))))
    }

    fn to_device<const D: usize>(mut state: Self::State<D>, device: &Device) -> Self::State<D> {
        state.momentum = state.momentum.to_device(device);
        state
    }
}

#[cfg(test)]
mod tests {
    use burn::module::{Module, Param};
    use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer, decay::WeightDecayConfig};
    use burn::tensor::{Tensor, TensorData};

    use super::FusedAdam;

    #[derive(Module, Debug)]
    struct Weights {
        w: Param<Tensor<2>>,
    }

    fn run(opt: ModuleOptimizer) -> Vec<f32> {
        run_at(opt, 1e-2)
    }

    fn run_at(mut opt: ModuleOptimizer, lr: f64) -> Vec<f32> {
        let device = crate::backend::training_device();
        let init: Vec<f32> = (0..600).map(|i| ((i * 37 % 101) as f32 / 50.0) - 1.0).collect();
        let mut model = Weights { w: Param::from_tensor(Tensor::from_data(TensorData::new(init, [20, 30]), &device)) };
        for step in 0..5 {
            let target: Vec<f32> = (0..600).map(|i| ((i * 13 + step * 7) % 29) as f32 / 29.0).collect();
            let target = Tensor::<2>::from_data(TensorData::new(target, [20, 30]), &device);
            let loss = (model.w.val() - target).square().sum();
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = opt.step(lr, model, grads);
        }
        model.w.val().into_data().try_to_vec::<f32>().unwrap()
    }

    /// A group's learning-rate factor is the same as a learning rate that many times larger.
    #[test]
    fn the_learning_rate_scale_multiplies_the_rate() {
        let adam = |lr_scale| FusedAdam {
            beta1: 0.9,
            beta2: 0.99,
            epsilon: 1e-8,
            weight_decay: 0.0,
            lr_scale,
            segments: None,
        };
        let scaled = run_at(adam(2.0).into(), 1e-2);
        let doubled = run_at(adam(1.0).into(), 2e-2);
        assert_eq!(scaled, doubled);
        assert_ne!(scaled, run_at(adam(1.0).into(), 1e-2));
    }

    /// Each stretch of the elements moves as it would with its factor on the whole parameter.
    #[test]
    fn segments_scale_their_own_elements() {
        let adam = |lr_scale, segments| FusedAdam {
            beta1: 0.9,
            beta2: 0.99,
            epsilon: 1e-8,
            weight_decay: 0.0,
            lr_scale,
            segments,
        };
        let split: super::RateSegments = vec![(250, 2.0), (600, 0.5)].into();
        let segmented = run(adam(1.0, Some(split)).into());
        let (doubled, halved) = (run(adam(2.0, None).into()), run(adam(0.5, None).into()));
        assert_eq!(segmented[..250], doubled[..250]);
        assert_eq!(segmented[250..], halved[250..]);
        assert_ne!(doubled[250..], halved[250..]);
        // Segments that do not match the parameter's length leave it to `lr_scale`.
        let other: super::RateSegments = vec![(10, 4.0)].into();
        assert_eq!(run(adam(2.0, Some(other)).into()), doubled);
    }

    /// Same trajectory as burn's Adam (with weight decay) to rounding.
    #[test]
    fn matches_burns_adam() {
        let burn = run(AdamConfig::new()
            .with_beta_1(0.9)
            .with_beta_2(0.99)
            .with_epsilon(1e-8)
            .with_weight_decay(Some(WeightDecayConfig::new(0.1)))
            .init());
        let fused =
            run(FusedAdam { beta1: 0.9, beta2: 0.99, epsilon: 1e-8, weight_decay: 0.1, lr_scale: 1.0, segments: None }
                .into());
        for (a, b) in burn.iter().zip(&fused) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
        assert!(burn.iter().zip(&fused).any(|(a, _)| *a != 0.0));
    }
}
