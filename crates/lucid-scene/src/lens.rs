//! Lens distortion: how a real lens moves image points away from where a pinhole would put
//! them. Coordinates are normalised image coordinates in the computer-vision convention
//! (`x = (px − cx)/fx` right, `y = (py − cy)/fy` down), as COLMAP, OpenCV and nerfstudio write
//! their parameters.
//!
//! Two families cover the camera models captures come with:
//! - [`LensDistortion::OpenCv`], the Brown–Conrady model with OpenCV's rational radial term:
//!   COLMAP's SIMPLE_RADIAL, RADIAL, OPENCV and FULL_OPENCV, and nerfstudio's OPENCV (whose
//!   `k4` multiplies r⁸ in the numerator, unlike FULL_OPENCV's denominator `k4`; both fit);
//! - [`LensDistortion::Fisheye`], OpenCV's equidistant fisheye (Kannala–Brandt), COLMAP's
//!   OPENCV_FISHEYE and nerfstudio's OPENCV_FISHEYE.
//!
//! Written by hand: the crates that model lenses (opencv bindings, cv-core) bring a C++ build
//! or a different geometry stack, while the models are a few lines each. The inverse has no
//! closed form and is found by Newton's method in `f64`, as COLMAP and nerfstudio do.

use glam::{DVec2, Vec2};

/// Newton iterations at most; converging models need fewer than ten.
const MAX_ITERATIONS: usize = 50;

/// A residual below this (in normalised units, about 1e-9 px at f = 1000) ends the iteration.
const TOLERANCE: f64 = 1e-12;

/// Fisheye angles are kept below a right angle by this margin, where `tan θ` (the pinhole
/// coordinate) is still finite.
const MAX_FISHEYE_ANGLE: f64 = std::f64::consts::FRAC_PI_2 - 1e-4;

/// How a lens distorts normalised image coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LensDistortion {
    /// An ideal pinhole.
    #[default]
    None,
    /// `x_d = x·R(r²) + 2p₁xy + p₂(r² + 2x²)`, `y_d = y·R(r²) + 2p₂xy + p₁(r² + 2y²)` with
    /// `R = (1 + k₁r² + k₂r⁴ + k₃r⁶ + k₄r⁸) / (1 + k₅r² + k₆r⁴ + k₇r⁶)`.
    OpenCv {
        /// Numerator coefficients of r², r⁴, r⁶, r⁸.
        radial: [f32; 4],
        /// Denominator coefficients of r², r⁴, r⁶ (FULL_OPENCV's k4, k5, k6).
        rational: [f32; 3],
        /// Tangential `p₁, p₂`.
        tangential: [f32; 2],
    },
    /// The angle θ = atan(r) from the axis is imaged at radius
    /// `θ(1 + k₁θ² + k₂θ⁴ + k₃θ⁶ + k₄θ⁸)`.
    Fisheye {
        /// `k₁ … k₄`.
        k: [f32; 4],
    },
}

impl LensDistortion {
    /// Radial and tangential distortion without a rational term (COLMAP's OPENCV).
    pub fn opencv(k1: f32, k2: f32, p1: f32, p2: f32) -> Self {
        Self::OpenCv { radial: [k1, k2, 0.0, 0.0], rational: [0.0; 3], tangential: [p1, p2] }.simplified()
    }

    /// [`LensDistortion::None`] where every coefficient is zero, else `self`.
    pub fn simplified(self) -> Self {
        let zero = match self {
            Self::None => true,
            Self::OpenCv { radial, rational, tangential } => {
                radial.iter().chain(&rational).chain(&tangential).all(|&c| c == 0.0)
            }
            Self::Fisheye { .. } => false,
        };
        if zero { Self::None } else { self }
    }

    /// Whether this is an ideal pinhole.
    pub fn is_pinhole(&self) -> bool {
        matches!(self, Self::None)
    }

    /// Where the lens images the pinhole point `u`.
    pub fn distort(&self, u: Vec2) -> Vec2 {
        self.distort_f64(u.as_dvec2()).as_vec2()
    }

