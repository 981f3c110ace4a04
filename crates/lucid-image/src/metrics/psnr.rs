//! Peak signal-to-noise ratio on `[0,1]`-clipped RGB.

use super::{MetricError, check_sizes};
use crate::Image;

/// Mean squared error over the RGB channels of the (masked) pixels, after clipping both
/// images to `[0,1]`.
pub fn mse(a: &Image, b: &Image, mask: Option<&[f32]>) -> Result<f64, MetricError> {
    check_sizes(a, b, mask)?;
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for (i, (pa, pb)) in a.pixels().iter().zip(b.pixels()).enumerate() {
        if mask.is_some_and(|m| m[i] <= 0.5) {
            continue;
        }
        for c in 0..3 {
            let d = pa[c].clamp(0.0, 1.0) as f64 - pb[c].clamp(0.0, 1.0) as f64;
            sum += d * d;
        }
        count += 3;
    }
    if count == 0 {
        return Err(MetricError::EmptyMask);
    }
    Ok(sum / count as f64)
}

/// PSNR in dB for a peak value of 1: `−10·log10(MSE)`; `+∞` when the MSE is zero.
pub fn psnr_from_mse(mse: f64) -> f64 {
    if mse <= 0.0 { f64::INFINITY } else { -10.0 * mse.log10() }
}

/// PSNR of two images (see [`mse`]).
pub fn psnr(a: &Image, b: &Image, mask: Option<&[f32]>) -> Result<f64, MetricError> {
    mse(a, b, mask).map(psnr_from_mse)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_offset_gives_closed_form_psnr() {
        // An offset d on every channel gives MSE = d², so PSNR = −20·log10(d).
        for d in [0.5f32, 0.1, 0.01, 0.001] {
            let a = Image::filled(7, 5, [0.1, 0.2, 0.3, 1.0]);
            let b = a.map(|p| [p[0] + d, p[1] + d, p[2] + d, 1.0]);
            let expected = -20.0 * (d as f64).log10();
            let got = psnr(&a, &b, None).unwrap();
            assert!((got - expected).abs() < 1e-3, "offset {d}: {got} vs {expected}");
        }
    }

    #[test]
    fn identical_images_give_infinite_psnr() {
        let a = Image::filled(3, 3, [0.1, 0.2, 0.3, 1.0]);
        assert_eq!(psnr(&a, &a, None).unwrap(), f64::INFINITY);
    }

    #[test]
    fn values_are_clipped_and_alpha_ignored() {
        let a = Image::filled(2, 2, [2.0, -1.0, 1.0, 0.0]);
        let b = Image::filled(2, 2, [1.0, 0.0, 1.0, 1.0]);
        assert_eq!(mse(&a, &b, None).unwrap(), 0.0);
    }

    #[test]
    fn mask_restricts_the_error() {
        let a = Image::from_fn(4, 1, |x, _| if x == 0 { [1.0, 1.0, 1.0, 1.0] } else { [0.0, 0.0, 0.0, 1.0] });
        let b = Image::black(4, 1);
        let mask = [0.0, 1.0, 1.0, 1.0];
        assert_eq!(mse(&a, &b, Some(&mask)).unwrap(), 0.0);
        assert_eq!(mse(&a, &b, None).unwrap(), 0.25);
        assert_eq!(mse(&a, &b, Some(&[0.0; 4])), Err(MetricError::EmptyMask));
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = Image::black(4, 4);
        let b = Image::black(4, 3);
        assert!(matches!(psnr(&a, &b, None), Err(MetricError::SizeMismatch { .. })));
    }
}
