//! Real spherical harmonics up to degree 4 (16 coefficients) as a direction encoding, in the
//! basis and sign convention of instant-ngp / tiny-cuda-nn, so that view-dependent colour
//! varies smoothly with direction. Directions are constants in NeRF, so there is no backward.

/// Number of coefficients for degree 4 (bands 0..=3).
pub const SH_COEFFICIENTS: usize = 16;

/// Evaluates the 16 real spherical harmonics at the unit direction `d` into `out`.
#[inline(always)]
pub fn sh_encode(d: [f32; 3], out: &mut [f32]) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis is orthonormal on the sphere: `∫ Y_i Y_j dω = δ_ij`, checked with a
    /// deterministic midpoint quadrature in (cos θ, φ), exact enough for polynomials of degree 6.
    #[test]
    fn basis_is_orthonormal() {
        let (nu, nphi) = (400, 800);
        let mut gram = [[0f64; SH_COEFFICIENTS]; SH_COEFFICIENTS];
        let mut y = [0f32; SH_COEFFICIENTS];
        let dw = (2.0 / nu as f64) * (2.0 * std::f64::consts::PI / nphi as f64);
        for i in 0..nu {
            let z = -1.0 + (i as f64 + 0.5) * 2.0 / nu as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..nphi {
                let phi = (j as f64 + 0.5) * 2.0 * std::f64::consts::PI / nphi as f64;
                sh_encode([(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32], &mut y);
                for a in 0..SH_COEFFICIENTS {
                    for b in 0..SH_COEFFICIENTS {
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
}
