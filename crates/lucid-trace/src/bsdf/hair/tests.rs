//! The checks pbrt-v3 runs on its hair model (white furnace with and without importance
//! sampling, sampling weights, the density's integral) plus a chi-square test of the sampler,
//! the geometry of the R lobe, and the Kajiya–Kay model's energy and reciprocity.

use super::*;
use crate::bsdf::chi_square::chi_square_p_value;
use crate::sampling::{Rng, UNIFORM_SPHERE_PDF, uniform_sphere};

fn fibre(sigma_a: f32, beta_m: f32, beta_n: f32, alpha_degrees: f32, h: f32) -> HairBsdf {
    HairBsdf { model: HairModel::new(Vec3::splat(sigma_a), beta_m, beta_n, alpha_degrees.to_radians(), 1.55), h }
}

/// ∫ S(ωo, ωi) dωi over the sphere, by uniform sampling and by the model's own sampler.
fn furnace(f: &HairBsdf, wo: Vec3, n: usize, rng: &mut Rng) -> (f64, f64) {
    let (mut uniform, mut sampled) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let wi = uniform_sphere(rng.uniform2());
        uniform += (f.scattering(wo, wi).y / UNIFORM_SPHERE_PDF) as f64;
        let wi = f.sample_direction(wo, rng.uniform2(), rng.uniform());
        let pdf = f.density(wo, wi);
        if pdf > 0.0 {
            sampled += (f.scattering(wo, wi).y / pdf) as f64;
        }
    }
    (uniform / n as f64, sampled / n as f64)
}

#[test]
fn a_fibre_without_absorption_scatters_all_light() {
    let mut rng = Rng::new(1, 0);
    for beta_m in [0.1f32, 0.3, 0.6, 1.0] {
        for beta_n in [0.1f32, 0.3, 0.6, 1.0] {
            for _ in 0..3 {
                let h = 2.0 * rng.uniform() - 1.0;
                let wo = uniform_sphere(rng.uniform2());
                let f = fibre(0.0, beta_m, beta_n, 2.0, h);
                let (uniform, sampled) = furnace(&f, wo, 60_000, &mut rng);
                assert!((sampled - 1.0).abs() < 0.01, "βm {beta_m} βn {beta_n} h {h}: sampled furnace {sampled}");
                // Narrow lobes make uniform sampling noisy.
                if beta_m >= 0.3 && beta_n >= 0.3 {
                    assert!((uniform - 1.0).abs() < 0.05, "βm {beta_m} βn {beta_n} h {h}: uniform furnace {uniform}");
                }
            }
        }
    }
}

#[test]
fn absorption_removes_light_by_colour() {
    let mut rng = Rng::new(2, 0);
    let sigma_a = HairModel::sigma_a_from_colour(Vec3::new(0.6, 0.3, 0.1), 0.3);
    assert!(sigma_a.x < sigma_a.y && sigma_a.y < sigma_a.z, "{sigma_a}");
    let f = HairBsdf { model: HairModel::new(sigma_a, 0.3, 0.3, 0.0, 1.55), h: 0.3 };
    let wo = Vec3::new(0.2, 0.5, 0.84).normalize();
    let mut sum = Vec3::ZERO;
    let n = 100_000;
    for _ in 0..n {
        let wi = f.sample_direction(wo, rng.uniform2(), rng.uniform());
        sum += f.scattering(wo, wi) / f.density(wo, wi) / n as f32;
    }
    assert!(sum.x > sum.y && sum.y > sum.z && sum.x < 1.0, "{sum}");
    // Melanin: eumelanin darkens all channels, blue most.
    let dark = HairModel::sigma_a_from_melanin(1.3, 0.0);
    assert!(dark.z > dark.y && dark.y > dark.x && dark.x > 0.5);
}

#[test]
fn the_density_integrates_to_one_and_matches_the_sampler() {
    let mut rng = Rng::new(3, 0);
    for (beta_m, beta_n, h) in [(0.3f32, 0.3f32, 0.0f32), (0.5, 0.2, 0.7), (0.25, 0.6, -0.5)] {
        let f = fibre(0.4, beta_m, beta_n, 2.0, h);
        for wo in [Vec3::new(0.3, 0.5, 0.81).normalize(), Vec3::new(-0.7, 0.1, 0.7).normalize()] {
            let mut integral = 0.0f64;
            let n = 400_000;
            for _ in 0..n {
                let wi = uniform_sphere(rng.uniform2());
                integral += (f.density(wo, wi) / UNIFORM_SPHERE_PDF) as f64 / n as f64;
            }
            assert!((integral - 1.0).abs() < 0.02, "βm {beta_m} βn {beta_n} h {h}: ∫ pdf = {integral}");
            let p = chi_square_p_value(
                300_000,
                7,
                |rng| Some(f.sample_direction(wo, rng.uniform2(), rng.uniform())),
                |wi| f.density(wo, wi),
            );
            assert!(p > 1e-4, "βm {beta_m} βn {beta_n} h {h}: chi-square p = {p}");
        }
    }
}

