//! burn glue shared by Lucid's trainers.
//!
//! Our hot loops are plain Rust over slices exposed as burn backend extensions. On the flex
//! CPU backend they read and write the tensors' own storage ([`values`]); other backends run
//! the same kernels through a host round trip ([`to_host`]) until they get kernels of their
//! own. Results that no gradient flows through are wrapped as untracked autodiff tensors
//! ([`constant`]). [`optim::FusedAdam`] is burn's Adam update as one pass per parameter.

// burn-ndarray is deprecated upstream; the `ndarray` feature keeps it selectable on purpose.
#![cfg_attr(feature = "ndarray", allow(deprecated))]

pub mod backend;
pub mod checkpoint;
pub mod config;
pub mod memory;
pub mod optim;
pub mod run;

use burn::backend::autodiff::checkpoint::{base::Checkpointer, strategy::CheckpointStrategy};
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::{Autodiff, Backend, tensor::FloatTensor};

pub use optim::FusedAdam;

/// The path (`encoder.weight`) of the first float parameter of `module` that holds NaN or an
/// infinity. Each parameter is checked through its sum, one reduction on the device, so the
/// parameters are not copied to the host; a sum overflowing `f32` counts as non-finite too,
/// which no healthy model's parameters reach.
pub fn first_non_finite<M: burn::module::Module>(module: &M) -> Option<String> {
    struct Finder {
        path: Vec<String>,
        found: Option<String>,
    }
    impl burn::module::ModuleVisitor for Finder {
        fn enter_module(&mut self, name: &str, _: &str) {
            self.path.push(name.to_string());
        }
        fn exit_module(&mut self, _: &str, _: &str) {
            self.path.pop();
        }
        fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<burn::tensor::Tensor<D>>) {
            if self.found.is_none() && !param.val().sum().into_scalar::<f32>().is_finite() {
                self.found = Some(if self.path.is_empty() { "a parameter".into() } else { self.path.join(".") });
            }
        }
    }
    let mut finder = Finder { path: Vec::new(), found: None };
    module.visit(&mut finder);
    finder.found
}

/// Reads a float tensor to host memory as `f32` (the portable bodies of our ops).
pub fn to_host<B: Backend>(tensor: FloatTensor<B>) -> Vec<f32> {
    let data = burn::tensor::try_read_sync(B::float_into_data(tensor))
        .expect("a synchronous read is possible")
        .expect("tensor data is readable");
    data.try_into_vec_as::<f32>().expect("float data converts to f32")
}

/// A tensor's values on the host as `f32`, row-major.
pub fn to_host_tensor<const D: usize>(t: burn::tensor::Tensor<D>) -> Vec<f32> {
    t.into_data().try_into_vec_as::<f32>().expect("float data converts to f32")
}

/// Wraps a result that no backward pass flows through (gradients of gradients, optimiser
/// updates, densities for an occupancy grid) as an untracked autodiff tensor.
pub fn constant<B: Backend, C: CheckpointStrategy>(t: FloatTensor<B>) -> FloatTensor<Autodiff<B, C>> {
    #[derive(Debug)]
    struct Constant;

    impl<B: Backend> Backward<B, 0> for Constant {
        type State = ();

        fn backward(self, _ops: Ops<(), 0>, _grads: &mut Gradients, _checkpointer: &mut Checkpointer) {}
    }

    match Constant.prepare::<C>([]).compute_bound().stateful() {
        OpsKind::Tracked(prep) => prep.finish((), t),
        OpsKind::UnTracked(prep) => prep.finish(t),
    }
}

/// The tensor's `f32` values in row-major order, borrowed when already contiguous.
#[cfg(feature = "flex")]
pub fn values(t: &burn::backend::flex::FlexTensor) -> std::borrow::Cow<'_, [f32]> {
    use std::borrow::Cow;
    assert_eq!(t.dtype(), burn::tensor::DType::F32, "our kernels work on f32 tensors");
    match t.as_slice::<f32>() {
        Some(s) => Cow::Borrowed(s),
        None => Cow::Owned(t.to_contiguous().as_slice::<f32>().expect("contiguous").to_vec()),
    }
}

/// A flex tensor from row-major `f32` values.
#[cfg(feature = "flex")]
pub fn flex_tensor(values: Vec<f32>, shape: impl Into<burn::tensor::Shape>) -> burn::backend::flex::FlexTensor {
    burn::backend::flex::FlexTensor::from_data(burn::tensor::TensorData::new(values, shape.into()))
}