    /// The pinhole point the lens images at `d`: the inverse of [`Self::distort`], by Newton's
    /// method from `d`. Where the model folds over (a strong barrel lens far outside its
    /// image), the iteration returns its best point.
    pub fn undistort(&self, d: Vec2) -> Vec2 {
        match self {
            Self::None => d,
            Self::OpenCv { .. } => self.undistort_opencv(d.as_dvec2()).as_vec2(),
            Self::Fisheye { k } => undistort_fisheye(k, d.as_dvec2()).as_vec2(),
        }
    }

    fn distort_f64(&self, u: DVec2) -> DVec2 {
        match *self {
            Self::None => u,
            Self::OpenCv { radial, rational, tangential } => opencv_with_jacobian(radial, rational, tangential, u).0,
            Self::Fisheye { k } => {
                let r = u.length();
                if r < 1e-12 {
                    return u;
                }
                let theta = r.atan();
                u * (fisheye_radius(&k, theta).0 / r)
            }
        }
    }

    fn undistort_opencv(&self, d: DVec2) -> DVec2 {
        let Self::OpenCv { radial, rational, tangential } = *self else { return d };
        let mut u = d;
        let mut best = (f64::INFINITY, d);
        for _ in 0..MAX_ITERATIONS {
            let (value, [[a, b], [c, e]]) = opencv_with_jacobian(radial, rational, tangential, u);
            let residual = value - d;
            let size = residual.length();
            if size < best.0 {
                best = (size, u);
            }
            if size < TOLERANCE {
                break;
            }
            let det = a * e - b * c;
            if det.abs() < 1e-12 || !det.is_finite() {
                break;
            }
            let step = DVec2::new(e * residual.x - b * residual.y, -c * residual.x + a * residual.y) / det;
            u -= step;
            if !u.is_finite() {
                break;
            }
        }
        best.1
    }
}

/// The OpenCV model at `u` and its Jacobian `[[∂x_d/∂x, ∂x_d/∂y], [∂y_d/∂x, ∂y_d/∂y]]`.
fn opencv_with_jacobian(
    radial: [f32; 4],
    rational: [f32; 3],
    tangential: [f32; 2],
    u: DVec2,
) -> (DVec2, [[f64; 2]; 2]) {
    let [k1, k2, k3, k4] = radial.map(f64::from);
    let [k5, k6, k7] = rational.map(f64::from);
    let [p1, p2] = tangential.map(f64::from);
    let (x, y) = (u.x, u.y);
    let r2 = x * x + y * y;
    let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * (k3 + r2 * k4)));
    let num_d = k1 + r2 * (2.0 * k2 + r2 * (3.0 * k3 + r2 * 4.0 * k4));
    let den = 1.0 + r2 * (k5 + r2 * (k6 + r2 * k7));
    let den_d = k5 + r2 * (2.0 * k6 + r2 * 3.0 * k7);
    let scale = num / den;
    // d(scale)/d(r²).
    let scale_d = (num_d * den - num * den_d) / (den * den);
    let value = DVec2::new(
        x * scale + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * scale + 2.0 * p2 * x * y + p1 * (r2 + 2.0 * y * y),
    );
    let jacobian = [
        [
            scale + 2.0 * x * x * scale_d + 2.0 * p1 * y + 6.0 * p2 * x,
            2.0 * x * y * scale_d + 2.0 * p1 * x + 2.0 * p2 * y,
        ],
        [
            2.0 * x * y * scale_d + 2.0 * p2 * y + 2.0 * p1 * x,
            scale + 2.0 * y * y * scale_d + 2.0 * p2 * x + 6.0 * p1 * y,
        ],
    ];
    (value, jacobian)
}

/// The fisheye's image radius of the angle θ, and its derivative in θ.
fn fisheye_radius(k: &[f32; 4], theta: f64) -> (f64, f64) {
    let [k1, k2, k3, k4] = k.map(f64::from);
    let t2 = theta * theta;
    let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
    let poly_d = 2.0 * theta * (k1 + t2 * (2.0 * k2 + t2 * (3.0 * k3 + t2 * 4.0 * k4)));
    (theta * poly, poly + theta * poly_d)
}

