//! Mertens, Kautz and Van Reeth's exposure fusion (2007): the stack blended straight into one
//! display image, weighting each frame per pixel by contrast, saturation and
//! well-exposedness, in a Laplacian pyramid so that the seams of the weights do not show.
//! No response curve and no exposure times are needed.

use lucid_image::Image;
use lucid_image::color::srgb_decode;

use rayon::prelude::*;

use crate::blur::Plane;
use crate::pyramid::{collapse, gaussian_pyramid, laplacian_pyramid, levels_for};
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
pub fn mertens(stack: &ExposureStack, settings: FusionSettings) -> Image {
    let (w, h) = (stack.width(), stack.height());
    let n = stack.len();
    // Codes to values once per frame, planar per channel: the pyramids read them row by row.
    let channels: Vec<[Plane; 3]> =
        (0..n).map(|k| std::array::from_fn(|c| Plane::from_fn(w, h, |i| stack.code(k, i, c) as f32 / 255.0))).collect();
    let mut weights: Vec<Plane> = channels.iter().map(|rgb| quality(rgb, &settings)).collect();
    // Normalise per pixel.
    let sums = Plane::from_fn(w, h, |i| weights.iter().map(|p| p.data[i]).sum());
    for p in &mut weights {
        p.data.par_iter_mut().zip(&sums.data).for_each(|(v, s)| *v /= s);
    }
    let levels = levels_for(w, h);
    let weight_pyramids: Vec<Vec<Plane>> = weights.iter().map(|p| gaussian_pyramid(p, levels)).collect();
    let fused: Vec<Plane> = (0..3)
        .map(|c| {
            let mut blended: Option<Vec<Plane>> = None;
            for (rgb, wp) in channels.iter().zip(&weight_pyramids) {
                let mut lap = laplacian_pyramid(&rgb[c], levels);
                match &mut blended {
                    None => {
                        for (l, g) in lap.iter_mut().zip(wp) {
                            l.data.par_iter_mut().zip(&g.data).for_each(|(a, b)| *a *= b);
                        }
                        blended = Some(lap);
                    }
                    Some(acc) => {
                        for ((a, l), g) in acc.iter_mut().zip(&lap).zip(wp) {
                            a.data.par_iter_mut().zip(&l.data).zip(&g.data).for_each(|((d, x), y)| *d += x * y);
                        }
                    }
                }
            }
            collapse(&blended.expect("at least one frame"))
        })
        .collect();
    let pixels = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let v = |c: usize| srgb_decode(fused[c].data[i].clamp(0.0, 1.0));
            [v(0), v(1), v(2), 1.0]
        })
        .collect();
    Image::from_pixels(w, h, pixels)
}

/// `x^e`, exact and free for the default exponent of 1 (`powf` is most of the weights' cost).
fn power(x: f32, e: f32) -> f32 {
    if e == 1.0 { x } else { x.powf(e) }
}

/// One frame's weight per pixel: contrast × saturation × well-exposedness (each raised to its
/// exponent), plus a tiny floor so that a pixel every frame rates zero still averages them.
fn quality(rgb: &[Plane; 3], settings: &FusionSettings) -> Plane {
    let (w, h) = (rgb[0].width, rgb[0].height);
    let grey = Plane::from_fn(w, h, |i| (rgb[0].data[i] + rgb[1].data[i] + rgb[2].data[i]) / 3.0);
    let spread = -1.0 / (2.0 * settings.sigma * settings.sigma);
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        let line = |yy: usize| &grey.data[yy * w..(yy + 1) * w];
        let (up, here, down) = (line(y.saturating_sub(1)), line(y), line((y + 1).min(h - 1)));
        for (x, out) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let (left, right) = (here[x.saturating_sub(1)], here[(x + 1).min(w - 1)]);
            let contrast = (left + right + up[x] + down[x] - 4.0 * here[x]).abs();
            let v = [rgb[0].data[i], rgb[1].data[i], rgb[2].data[i]];
            let mean = (v[0] + v[1] + v[2]) / 3.0;
            let saturation = (v.iter().map(|c| (c - mean) * (c - mean)).sum::<f32>() / 3.0).sqrt();
            // One exponential of the summed exponents rather than a product of three.
            let exposedness = (spread * v.iter().map(|c| (c - 0.5) * (c - 0.5)).sum::<f32>()).exp();
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

    /// The fusion as first written, pixel by pixel with every exponent applied: the
    /// definition the fast version must reproduce.
    fn reference(stack: &ExposureStack, settings: FusionSettings) -> Image {
        let (w, h) = (stack.width(), stack.height());
        let n = stack.len();
        let value = |k: usize, i: usize, c: usize| stack.code(k, i, c) as f32 / 255.0;
        let mut weights: Vec<Plane> = (0..n)
            .map(|k| {
                let grey = Plane::from_fn(w, h, |i| (value(k, i, 0) + value(k, i, 1) + value(k, i, 2)) / 3.0);
                Plane::from_fn(w, h, |i| {
                    let (x, y) = (i % w, i / w);
                    let at = |dx: isize, dy: isize| {
                        let xx = (x as isize + dx).clamp(0, w as isize - 1) as usize;
                        let yy = (y as isize + dy).clamp(0, h as isize - 1) as usize;
                        grey.at(xx, yy)
                    };
                    let contrast = (at(-1, 0) + at(1, 0) + at(0, -1) + at(0, 1) - 4.0 * at(0, 0)).abs();
                    let rgb = [value(k, i, 0), value(k, i, 1), value(k, i, 2)];
                    let mean = (rgb[0] + rgb[1] + rgb[2]) / 3.0;
                    let saturation = (rgb.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / 3.0).sqrt();
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
        let weight_pyramids: Vec<Vec<Plane>> = weights.iter().map(|p| gaussian_pyramid(p, levels)).collect();
        let channels: Vec<Plane> = (0..3)
            .map(|c| {
                let mut acc: Vec<Plane> =
                    weight_pyramids[0].iter().map(|g| Plane::filled(g.width, g.height, 0.0)).collect();
                for (k, wp) in weight_pyramids.iter().enumerate() {
                    let lap = laplacian_pyramid(&Plane::from_fn(w, h, |i| value(k, i, c)), levels);
                    for ((a, l), g) in acc.iter_mut().zip(&lap).zip(wp) {
                        for ((d, x), y) in a.data.iter_mut().zip(&l.data).zip(&g.data) {
                            *d += x * y;
                        }
                    }
                }
                collapse(&acc)
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
