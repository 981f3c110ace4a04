//! Energy, normalisation, sampling and reciprocity checks of the classic analytic BRDFs,
//! plus the closed forms some of them have.

use glam::Vec3;
use std::f32::consts::PI;

use super::testing::*;
use super::*;

fn phong(kd: f32, ks: f32, n: f32) -> DiffuseAndLobe<PhongLobe> {
    DiffuseAndLobe { diffuse: Vec3::splat(kd), lobe: PhongLobe { ks: Vec3::splat(ks), exponent: n } }
}

/// The checks every reflection model passes: sampled and evaluated values agree, sampling is
/// unbiased against uniform sampling, the pdf integrates to at most 1, and f is reciprocal.
fn common_checks(name: &str, bsdf: &dyn Bsdf, max_albedo: f32) {
    for wo in outgoing_directions() {
        sample_matches_eval(bsdf, wo, 3000);
        let sampled = albedo_by_sampling(bsdf, wo, 300_000).x;
        let uniform = albedo_by_uniform(bsdf, wo, 1_500_000).x;
        assert!(sampled <= max_albedo, "{name}, cos {}: albedo {sampled} above {max_albedo}", wo.z);
        assert!(
            (sampled - uniform).abs() < 0.02 + 0.03 * uniform,
            "{name}, cos {}: importance-sampled {sampled} vs uniform {uniform}",
            wo.z
        );
        let pdf = pdf_integral(bsdf, wo, 1_000_000);
        assert!(pdf <= 1.02, "{name}, cos {}: pdf integrates to {pdf}", wo.z);
    }
    reciprocal(bsdf, 3000);
}

#[test]
fn modified_phong_reflects_exactly_ks_at_normal_incidence() {
    // ∫ (n+2)/2π cos^n θ cos θ dω = 1 when the mirror direction is the normal.
    for n in [1.0f32, 10.0, 100.0] {
        let specular_only = phong(0.0, 1.0, n);
        let albedo = albedo_by_uniform(&specular_only, Vec3::Z, 2_000_000).x;
        assert!((albedo - 1.0).abs() < 0.02, "n = {n}: {albedo}");
    }
    common_checks("phong", &phong(0.4, 0.6, 20.0), 1.001);
}

#[test]
fn blinn_phong_albedo_is_ks_at_normal_incidence_and_falls_off() {
    for n in [1.0f32, 8.0, 64.0, 500.0] {
        let b = DiffuseAndLobe { diffuse: Vec3::ZERO, lobe: BlinnPhongLobe::new(Vec3::ONE, n) };
        let normal = albedo_by_sampling(&b, Vec3::Z, 400_000).x;
        assert!((normal - 1.0).abs() < 0.01, "n = {n}: {normal}");
        let oblique = albedo_by_sampling(&b, Vec3::new(0.8, 0.0, 0.6), 400_000).x;
        assert!(oblique < normal, "n = {n}: {oblique} vs {normal}");
    }
    let b = DiffuseAndLobe { diffuse: Vec3::splat(0.5), lobe: BlinnPhongLobe::new(Vec3::splat(0.5), 30.0) };
    common_checks("blinn-phong", &b, 1.01);
}

