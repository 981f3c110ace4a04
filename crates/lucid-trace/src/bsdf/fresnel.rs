//! Fresnel reflectance of dielectric and conductor interfaces (unpolarised light).

use glam::Vec3;

/// Reflectance of a dielectric interface for `cos_i` (signed: negative means the ray arrives
/// from inside) and relative index `eta = η_t / η_i` of the outside-to-inside crossing.
/// Returns 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (cos_i, eta) = if cos_i < 0.0 { (-cos_i, 1.0 / eta) } else { (cos_i, eta) };
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// Reflectance of a conductor with complex index `eta + i·k` (per channel) at `cos_i ≥ 0`
/// (the exact formula for an interface with a dielectric of index 1).
pub fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_i.clamp(0.0, 1.0);
    Vec3::new(conductor_channel(c, eta.x, k.x), conductor_channel(c, eta.y, k.y), conductor_channel(c, eta.z, k.z))
}

fn conductor_channel(cos_i: f32, eta: f32, k: f32) -> f32 {
    // pbrt's FrComplex with complex arithmetic written out: η̃ = η + ik,
    // sin²t = sin²i / η̃², cos t = √(1 − sin²t).
    let (cos_i, sin2_i) = (cos_i as f64, 1.0 - (cos_i as f64).powi(2));
    let (eta, k) = (eta as f64, k as f64);
    let (e2r, e2i) = (eta * eta - k * k, 2.0 * eta * k);
    let denom = e2r * e2r + e2i * e2i;
    let (s2r, s2i) = (sin2_i * e2r / denom, -sin2_i * e2i / denom);
    let (cr, ci) = complex_sqrt(1.0 - s2r, -s2i);
    // r_parl = (η̃ cos i − cos t)/(η̃ cos i + cos t), r_perp = (cos i − η̃ cos t)/(cos i + η̃ cos t)
    let (ar, ai) = (eta * cos_i, k * cos_i);
    let r_parl = complex_norm_ratio(ar - cr, ai - ci, ar + cr, ai + ci);
    let (bt_r, bt_i) = (eta * cr - k * ci, eta * ci + k * cr);
    let r_perp = complex_norm_ratio(cos_i - bt_r, -bt_i, cos_i + bt_r, bt_i);
    (0.5 * (r_parl + r_perp)) as f32
}

fn complex_sqrt(re: f64, im: f64) -> (f64, f64) {
    let n = (re * re + im * im).sqrt();
    let r = ((n + re) * 0.5).max(0.0).sqrt();
    let i = ((n - re) * 0.5).max(0.0).sqrt();
    (r, if im < 0.0 { -i } else { i })
}

fn complex_norm_ratio(ar: f64, ai: f64, br: f64, bi: f64) -> f64 {
    (ar * ar + ai * ai) / (br * br + bi * bi).max(1e-300)
}

/// Hemispherical average of the dielectric reflectance, `2∫₀¹ F(μ) μ dμ` (by quadrature).
pub fn average_fresnel_dielectric(eta: f32) -> f32 {
    let n = 512;
    (0..n)
        .map(|i| {
            let mu = (i as f32 + 0.5) / n as f32;
            2.0 * fresnel_dielectric(mu, eta) * mu / n as f32
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_known_values() {
        // Normal incidence: ((η−1)/(η+1))², 0.04 for η = 1.5.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Brewster's angle: the parallel component vanishes, so F = r_perp²/2.
        let theta_b = 1.5f32.atan();
        let f = fresnel_dielectric(theta_b.cos(), 1.5);
        let cos_t = (1.0 - theta_b.sin().powi(2) / 2.25).sqrt();
        let r_perp = (theta_b.cos() - 1.5 * cos_t) / (theta_b.cos() + 1.5 * cos_t);
        assert!((f - 0.5 * r_perp * r_perp).abs() < 1e-6);
        // Total internal reflection from inside beyond the critical angle asin(1/1.5).
        assert_eq!(fresnel_dielectric(-(0.8f32.asin()).cos(), 1.5), 1.0);
        assert!(fresnel_dielectric(-(0.6f32.asin()).cos(), 1.5) < 1.0);
        // Grazing incidence reflects everything.
        assert!(fresnel_dielectric(1e-4, 1.5) > 0.99);
    }

    #[test]
    fn conductor_reduces_to_dielectric_and_to_normal_incidence_formula() {
        // k = 0 is a dielectric.
        for c in [0.1f32, 0.5, 0.9, 1.0] {
            let f = fresnel_conductor(c, Vec3::splat(1.5), Vec3::ZERO).x;
            assert!((f - fresnel_dielectric(c, 1.5)).abs() < 1e-5, "{c}");
        }
        // Normal incidence: ((η−1)² + k²)/((η+1)² + k²); gold-like values at 600 nm.
        let (eta, k) = (0.2f32, 3.0f32);
        let expected = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, Vec3::splat(eta), Vec3::splat(k)).x - expected).abs() < 1e-5);
    }

    #[test]
    fn average_fresnel_is_known_for_glass() {
        // The hemispherical average for η = 1.5 is about 0.0918 (d'Eon's tables).
        assert!((average_fresnel_dielectric(1.5) - 0.0918).abs() < 1e-3, "{}", average_fresnel_dielectric(1.5));
    }
}
