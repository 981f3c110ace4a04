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
    // Each chunk of splats writes its own rows of every gradient array, in parallel.
    const CHUNK: usize = 512;
    let screen = &screen;
    grads
        .means
        .par_chunks_mut(3 * CHUNK)
        .zip(grads.log_scales.par_chunks_mut(3 * CHUNK))
        .zip(grads.rotations.par_chunks_mut(4 * CHUNK))
        .zip(grads.opacities.par_chunks_mut(CHUNK))
        .zip(grads.sh_dc.par_chunks_mut(3 * CHUNK))
        .zip(grads.sh_rest.par_chunks_mut(SH_REST * CHUNK))
        .zip(grads.means_2d.par_chunks_mut(2 * CHUNK))
        .enumerate()
        .for_each(|(c, ((((((means, log_scales), rotations), opacities), sh_dc), sh_rest), means_2d))| {
            for j in 0..opacities.len() {
                let i = c * CHUNK + j;
                if state.projected[i].radius <= 0.0 {
                    continue;
                }
                let g = project_backward_one(params, i, cam, &state.settings, &screen[i]);
                means[3 * j..3 * j + 3].copy_from_slice(&g.mean.to_array());
                log_scales[3 * j..3 * j + 3].copy_from_slice(&g.log_scale.to_array());
                rotations[4 * j..4 * j + 4].copy_from_slice(&g.rotation);
                opacities[j] = g.opacity;
                sh_dc[3 * j..3 * j + 3].copy_from_slice(&g.sh[0].to_array());
                for k in 1..SH_COEFFS {
                    let o = SH_REST * j + 3 * (k - 1);
                    sh_rest[o..o + 3].copy_from_slice(&g.sh[k].to_array());
                }
                means_2d[2 * j] = screen[i].mean.x * 0.5 * w as f32;
                means_2d[2 * j + 1] = screen[i].mean.y * 0.5 * h as f32;
            }
        });
    grads
}