#[test]
fn the_surface_reads_its_offset_from_the_view_and_reflects_about_the_normal() {
    // A smooth, dark fibre: only R is left, a near-mirror about the shading normal.
    let model = HairModel::new(Vec3::splat(20.0), 0.08, 0.08, 0.0, 1.55);
    let surface = HairSurface { model };
    let mut rng = Rng::new(4, 0);
    for _ in 0..50 {
        let mut wo = uniform_sphere(rng.uniform2());
        wo.z = wo.z.abs().max(0.2);
        let wo = wo.normalize();
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        let peak = surface.eval(wo, mirror).x * mirror.z;
        for turn in [-0.4f32, -0.2, 0.2, 0.4] {
            // The same elevation, turned about the fibre.
            let (s, c) = turn.sin_cos();
            let other = Vec3::new(mirror.x, c * mirror.y - s * mirror.z, s * mirror.y + c * mirror.z);
            let value = surface.eval(wo, other).x * other.z.abs();
            assert!(peak > value, "wo {wo}: mirror {peak} vs turned by {turn}: {value}");
        }
    }
}

#[test]
fn sampled_values_match_evaluation() {
    let surface = HairSurface { model: HairModel::new(Vec3::new(0.2, 0.5, 1.0), 0.3, 0.4, 0.05, 1.55) };
    let kk = KajiyaKay { kd: Vec3::splat(0.4), ks: Vec3::splat(0.5), v: 0.05 };
    let mut rng = Rng::new(5, 0);
    for bsdf in [&surface as &dyn Bsdf, &kk] {
        for _ in 0..3000 {
            let mut wo = uniform_sphere(rng.uniform2());
            wo.z = wo.z.abs().max(0.05);
            let wo = wo.normalize();
            let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform()) else { continue };
            let (f, pdf) = (bsdf.eval(wo, s.wi), bsdf.pdf(wo, s.wi));
            assert!((f - s.f).abs().max_element() <= 1e-4 * (1.0 + f.max_element()), "{f} vs {}", s.f);
            assert!((pdf - s.pdf).abs() <= 1e-4 * (1.0 + pdf));
            assert_eq!(s.transmission, s.wi.z < 0.0);
        }
    }
}

#[test]
fn kajiya_kay_reflects_its_albedos_and_its_cone_is_reciprocal() {
    let mut rng = Rng::new(6, 0);
    // Diffuse only: exactly kd for every view.
    let diffuse = KajiyaKay { kd: Vec3::splat(0.7), ks: Vec3::ZERO, v: 0.1 };
    for v in [0.02f32, 0.1, 0.5] {
        let kk = KajiyaKay { kd: Vec3::splat(0.3), ks: Vec3::splat(0.7), v };
        for _ in 0..4 {
            let wo = uniform_sphere(rng.uniform2());
            let n = 200_000;
            let (mut d, mut uniform, mut sampled) = (0.0f64, 0.0f64, 0.0f64);
            for _ in 0..n {
                let wi = uniform_sphere(rng.uniform2());
                d += (diffuse.scattering(wo, wi).x / UNIFORM_SPHERE_PDF) as f64 / n as f64;
                uniform += (kk.scattering(wo, wi).x / UNIFORM_SPHERE_PDF) as f64 / n as f64;
                if let Some(s) = kk.sample(wo, rng.uniform2(), rng.uniform()) {
                    sampled += (s.f.x * s.wi.z.abs() / s.pdf) as f64 / n as f64;
                }
            }
            assert!((d - 0.7).abs() < 0.01, "diffuse albedo {d}");
            assert!(sampled <= 1.0 + 0.01 && (sampled - 1.0).abs() < 0.02, "v {v}: albedo {sampled}");
            if v >= 0.1 {
                assert!((uniform - sampled).abs() < 0.03, "v {v}: uniform {uniform} vs sampled {sampled}");
            }
        }
        let cone = KajiyaKay { kd: Vec3::ZERO, ks: Vec3::ONE, v };
        for _ in 0..1000 {
            let (a, b) = (uniform_sphere(rng.uniform2()), uniform_sphere(rng.uniform2()));
            let (ab, ba) = (cone.scattering(a, b).x, cone.scattering(b, a).x);
            assert!((ab - ba).abs() <= 1e-4 * (1.0 + ab), "{ab} vs {ba}");
        }
        let p = chi_square_p_value(
            300_000,
            8,
            |rng| kk.sample(Vec3::new(0.4, 0.3, 0.87).normalize(), rng.uniform2(), rng.uniform()).map(|s| s.wi),
            |wi| kk.pdf(Vec3::new(0.4, 0.3, 0.87).normalize(), wi),
        );
        assert!(p > 1e-4, "v {v}: chi-square p = {p}");
    }
}