#[test]
fn lafortune_with_mirror_coefficients_is_modified_phong() {
    // Cx = Cy = −c, Cz = c with ρ·c^n = (n+2)/2π reproduces Phong's lobe exactly.
    let n = 12.0f32;
    let term =
        LafortuneTerm { c: Vec3::new(-1.0, -1.0, 1.0), exponent: n, albedo: Vec3::splat((n + 2.0) / (2.0 * PI)) };
    let laf = DiffuseAndLobe { diffuse: Vec3::splat(0.3), lobe: LafortuneLobes::new(&[term]) };
    let ph = phong(0.3, 1.0, n);
    let mut rng = crate::sampling::Rng::new(21, 0);
    for _ in 0..1000 {
        let wo = crate::sampling::cosine_hemisphere(rng.uniform2());
        let wi = crate::sampling::cosine_hemisphere(rng.uniform2());
        let (a, b) = (laf.eval(wo, wi), ph.eval(wo, wi));
        assert!((a - b).abs().max_element() < 1e-4 * (1.0 + b.x), "{a} vs {b}");
    }
    // A two-lobe fit (forward glossy + retro-reflection) keeps its estimators consistent.
    let retro = LafortuneTerm { c: Vec3::new(0.9, 0.9, 0.9), exponent: 8.0, albedo: Vec3::splat(0.15) };
    let glossy = LafortuneTerm { c: Vec3::new(-1.0, -1.0, 1.0), exponent: 30.0, albedo: Vec3::splat(2.0) };
    common_checks(
        "lafortune",
        &DiffuseAndLobe { diffuse: Vec3::splat(0.3), lobe: LafortuneLobes::new(&[glossy, retro]) },
        1.0,
    );
}

#[test]
fn ward_albedo_is_bounded_and_anisotropy_orients_the_highlight() {
    for (ax, ay) in [(0.1f32, 0.1f32), (0.3, 0.3), (0.1, 0.4)] {
        let w = DiffuseAndLobe { diffuse: Vec3::ZERO, lobe: WardLobe { ks: Vec3::ONE, alpha_x: ax, alpha_y: ay } };
        common_checks("ward", &w, 1.005);
    }
    // Stretched along y: a direction tilted off the mirror along y reflects more than the
    // same tilt along x.
    let w = WardLobe { ks: Vec3::ONE, alpha_x: 0.05, alpha_y: 0.3 };
    let wo = Vec3::Z;
    let tilt_y = Vec3::new(0.0, 0.2, 1.0).normalize();
    let tilt_x = Vec3::new(0.2, 0.0, 1.0).normalize();
    use super::lobe::Lobe;
    assert!(w.eval(wo, tilt_y).x > 10.0 * w.eval(wo, tilt_x).x);
}

#[test]
fn ashikhmin_shirley_conserves_energy() {
    for (nu, nv) in [(10.0f32, 10.0f32), (100.0, 1000.0), (1.0, 1.0)] {
        let a = AshikhminShirley { rd: Vec3::splat(0.9), rs: Vec3::splat(0.1), nu, nv };
        common_checks("ashikhmin-shirley", &a, 1.01);
    }
    // All-specular with Rs = 1: the lobe alone, near-total reflection at moderate angles.
    let mirrorish = AshikhminShirley { rd: Vec3::ZERO, rs: Vec3::ONE, nu: 1000.0, nv: 1000.0 };
    let albedo = albedo_by_sampling(&mirrorish, Vec3::new(0.6, 0.0, 0.8), 300_000).x;
    assert!((albedo - 1.0).abs() < 0.05, "{albedo}");
}

#[test]
fn cook_torrance_beckmann_is_normalised_and_bounded() {
    // ∫ D(h) cos θh dωh = 1.
    let lobe = CookTorranceLobe { ks: Vec3::ONE, m: 0.3, eta: 1.5 };
    let mut rng = crate::sampling::Rng::new(22, 0);
    let n = 2_000_000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        let h = crate::sampling::cosine_hemisphere(rng.uniform2());
        // cos-weighted sampling: D cos / (cos/π) = π D.
        sum += (PI * lobe.beckmann(h)) as f64;
    }
    assert!((sum / n as f64 - 1.0).abs() < 0.02, "{}", sum / n as f64);
    for m in [0.1f32, 0.3, 0.6] {
        // A huge index makes F ≈ 1, the worst case for energy.
        let ct = DiffuseAndLobe { diffuse: Vec3::ZERO, lobe: CookTorranceLobe { ks: Vec3::ONE, m, eta: 1e4 } };
        common_checks("cook-torrance", &ct, 1.01);
    }
}