fn undistort_fisheye(k: &[f32; 4], d: DVec2) -> DVec2 {
    let rd = d.length();
    if rd < 1e-12 {
        return d;
    }
    let mut theta = rd.min(MAX_FISHEYE_ANGLE);
    for _ in 0..MAX_ITERATIONS {
        let (r, slope) = fisheye_radius(k, theta);
        let residual = r - rd;
        if residual.abs() < TOLERANCE || slope.abs() < 1e-12 {
            break;
        }
        theta = (theta - residual / slope).clamp(0.0, MAX_FISHEYE_ANGLE);
    }
    d * (theta.tan() / rd)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lenses as captures have them: a phone's mild barrel, a strong wide-angle with
    /// tangential terms, FULL_OPENCV's rational model, nerfstudio's r⁸ term and a fisheye.
    pub(crate) fn lenses() -> Vec<LensDistortion> {
        vec![
            LensDistortion::opencv(-0.05, 0.0, 0.0, 0.0),
            LensDistortion::opencv(-0.28, 0.09, 0.0012, -0.0008),
            LensDistortion::OpenCv {
                radial: [0.12, -0.03, 0.004, 0.0],
                rational: [0.1, -0.02, 0.003],
                tangential: [0.001, 0.0005],
            },
            LensDistortion::OpenCv { radial: [-0.1, 0.02, -0.002, 0.0003], rational: [0.0; 3], tangential: [0.0; 2] },
            LensDistortion::Fisheye { k: [0.03, -0.01, 0.002, -0.0005] },
        ]
    }

    #[test]
    fn undistort_inverts_distort_across_the_image() {
        // A 1000-pixel-wide image at f = 600 reaches |x| ≈ 0.83.
        for lens in lenses() {
            for i in -20..=20 {
                for j in -15..=15 {
                    let d = Vec2::new(i as f32 * 0.042, j as f32 * 0.042);
                    let back = lens.distort(lens.undistort(d));
                    // 1e-4 px at f = 600.
                    assert!((back - d).length() * 600.0 < 1e-4, "{lens:?} at {d}: {back}");
                }
            }
        }
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let LensDistortion::OpenCv { radial, rational, tangential } = lenses()[2] else { unreachable!() };
        let u = DVec2::new(0.31, -0.22);
        let (_, j) = opencv_with_jacobian(radial, rational, tangential, u);
        let h = 1e-6;
        for (axis, e) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
            let fd = (opencv_with_jacobian(radial, rational, tangential, u + h * e).0
                - opencv_with_jacobian(radial, rational, tangential, u - h * e).0)
                / (2.0 * h);
            assert!((fd.x - j[0][axis]).abs() < 1e-7 && (fd.y - j[1][axis]).abs() < 1e-7, "{fd} vs {j:?}");
        }
    }

    #[test]
    fn known_values_of_each_model() {
        // SIMPLE_RADIAL k = 0.1 at (0.3, 0.4): r² = 0.25, scale 1.025.
        let d = LensDistortion::opencv(0.1, 0.0, 0.0, 0.0).distort(Vec2::new(0.3, 0.4));
        assert!((d - Vec2::new(0.3075, 0.41)).length() < 1e-6, "{d}");
        // Tangential p1 alone at (0.3, 0.4): x += 2·p1·x·y, y += p1·(r² + 2y²).
        let d = LensDistortion::opencv(0.0, 0.0, 0.01, 0.0).distort(Vec2::new(0.3, 0.4));
        assert!((d - Vec2::new(0.3024, 0.4057)).length() < 1e-6, "{d}");
        // An equidistant fisheye without coefficients images θ at radius θ.
        let d = LensDistortion::Fisheye { k: [0.0; 4] }.distort(Vec2::new(1.0, 0.0));
        assert!((d.x - std::f32::consts::FRAC_PI_4).abs() < 1e-6, "{d}");
        // Beyond a right angle nothing is imaged: the inverse stays finite.
        let u = LensDistortion::Fisheye { k: [0.0; 4] }.undistort(Vec2::new(2.0, 0.0));
        assert!(u.is_finite() && u.x > 100.0);
    }

    #[test]
    fn all_zero_coefficients_are_a_pinhole() {
        assert!(LensDistortion::opencv(0.0, 0.0, 0.0, 0.0).is_pinhole());
        assert!(!LensDistortion::opencv(0.0, 0.0, 0.0, 1e-6).is_pinhole());
    }
}
