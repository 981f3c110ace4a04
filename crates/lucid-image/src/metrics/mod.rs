//! Image quality metrics: PSNR and SSIM, with the conventions of the NeRF literature.
//!
//! Both compare the RGB channels of two images of the same size after clipping them to
//! `[0,1]`; alpha is ignored. [`prepare_for_metrics`] puts images in the space the NeRF
//! literature measures in: sRGB-encoded, composited over a background colour. An optional mask (one weight per
//! pixel, counted where > 0.5) restricts either metric to a region.

mod psnr;
mod ssim;

pub use psnr::{mse, psnr, psnr_from_mse};
pub use ssim::{SSIM_K1, SSIM_K2, SSIM_SIGMA, SSIM_WINDOW, ssim, ssim_map};

use crate::Image;

/// Why two images could not be compared.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricError {
    /// The images (or the mask) differ in size.
    #[error("image sizes differ: {a:?} vs {b:?}")]
    SizeMismatch {
        /// `(width, height)` of the first.
        a: (usize, usize),
        /// `(width, height)` of the second.
        b: (usize, usize),
    },
    /// SSIM needs at least one full 11×11 window.
    #[error("image of {0}x{1} is smaller than the 11x11 SSIM window")]
    TooSmall(usize, usize),
    /// The mask selects no pixel.
    #[error("the mask selects no pixel")]
    EmptyMask,
}

/// PSNR and SSIM of one pair of images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageMetrics {
    /// Peak signal-to-noise ratio in dB (infinite for identical images).
    pub psnr: f64,
    /// Structural similarity, in `[-1, 1]`.
    pub ssim: f64,
}

/// Computes both metrics of `prediction` against `reference`.
pub fn compare(prediction: &Image, reference: &Image, mask: Option<&[f32]>) -> Result<ImageMetrics, MetricError> {
    Ok(ImageMetrics { psnr: psnr(prediction, reference, mask)?, ssim: ssim(prediction, reference, mask)? })
}

/// Why two image files could not be compared; the message names the files.
#[derive(Debug, thiserror::Error)]
pub enum FileMetricError {
    /// A file could not be read.
    #[error(transparent)]
    Read(#[from] crate::ImageError),
    /// An image holds NaN or infinite values, which have no score.
    #[error("{}: {count} values are NaN or infinite; such an image has no PSNR or SSIM", path.display())]
    NonFinite {
        /// The image.
        path: std::path::PathBuf,
        /// How many values.
        count: usize,
    },
    /// The images cannot be compared.
    #[error("comparing {} with {}: {source}", a.display(), b.display())]
    Compare {
        /// The prediction.
        a: std::path::PathBuf,
        /// The reference.
        b: std::path::PathBuf,
        /// Why.
        source: MetricError,
    },
}

/// Compares two image files in the metric space, composited on `background`.
pub fn compare_files(
    a: &std::path::Path,
    b: &std::path::Path,
    background: [f32; 3],
    space: MetricSpace,
) -> Result<ImageMetrics, FileMetricError> {
    let read = |path: &std::path::Path| -> Result<Image, FileMetricError> {
        let image = crate::read_image(path)?;
        let count = image.non_finite_count();
        if count > 0 {
            return Err(FileMetricError::NonFinite { path: path.to_path_buf(), count });
        }
        Ok(image)
    };
    let ia = prepare_for_metrics(&read(a)?, background, space);
    let ib = prepare_for_metrics(&read(b)?, background, space);
    compare(&ia, &ib, None).map_err(|source| FileMetricError::Compare { a: a.into(), b: b.into(), source })
}

/// Averages of metrics over a set of image pairs, per image as the literature does
/// (mean of per-image PSNRs, not PSNR of the mean error).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetricSummary {
    /// Number of pairs.
    pub count: usize,
    /// Mean PSNR in dB.
    pub psnr: f64,
    /// Mean SSIM.
    pub ssim: f64,
}

impl MetricSummary {
    /// Averages a list of per-image metrics. An empty list averages to NaN.
    pub fn from_images(metrics: &[ImageMetrics]) -> Self {
        let n = metrics.len() as f64;
        Self {
            count: metrics.len(),
            psnr: metrics.iter().map(|m| m.psnr).sum::<f64>() / n,
            ssim: metrics.iter().map(|m| m.ssim).sum::<f64>() / n,
        }
    }
}

/// The colour space metrics are computed in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MetricSpace {
    /// sRGB-encoded values, as stored in 8-bit files: the convention of the NeRF literature
    /// (published PSNRs are on PNG pixel values / 255).
    #[default]
    Srgb,
    /// Linear radiance clipped to `[0,1]`.
    Linear,
}

/// Prepares an image for comparison: composites it over an opaque `background` (given in
/// the same space as the result) and, for [`MetricSpace::Srgb`], encodes it first, so that
/// compositing happens on encoded values exactly as evaluation scripts do with RGBA PNGs.
pub fn prepare_for_metrics(image: &Image, background: [f32; 3], space: MetricSpace) -> Image {
    let encoded = match space {
        MetricSpace::Srgb => {
            use crate::color::srgb_encode;
            image.map(|p| [srgb_encode(p[0]), srgb_encode(p[1]), srgb_encode(p[2]), p[3]])
        }
        MetricSpace::Linear => image.clone(),
    };
    crate::color::composite_over(&encoded, background)
}

pub(crate) fn check_sizes(a: &Image, b: &Image, mask: Option<&[f32]>) -> Result<(), MetricError> {
    if a.dimensions() != b.dimensions() {
        return Err(MetricError::SizeMismatch { a: a.dimensions(), b: b.dimensions() });
    }
    if let Some(m) = mask
        && m.len() != a.width() * a.height()
    {
        return Err(MetricError::SizeMismatch { a: a.dimensions(), b: (m.len(), 1) });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preparation_composites_encoded_values() {
        // Half-transparent linear 0.18 grey over white: encode (0.4614), then blend with 1.
        let img = Image::filled(1, 1, [0.18, 0.18, 0.18, 0.5]);
        let p = prepare_for_metrics(&img, [1.0; 3], MetricSpace::Srgb).get(0, 0);
        assert!((p[0] - (0.5 * 0.461_356 + 0.5)).abs() < 1e-4, "{p:?}");
        let p = prepare_for_metrics(&img, [0.0; 3], MetricSpace::Linear).get(0, 0);
        assert!((p[0] - 0.09).abs() < 1e-7 && p[3] == 1.0);
    }
}
