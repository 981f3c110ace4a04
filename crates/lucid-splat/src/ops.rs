//! Splat rendering as one custom burn autodiff operation.
//!
//! The forward projects, bins and rasterizes on the tensors' own storage (flex) and keeps the
//! [`RenderState`] the backward needs in the op's arguments; the backward turns
//! `∂loss/∂image` into the gradient of every parameter tensor, plus the screen-space gradient
//! of each centre (reported through a zero `N×2` input, as gsplat's `means2d`) that
//! densification thresholds. Other backends run the same kernels through a host round trip.

#![cfg_attr(feature = "ndarray", allow(deprecated))]
// One tensor argument per parameter kind, as the optimiser sees them.
#![allow(clippy::too_many_arguments)]

use std::sync::{Arc, Mutex};

use burn::backend::autodiff::checkpoint::{base::Checkpointer, strategy::CheckpointStrategy};
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::{Autodiff, Backend, Dispatch, TensorMetadata, backend_extension, tensor::FloatTensor};
use burn::tensor::{Tensor, TensorData};
use lucid_burn::{constant, to_host};

use crate::camera::SplatCamera;
use crate::project::{RenderSettings, SplatParams};
use crate::render::{RenderState, SplatGrads, render, render_backward};

/// What a render op needs besides the parameters, and where its forward leaves the state
/// for the backward.
#[derive(Clone, Debug)]
pub struct SplatRenderArgs {
    /// The view.
    pub camera: SplatCamera,
    /// Projection and blending settings.
    pub settings: RenderSettings,
    /// Filled by the forward.
    pub state: Arc<Mutex<Option<Arc<RenderState>>>>,
}

impl SplatRenderArgs {
    /// Arguments for one view.
    pub fn new(camera: SplatCamera, settings: RenderSettings) -> Self {
        Self { camera, settings, state: Arc::new(Mutex::new(None)) }
    }

    fn keep(&self, state: RenderState) {
        *self.state.lock().expect("render state lock") = Some(Arc::new(state));
    }

    /// The forward's state (panics if the forward has not run).
    pub fn take_state(&self) -> Arc<RenderState> {
        self.state.lock().expect("render state lock").clone().expect("the forward ran")
    }
}

/// The parameter gradients as host vectors in op order.
fn grads_in_order(g: SplatGrads) -> [Vec<f32>; 7] {
    [g.means, g.log_scales, g.rotations, g.opacities, g.sh_dc, g.sh_rest, g.means_2d]
}

/// Splat rendering as backend operations.
#[backend_extension(
    Flex: cfg(feature = "flex"),
    NdArray: cfg(feature = "ndarray"),
    Cube: cfg(feature = "wgpu"),
    Autodiff,
)]
pub trait SplatOps: Backend {
    /// Renders the cloud: `H×W×4` (RGB over the background, then alpha).
    fn splat_render(
        means: FloatTensor<Self>,
        log_scales: FloatTensor<Self>,
        rotations: FloatTensor<Self>,
        opacities: FloatTensor<Self>,
        sh_dc: FloatTensor<Self>,
        sh_rest: FloatTensor<Self>,
        means_2d: FloatTensor<Self>,
        args: SplatRenderArgs,
    ) -> FloatTensor<Self> {
        drop(means_2d);
        let device = means.device();
        let v = [means, log_scales, rotations, opacities, sh_dc, sh_rest].map(to_host::<Self>);
        let p = SplatParams::from_kinds(v.each_ref().map(Vec::as_slice));
        let (image, state) = render(&p, &args.camera, &args.settings);
        args.keep(state);
        let (w, h) = (args.camera.width as usize, args.camera.height as usize);
        Self::float_from_data(TensorData::new(image, [h, w, 4]), &device)
    }

