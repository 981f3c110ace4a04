//! Real spherical harmonics up to degree 3 in the convention of the 3DGS reference
//! implementation (its constants and signs), so that colours stored in a standard `.ply`
//! mean the same here as in every splat viewer.

use glam::Vec3;

/// Coefficients per colour channel at degree 3.
pub const SH_COEFFS: usize = 16;

/// The zeroth-order constant `1/(2√π)`: DC coefficient ↔ colour (`c = C0·f_dc + 0.5`).
pub const C0: f32 = 0.282_094_8;
const C1: f32 = 0.488_602_52;
const C2: [f32; 5] = [1.092_548_4, -1.092_548_4, 0.315_391_57, -1.092_548_4, 0.546_274_2];
const C3: [f32; 7] = [-0.590_043_6, 2.890_611_4, -0.457_045_8, 0.373_176_33, -0.457_045_8, 1.445_305_7, -0.590_043_6];

/// Number of coefficients used at `degree` (0..=3).
pub fn coeffs_for_degree(degree: usize) -> usize {
    (degree + 1) * (degree + 1)
}

/// The basis functions at unit direction `d`; those above `degree` are zero.
pub fn basis(d: Vec3, degree: usize) -> [f32; SH_COEFFS] {
    let mut y = [0.0; SH_COEFFS];
    y[0] = C0;
    if degree == 0 {
        return y;
    }
    let (x, yy_, z) = (d.x, d.y, d.z);
    y[1] = -C1 * yy_;
    y[2] = C1 * z;
    y[3] = -C1 * x;
    if degree == 1 {
        return y;
    }
    let (xx, yy, zz) = (x * x, yy_ * yy_, z * z);
    let (xy, yz, xz) = (x * yy_, yy_ * z, x * z);
    y[4] = C2[0] * xy;
    y[5] = C2[1] * yz;
    y[6] = C2[2] * (2.0 * zz - xx - yy);
    y[7] = C2[3] * xz;
    y[8] = C2[4] * (xx - yy);
    if degree == 2 {
        return y;
    }
    y[9] = C3[0] * yy_ * (3.0 * xx - yy);
    y[10] = C3[1] * xy * z;
    y[11] = C3[2] * yy_ * (4.0 * zz - xx - yy);
    y[12] = C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
    y[13] = C3[4] * x * (4.0 * zz - xx - yy);
    y[14] = C3[5] * z * (xx - yy);
    y[15] = C3[6] * x * (xx - 3.0 * yy);
    y
}

/// `∂Y_k/∂d` of every basis function (as polynomials in the components of `d`, not
/// restricted to the sphere; the caller projects through the normalisation).
pub fn basis_gradient(d: Vec3, degree: usize) -> [Vec3; SH_COEFFS] {
    let mut g = [Vec3::ZERO; SH_COEFFS];
    if degree == 0 {
        return g;
    }
    let (x, y, z) = (d.x, d.y, d.z);
    g[1] = Vec3::new(0.0, -C1, 0.0);
    g[2] = Vec3::new(0.0, 0.0, C1);
    g[3] = Vec3::new(-C1, 0.0, 0.0);
    if degree == 1 {
        return g;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    g[4] = C2[0] * Vec3::new(y, x, 0.0);
    g[5] = C2[1] * Vec3::new(0.0, z, y);
    g[6] = C2[2] * Vec3::new(-2.0 * x, -2.0 * y, 4.0 * z);
    g[7] = C2[3] * Vec3::new(z, 0.0, x);
    g[8] = C2[4] * Vec3::new(2.0 * x, -2.0 * y, 0.0);
    if degree == 2 {
        return g;
    }
    g[9] = C3[0] * Vec3::new(6.0 * x * y, 3.0 * xx - 3.0 * yy, 0.0);
    g[10] = C3[1] * Vec3::new(y * z, x * z, x * y);
    g[11] = C3[2] * Vec3::new(-2.0 * x * y, 4.0 * zz - xx - 3.0 * yy, 8.0 * y * z);
    g[12] = C3[3] * Vec3::new(-6.0 * x * z, -6.0 * y * z, 6.0 * zz - 3.0 * xx - 3.0 * yy);
    g[13] = C3[4] * Vec3::new(4.0 * zz - 3.0 * xx - yy, -2.0 * x * y, 8.0 * x * z);
    g[14] = C3[5] * Vec3::new(2.0 * x * z, -2.0 * y * z, xx - yy);
    g[15] = C3[6] * Vec3::new(3.0 * xx - 3.0 * yy, -6.0 * x * y, 0.0);
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences() {
        let d = Vec3::new(0.3, -0.5, 0.7);
        let g = basis_gradient(d, 3);
        let h = 1e-3;
        for axis in 0..3 {
            let mut e = Vec3::ZERO;
            e[axis] = h;
            let (p, m) = (basis(d + e, 3), basis(d - e, 3));
            for k in 0..SH_COEFFS {
                let fd = (p[k] - m[k]) / (2.0 * h);
                assert!((fd - g[k][axis]).abs() < 1e-3, "Y{k} axis {axis}: fd {fd} vs {}", g[k][axis]);
            }
        }
    }

    /// The basis is orthonormal on the sphere: a quadrature over a fine lat-long grid.
    #[test]
    fn basis_is_orthonormal() {
        let (nt, np) = (200, 400);
        let mut gram = [[0.0f64; SH_COEFFS]; SH_COEFFS];
        for i in 0..nt {
            let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::PI;
            for j in 0..np {
                let phi = (j as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
                let d =
                    Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32);
                let w = theta.sin() * (std::f64::consts::PI / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
                let y = basis(d, 3);
                for a in 0..SH_COEFFS {
                    for b in 0..SH_COEFFS {
                        gram[a][b] += w * y[a] as f64 * y[b] as f64;
                    }
                }
            }
        }
        for (a, row) in gram.iter().enumerate() {
            for (b, v) in row.iter().enumerate() {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 2e-3, "<Y{a},Y{b}> = {v}");
            }
        }
    }
}
