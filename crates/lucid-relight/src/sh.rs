//! Spherical harmonics of bands 0–2 (9 coefficients per channel) for diffuse lighting: the
//! projection of an environment map, and the irradiance `E(n) = Σ Âₗ Lₗₘ Yₗₘ(n)` with
//! `Â₀ = π, Â₁ = 2π/3, Â₂ = π/4` (Ramamoorthi and Hanrahan 2001), which is accurate to a few
//! percent for any lighting because the cosine lobe has almost no energy above band 2.

use glam::Vec3;
use lucid_image::Image;

use crate::envmap::{pixel_direction, pixel_solid_angle};

/// The real SH basis `Y₀₀, Y₁₋₁, Y₁₀, Y₁₁, Y₂₋₂, Y₂₋₁, Y₂₀, Y₂₁, Y₂₂` at a unit direction.
pub fn basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// Band of each coefficient.
const BAND: [usize; 9] = [0, 1, 1, 1, 2, 2, 2, 2, 2];
/// Convolution with the clamped cosine, per band.
const COSINE: [f32; 3] = [std::f32::consts::PI, 2.0 * std::f32::consts::PI / 3.0, std::f32::consts::PI / 4.0];

/// `L_lm = ∫ L(ω) Y_lm(ω) dω` per channel, summed over the map's pixels.
pub fn project(map: &Image) -> [[f32; 3]; 9] {
    let (w, h) = map.dimensions();
    let mut out = [[0.0f64; 3]; 9];
    for y in 0..h {
        let omega = pixel_solid_angle(y, w, h) as f64;
        for x in 0..w {
            let p = map.get(x, y);
            let b = basis(pixel_direction(x, y, w, h));
            for k in 0..9 {
                for c in 0..3 {
                    out[k][c] += p[c] as f64 * b[k] as f64 * omega;
                }
            }
        }
    }
    out.map(|v| v.map(|x| x as f32))
}

/// Irradiance on a surface with normal `n` under the lighting of `coeffs`.
pub fn irradiance(coeffs: &[[f32; 3]; 9], n: Vec3) -> [f32; 3] {
    let b = basis(n.normalize_or_zero());
    let mut e = [0.0f32; 3];
    for k in 0..9 {
        for c in 0..3 {
            e[c] += COSINE[BAND[k]] * coeffs[k][c] * b[k];
        }
    }
    e.map(|v| v.max(0.0))
}

/// The irradiance map (lat-long, `w × h`): at each direction, the irradiance of a surface
/// facing it.
pub fn irradiance_map(coeffs: &[[f32; 3]; 9], w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let e = irradiance(coeffs, pixel_direction(x, y, w, h));
        [e[0], e[1], e[2], 1.0]
    })
}

/// Diffuse precomputed radiance transfer: the radiance `ρ/π · E(n)` of a Lambertian surface
/// of albedo `ρ` and normal `n` (its transfer vector is `ρ/π · Âₗ Yₗₘ(n)`, dotted with the
/// lighting coefficients here), for unshadowed surfaces.
pub fn diffuse_radiance(coeffs: &[[f32; 3]; 9], albedo: [f32; 3], n: Vec3) -> [f32; 3] {
    let e = irradiance(coeffs, n);
    [0, 1, 2].map(|c| albedo[c] * std::f32::consts::FRAC_1_PI * e[c])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn map(f: impl Fn(Vec3) -> f32) -> Image {
        Image::from_fn(256, 128, |x, y| {
            let v = f(pixel_direction(x, y, 256, 128));
            [v, v, v, 1.0]
        })
    }

    #[test]
    fn constant_and_cosine_lobe_have_their_closed_form_coefficients() {
        // A constant 1: only L00 = √(4π)... = 4π·Y00 = 2√π.
        let c = project(&map(|_| 1.0));
        assert!((c[0][0] - 2.0 * PI.sqrt()).abs() < 1e-3, "{}", c[0][0]);
        for (k, v) in c.iter().enumerate().skip(1) {
            assert!(v[0].abs() < 1e-3, "coefficient {k}: {}", v[0]);
        }
        // A clamped cosine about +Z: L00 = Y00·π, L10 = 0.4886·2π/3, L20 = 0.3154·π/2·... = 2π·0.3154·(3/4 − 1/2).
        let c = project(&map(|d| d.z.max(0.0)));
        let want = [(0, 0.282_094_8 * PI), (2, 0.488_602_5 * 2.0 * PI / 3.0), (6, 0.315_391_57 * 2.0 * PI * 0.25)];
        for (k, v) in want {
            assert!((c[k][0] - v).abs() < 2e-3, "coefficient {k}: {} vs {v}", c[k][0]);
        }
        for k in [1, 3, 4, 5, 7, 8] {
            assert!(c[k][0].abs() < 2e-3, "coefficient {k}: {}", c[k][0]);
        }
    }

    /// Under a constant environment of radiance 1 every surface receives irradiance π.
    #[test]
    fn irradiance_of_a_constant_environment_is_pi() {
        let c = project(&map(|_| 1.0));
        for n in [Vec3::Z, Vec3::new(0.3, -0.6, 0.2)] {
            assert!((irradiance(&c, n)[0] - PI).abs() < 2e-3);
        }
        // A white Lambertian surface then has radiance 1.
        assert!((diffuse_radiance(&c, [1.0; 3], Vec3::X)[0] - 1.0).abs() < 1e-3);
    }
}
