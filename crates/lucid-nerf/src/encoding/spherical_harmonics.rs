//! Real spherical harmonics as a direction encoding, in the basis and sign convention of
//! instant-ngp / tiny-cuda-nn (Condon–Shortley phase, coefficient `l² + l + m` for band `l`,
//! order `m`), so that view-dependent colour varies smoothly with direction. Directions are
//! constants in NeRF, so there is no backward.
//!
//! Bands 0..=3 (instant-ngp's degree 4) are written out; higher bands, for a field that
//! asks for them, come from the associated Legendre recurrence (no crate evaluates real
//! spherical harmonics of a unit vector in this convention without trigonometry).

use std::sync::LazyLock;

/// Largest degree (number of bands) the encoding offers.
pub const MAX_DEGREE: usize = 8;

/// Coefficients of the encoding of `degree` bands.
pub const fn coefficients(degree: usize) -> usize {
    degree * degree
}

/// Coefficients of instant-ngp's degree 4 (bands 0..=3), the ones written out.
const SH_COEFFICIENTS: usize = coefficients(4);

/// Evaluates the first `out.len()` real spherical harmonics (a square: 1, 4, 9, …, 64) at the
/// unit direction `d` into `out`.
#[inline(always)]
pub fn sh_encode(d: [f32; 3], out: &mut [f32]) {
    if out.len() == SH_COEFFICIENTS {
        sh_encode_degree4(d, out);
    } else {
        sh_encode_any(d, out);
    }
}

/// The 16 real spherical harmonics of bands 0..=3 at the unit direction `d`.
#[inline(always)]
fn sh_encode_degree4(d: [f32; 3], out: &mut [f32]) {
    let [x, y, z] = d;
    let (xy, xz, yz) = (x * y, x * z, y * z);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    out[0] = 0.282_094_8;
    out[1] = -0.488_602_5 * y;
    out[2] = 0.488_602_5 * z;
    out[3] = -0.488_602_5 * x;
    out[4] = 1.092_548_4 * xy;
    out[5] = -1.092_548_4 * yz;
    out[6] = 0.946_174_7 * z2 - 0.315_391_57;
    out[7] = -1.092_548_4 * xz;
    out[8] = 0.546_274_2 * (x2 - y2);
    out[9] = -0.590_043_6 * y * (3.0 * x2 - y2);
    out[10] = 2.890_611_4 * xy * z;
    out[11] = 0.457_045_8 * y * (1.0 - 5.0 * z2);
    out[12] = 0.373_176_33 * z * (5.0 * z2 - 3.0);
    out[13] = 0.457_045_8 * x * (1.0 - 5.0 * z2);
    out[14] = 1.445_305_7 * z * (x2 - y2);
    out[15] = 0.590_043_6 * x * (3.0 * y2 - x2);
}

/// `√2·K_l^m` (`K_l^0` for `m = 0`), where `K_l^m = √((2l+1)/(4π)·(l−m)!/(l+m)!)`, at
/// `l·(l+1)/2 + m` for `0 ≤ m ≤ l < MAX_DEGREE`.
static NORMALISATION: LazyLock<Vec<f32>> = LazyLock::new(|| {
    let mut k = Vec::new();
    for l in 0..MAX_DEGREE {
        for m in 0..=l {
            let ratio: f64 = ((l - m + 1)..=(l + m)).map(|i| 1.0 / i as f64).product();
            let base = ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * ratio).sqrt();
            k.push((if m == 0 { base } else { std::f64::consts::SQRT_2 * base }) as f32);
        }
    }
    k
});

/// Any number of bands: `Y_l^m = √2·K_l^m·P̃_l^m(z)·Re/Im (x + iy)^|m|`, where
/// `P̃_l^m = P_l^m / sin^m θ` is a polynomial in `z` (with the Condon–Shortley phase) and
/// `(x + iy)^m = sin^m θ·e^{imφ}`.
fn sh_encode_any(d: [f32; 3], out: &mut [f32]) {
    let degree = (out.len() as f64).sqrt() as usize;
    assert!(degree * degree == out.len() && degree <= MAX_DEGREE, "{} is not a square up to 64", out.len());
    let [x, y, z] = d;
    let k = &*NORMALISATION;
    // P̃_l^m for the current m, down the bands: p[l].
    let mut p = [0f32; MAX_DEGREE];
    let (mut c, mut s) = (1.0f32, 0.0f32);
    let mut pmm = 1.0f32;
    for m in 0..degree {
        if m > 0 {
            (c, s) = (x * c - y * s, x * s + y * c);
            pmm *= -((2 * m - 1) as f32);
        }
        p[m] = pmm;
        if m + 1 < degree {
            p[m + 1] = z * (2 * m + 1) as f32 * pmm;
        }
        for l in m + 2..degree {
            p[l] = ((2 * l - 1) as f32 * z * p[l - 1] - (l + m - 1) as f32 * p[l - 2]) / (l - m) as f32;
        }
        for l in m..degree {
            let norm = k[l * (l + 1) / 2 + m] * p[l];
            if m == 0 {
                out[l * l + l] = norm;
            } else {
                out[l * l + l + m] = norm * c;
                out[l * l + l - m] = norm * s;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis is orthonormal on the sphere: `∫ Y_i Y_j dω = δ_ij`, checked with a
    /// deterministic midpoint quadrature in (cos θ, φ), for instant-ngp's 16 coefficients and
    /// for the recurrence's 64.
    #[test]
    fn basis_is_orthonormal() {
        orthonormal::<SH_COEFFICIENTS>();
        orthonormal::<{ coefficients(MAX_DEGREE) }>();
    }

    fn orthonormal<const N: usize>() {
        let (nu, nphi) = (400, 800);
        let mut gram = [[0f64; N]; N];
        let mut y = [0f32; N];
        let dw = (2.0 / nu as f64) * (2.0 * std::f64::consts::PI / nphi as f64);
        for i in 0..nu {
            let z = -1.0 + (i as f64 + 0.5) * 2.0 / nu as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..nphi {
                let phi = (j as f64 + 0.5) * 2.0 * std::f64::consts::PI / nphi as f64;
                sh_encode([(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32], &mut y);
                for a in 0..N {
                    for b in 0..N {
                        gram[a][b] += y[a] as f64 * y[b] as f64 * dw;
                    }
                }
            }
        }
        for (a, row) in gram.iter().enumerate() {
            for (b, v) in row.iter().enumerate() {
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 2e-3, "<Y{a},Y{b}> = {v}");
            }
        }
    }

    /// The recurrence gives the written-out bands exactly (the same basis, signs and order),
    /// and each band of a higher degree is the same as in a lower one.
    #[test]
    fn the_recurrence_matches_the_written_out_bands() {
        for d in [[0.0, 0.0, 1.0], [0.6, -0.8, 0.0], [0.36, 0.48, -0.8], [-0.5, 0.5, 0.70710677]] {
            let (mut four, mut any) = ([0f32; 16], [0f32; 16]);
            sh_encode(d, &mut four);
            sh_encode_any(d, &mut any);
            for (i, (a, b)) in four.iter().zip(&any).enumerate() {
                assert!((a - b).abs() < 1e-5, "coefficient {i} at {d:?}: {a} against {b}");
            }
            let (mut five, mut eight) = ([0f32; 25], [0f32; 64]);
            sh_encode(d, &mut five);
            sh_encode(d, &mut eight);
            assert_eq!(five[..], eight[..25]);
        }
    }
}
