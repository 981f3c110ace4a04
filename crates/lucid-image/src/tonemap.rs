//! Global tone curves that map linear HDR radiance to display-referred `[0,1]`, used when
//! converting HDR files to LDR ones. Local operators and the full tone-mapping toolkit
//! build on these.

use std::str::FromStr;

/// A per-channel global tone curve, applied after exposure scaling and before sRGB encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ToneCurve {
    /// Identity then clip to `[0,1]`: what a linear camera with a hard white point records.
    #[default]
    Clip,
    /// Reinhard's simple operator `x / (1 + x)`: never clips, compresses highlights.
    Reinhard,
    /// Narkowicz's fit of the ACES filmic reference curve:
    /// `(x(2.51x+0.03)) / (x(2.43x+0.59)+0.14)`, clipped to `[0,1]`.
    Aces,
}

impl ToneCurve {
    /// Applies the curve to one linear value.
    pub fn apply(self, x: f32) -> f32 {
        let x = x.max(0.0);
        match self {
            ToneCurve::Clip => x.min(1.0),
            ToneCurve::Reinhard => x / (1.0 + x),
            ToneCurve::Aces => ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0),
        }
    }

    /// Exposes the colour of an image by `2^stops` and applies the curve; alpha is kept.
    pub fn map_image(self, image: &crate::Image, stops: f32) -> crate::Image {
        let k = crate::color::exposure_factor(stops);
        image.map(|p| [self.apply(p[0] * k), self.apply(p[1] * k), self.apply(p[2] * k), p[3]])
    }
}

impl FromStr for ToneCurve {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "clip" | "linear" => Ok(Self::Clip),
            "reinhard" => Ok(Self::Reinhard),
            "aces" | "filmic" => Ok(Self::Aces),
            other => Err(format!("unknown tone curve {other:?} (expected clip, reinhard or aces)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_are_monotone_and_bounded() {
        for curve in [ToneCurve::Clip, ToneCurve::Reinhard, ToneCurve::Aces] {
            let mut prev = curve.apply(0.0);
            assert!(prev.abs() < 1e-6, "{curve:?} maps 0 to {prev}");
            for i in 1..2000 {
                let y = curve.apply(i as f32 * 0.01);
                assert!(y >= prev && y <= 1.0, "{curve:?} at {}", i as f32 * 0.01);
                prev = y;
            }
        }
        assert_eq!(ToneCurve::Reinhard.apply(1.0), 0.5);
        // The ACES fit passes close to 0.8 at an input of 1.
        assert!((ToneCurve::Aces.apply(1.0) - 0.8038).abs() < 1e-3);
    }
}
