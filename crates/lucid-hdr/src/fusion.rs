//! Mertens, Kautz and Van Reeth's exposure fusion (2007): the stack blended straight into one
//! display image, weighting each frame per pixel by contrast, saturation and
//! well-exposedness, in a Laplacian pyramid so that the seams of the weights do not show.
//! No response curve and no exposure times are needed.

use lucid_image::Image;
use lucid_image::color::srgb_decode_fast;

use rayon::prelude::*;

use crate::blur::Plane;
use crate::pyramid::{collapse, expand_rows, fill_gaussian_pyramid, levels_for, mirror, pyramid_sizes};
use crate::stack::ExposureStack;

/// Exponents of the three quality measures (the paper's `ω_C`, `ω_S`, `ω_E`; 1 each by
/// default) and the spread of well-exposedness around mid-grey.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusionSettings {
    /// Weight of local contrast (absolute Laplacian of the grey image).
    pub contrast: f32,
    /// Weight of saturation (standard deviation of R, G, B).
    pub saturation: f32,
    /// Weight of well-exposedness (a Gaussian around 0.5 per channel).
    pub exposedness: f32,
    /// σ of the well-exposedness Gaussian.
    pub sigma: f32,
}

impl Default for FusionSettings {
    fn default() -> Self {
        Self { contrast: 1.0, saturation: 1.0, exposedness: 1.0, sigma: 0.2 }
    }
}

/// The fused image, display-referred (sRGB-encoded values in `[0,1]` of the files),
/// returned linearised like every LDR image read from a file.
///
/// The definitions are OpenCV's `MergeMertens` (the reference implementation users compare
/// against): contrast is the absolute 3×3 Laplacian of the Rec. 601 luma with mirrored edges,
/// saturation the spread of R, G, B about their mean, well-exposedness a Gaussian about 0.5 per
/// channel, and the pyramids go down to one or two pixels with OpenCV's edge rules.
pub fn mertens(stack: &ExposureStack, settings: FusionSettings) -> Image {
    let (w, h) = (stack.width(), stack.height());
    let n = stack.len();
    let mut grey = vec![0.0f32; w * h];
    let mut weights: Vec<Plane> = (0..n).map(|k| quality(stack, k, &settings, &mut grey)).collect();
    let sums = Plane::from_fn(w, h, |i| weights.iter().map(|p| p.data[i]).sum());
    for p in &mut weights {
        p.data.par_iter_mut().zip(&sums.data).for_each(|(v, s)| *v /= s);
    }
    drop(sums);
    let levels = levels_for(w, h);
    let planes =
        || -> Vec<Plane> { pyramid_sizes(w, h, levels).into_iter().map(|(a, b)| Plane::filled(a, b, 0.0)).collect() };
    // The blend Σ_k L(I_k)·G(W_k), level by level; each band is added where it is formed, and
    // the pyramids of one frame's channel and weight reuse the same buffers frame after frame.
    let mut blended: [Vec<Plane>; 3] = std::array::from_fn(|_| planes());
    let (mut g, mut gw) = (planes(), planes());
    for (k, mut weight) in weights.into_iter().enumerate() {
        std::mem::swap(&mut gw[0], &mut weight);
        fill_gaussian_pyramid(&mut gw);
        let codes = stack.frame(k);
        for (c, acc) in blended.iter_mut().enumerate() {
            g[0].data.par_iter_mut().zip(codes).for_each(|(v, code)| *v = value(code[c]));
            fill_gaussian_pyramid(&mut g);
            for l in 0..levels - 1 {
                let (fine, wt) = (&g[l], &gw[l]);
                expand_rows(&g[l + 1], fine.width, fine.height, &mut acc[l].data, |y, dst, up| {
                    let row = y * fine.width..(y + 1) * fine.width;
                    for (((d, u), f), t) in dst.iter_mut().zip(up).zip(&fine.data[row.clone()]).zip(&wt.data[row]) {
                        *d += (f - u) * t;
                    }
                });
            }
            let (top, wt) = (&g[levels - 1], &gw[levels - 1]);
            acc[levels - 1].data.par_iter_mut().zip(&top.data).zip(&wt.data).for_each(|((d, v), t)| *d += v * t);
        }
    }
    drop((g, gw));
    let fused = blended.map(collapse);
    let pixels = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let v = |c: usize| srgb_decode_fast(fused[c].data[i]);
            [v(0), v(1), v(2), 1.0]
        })
        .collect();
    Image::from_pixels(w, h, pixels)
}

