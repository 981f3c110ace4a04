//! Merging an exposure stack into scene radiance with a known response.

use lucid_image::Image;
use rayon::prelude::*;

use crate::response::ResponseCurve;
use crate::stack::{ExposureStack, hat_weight};

/// Radiance of every pixel: the hat-weighted mean over frames of `g(Z_j) − ln Δt_j` in the
/// log domain (Debevec and Malik's equation 6), exponentiated. Where every frame is clipped
/// or black (all weights 0) the best-placed frame decides: the shortest exposure for
/// saturated pixels, the longest for dark ones. Alpha is 1.
pub fn merge_radiance(stack: &ExposureStack, curve: &ResponseCurve) -> Image {
    let (w, h) = (stack.width(), stack.height());
    let order = stack.by_time();
    let (shortest, longest) = (order[0], order[order.len() - 1]);
    let log_times: Vec<f32> = stack.times().iter().map(|t| t.ln()).collect();
    let mut pixels = vec![[0.0f32; 4]; w * h];
    pixels.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let i = y * w + x;
            for (c, v) in out.iter_mut().take(3).enumerate() {
                let (mut num, mut den) = (0.0f32, 0.0f32);
                for (j, lt) in log_times.iter().enumerate() {
                    let z = stack.code(j, i, c);
                    let wgt = hat_weight(z);
                    num += wgt * (curve.log_exposure[c][z as usize] - lt);
                    den += wgt;
                }
                let log_e = if den > 0.0 {
                    num / den
                } else {
                    // All codes are 0 or 255: 255 in the shortest frame means brighter than
                    // anything measurable, 0 in the longest means darker.
                    let j = if stack.code(shortest, i, c) == 255 { shortest } else { longest };
                    curve.log_exposure[c][stack.code(j, i, c) as usize] - log_times[j]
                };
                *v = log_e.exp();
            }
            out[3] = 1.0;
        }
    });
    Image::from_pixels(w, h, pixels)
}
