//! The fused radiance field and the compositing as burn backend operations.
//!
//! The flex CPU backend runs the slice kernels of
//! [`crate::field`] and [`crate::render::composite`] on the tensors' own storage; other
//! backends use the default bodies (host round trip) until they get kernels of their own.
//! On the autodiff backend the forwards register backward steps: the field's gives
//! `∂loss/∂table` and `∂loss/∂mlp` from the activations it saved; the compositing's gives
//! `∂loss/∂(σ, rgb)`. Positions, footprints, directions and sample spacing are constants.

#![cfg_attr(feature = "ndarray", allow(deprecated))]

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::{base::Checkpointer, strategy::CheckpointStrategy};
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::backend::{Autodiff, Backend, Dispatch, TensorMetadata, backend_extension, tensor::FloatTensor};
use burn::tensor::{Tensor, TensorData};

use crate::field::FieldConfig;
use crate::render::composite::{
    PackedSamples, RAY_OUTPUTS, add_distortion_gradient, composite_backward, composite_forward,
};
use lucid_burn::{constant, to_host};

/// Compositing parameters that travel with the op.
#[derive(Clone, Debug)]
pub struct CompositeArgs {
    /// The packed samples (ray offsets, distances, spacing).
    pub samples: Arc<PackedSamples>,
    /// Rays stop once transmittance falls below this.
    pub min_transmittance: f32,
    /// Weight of the rays' summed distortion loss in the loss being differentiated (0: none);
    /// it enters only the backward ([`crate::render::composite::add_distortion_gradient`]).
    pub distortion: f32,
}

impl CompositeArgs {
    /// The op's forward on host values: `R×5` (`r, g, b, opacity, depth`).
    fn forward(&self, raw: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0; self.samples.rays() * RAY_OUTPUTS];
        composite_forward(&self.samples, raw, self.min_transmittance, &mut out);
        out
    }

    /// The op's backward on host values: `∂loss/∂raw` (`S×4`) from `∂loss/∂out` and the
    /// forward's `out`, with the weighted distortion loss's gradient added.
    fn backward(&self, raw: &[f32], out: &[f32], grad_out: &[f32]) -> Vec<f32> {
        let mut g = vec![0.0; raw.len()];
        composite_backward(&self.samples, raw, out, grad_out, self.min_transmittance, &mut g);
        if self.distortion > 0.0 {
            add_distortion_gradient(&self.samples, raw, self.distortion, self.min_transmittance, &mut g);
        }
        g
    }
}

/// The NeRF field and compositing as backend operations.
#[backend_extension(
    Flex: cfg(feature = "flex"),
    NdArray: cfg(feature = "ndarray"),
    Cube: cfg(feature = "wgpu"),
    Autodiff,
)]
pub trait NerfOps: Backend {
    /// `σ, r, g, b` (`S×4`) at `positions` (`S×3` in `[0,1]`) along unit `directions` (`S×3`).
    fn field_forward(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        field_host::<Self>(positions, footprints, directions, None, table, mlp, config, false).0
    }

