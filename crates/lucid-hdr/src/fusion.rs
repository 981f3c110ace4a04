//! Mertens, Kautz and Van Reeth's exposure fusion (2007): the stack blended straight into one
//! display image, weighting each frame per pixel by contrast, saturation and
//! well-exposedness, in a Laplacian pyramid so that the seams of the weights do not show.
//! No response curve and no exposure times are needed.

use lucid_image::Image;
use lucid_image::color::srgb_decode;

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
    // Normalise per pixel.
    for i in 0..w * h {
        let sum: f32 = weights.iter().map(|p| p.data[i]).sum();
        for p in &mut weights {
            p.data[i] /= sum;
        }
    }
    let levels = levels_for(w, h);
    let weight_pyramids: Vec<Vec<Plane>> = weights.iter().map(|p| gaussian_pyramid(p, levels)).collect();
    let mut channels = Vec::with_capacity(3);
    for c in 0..3 {
        let mut blended: Option<Vec<Plane>> = None;
        for (k, wp) in weight_pyramids.iter().enumerate() {
            let lap = laplacian_pyramid(&Plane::from_fn(w, h, |i| value(k, i, c)), levels);
            match &mut blended {
                None => {
                    blended = Some(
                        lap.iter()
                            .zip(wp)
                            .map(|(l, g)| Plane {
                                width: l.width,
                                height: l.height,
                                data: l.data.iter().zip(&g.data).map(|(a, b)| a * b).collect(),
                            })
                            .collect(),
                    )
                }
                Some(acc) => {
                    for ((a, l), g) in acc.iter_mut().zip(&lap).zip(wp) {
                        for ((d, x), y) in a.data.iter_mut().zip(&l.data).zip(&g.data) {
                            *d += x * y;
                        }
                    }
                }
            }
        }
        channels.push(collapse(&blended.expect("at least one frame")));
    }
    Image::from_fn(w, h, |x, y| {
        let i = y * w + x;
        let v = |c: usize| srgb_decode(channels[c].data[i].clamp(0.0, 1.0));
        [v(0), v(1), v(2), 1.0]
    })
}
