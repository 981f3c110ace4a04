//! Tone mapping: scene radiance to display values in `[0,1]`.
//!
//! Every operator works on luminance `L` (Rec. 709) and maps it to a display luminance
//! `L_d`; colour follows Schlick's rule `c_d = L_d · (c / L)^s`, where the saturation `s`
//! (1 by default) desaturates below 1 and saturates above. Global operators apply one curve
//! to every pixel; local ones adapt it to each pixel's neighbourhood.
//!
//! | operator | parameters |
//! |---|---|
//! | `linear` | `exposure` (stops): `L_d = L·2^exposure`, clipped |
//! | `reinhard` | `key` a (0.18), `white` (scaled luminance that maps to 1; default the image's maximum): `L_m = a·L/L̄`, `L_d = L_m(1 + L_m/L_white²)/(1 + L_m)`, with `L̄` the log-average luminance |
//! | `drago` | `bias` b (0.85), `exposure`: adaptive logarithmic, `L_d = ln(1+L)/ln(2+8(L/L_max)^(ln b/ln ½)) / log₁₀(1+L_max)` on luminance scaled by its log-average |
//! | `aces` | `exposure` (stops): Narkowicz's fit of the ACES filmic curve |
//! | `photographic` | `key`, `sharpening` φ (8), `threshold` ε (0.05): Reinhard et al.'s dodge-and-burn, `L_d = L_m/(1 + V₁(x, s_max))` with the largest centre-surround scale whose normalised difference stays under ε |
//! | `bilateral` | `contrast` (5:1 base range), `spatial_sigma` (fraction of the image size, 0.02), `range_sigma` (0.4 in log₁₀ units): Durand and Dorsey's base/detail split, the base compressed, the detail kept |

mod bilateral;
mod global;
mod local;

use lucid_image::Image;
use lucid_image::color::luminance;
use rayon::prelude::*;

pub use bilateral::bilateral_grid;
pub use global::{aces, drago, linear, log_average, reinhard};
pub use local::{durand_dorsey, photographic};

use crate::HdrError;
use crate::blur::Plane;

/// A tone-mapping operator and its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneMapper {
    /// Exposure then clip.
    Linear {
        /// Stops.
        exposure: f32,
    },
    /// Reinhard et al.'s global photographic operator.
    Reinhard {
        /// Key value: the display luminance of the log-average scene luminance.
        key: f32,
        /// Scaled luminance that maps to white; `None`: the image's maximum.
        white: Option<f32>,
    },
    /// Drago et al.'s adaptive logarithmic mapping.
    Drago {
        /// Bias of the logarithm base (0.7–0.9; higher is darker and more contrasted).
        bias: f32,
        /// Stops applied before the mapping.
        exposure: f32,
    },
    /// Narkowicz's ACES filmic fit.
    Aces {
        /// Stops.
        exposure: f32,
    },
    /// Reinhard et al.'s local dodge-and-burn.
    Photographic {
        /// Key value.
        key: f32,
        /// Sharpening φ of the centre-surround test.
        sharpening: f32,
        /// Threshold ε on the normalised centre-surround difference.
        threshold: f32,
    },
    /// Durand and Dorsey's bilateral base/detail decomposition.
    Bilateral {
        /// Contrast (ratio) the base layer is compressed to.
        contrast: f32,
        /// Spatial σ as a fraction of the larger image side.
        spatial_sigma: f32,
        /// Range σ in log₁₀ luminance.
        range_sigma: f32,
    },
}

