//! The photometric loss ([`crate::photometric`]) as one custom burn autodiff operation on the
//! rendered `H×W×4` image: the forward computes the loss and its gradient together (the kernel
//! needs the same blurred maps for both) and keeps the gradient for the backward, which only
//! scales it. Other backends than flex run the kernel through a host round trip.

#![cfg_attr(feature = "ndarray", allow(deprecated))]

use std::sync::{Arc, Mutex};

use burn::backend::autodiff::checkpoint::{base::Checkpointer, strategy::CheckpointStrategy};
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::backend::{Autodiff, Backend, Dispatch, TensorMetadata, backend_extension, tensor::FloatTensor};
use burn::tensor::{Tensor, TensorData};
use lucid_burn::to_host;

use crate::photometric::{LossInputs, LossOutput, photometric_loss};

/// What the loss compares the image with, and where the forward leaves the gradient.
#[derive(Clone, Debug)]
pub struct LossArgs {
    /// The target, `H×W×3`.
    pub target: Arc<Vec<f32>>,
    /// Per-pixel weights, `H×W`.
    pub mask: Option<Arc<Vec<f32>>>,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// λ, the weight of the SSIM term.
    pub ssim_weight: f32,
    result: Arc<Mutex<Option<LossOutput>>>,
}

impl LossArgs {
    /// Arguments for one comparison.
    pub fn new(target: Vec<f32>, mask: Option<Vec<f32>>, width: usize, height: usize, ssim_weight: f32) -> Self {
        Self {
            target: Arc::new(target),
            mask: mask.map(Arc::new),
            width,
            height,
            ssim_weight,
            result: Arc::new(Mutex::new(None)),
        }
    }

    fn compute(&self, image: &[f32]) -> f32 {
        let out = photometric_loss(&LossInputs {
            image,
            target: &self.target,
            mask: self.mask.as_deref().map(Vec::as_slice),
            width: self.width,
            height: self.height,
            ssim_weight: self.ssim_weight,
        });
        let loss = out.loss;
        *self.result.lock().expect("loss lock") = Some(out);
        loss
    }

    /// The image's mean squared error against the target (after the forward ran).
    pub fn mse(&self) -> f32 {
        self.result.lock().expect("loss lock").as_ref().expect("the forward ran").mse
    }

    /// `scale · ∂loss/∂image`.
    fn scaled_grad(&self, scale: f32) -> Vec<f32> {
        let guard = self.result.lock().expect("loss lock");
        guard.as_ref().expect("the forward ran").grad.iter().map(|g| g * scale).collect()
    }
}

/// The photometric loss as backend operations.
#[backend_extension(
    Flex: cfg(feature = "flex"),
    NdArray: cfg(feature = "ndarray"),
    Cube: cfg(feature = "wgpu"),
    Autodiff,
)]
pub trait PhotometricOps: Backend {
    /// The loss of `image` (`H×W×4`), shape `[1]`.
    fn photometric_loss(image: FloatTensor<Self>, args: LossArgs) -> FloatTensor<Self> {
        let device = image.device();
        let loss = args.compute(&to_host::<Self>(image));
        Self::float_from_data(TensorData::new(vec![loss], [1]), &device)
    }

    /// `∂loss/∂image` scaled by the upstream gradient (`[1]`).
    fn photometric_loss_grad(grad_loss: FloatTensor<Self>, args: LossArgs) -> FloatTensor<Self> {
        let device = grad_loss.device();
        let g = args.scaled_grad(to_host::<Self>(grad_loss)[0]);
        Self::float_from_data(TensorData::new(g, [args.height, args.width, 4]), &device)
    }
}

#[cfg(feature = "flex")]
mod flex_impl {
    use burn::backend::Flex;
    use burn::backend::flex::FlexTensor;
    use lucid_burn::{flex_tensor, values};

    use super::{LossArgs, PhotometricOps};

    impl PhotometricOps for Flex {
        fn photometric_loss(image: FlexTensor, args: LossArgs) -> FlexTensor {
            flex_tensor(vec![args.compute(&values(&image))], [1])
        }

        fn photometric_loss_grad(grad_loss: FlexTensor, args: LossArgs) -> FlexTensor {
            let g = args.scaled_grad(values(&grad_loss)[0]);
            flex_tensor(g, [args.height, args.width, 4])
        }
    }
}

#[cfg(feature = "ndarray")]
impl PhotometricOps for burn::backend::NdArray {}

#[cfg(feature = "wgpu")]
impl PhotometricOps for burn::backend::Cube {}

impl<B: Backend + PhotometricOps, C: CheckpointStrategy> PhotometricOps for Autodiff<B, C> {
    fn photometric_loss(image: FloatTensor<Self>, args: LossArgs) -> FloatTensor<Self> {
        #[derive(Debug)]
        struct LossBackward;

        impl<B: Backend + PhotometricOps> Backward<B, 1> for LossBackward {
            type State = LossArgs;

            fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
                let args = ops.state;
                unary::<B, _>(ops.parents, ops.node, grads, |grad| B::photometric_loss_grad(grad, args));
            }
        }

        let node = image.node();
        let image = image.into_primitive();
        match LossBackward.prepare::<C>([node]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => {
                let out = B::photometric_loss(image, args.clone());
                prep.finish(args, out)
            }
            OpsKind::UnTracked(prep) => prep.finish(B::photometric_loss(image, args)),
        }
    }

    fn photometric_loss_grad(grad_loss: FloatTensor<Self>, args: LossArgs) -> FloatTensor<Self> {
        // No trainer needs second derivatives.
        lucid_burn::constant::<B, C>(B::photometric_loss_grad(grad_loss.into_primitive(), args))
    }
}

/// `(1 − λ)·L1 + λ·(1 − SSIM)` of a rendered `H×W×4` image (RGB compared, alpha ignored)
/// against `args.target`, differentiable with respect to the image.
pub fn image_loss(image: Tensor<3>, args: LossArgs) -> Tensor<1> {
    Tensor::from_dispatch(<Dispatch as PhotometricOps>::photometric_loss(image.into_dispatch(), args))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Through burn's autodiff the op's gradient is the kernel's, scaled by the upstream one.
    #[test]
    fn the_op_differentiates_through_autodiff() {
        let (w, h) = (9, 7);
        let image: Vec<f32> = (0..w * h * 4).map(|k| ((k * 29) % 53) as f32 / 53.0).collect();
        let target: Vec<f32> = (0..w * h * 3).map(|k| ((k * 31) % 47) as f32 / 47.0).collect();
        let device = lucid_burn::backend::training_device();
        let t = Tensor::<3>::from_data(TensorData::new(image.clone(), [h, w, 4]), &device).require_grad();
        let args = LossArgs::new(target.clone(), None, w, h, 0.2);
        let loss = image_loss(t.clone(), args.clone()) * 3.0;
        let grads = loss.backward();
        let got = t.grad(&grads).unwrap().into_data().try_to_vec::<f32>().unwrap();
        let want = photometric_loss(&LossInputs {
            image: &image,
            target: &target,
            mask: None,
            width: w,
            height: h,
            ssim_weight: 0.2,
        });
        for (g, e) in got.iter().zip(&want.grad) {
            assert!((g - 3.0 * e).abs() < 1e-7, "{g} vs {}", 3.0 * e);
        }
        assert!((args.mse() - want.mse).abs() < 1e-9);
    }
}
