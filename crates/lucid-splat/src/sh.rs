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

/// Turns functions given by their SH coefficients: `f ↦ f∘R⁻¹`, band by band (a rotation
/// mixes the coefficients of one degree only). Used to carry a cloud's view-dependent colour
/// into another frame.
pub struct ShRotation {
    /// The `(2l+1)²` row-major matrix of each band `l = 1..=3`.
    bands: [Vec<f64>; 3],
}

impl ShRotation {
    /// The rotation of coefficients by `r`.
    ///
    /// Each band's matrix is fitted, in least squares, to the rotated basis at directions
    /// spread over the sphere. Exact (to rounding) because a rotated band is a combination of
    /// the same band; a closed-form recurrence (Ivanic–Ruedenberg) would need this module's
    /// sign conventions re-derived, and no crate implements the 3DGS basis.
    pub fn new(r: glam::DMat3) -> Self {
        const SAMPLES: usize = 64;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let dirs: Vec<glam::DVec3> = (0..SAMPLES)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / SAMPLES as f64;
                let rho = (1.0 - z * z).sqrt();
                let phi = golden * k as f64;
                glam::DVec3::new(rho * phi.cos(), rho * phi.sin(), z)
            })
            .collect();
        let inverse = r.transpose();
        let at = |d: glam::DVec3| basis(d.as_vec3(), 3).map(f64::from);
        let (plain, turned): (Vec<_>, Vec<_>) = dirs.iter().map(|&d| (at(d), at(inverse * d))).unzip();
        let bands = [1usize, 2, 3].map(|l| {
            let (o, n) = (l * l, 2 * l + 1);
            // Normal equations (AᵀA) M = AᵀB, with A the basis and B the turned basis.
            let mut ata = vec![0.0; n * n];
            let mut atb = vec![0.0; n * n];
            for (a, b) in plain.iter().zip(&turned) {
                for i in 0..n {
                    for j in 0..n {
                        ata[i * n + j] += a[o + i] * a[o + j];
                        atb[i * n + j] += a[o + i] * b[o + j];
                    }
                }
            }
            solve(&mut ata, &mut atb, n);
            atb
        });
        Self { bands }
    }

    /// Turns one Gaussian's rest coefficients, laid out `[3·(k−1) + channel]` for basis
    /// functions `k = 1..16`, in place.
    pub fn apply_rest(&self, rest: &mut [f32]) {
        for (l, m) in (1usize..=3).zip(&self.bands) {
            let (o, n) = (l * l - 1, 2 * l + 1);
            for c in 0..3 {
                let old: Vec<f64> = (0..n).map(|j| f64::from(rest[3 * (o + j) + c])).collect();
                for i in 0..n {
                    let v: f64 = (0..n).map(|j| m[i * n + j] * old[j]).sum();
                    rest[3 * (o + i) + c] = v as f32;
                }
            }
        }
    }
}

/// Solves `A X = B` for `n×n` row-major `A` (symmetric positive definite here) and `B`,
/// leaving `X` in `b`: Gaussian elimination with partial pivoting, for matrices of at most
/// 7×7, where a linear-algebra dependency would be out of proportion.
fn solve(a: &mut [f64], b: &mut [f64], n: usize) {
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs())).unwrap_or(col);
        for k in 0..n {
            a.swap(col * n + k, pivot * n + k);
            b.swap(col * n + k, pivot * n + k);
        }
        let p = a[col * n + col];
        for row in 0..n {
            if row == col {
                continue;
            }
            let f = a[row * n + col] / p;
            for k in 0..n {
                a[row * n + k] -= f * a[col * n + k];
                b[row * n + k] -= f * b[col * n + k];
            }
        }
    }
    for row in 0..n {
        let p = a[row * n + row];
        b[row * n..(row + 1) * n].iter_mut().for_each(|v| *v /= p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A turned function at a turned direction has the original's value there, at every
    /// degree, for rest coefficients of every channel.
    #[test]
    fn rotation_turns_the_function() {
        let r = glam::DMat3::from_quat(glam::DQuat::from_axis_angle(glam::DVec3::new(0.3, -0.8, 0.5).normalize(), 2.1));
        let rotation = ShRotation::new(r);
        let rest: Vec<f32> = (0..45).map(|k| ((k * 37 % 11) as f32 - 5.0) * 0.1).collect();
        let mut turned = rest.clone();
        rotation.apply_rest(&mut turned);
        let value = |rest: &[f32], d: Vec3, c: usize| -> f32 {
            let y = basis(d, 3);
            (1..SH_COEFFS).map(|k| y[k] * rest[3 * (k - 1) + c]).sum()
        };
        for k in 0..50 {
            let d =
                Vec3::new((k as f32 * 0.7).sin(), (k as f32 * 1.3).cos(), (k as f32 * 0.37).sin() - 0.2).normalize();
            let rd = (r * d.as_dvec3()).as_vec3();
            for c in 0..3 {
                let (want, got) = (value(&rest, d, c), value(&turned, rd, c));
                assert!((want - got).abs() < 1e-4, "direction {d}, channel {c}: {want} vs {got}");
            }
        }
        // And a turn that changes nothing leaves the coefficients.
        let mut same = rest.clone();
        ShRotation::new(glam::DMat3::IDENTITY).apply_rest(&mut same);
        for (a, b) in rest.iter().zip(&same) {
            assert!((a - b).abs() < 1e-5);
        }
    }

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