impl ToneMapper {
    /// Operator names, as the CLI takes them.
    pub const NAMES: [&'static str; 6] = ["linear", "reinhard", "drago", "aces", "photographic", "bilateral"];

    /// The operator `name` with its default parameters.
    pub fn by_name(name: &str) -> Result<Self, HdrError> {
        Ok(match name.to_ascii_lowercase().as_str() {
            "linear" => Self::Linear { exposure: 0.0 },
            "reinhard" => Self::Reinhard { key: 0.18, white: None },
            "drago" => Self::Drago { bias: 0.85, exposure: 0.0 },
            "aces" | "filmic" => Self::Aces { exposure: 0.0 },
            "photographic" | "reinhard-local" | "dodge-and-burn" => {
                Self::Photographic { key: 0.18, sharpening: 8.0, threshold: 0.05 }
            }
            "bilateral" | "durand" => Self::Bilateral { contrast: 5.0, spatial_sigma: 0.02, range_sigma: 0.4 },
            other => {
                return Err(HdrError::Parameter(format!(
                    "unknown tone-mapping operator {other:?} (expected one of {})",
                    Self::NAMES.join(", ")
                )));
            }
        })
    }

    /// Checks the parameters: finite, and positive where they must be.
    pub fn validate(&self) -> Result<(), HdrError> {
        let check = |name: &str, v: f32, positive: bool| {
            if !v.is_finite() || (positive && v <= 0.0) {
                Err(HdrError::Parameter(format!(
                    "{name} must be {}, got {v}",
                    if positive { "positive and finite" } else { "finite" }
                )))
            } else {
                Ok(())
            }
        };
        match *self {
            Self::Linear { exposure } | Self::Aces { exposure } => check("exposure", exposure, false),
            Self::Reinhard { key, white } => {
                check("key", key, true)?;
                white.map_or(Ok(()), |w| check("white", w, true))
            }
            Self::Drago { bias, exposure } => {
                check("exposure", exposure, false)?;
                if !(bias > 0.0 && bias < 1.0) {
                    return Err(HdrError::Parameter(format!("bias must be in (0, 1), got {bias}")));
                }
                Ok(())
            }
            Self::Photographic { key, sharpening, threshold } => {
                check("key", key, true)?;
                check("sharpening", sharpening, true)?;
                check("threshold", threshold, true)
            }
            Self::Bilateral { contrast, spatial_sigma, range_sigma } => {
                check("spatial_sigma", spatial_sigma, true)?;
                check("range_sigma", range_sigma, true)?;
                if !(contrast.is_finite() && contrast > 1.0) {
                    return Err(HdrError::Parameter(format!("contrast must be a ratio above 1, got {contrast}")));
                }
                Ok(())
            }
        }
    }

    /// The display luminance of every pixel of `lum` (`width × height`).
    pub fn map_luminance(&self, lum: &Plane) -> Plane {
        match *self {
            Self::Linear { exposure } => linear(lum, exposure),
            Self::Reinhard { key, white } => reinhard(lum, key, white),
            Self::Drago { bias, exposure } => drago(lum, bias, exposure),
            Self::Aces { exposure } => aces(lum, exposure),
            Self::Photographic { key, sharpening, threshold } => photographic(lum, key, sharpening, threshold),
            Self::Bilateral { contrast, spatial_sigma, range_sigma } => {
                durand_dorsey(lum, contrast, spatial_sigma, range_sigma)
            }
        }
    }
}

/// Tone maps `image` (linear radiance) to display-linear colour in `[0,1]` (sRGB-encode it
/// to store it, as `lucid_image::write_image` does for PNG). Alpha is kept.
pub fn tone_map(image: &Image, op: &ToneMapper, saturation: f32) -> Result<Image, HdrError> {
    op.validate()?;
    if !(saturation.is_finite() && saturation >= 0.0) {
        return Err(HdrError::Parameter(format!("saturation must be finite and ≥ 0, got {saturation}")));
    }
    let (w, h) = image.dimensions();
    let lum = Plane::from_fn(w, h, |i| {
        let p = image.pixels()[i];
        luminance([p[0], p[1], p[2]]).max(0.0)
    });
    let display = op.map_luminance(&lum);
    let pixels: Vec<[f32; 4]> = image
        .pixels()
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let (l, ld) = (lum.data[i], display.data[i]);
            let mut out = [0.0f32; 4];
            for c in 0..3 {
                out[c] = if l > 0.0 { (ld * (p[c].max(0.0) / l).powf(saturation)).clamp(0.0, 1.0) } else { 0.0 };
            }
            out[3] = p[3];
            out
        })
        .collect();
    Ok(Image::from_pixels(w, h, pixels))
}

#[cfg(test)]
mod tests;
