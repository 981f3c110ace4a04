//! Random numbers and the warps from the unit square that the renderer samples with.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

pub use lucid_scene::sampling::{Rng, mix};

/// Where an estimator draws its uniform numbers: a pseudo-random stream, or (for Metropolis
/// light transport) a point of primary sample space that the Markov chain mutates.
pub trait UniformSource {
    /// A number in [0, 1).
    fn uniform(&mut self) -> f32;

    /// Two numbers in [0, 1), in order.
    #[inline]
    fn uniform2(&mut self) -> Vec2 {
        let x = self.uniform();
        Vec2::new(x, self.uniform())
    }
}

impl UniformSource for Rng {
    #[inline(always)]
    fn uniform(&mut self) -> f32 {
        Rng::uniform(self)
    }

    #[inline(always)]
    fn uniform2(&mut self) -> Vec2 {
        Rng::uniform2(self)
    }
}

/// Cosine-weighted direction on the hemisphere around +Z (Malley's method).
#[inline(always)]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = lucid_scene::sampling::concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] in solid angle: `cos θ / π`.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`uniform_sphere`]: `1 / 4π`.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform barycentrics `(b0, b1)` on a triangle (the square-root parametrisation).
#[inline(always)]
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (1.0 - s, u.y * s)
}

/// Veach's power heuristic with β = 2 for one sample from each of two strategies.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a + b == 0.0 { 0.0 } else { a / (a + b) }
}

/// An orthonormal basis with `n` as its z axis (Duff et al. 2017, branchless).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::new(0.3, -0.5, 0.81).normalize(), Vec3::new(1.0, 0.0, 0.0)] {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!((t.cross(b) - n).length() < 1e-5, "right-handed");
        }
    }

    #[test]
    fn cosine_sampling_has_the_mean_cosine_of_its_density() {
        // Under p = cos θ / π the mean of cos θ is ∫cos² θ/π dω = 2/3.
        let mut rng = Rng::new(3, 3);
        let n = 200_000;
        let mut mean_cos = 0.0f64;
        for _ in 0..n {
            let d = cosine_hemisphere(rng.uniform2());
            assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-4);
            mean_cos += d.z as f64;
        }
        assert!((mean_cos / n as f64 - 2.0 / 3.0).abs() < 0.003);
    }
}
