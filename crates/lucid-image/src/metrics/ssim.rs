//! Structural similarity (Wang et al. 2004) with the usual constants: an 11×11 Gaussian
//! window of σ = 1.5, k1 = 0.01, k2 = 0.03, a data range of 1, computed per RGB channel
//! and averaged.
//!
//! The SSIM map covers only the pixels whose whole window lies inside the image (a
//! "valid" filter), which equals scikit-image's `structural_similarity(gaussian_weights=True,
//! sigma=1.5, use_sample_covariance=False, data_range=1)`: it filters with reflected borders
//! and then crops the same 5-pixel margin, so the border handling never reaches the mean.

use rayon::prelude::*;

use super::{MetricError, check_sizes};
use crate::Image;

/// Side of the Gaussian window.
pub const SSIM_WINDOW: usize = 11;
/// Standard deviation of the Gaussian window, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
/// Luminance stabiliser: C1 = (k1·L)².
pub const SSIM_K1: f64 = 0.01;
/// Contrast stabiliser: C2 = (k2·L)².
pub const SSIM_K2: f64 = 0.03;

const RADIUS: usize = SSIM_WINDOW / 2;

fn gaussian_window() -> [f64; SSIM_WINDOW] {
    let mut w = [0.0; SSIM_WINDOW];
    for (i, v) in w.iter_mut().enumerate() {
        let x = i as f64 - RADIUS as f64;
        *v = (-x * x / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// Separable "valid" Gaussian filter of a `w`×`h` plane: the result is `(w−10)`×`(h−10)`.
fn filter_valid(plane: &[f64], w: usize, h: usize, kernel: &[f64; SSIM_WINDOW]) -> Vec<f64> {
    let ow = w - 2 * RADIUS;
    let oh = h - 2 * RADIUS;
    let mut horizontal = vec![0.0; ow * h];
    horizontal.par_chunks_mut(ow).enumerate().for_each(|(y, row)| {
        let src = &plane[y * w..(y + 1) * w];
        for (x, out) in row.iter_mut().enumerate() {
            *out = kernel.iter().zip(&src[x..x + SSIM_WINDOW]).map(|(k, v)| k * v).sum();
        }
    });
    let mut out = vec![0.0; ow * oh];
    out.par_chunks_mut(ow).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            *o = (0..SSIM_WINDOW).map(|k| kernel[k] * horizontal[(y + k) * ow + x]).sum();
        }
    });
    out
}

/// The SSIM map of the RGB-averaged similarity, `(w−10)`×`(h−10)` values, row-major; entry
/// `(i, j)` belongs to image pixel `(i+5, j+5)`.
pub fn ssim_map(a: &Image, b: &Image) -> Result<Vec<f64>, MetricError> {
    check_sizes(a, b, None)?;
    let (w, h) = a.dimensions();
    if w < SSIM_WINDOW || h < SSIM_WINDOW {
        return Err(MetricError::TooSmall(w, h));
    }
    let kernel = gaussian_window();
    let c1 = (SSIM_K1 * 1.0).powi(2);
    let c2 = (SSIM_K2 * 1.0).powi(2);
    let n = (w - 2 * RADIUS) * (h - 2 * RADIUS);
    let mut map = vec![0.0; n];
    for c in 0..3 {
        let x: Vec<f64> = a.pixels().iter().map(|p| p[c].clamp(0.0, 1.0) as f64).collect();
        let y: Vec<f64> = b.pixels().iter().map(|p| p[c].clamp(0.0, 1.0) as f64).collect();
        let product = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { x.iter().zip(&y).map(|(&u, &v)| f(u, v)).collect() };
        let mu_x = filter_valid(&x, w, h, &kernel);
        let mu_y = filter_valid(&y, w, h, &kernel);
        let xx = filter_valid(&product(&|u, _| u * u), w, h, &kernel);
        let yy = filter_valid(&product(&|_, v| v * v), w, h, &kernel);
        let xy = filter_valid(&product(&|u, v| u * v), w, h, &kernel);
        for i in 0..n {
            let (mx, my) = (mu_x[i], mu_y[i]);
            let var_x = xx[i] - mx * mx;
            let var_y = yy[i] - my * my;
            let cov = xy[i] - mx * my;
            let s = ((2.0 * mx * my + c1) * (2.0 * cov + c2)) / ((mx * mx + my * my + c1) * (var_x + var_y + c2));
            map[i] += s / 3.0;
        }
    }
    Ok(map)
}

/// Mean SSIM over the valid region (optionally only where the mask, sampled at each
/// window's centre pixel, is > 0.5).
pub fn ssim(a: &Image, b: &Image, mask: Option<&[f32]>) -> Result<f64, MetricError> {
    check_sizes(a, b, mask)?;
    let map = ssim_map(a, b)?;
    let (w, h) = a.dimensions();
    let ow = w - 2 * RADIUS;
    let mut sum = 0.0;
    let mut count = 0usize;
    for y in 0..h - 2 * RADIUS {
        for x in 0..ow {
            if mask.is_some_and(|m| m[(y + RADIUS) * w + x + RADIUS] <= 0.5) {
                continue;
            }
            sum += map[y * ow + x];
            count += 1;
        }
    }
    if count == 0 {
        return Err(MetricError::EmptyMask);
    }
    Ok(sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise_image(w: usize, h: usize, seed: u64) -> Image {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) as f32) / (1u64 << 31) as f32
        };
        Image::from_fn(w, h, |_, _| [next(), next(), next(), 1.0])
    }

    #[test]
    fn identical_images_have_ssim_one() {
        let a = noise_image(20, 17, 1);
        assert!((ssim(&a, &a, None).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn window_is_normalised_and_symmetric() {
        let w = gaussian_window();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for i in 0..SSIM_WINDOW {
            assert_eq!(w[i], w[SSIM_WINDOW - 1 - i]);
        }
    }

    #[test]
    fn constant_images_follow_the_luminance_term() {
        // For constant images the variances vanish and SSIM = (2ab + C1) / (a² + b² + C1).
        let (a, b) = (0.3f64, 0.6f64);
        let ia = Image::filled(16, 16, [a as f32; 4]);
        let ib = Image::filled(16, 16, [b as f32; 4]);
        let c1 = 1e-4;
        let expected = (2.0 * a * b + c1) / (a * a + b * b + c1);
        let got = ssim(&ia, &ib, None).unwrap();
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    }

    #[test]
    fn noise_lowers_ssim_and_small_images_are_rejected() {
        let a = noise_image(32, 32, 7);
        let b = noise_image(32, 32, 8);
        assert!(ssim(&a, &b, None).unwrap() < 0.1);
        assert_eq!(ssim(&Image::black(10, 30), &Image::black(10, 30), None), Err(MetricError::TooSmall(10, 30)));
    }
}