    /// As [`Self::field_forward`], also returning the activations the backward needs.
    fn field_forward_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let (out, saved) = field_host::<Self>(positions, footprints, directions, None, table, mlp, config, true);
        (out, saved.expect("saved activations"))
    }

    /// As [`Self::field_forward`], going on from the density's activations at the positions
    /// (`S×`[`crate::field::FieldLayout::density_width`], as [`Self::field_density_saving`]
    /// gave them with these weights).
    fn field_from_density(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        density: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        field_host::<Self>(positions, footprints, directions, Some(density), table, mlp, config, false).0
    }

    /// As [`Self::field_from_density`], also returning the activations the backward needs.
    fn field_from_density_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        density: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let (out, saved) =
            field_host::<Self>(positions, footprints, directions, Some(density), table, mlp, config, true);
        (out, saved.expect("saved activations"))
    }

    /// `(∂loss/∂table, ∂loss/∂mlp)` from `∂loss/∂out`.
    fn field_backward(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        saved: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let device = positions.device();
        let layout = config.layout();
        let mut gt = zeros(layout.grid.entries * layout.grid.features);
        let mut gm = vec![0.0; layout.mlp_params()];
        let (pos, foot, mlp, saved, grad) = (
            to_host::<Self>(positions),
            to_host::<Self>(footprints),
            to_host::<Self>(mlp),
            to_host::<Self>(saved),
            to_host::<Self>(grad_out),
        );
        layout.backward(&pos, &foot, &mlp, &saved, &grad, &mut gt, &mut gm);
        let gt = Self::float_from_data(TensorData::new(gt, [layout.grid.entries, layout.grid.features]), &device);
        let gm = Self::float_from_data(TensorData::new(gm, [layout.mlp_params()]), &device);
        (gt, gm)
    }

    /// Density only (`S`), for the occupancy grid.
    fn field_density(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        let device = positions.device();
        let pos = to_host::<Self>(positions);
        let mut out = vec![0.0; pos.len() / 3];
        config.layout().density(
            &pos,
            &to_host::<Self>(footprints),
            &to_host::<Self>(table),
            &to_host::<Self>(mlp),
            &mut out,
        );
        let n = out.len();
        Self::float_from_data(TensorData::new(out, [n]), &device)
    }

    /// Density (`S`) and the activations that gave it (`S×`
    /// [`crate::field::FieldLayout::density_width`]), for [`Self::field_forward`] to go on from.
    fn field_density_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let device = positions.device();
        let layout = config.layout();
        let pos = to_host::<Self>(positions);
        let n = pos.len() / 3;
        let (mut out, mut saved) = (vec![0.0; n], zeros(n * layout.density_width()));
        layout.density_saving(
            &pos,
            &to_host::<Self>(footprints),
            &to_host::<Self>(table),
            &to_host::<Self>(mlp),
            &mut out,
            &mut saved,
        );
        (
            Self::float_from_data(TensorData::new(out, [n]), &device),
            Self::float_from_data(TensorData::new(saved, [n, layout.density_width()]), &device),
        )
    }

    /// Composites `raw` (`S×4`) into `R×5` (`r, g, b, opacity, depth`).
    fn composite(raw: FloatTensor<Self>, args: CompositeArgs) -> FloatTensor<Self> {
        let device = raw.device();
        let out = args.forward(&to_host::<Self>(raw));
        Self::float_from_data(TensorData::new(out, [args.samples.rays(), RAY_OUTPUTS]), &device)
    }

    /// `∂loss/∂raw` from `∂loss/∂out` and the forward's `out`.
    fn composite_grad(
        raw: FloatTensor<Self>,
        out: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        args: CompositeArgs,
    ) -> FloatTensor<Self> {
        let device = raw.device();
        let (raw, out, grad) = (to_host::<Self>(raw), to_host::<Self>(out), to_host::<Self>(grad_out));
        let g = args.backward(&raw, &out, &grad);
        Self::float_from_data(TensorData::new(g, [raw.len() / 4, 4]), &device)
    }
}

/// `n` zeros, written by both cores: the gradient table (16 MB by default) and the saved
/// activations (about 20 MB a step) come from reused memory, and one core's memset of them was
/// 4 % of a training step (`perf`).
fn zeros(n: usize) -> Vec<f32> {
    use rayon::prelude::*;
    let mut zeros = Vec::with_capacity(n);
    zeros.par_extend(rayon::iter::repeat_n(0.0f32, n));
    zeros
}

#[allow(clippy::too_many_arguments)] // the op's tensors and settings, as the trait passes them
fn field_host<B: Backend>(
    positions: FloatTensor<B>,
    footprints: FloatTensor<B>,
    directions: FloatTensor<B>,
    density: Option<FloatTensor<B>>,
    table: FloatTensor<B>,
    mlp: FloatTensor<B>,
    config: FieldConfig,
    save: bool,
) -> (FloatTensor<B>, Option<FloatTensor<B>>) {
    let device = positions.device();
    let layout = config.layout();
    let dir = to_host::<B>(directions);
    let s = dir.len() / 3;
    let mut out = vec![0.0; 4 * s];
    let mut saved = save.then(|| zeros(s * layout.saved_per_sample()));
    let mlp = to_host::<B>(mlp);
    match density {
        Some(d) => layout.forward_from_density(&to_host::<B>(d), &dir, &mlp, &mut out, saved.as_deref_mut()),
        None => {
            let (pos, foot, table) = (to_host::<B>(positions), to_host::<B>(footprints), to_host::<B>(table));
            layout.forward(&pos, &foot, &dir, &table, &mlp, &mut out, saved.as_deref_mut())
        }
    }
    let out = B::float_from_data(TensorData::new(out, [s, 4]), &device);
    let saved = saved.map(|v| B::float_from_data(TensorData::new(v, [s, layout.saved_per_sample()]), &device));
    (out, saved)
}

#[cfg(feature = "flex")]
mod flex;

#[cfg(feature = "ndarray")]
#[allow(deprecated)]
impl NerfOps for burn::backend::NdArray {}

#[cfg(feature = "wgpu")]
impl NerfOps for burn::backend::Cube {}

impl<B: Backend + NerfOps, C: CheckpointStrategy> NerfOps for Autodiff<B, C> {
    fn field_forward(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        tracked_field::<B, C>(positions, footprints, directions, None, table, mlp, config)
    }

