//! The relighting head: a feature vector per Gaussian and a small MLP decoding it, with the
//! light and viewing directions, into the Gaussian's radiance under one directional light of
//! the dataset's irradiance.
//!
//! The first layer is the sum of three linear maps — of the features, of the SH encoding of
//! the viewing direction (per Gaussian) and of the SH encoding of the light direction (one
//! row, broadcast) — which is a linear layer on their concatenation without building it.
//! Softplus keeps the radiance positive, so the rasterizer's clamp at zero never cuts the
//! gradient.
//!
//! The features are stored divided by a scale `s` (`feature_learning_rate / learning_rate`)
//! and multiplied by it when used: Adam moves every stored value by about the learning rate,
//! so the features move `s` times as fast as the decoder's weights with one optimiser.

use burn::module::{Module, Param};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::{relu, softplus};
use burn::tensor::{Device, Distribution, Tensor, TensorData};
use glam::Vec3;
use lucid_splat::sh::{basis, coeffs_for_degree};

use crate::config::{HeadConfig, RelightConfig};

/// The head's parameters.
#[derive(Module, Debug)]
pub struct RelightHead {
    /// `N×F` features, one row per Gaussian.
    pub features: Param<Tensor<2>>,
    feature_in: Linear,
    view_in: Linear,
    light_in: Linear,
    hidden: Vec<Linear>,
    out: Linear,
}

/// The SH encoding of unit directions, `n×(degree+1)²`, row-major.
pub fn encode_directions(dirs: &[Vec3], degree: usize) -> Vec<f32> {
    let k = coeffs_for_degree(degree);
    dirs.iter().flat_map(|d| basis(*d, degree).into_iter().take(k)).collect()
}

impl RelightHead {
    /// A fresh head for `gaussians` Gaussians (draws from the device's generator: seed it).
    pub fn new(config: &RelightConfig, gaussians: usize, device: &Device) -> Self {
        let scale = config.feature_scale() as f64;
        let config: &HeadConfig = &config.head;
        let h = config.hidden;
        let linear = |i: usize, o: usize, bias: bool| LinearConfig::new(i, o).with_bias(bias).init(device);
        let features =
            Tensor::<2>::random([gaussians, config.features], Distribution::Normal(0.0, 0.1 / scale), device);
        Self {
            features: Param::from_tensor(features),
            feature_in: linear(config.features, h, true),
            view_in: linear(coeffs_for_degree(config.view_degree), h, false),
            light_in: linear(coeffs_for_degree(config.light_degree), h, false),
            hidden: (1..config.layers).map(|_| linear(h, h, true)).collect(),
            out: linear(h, 3, true),
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.features.val().dims()[0]
    }

    /// Whether the head has no Gaussians.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The part of the first layer that does not depend on the light: `N×hidden`
    /// (`feature_scale`: [`RelightConfig::feature_scale`]).
    pub fn light_free(&self, view_encoding: Tensor<2>, feature_scale: f32) -> Tensor<2> {
        self.feature_in.forward(self.features.val() * feature_scale) + self.view_in.forward(view_encoding)
    }

    /// Radiance `N×3` of every Gaussian under a light whose direction's encoding is
    /// `light_encoding` (`1×(degree+1)²`), given [`Self::light_free`].
    pub fn decode(&self, light_free: Tensor<2>, light_encoding: Tensor<2>) -> Tensor<2> {
        let mut x = relu(light_free + self.light_in.forward(light_encoding));
        for layer in &self.hidden {
            x = relu(layer.forward(x));
        }
        softplus(self.out.forward(x), 1.0)
    }

    /// Radiance `N×3` of every Gaussian seen along `view_dirs` (one unit vector per Gaussian,
    /// camera to Gaussian) under a light from `light`.
    pub fn radiance(&self, config: &RelightConfig, view_dirs: &[Vec3], light: Vec3, device: &Device) -> Tensor<2> {
        let free = self.light_free(encoding_tensor(view_dirs, config.head.view_degree, device), config.feature_scale());
        self.decode(free, encoding_tensor(&[light], config.head.light_degree, device))
    }
}

/// [`encode_directions`] as a tensor.
pub fn encoding_tensor(dirs: &[Vec3], degree: usize, device: &Device) -> Tensor<2> {
    let k = coeffs_for_degree(degree);
    Tensor::from_data(TensorData::new(encode_directions(dirs, degree), [dirs.len(), k]), device)
}