    /// The gradients of `means, log_scales, rotations, opacities, sh_dc, sh_rest` and of the
    /// screen-space centres (`N×2`, NDC) from `∂loss/∂image`.
    #[allow(clippy::type_complexity)]
    fn splat_render_backward(
        means: FloatTensor<Self>,
        log_scales: FloatTensor<Self>,
        rotations: FloatTensor<Self>,
        opacities: FloatTensor<Self>,
        sh_dc: FloatTensor<Self>,
        sh_rest: FloatTensor<Self>,
        grad_image: FloatTensor<Self>,
        args: SplatRenderArgs,
    ) -> (
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
    ) {
        let device = means.device();
        let shapes = [&means, &log_scales, &rotations, &opacities, &sh_dc, &sh_rest].map(|t| t.shape());
        let v = [means, log_scales, rotations, opacities, sh_dc, sh_rest].map(to_host::<Self>);
        let p = SplatParams::from_kinds(v.each_ref().map(Vec::as_slice));
        let g = render_backward(&p, &args.take_state(), &to_host::<Self>(grad_image));
        let n = p.len();
        let [a, b, c, d, e, f, m] = grads_in_order(g);
        let up = |x: Vec<f32>, shape: burn::tensor::Shape| Self::float_from_data(TensorData::new(x, shape), &device);
        let [s0, s1, s2, s3, s4, s5] = shapes;
        (up(a, s0), up(b, s1), up(c, s2), up(d, s3), up(e, s4), up(f, s5), up(m, [n, 2].into()))
    }
}

#[cfg(feature = "flex")]
mod flex_impl {
    use burn::backend::Flex;
    use burn::backend::flex::FlexTensor;
    use lucid_burn::{flex_tensor, values};

    use super::{SplatOps, SplatRenderArgs, grads_in_order};
    use crate::project::SplatParams;
    use crate::render::{render, render_backward};

    impl SplatOps for Flex {
        fn splat_render(
            means: FlexTensor,
            log_scales: FlexTensor,
            rotations: FlexTensor,
            opacities: FlexTensor,
            sh_dc: FlexTensor,
            sh_rest: FlexTensor,
            _means_2d: FlexTensor,
            args: SplatRenderArgs,
        ) -> FlexTensor {
            let v = [&means, &log_scales, &rotations, &opacities, &sh_dc, &sh_rest].map(values);
            let p = SplatParams::from_kinds(v.each_ref().map(|c| &c[..]));
            let (image, state) = render(&p, &args.camera, &args.settings);
            args.keep(state);
            flex_tensor(image, [args.camera.height as usize, args.camera.width as usize, 4])
        }

        fn splat_render_backward(
            means: FlexTensor,
            log_scales: FlexTensor,
            rotations: FlexTensor,
            opacities: FlexTensor,
            sh_dc: FlexTensor,
            sh_rest: FlexTensor,
            grad_image: FlexTensor,
            args: SplatRenderArgs,
        ) -> (FlexTensor, FlexTensor, FlexTensor, FlexTensor, FlexTensor, FlexTensor, FlexTensor) {
            let v = [&means, &log_scales, &rotations, &opacities, &sh_dc, &sh_rest].map(values);
            let p = SplatParams::from_kinds(v.each_ref().map(|c| &c[..]));
            let g = render_backward(&p, &args.take_state(), &values(&grad_image));
            let n = p.len();
            let [ga, gb, gc, gd, ge, gf, gm] = grads_in_order(g);
            let shape = |t: &FlexTensor| t.layout().shape().clone();
            (
                flex_tensor(ga, shape(&means)),
                flex_tensor(gb, shape(&log_scales)),
                flex_tensor(gc, shape(&rotations)),
                flex_tensor(gd, shape(&opacities)),
                flex_tensor(ge, shape(&sh_dc)),
                flex_tensor(gf, shape(&sh_rest)),
                flex_tensor(gm, [n, 2]),
            )
        }
    }
}

#[cfg(feature = "ndarray")]
impl SplatOps for burn::backend::NdArray {}

#[cfg(feature = "wgpu")]
impl SplatOps for burn::backend::Cube {}