    fn field_forward_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let (out, saved) = B::field_forward_saving(
            positions.into_primitive(),
            footprints.into_primitive(),
            directions.into_primitive(),
            table.into_primitive(),
            mlp.into_primitive(),
            config,
        );
        (constant::<B, C>(out), constant::<B, C>(saved))
    }

    fn field_from_density(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        density: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        tracked_field::<B, C>(positions, footprints, directions, Some(density.into_primitive()), table, mlp, config)
    }

    fn field_from_density_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        directions: FloatTensor<Self>,
        density: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let (out, saved) = B::field_from_density_saving(
            positions.into_primitive(),
            footprints.into_primitive(),
            directions.into_primitive(),
            density.into_primitive(),
            table.into_primitive(),
            mlp.into_primitive(),
            config,
        );
        (constant::<B, C>(out), constant::<B, C>(saved))
    }

    fn field_backward(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        saved: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        // Second derivatives are not needed by any trainer: the results are constants.
        let (gt, gm) = B::field_backward(
            positions.into_primitive(),
            footprints.into_primitive(),
            mlp.into_primitive(),
            saved.into_primitive(),
            grad_out.into_primitive(),
            config,
        );
        (constant::<B, C>(gt), constant::<B, C>(gm))
    }

    fn field_density(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> FloatTensor<Self> {
        let out = B::field_density(
            positions.into_primitive(),
            footprints.into_primitive(),
            table.into_primitive(),
            mlp.into_primitive(),
            config,
        );
        constant::<B, C>(out)
    }

    fn field_density_saving(
        positions: FloatTensor<Self>,
        footprints: FloatTensor<Self>,
        table: FloatTensor<Self>,
        mlp: FloatTensor<Self>,
        config: FieldConfig,
    ) -> (FloatTensor<Self>, FloatTensor<Self>) {
        let (out, saved) = B::field_density_saving(
            positions.into_primitive(),
            footprints.into_primitive(),
            table.into_primitive(),
            mlp.into_primitive(),
            config,
        );
        (constant::<B, C>(out), constant::<B, C>(saved))
    }

    fn composite(raw: FloatTensor<Self>, args: CompositeArgs) -> FloatTensor<Self> {
        #[derive(Debug)]
        struct CompositeBackward;

        impl<B: Backend + NerfOps> Backward<B, 1> for CompositeBackward {
            type State = (FloatTensor<B>, FloatTensor<B>, CompositeArgs);

            fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
                let (raw, out, args) = ops.state;
                unary::<B, _>(ops.parents, ops.node, grads, |grad| B::composite_grad(raw, out, grad, args));
            }
        }

        let raw_node = raw.node();
        let raw = raw.into_primitive();
        let out = B::composite(raw.clone(), args.clone());
        match CompositeBackward.prepare::<C>([raw_node]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => prep.finish((raw, out.clone(), args), out),
            OpsKind::UnTracked(prep) => prep.finish(out),
        }
    }

    fn composite_grad(
        raw: FloatTensor<Self>,
        out: FloatTensor<Self>,
        grad_out: FloatTensor<Self>,
        args: CompositeArgs,
    ) -> FloatTensor<Self> {
        let g = B::composite_grad(raw.into_primitive(), out.into_primitive(), grad_out.into_primitive(), args);
        constant::<B, C>(g)
    }
}

