//! Rendering a relightable cloud: the frozen geometry composited by the splat op with each
//! Gaussian's colour taken from the head (passed as degree-0 SH, which the op turns back into
//! exactly that colour).
//!
//! For fixed geometry, alpha compositing is linear in the colours, so the view under a sum of
//! lights is the render of the summed per-Gaussian radiances: an environment map is
//! integrated per Gaussian over a set of light directions (weights from
//! [`lucid_relight::transport::light_weights`]) before one render, not by summing renders.

use burn::tensor::{Device, Tensor, TensorData};
use glam::Vec3;
use lucid_image::Image;
use lucid_scene::PinholeCamera;
use lucid_splat::camera::SplatCamera;
use lucid_splat::cloud::SplatCloud;
use lucid_splat::ops::{SplatRenderArgs, SplatTensors, render_splats};
use lucid_splat::project::{RenderSettings, SH_REST};
use lucid_splat::sh::C0;

use crate::config::RelightConfig;
use crate::head::{RelightHead, encoding_tensor};

/// The frozen geometry as tensors on one device.
#[derive(Clone, Debug)]
pub struct Geometry {
    /// The Gaussians (their colours unused).
    pub cloud: SplatCloud,
    /// Projection settings (degree 0, black background).
    pub settings: RenderSettings,
    means: Tensor<2>,
    log_scales: Tensor<2>,
    rotations: Tensor<2>,
    opacities: Tensor<2>,
    sh_rest: Tensor<2>,
}

fn tensor(values: &[f32], width: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values.to_vec(), [values.len() / width, width]), device)
}

impl Geometry {
    /// The cloud's geometry on `device`, rendered with `settings` (its SH degree and
    /// background are replaced by 0 and black).
    pub fn new(cloud: SplatCloud, settings: RenderSettings, device: &Device) -> Self {
        let settings = RenderSettings { sh_degree: 0, background: [0.0; 3], ..settings };
        let n = cloud.len();
        Self {
            means: tensor(&cloud.means, 3, device),
            log_scales: tensor(&cloud.log_scales, 3, device),
            rotations: tensor(&cloud.rotations, 4, device),
            opacities: tensor(&cloud.opacities, 1, device),
            sh_rest: Tensor::zeros([n, SH_REST], device),
            cloud,
            settings,
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.cloud.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.cloud.is_empty()
    }

    /// Unit directions from the camera centre to each Gaussian.
    pub fn view_directions(&self, camera: &PinholeCamera) -> Vec<Vec3> {
        let eye = camera.position();
        self.cloud
            .means
            .chunks_exact(3)
            .map(|m| (Vec3::from_slice(m) - eye).try_normalize().unwrap_or(Vec3::Z))
            .collect()
    }

    /// Renders the Gaussians with colours `N×3` (linear radiance): `H×W×4`, RGB premultiplied
    /// (over black) then alpha; differentiable with respect to the colours.
    pub fn render(&self, colours: Tensor<2>, camera: &PinholeCamera) -> Tensor<3> {
        let device = colours.device();
        let tensors = SplatTensors {
            means: self.means.clone(),
            log_scales: self.log_scales.clone(),
            rotations: self.rotations.clone(),
            opacities: self.opacities.clone(),
            sh_dc: (colours - 0.5) / C0,
            sh_rest: self.sh_rest.clone(),
        };
        let args = SplatRenderArgs::new(SplatCamera::from_pinhole(camera), self.settings);
        render_splats(&tensors, Tensor::zeros([self.len(), 2], &device), args)
    }
}

/// A rendered `H×W×4` tensor as an image with straight alpha (the dataset's convention).
pub fn to_image(rendered: Tensor<3>) -> Image {
    let [h, w, _] = rendered.dims();
    let v = lucid_burn::to_host_tensor(rendered);
    Image::from_fn(w, h, |x, y| {
        let p = &v[4 * (y * w + x)..4 * (y * w + x) + 4];
        let a = p[3];
        let s = |c: f32| if a > 1e-6 { c / a } else { 0.0 };
        [s(p[0]), s(p[1]), s(p[2]), a]
    })
}

/// Each Gaussian's radiance towards `camera` under light from every direction in `dirs`
/// with per-channel weights `weights` (units of one OLAT light): `Σⱼ wⱼ·head(ωⱼ)`, `N×3`.
pub fn integrated_radiance(
    head: &RelightHead,
    config: &RelightConfig,
    geometry: &Geometry,
    camera: &PinholeCamera,
    dirs: &[Vec3],
    weights: &[[f32; 3]],
    device: &Device,
) -> Tensor<2> {
    let view = encoding_tensor(&geometry.view_directions(camera), config.head.view_degree, device);
    let free = head.light_free(view, config.feature_scale());
    let mut sum = Tensor::<2>::zeros([geometry.len(), 3], device);
    for (d, w) in dirs.iter().zip(weights) {
        if w.iter().all(|&v| v == 0.0) {
            continue;
        }
        let radiance = head.decode(free.clone(), encoding_tensor(&[*d], config.head.light_degree, device));
        let w = Tensor::<2>::from_data(TensorData::new(w.to_vec(), [1, 3]), device);
        sum = sum + radiance * w;
    }
    sum
}