/// `x^e`, exact and free for the default exponent of 1 (`powf` is most of the weights' cost).
fn power(x: f32, e: f32) -> f32 {
    if e == 1.0 { x } else { x.powf(e) }
}

/// A code as a value in `[0,1]`, multiplied by a rounded 1/255 as OpenCV's `convertTo` does
/// (dividing rounds differently for some codes, and the weights are sensitive enough to show
/// it: up to 3e-3 in the fused image).
fn value(code: u8) -> f32 {
    code as f32 * (1.0 / 255.0)
}

/// Rec. 601 luma, as OpenCV's `COLOR_RGB2GRAY` weighs the channels.
const LUMA: [f32; 3] = [0.299, 0.587, 0.114];

/// Luma rounded as OpenCV's vectorised `cvtColor` rounds it, `fma(b, c_b, fma(r, c_r, g·c_g))`:
/// contrast is a difference of nearly equal lumas on smooth ground, so each rounding shows in
/// the weights. `f32::mul_add` is a library call without target FMA; an `f32` product is exact
/// in `f64`, so one `f64` sum rounded once to `f32` is the fused result (double rounding aside,
/// about one case in 2^29).
fn luma(r: f32, g: f32, b: f32) -> f32 {
    let fma = |a: f32, x: f32, c: f32| (a as f64 * x as f64 + c as f64) as f32;
    fma(b, LUMA[2], fma(r, LUMA[0], g * LUMA[1]))
}