impl<B: Backend + SplatOps, C: CheckpointStrategy> SplatOps for Autodiff<B, C> {
    fn splat_render(
        means: FloatTensor<Self>,
        log_scales: FloatTensor<Self>,
        rotations: FloatTensor<Self>,
        opacities: FloatTensor<Self>,
        sh_dc: FloatTensor<Self>,
        sh_rest: FloatTensor<Self>,
        means_2d: FloatTensor<Self>,
        args: SplatRenderArgs,
    ) -> FloatTensor<Self> {
        #[derive(Debug)]
        struct SplatBackward;

        impl<B: Backend + SplatOps> Backward<B, 7> for SplatBackward {
            type State = ([FloatTensor<B>; 6], SplatRenderArgs);

            fn backward(self, ops: Ops<Self::State, 7>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
                let ([a, b, c, d, e, f], args) = ops.state;
                let grad_image = grads.consume::<B>(&ops.node);
                let (ga, gb, gc, gd, ge, gf, gm) = B::splat_render_backward(a, b, c, d, e, f, grad_image, args);
                for (node, g) in ops.parents.into_iter().zip([ga, gb, gc, gd, ge, gf, gm]) {
                    if let Some(node) = node {
                        grads.register::<B>(node.id, g);
                    }
                }
            }
        }

        let nodes = [
            means.node(),
            log_scales.node(),
            rotations.node(),
            opacities.node(),
            sh_dc.node(),
            sh_rest.node(),
            means_2d.node(),
        ];
        let p = [means, log_scales, rotations, opacities, sh_dc, sh_rest].map(|t| t.into_primitive());
        let m2 = means_2d.into_primitive();
        match SplatBackward.prepare::<C>(nodes).compute_bound().stateful() {
            OpsKind::Tracked(prep) => {
                let [a, b, c, d, e, f] = p.clone();
                let out = B::splat_render(a, b, c, d, e, f, m2, args.clone());
                prep.finish((p, args), out)
            }
            OpsKind::UnTracked(prep) => {
                let [a, b, c, d, e, f] = p;
                prep.finish(B::splat_render(a, b, c, d, e, f, m2, args))
            }
        }
    }

    fn splat_render_backward(
        means: FloatTensor<Self>,
        log_scales: FloatTensor<Self>,
        rotations: FloatTensor<Self>,
        opacities: FloatTensor<Self>,
        sh_dc: FloatTensor<Self>,
        sh_rest: FloatTensor<Self>,
        grad_image: FloatTensor<Self>,
        args: SplatRenderArgs,
    ) -> (
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
        FloatTensor<Self>,
    ) {
        // Second derivatives are not needed by any trainer: the results are constants.
        let (a, b, c, d, e, f, m) = B::splat_render_backward(
            means.into_primitive(),
            log_scales.into_primitive(),
            rotations.into_primitive(),
            opacities.into_primitive(),
            sh_dc.into_primitive(),
            sh_rest.into_primitive(),
            grad_image.into_primitive(),
            args,
        );
        (
            constant::<B, C>(a),
            constant::<B, C>(b),
            constant::<B, C>(c),
            constant::<B, C>(d),
            constant::<B, C>(e),
            constant::<B, C>(f),
            constant::<B, C>(m),
        )
    }
}

/// The parameters of a cloud as tensors (rows per Gaussian, as [`SplatParams`]).
#[derive(Clone, Debug)]
pub struct SplatTensors {
    /// `N×3`.
    pub means: Tensor<2>,
    /// `N×3`.
    pub log_scales: Tensor<2>,
    /// `N×4`.
    pub rotations: Tensor<2>,
    /// `N×1`.
    pub opacities: Tensor<2>,
    /// `N×3`.
    pub sh_dc: Tensor<2>,
    /// `N×45`.
    pub sh_rest: Tensor<2>,
}

/// Renders `cloud` from `args.camera`: `H×W×4` (RGB over the background, alpha),
/// differentiable with respect to every parameter and to `means_2d` (`N×2` zeros marked as
/// requiring a gradient, whose gradient is then the NDC gradient of each screen centre).
pub fn render_splats(cloud: &SplatTensors, means_2d: Tensor<2>, args: SplatRenderArgs) -> Tensor<3> {
    let out = <Dispatch as SplatOps>::splat_render(
        cloud.means.clone().into_dispatch(),
        cloud.log_scales.clone().into_dispatch(),
        cloud.rotations.clone().into_dispatch(),
        cloud.opacities.clone().into_dispatch(),
        cloud.sh_dc.clone().into_dispatch(),
        cloud.sh_rest.clone().into_dispatch(),
        means_2d.into_dispatch(),
        args,
    );
    Tensor::from_dispatch(out)
}