/// The field on the autodiff backend, from the positions or (`density`) the density's
/// activations there: the backward gives `∂loss/∂table` and `∂loss/∂mlp`. Activations that
/// came from the table and the MLP outside the graph are the forward's first layers, and the
/// backward goes through them to both.
fn tracked_field<B: Backend + NerfOps, C: CheckpointStrategy>(
    positions: FloatTensor<Autodiff<B, C>>,
    footprints: FloatTensor<Autodiff<B, C>>,
    directions: FloatTensor<Autodiff<B, C>>,
    density: Option<FloatTensor<B>>,
    table: FloatTensor<Autodiff<B, C>>,
    mlp: FloatTensor<Autodiff<B, C>>,
    config: FieldConfig,
) -> FloatTensor<Autodiff<B, C>> {
    #[derive(Debug)]
    struct FieldBackward;

    impl<B: Backend + NerfOps> Backward<B, 2> for FieldBackward {
        type State = (FloatTensor<B>, FloatTensor<B>, FloatTensor<B>, FloatTensor<B>, FieldConfig);

        fn backward(self, ops: Ops<Self::State, 2>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
            let (positions, footprints, mlp, saved, config) = ops.state;
            let grad_out = grads.consume::<B>(&ops.node);
            let (gt, gm) = B::field_backward(positions, footprints, mlp, saved, grad_out, config);
            let [table_node, mlp_node] = ops.parents;
            if let Some(node) = table_node {
                grads.register::<B>(node.id, gt);
            }
            if let Some(node) = mlp_node {
                grads.register::<B>(node.id, gm);
            }
        }
    }

    let (table_node, mlp_node) = (table.node(), mlp.node());
    let (positions, footprints, directions) =
        (positions.into_primitive(), footprints.into_primitive(), directions.into_primitive());
    let (table, mlp) = (table.into_primitive(), mlp.into_primitive());
    match FieldBackward.prepare::<C>([table_node, mlp_node]).compute_bound().stateful() {
        OpsKind::Tracked(prep) => {
            let (out, saved) = match density {
                Some(d) => B::field_from_density_saving(
                    positions.clone(),
                    footprints.clone(),
                    directions,
                    d,
                    table,
                    mlp.clone(),
                    config,
                ),
                None => B::field_forward_saving(
                    positions.clone(),
                    footprints.clone(),
                    directions,
                    table,
                    mlp.clone(),
                    config,
                ),
            };
            prep.finish((positions, footprints, mlp, saved, config), out)
        }
        OpsKind::UnTracked(prep) => prep.finish(match density {
            Some(d) => B::field_from_density(positions, footprints, directions, d, table, mlp, config),
            None => B::field_forward(positions, footprints, directions, table, mlp, config),
        }),
    }
}

/// Evaluates the field: `S×4` (`σ, r, g, b`), differentiable with respect to `table` and `mlp`.
pub fn field(
    positions: Tensor<2>,
    footprints: Tensor<1>,
    directions: Tensor<2>,
    table: Tensor<2>,
    mlp: Tensor<1>,
    config: FieldConfig,
) -> Tensor<2> {
    let out = <Dispatch as NerfOps>::field_forward(
        positions.into_dispatch(),
        footprints.into_dispatch(),
        directions.into_dispatch(),
        table.into_dispatch(),
        mlp.into_dispatch(),
        config,
    );
    Tensor::from_dispatch(out)
}

/// As [`field`], going on from the density's activations at the positions (as
/// [`field_density_saving`] gave them with these weights): the same values and gradients,
/// without evaluating the encoding and the density MLP again.
pub fn field_from_density(
    positions: Tensor<2>,
    footprints: Tensor<1>,
    directions: Tensor<2>,
    density: Tensor<2>,
    table: Tensor<2>,
    mlp: Tensor<1>,
    config: FieldConfig,
) -> Tensor<2> {
    let out = <Dispatch as NerfOps>::field_from_density(
        positions.into_dispatch(),
        footprints.into_dispatch(),
        directions.into_dispatch(),
        density.into_dispatch(),
        table.into_dispatch(),
        mlp.into_dispatch(),
        config,
    );
    Tensor::from_dispatch(out)
}

/// The field's density (`S`) and the activations that gave it (`S×`
/// [`crate::field::FieldLayout::density_width`]), never tracked.
pub fn field_density_saving(
    positions: Tensor<2>,
    footprints: Tensor<1>,
    table: Tensor<2>,
    mlp: Tensor<1>,
    config: FieldConfig,
) -> (Tensor<1>, Tensor<2>) {
    let (out, saved) = <Dispatch as NerfOps>::field_density_saving(
        positions.into_dispatch(),
        footprints.into_dispatch(),
        table.into_dispatch(),
        mlp.into_dispatch(),
        config,
    );
    (Tensor::from_dispatch(out), Tensor::from_dispatch(saved))
}

/// The field's density only (`S`), never tracked.
pub fn field_density(
    positions: Tensor<2>,
    footprints: Tensor<1>,
    table: Tensor<2>,
    mlp: Tensor<1>,
    config: FieldConfig,
) -> Tensor<1> {
    let out = <Dispatch as NerfOps>::field_density(
        positions.into_dispatch(),
        footprints.into_dispatch(),
        table.into_dispatch(),
        mlp.into_dispatch(),
        config,
    );
    Tensor::from_dispatch(out)
}

/// Composites `raw` (`S×4`) along packed rays into `R×5` (`r, g, b, opacity, depth`),
/// differentiable with respect to `raw`; the gradient also carries `distortion` times the
/// rays' summed distortion loss.
pub fn composite(raw: Tensor<2>, samples: Arc<PackedSamples>, min_transmittance: f32, distortion: f32) -> Tensor<2> {
    let args = CompositeArgs { samples, min_transmittance, distortion };
    let out = <Dispatch as NerfOps>::composite(raw.into_dispatch(), args);
    Tensor::from_dispatch(out)
}
