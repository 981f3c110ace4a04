//! Custom burn operations over our slice kernels.
//!
//! [`HashGridOps`] is a burn backend extension: on the flex CPU backend it runs the kernels of
//! [`crate::encoding::hash_grid`] directly on the tensors' storage, with no host copy; other
//! backends (ndarray, and wgpu until it gets its own shaders) use the default bodies, which
//! read the inputs to the host, run the same kernels and upload the result. On the autodiff
//! backend the forward registers a backward step that scatters `∂loss/∂out` into the table.
//! Positions are treated as constants: NeRF samples them, it does not learn them.

// burn-ndarray is deprecated upstream; the `ndarray` feature keeps it selectable on purpose.
#![cfg_attr(feature = "ndarray", allow(deprecated))]

use burn::backend::autodiff::checkpoint::{base::Checkpointer, strategy::CheckpointStrategy};
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::backend::{Autodiff, Backend, Dispatch, TensorMetadata, backend_extension, tensor::FloatTensor};
use burn::tensor::{Tensor, TensorData};
use lucid_burn::{constant, to_host};

use crate::encoding::hash_grid::HashGridConfig;

/// The hash-grid encoding as backend operations.
#[backend_extension(
    Flex: cfg(feature = "flex"),
    NdArray: cfg(feature = "ndarray"),
    Cube: cfg(feature = "wgpu"),
    Autodiff,
)]
pub trait HashGridOps: Backend {
    /// Encodes `positions` (`N×3` in `[0,1]`) with `table` (`entries×F`): `N×L·F` features.
    fn hash_grid_forward(
        positions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        config: HashGridConfig,
    ) -> FloatTensor<Self> {
        let device = positions.device();
        let pos = to_host::<Self>(positions);
        let table = to_host::<Self>(table);
        let layout = config.layout();
        let n = pos.len() / 3;
        let mut out = vec![0.0; n * layout.output_dim()];
        layout.forward(&pos, &table, &mut out);
        Self::float_from_data(TensorData::new(out, [n, layout.output_dim()]), &device)
    }

    /// `∂loss/∂table` (`entries×F`) from `∂loss/∂out` (`N×L·F`).
    fn hash_grid_backward(
        positions: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        config: HashGridConfig,
    ) -> FloatTensor<Self> {
        let device = positions.device();
        let pos = to_host::<Self>(positions);
        let grad_out = to_host::<Self>(grad_out);
        let layout = config.layout();
        let mut grad = vec![0.0; layout.entries * layout.features];
        layout.backward(&pos, &grad_out, &mut grad);
        Self::float_from_data(TensorData::new(grad, [layout.entries, layout.features]), &device)
    }
}

#[cfg(feature = "flex")]
mod flex_impl {
    use burn::backend::Flex;
    use burn::backend::flex::FlexTensor;
    use burn::tensor::TensorData;
    use lucid_burn::values;

    use super::{HashGridConfig, HashGridOps};

    impl HashGridOps for Flex {
        fn hash_grid_forward(positions: FlexTensor, table: FlexTensor, config: HashGridConfig) -> FlexTensor {
            let layout = config.layout();
            let pos = values(&positions);
            let n = pos.len() / 3;
            let mut out = vec![0.0f32; n * layout.output_dim()];
            layout.forward(&pos, &values(&table), &mut out);
            FlexTensor::from_data(TensorData::new(out, [n, layout.output_dim()]))
        }

        fn hash_grid_backward(positions: FlexTensor, grad_out: FlexTensor, config: HashGridConfig) -> FlexTensor {
            let layout = config.layout();
            let mut grad = vec![0.0f32; layout.entries * layout.features];
            layout.backward(&values(&positions), &values(&grad_out), &mut grad);
            FlexTensor::from_data(TensorData::new(grad, [layout.entries, layout.features]))
        }
    }
}

#[cfg(feature = "ndarray")]
#[allow(deprecated)]
impl HashGridOps for burn::backend::NdArray {}

#[cfg(feature = "wgpu")]
impl HashGridOps for burn::backend::Cube {}

impl<B: Backend + HashGridOps, C: CheckpointStrategy> HashGridOps for Autodiff<B, C> {
    fn hash_grid_forward(
        positions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        config: HashGridConfig,
    ) -> FloatTensor<Self> {
        #[derive(Debug)]
        struct HashGridBackward;

        impl<B: Backend + HashGridOps> Backward<B, 1> for HashGridBackward {
            type State = (FloatTensor<B>, HashGridConfig);

            fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
                let (positions, config) = ops.state;
                unary::<B, _>(ops.parents, ops.node, grads, |grad| B::hash_grid_backward(positions, grad, config));
            }
        }

        let table_node = table.node();
        let positions = positions.into_primitive();
        let output = B::hash_grid_forward(positions.clone(), table.into_primitive(), config);
        match HashGridBackward.prepare::<C>([table_node]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => prep.finish((positions, config), output),
            OpsKind::UnTracked(prep) => prep.finish(output),
        }
    }

    fn hash_grid_backward(
        positions: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        config: HashGridConfig,
    ) -> FloatTensor<Self> {
        // Second derivatives are not needed by any trainer: the result is a constant.
        let grad = B::hash_grid_backward(positions.into_primitive(), grad_out.into_primitive(), config);
        constant::<B, C>(grad)
    }
}

/// Encodes `positions` (`N×3`, normalised to `[0,1]`) with the hash-grid `table`
/// (`entries×F`, see [`HashGridConfig::layout`]): returns `N×L·F` features, differentiable
/// with respect to the table on an autodiff device.
pub fn hash_grid_encode(positions: Tensor<2>, table: Tensor<2>, config: HashGridConfig) -> Tensor<2> {
    let layout = config.layout();
    assert_eq!(positions.dims()[1], 3, "positions must be N×3");
    assert_eq!(table.dims(), [layout.entries, layout.features], "table must be entries×F for this config");
    let out = <Dispatch as HashGridOps>::hash_grid_forward(positions.into_dispatch(), table.into_dispatch(), config);
    Tensor::from_dispatch(out)
}