/// Frame `k`'s weight per pixel: contrast × saturation × well-exposedness (each raised to its
/// exponent), plus a tiny floor so that a pixel every frame rates zero still averages them.
fn quality(stack: &ExposureStack, k: usize, settings: &FusionSettings, grey: &mut [f32]) -> Plane {
    let (w, h) = (stack.width(), stack.height());
    let codes = stack.frame(k);
    grey.par_iter_mut().zip(codes).for_each(|(v, code)| {
        let [r, g, b] = code.map(value);
        *v = luma(r, g, b);
    });
    let grey = &*grey;
    // Well-exposedness per channel depends on the code alone: one table, and the product of
    // three entries in OpenCV's order.
    let two_var = 2.0 * settings.sigma * settings.sigma;
    let exposed: [f32; 256] = std::array::from_fn(|code| {
        let d = value(code as u8) - 0.5;
        (-(d * d) / two_var).exp()
    });
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        let line = |yy: usize| &grey[yy * w..(yy + 1) * w];
        // Mirrored edges without repeating the edge pixel (OpenCV's default border, as the
        // pyramids have it).
        let (up, here, down) = (line(mirror(y as isize - 1, h)), line(y), line(mirror(y as isize + 1, h)));
        for (x, out) in row.iter_mut().enumerate() {
            let (left, right) = (here[mirror(x as isize - 1, w)], here[mirror(x as isize + 1, w)]);
            // Summed in OpenCV's kernel order, which is exact on flat ground: there the
            // contrast must be 0, not a rounding error that outweighs the 1e-12 floor.
            let contrast = (up[x] + left - 4.0 * here[x] + right + down[x]).abs();
            let v = codes[y * w + x].map(value);
            let mean = (v[0] + v[1] + v[2]) / 3.0;
            // √3 times the standard deviation, as OpenCV has it: normalising cancels the factor.
            let saturation = v.iter().map(|c| (c - mean) * (c - mean)).sum::<f32>().sqrt();
            let [r, g, b] = codes[y * w + x].map(|c| exposed[c as usize]);
            let exposedness = r * g * b;
            *out = power(contrast, settings.contrast)
                * power(saturation, settings.saturation)
                * power(exposedness, settings.exposedness)
                + 1e-12;
        }
    });
    Plane { width: w, height: h, data: out }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pyramid::{gaussian_pyramid, laplacian_pyramid};
    use lucid_image::color::srgb_decode;

    /// The fusion written from its definition: weights pixel by pixel with every exponent
    /// applied, whole Laplacian pyramids per frame and channel, summed, then collapsed.
    fn reference(stack: &ExposureStack, settings: FusionSettings) -> Image {
        let (w, h) = (stack.width(), stack.height());
        let n = stack.len();
        let value = |k: usize, i: usize, c: usize| super::value(stack.code(k, i, c));
        let mut weights: Vec<Plane> = (0..n)
            .map(|k| {
                let grey = Plane::from_fn(w, h, |i| luma(value(k, i, 0), value(k, i, 1), value(k, i, 2)));
                Plane::from_fn(w, h, |i| {
                    let (x, y) = ((i % w) as isize, (i / w) as isize);
                    let at = |dx: isize, dy: isize| grey.at(mirror(x + dx, w), mirror(y + dy, h));
                    let contrast = (at(0, -1) + at(-1, 0) - 4.0 * at(0, 0) + at(1, 0) + at(0, 1)).abs();
                    let rgb = [value(k, i, 0), value(k, i, 1), value(k, i, 2)];
                    let mean = (rgb[0] + rgb[1] + rgb[2]) / 3.0;
                    let saturation = rgb.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>().sqrt();
                    let exposedness: f32 = rgb
                        .iter()
                        .map(|v| (-(v - 0.5) * (v - 0.5) / (2.0 * settings.sigma * settings.sigma)).exp())
                        .product();
                    contrast.powf(settings.contrast)
                        * saturation.powf(settings.saturation)
                        * exposedness.powf(settings.exposedness)
                        + 1e-12
                })
            })
            .collect();
        for i in 0..w * h {
            let sum: f32 = weights.iter().map(|p| p.data[i]).sum();
            for p in &mut weights {
                p.data[i] /= sum;
            }
        }
        let levels = levels_for(w, h);
        let weight_pyramids: Vec<Vec<Plane>> = weights.into_iter().map(|p| gaussian_pyramid(p, levels)).collect();
        let channels: Vec<Plane> = (0..3)
            .map(|c| {
                let mut acc: Vec<Plane> =
                    weight_pyramids[0].iter().map(|g| Plane::filled(g.width, g.height, 0.0)).collect();
                for (k, wp) in weight_pyramids.iter().enumerate() {
                    let lap = laplacian_pyramid(Plane::from_fn(w, h, |i| value(k, i, c)), levels);
                    for ((a, l), g) in acc.iter_mut().zip(&lap).zip(wp) {
                        for ((d, x), y) in a.data.iter_mut().zip(&l.data).zip(&g.data) {
                            *d += x * y;
                        }
                    }
                }
                collapse(acc)
            })
            .collect();
        Image::from_fn(w, h, |x, y| {
            let v = |c: usize| srgb_decode(channels[c].data[y * w + x].clamp(0.0, 1.0));
            [v(0), v(1), v(2), 1.0]
        })
    }

    /// A bracket of a smooth gradient with texture, at an odd size.
    fn stack() -> ExposureStack {
        let (w, h) = (53, 37);
        let times = vec![0.25, 1.0, 4.0];
        let codes = times
            .iter()
            .map(|&t| {
                (0..w * h)
                    .map(|i| {
                        let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                        let l = 10f32.powf(-1.5 + 2.5 * x) * (1.0 + 0.3 * ((i * 7919 % 13) as f32 / 13.0));
                        [l, l * (0.4 + 0.6 * y), l * (1.0 - 0.5 * y)]
                            .map(|v| (lucid_image::color::srgb_encode((v * t).min(1.0)) * 255.0).round() as u8)
                    })
                    .collect()
            })
            .collect();
        ExposureStack::from_codes(w, h, codes, times).unwrap()
    }

    #[test]
    fn the_fast_fusion_is_the_reference_fusion() {
        let s = stack();
        for settings in
            [FusionSettings::default(), FusionSettings { contrast: 0.5, saturation: 2.0, exposedness: 1.5, sigma: 0.3 }]
        {
            let (fast, slow) = (mertens(&s, settings), reference(&s, settings));
            let worst = fast
                .pixels()
                .iter()
                .zip(slow.pixels())
                .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-5, "{settings:?}: differs by up to {worst}");
        }
    }
}
