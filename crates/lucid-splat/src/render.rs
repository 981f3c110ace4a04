//! One view of a splat cloud: projection, binning and rasterization, and the backward from
//! `∂loss/∂image` to every parameter.

use rayon::prelude::*;

use crate::camera::SplatCamera;
use crate::project::{ProjectedSplat, RenderSettings, SH_REST, SplatParams, project_backward_one, project_one};
use crate::raster::{PixelState, TileBins, bin, rasterize, rasterize_backward};
use crate::sh::SH_COEFFS;

/// What a forward pass leaves for its backward.
#[derive(Clone, Debug)]
pub struct RenderState {
    /// The camera.
    pub camera: SplatCamera,
    /// The settings.
    pub settings: RenderSettings,
    /// Every splat on screen (culled ones have radius 0).
    pub projected: Vec<ProjectedSplat>,
    /// Per-tile lists.
    pub bins: TileBins,
    /// Per-pixel transmittance and contributor counts.
    pub pixels: PixelState,
}

/// Renders `params` from `camera`: the `H×W×4` image (RGB over the background, alpha) and the
/// state for [`render_backward`].
pub fn render(params: &SplatParams, camera: &SplatCamera, settings: &RenderSettings) -> (Vec<f32>, RenderState) {
    params.check();
    let projected: Vec<ProjectedSplat> =
        (0..params.len()).into_par_iter().map(|i| project_one(params, i, camera, settings)).collect();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let bins = bin(&projected, w, h);
    let (image, pixels) = rasterize(&projected, &bins, w, h, settings.background, settings.min_alpha);
    (image, RenderState { camera: *camera, settings: *settings, projected, bins, pixels })
}

/// Gradients of every parameter, in the layout of [`SplatParams`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplatGrads {
    /// `N×3`.
    pub means: Vec<f32>,
    /// `N×3`.
    pub log_scales: Vec<f32>,
    /// `N×4`.
    pub rotations: Vec<f32>,
    /// `N`.
    pub opacities: Vec<f32>,
    /// `N×3`.
    pub sh_dc: Vec<f32>,
    /// `N×45`.
    pub sh_rest: Vec<f32>,
    /// `N×2`: `∂loss/∂` the screen centre in normalised device coordinates (pixels scaled by
    /// `2/W`, `2/H`), the statistic densification thresholds.
    pub means_2d: Vec<f32>,
}

/// `∂loss/∂parameters` from `∂loss/∂image` (`H×W×4`, RGB then alpha).
pub fn render_backward(params: &SplatParams, state: &RenderState, grad_image: &[f32]) -> SplatGrads {
    let cam = &state.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let screen = rasterize_backward(
        &state.projected,
        &state.bins,
        &state.pixels,
        w,
        h,
        state.settings.background,
        state.settings.min_alpha,
        grad_image,
    );
    let n = params.len();
    let mut grads = SplatGrads {
        means: vec![0.0; 3 * n],
        log_scales: vec![0.0; 3 * n],
        rotations: vec![0.0; 4 * n],
        opacities: vec![0.0; n],
        sh_dc: vec![0.0; 3 * n],
        sh_rest: vec![0.0; SH_REST * n],
        means_2d: vec![0.0; 2 * n],
    };
    let per_splat: Vec<_> = (0..n)
        .into_par_iter()
        .map(|i| {
            if state.projected[i].radius <= 0.0 {
                return None;
            }
            Some(project_backward_one(params, i, cam, &state.settings, &screen[i]))
        })
        .collect();
    for (i, g) in per_splat.into_iter().enumerate() {
        let Some(g) = g else { continue };
        grads.means[3 * i..3 * i + 3].copy_from_slice(&g.mean.to_array());
        grads.log_scales[3 * i..3 * i + 3].copy_from_slice(&g.log_scale.to_array());
        grads.rotations[4 * i..4 * i + 4].copy_from_slice(&g.rotation);
        grads.opacities[i] = g.opacity;
        grads.sh_dc[3 * i..3 * i + 3].copy_from_slice(&g.sh[0].to_array());
        for k in 1..SH_COEFFS {
            let o = SH_REST * i + 3 * (k - 1);
            grads.sh_rest[o..o + 3].copy_from_slice(&g.sh[k].to_array());
        }
        grads.means_2d[2 * i] = screen[i].mean.x * 0.5 * w as f32;
        grads.means_2d[2 * i + 1] = screen[i].mean.y * 0.5 * h as f32;
    }
    grads
}
