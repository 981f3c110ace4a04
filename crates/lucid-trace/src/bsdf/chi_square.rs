//! Chi-square goodness-of-fit test of direction samplers against their densities (the
//! method Mitsuba validates every BSDF with): directions drawn by `sample` are binned on a
//! grid that is uniform in (cos θ, φ), hence of equal solid angle per cell; the expected count
//! of each cell is the density integrated over it (supersampled midpoint rule); cells expected
//! to hold fewer than 5 samples are pooled. A wrong density, a biased sampler or a mismatch
//! between the two makes the statistic explode.

use glam::Vec3;
use std::f64::consts::PI;

use crate::sampling::Rng;

const Z_BINS: usize = 32;
const PHI_BINS: usize = 64;
const SUPERSAMPLING: usize = 8;

fn direction(z: f64, phi: f64) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

fn cell_of(w: Vec3) -> usize {
    let z = ((w.z as f64 + 1.0) * 0.5 * Z_BINS as f64) as usize;
    let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
    let p = (phi / (2.0 * PI) * PHI_BINS as f64) as usize;
    z.min(Z_BINS - 1) * PHI_BINS + p.min(PHI_BINS - 1)
}

/// Runs the test and returns its p-value. `sample(rng)` draws a direction (or `None` for a
/// failed or excluded sample, e.g. a delta component); `pdf(w)` is its density.
pub fn chi_square_p_value(
    samples: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> f64 {
    let mut observed = vec![0f64; Z_BINS * PHI_BINS];
    let mut rng = Rng::new(seed, 0);
    for _ in 0..samples {
        if let Some(w) = sample(&mut rng) {
            observed[cell_of(w.normalize())] += 1.0;
        }
    }
    let (dz, dphi) = (2.0 / Z_BINS as f64, 2.0 * PI / PHI_BINS as f64);
    let sub = (SUPERSAMPLING * SUPERSAMPLING) as f64;
    let expected: Vec<f64> = (0..Z_BINS * PHI_BINS)
        .map(|cell| {
            let (iz, ip) = (cell / PHI_BINS, cell % PHI_BINS);
            let mut sum = 0.0;
            for a in 0..SUPERSAMPLING {
                for b in 0..SUPERSAMPLING {
                    let z = -1.0 + dz * (iz as f64 + (a as f64 + 0.5) / SUPERSAMPLING as f64);
                    let phi = dphi * (ip as f64 + (b as f64 + 0.5) / SUPERSAMPLING as f64);
                    sum += pdf(direction(z, phi)) as f64;
                }
            }
            sum / sub * dz * dphi * samples as f64
        })
        .collect();
    // Pool sparse cells so that the chi-square approximation holds.
    let (mut chi2, mut bins) = (0.0, 0usize);
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pooled_obs += o;
            pooled_exp += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            bins += 1;
        }
    }
    if pooled_exp > 5.0 {
        chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        bins += 1;
    } else if pooled_obs > 20.0 {
        // Many samples where the density says there should be almost none.
        return 0.0;
    }
    chi_square_survival(chi2, bins.saturating_sub(1).max(1) as f64)
}

/// `P(X ≥ x)` for X chi-square with `k` degrees of freedom (Wilson–Hilferty normal
/// approximation, accurate to ~1e-3 for the hundreds of degrees of freedom used here).
fn chi_square_survival(x: f64, k: f64) -> f64 {
    let z = ((x / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// Complementary error function (Numerical Recipes' Chebyshev fit, |ε| < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::*;
    use crate::medium::HenyeyGreenstein;

    /// Significance per test. With fixed seeds each outcome is reproducible; 1e-3 keeps a
    /// correct sampler from failing by chance across the ~40 cases here (expected 4%).
    const ALPHA: f64 = 1e-3;
    const N: usize = 1_000_000;

    fn check(name: &str, bsdf: &dyn Bsdf) {
        for (k, wo) in
            [Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.6, 0.7, 0.0).normalize() * 0.95 + Vec3::new(0.0, 0.0, 0.3)]
                .into_iter()
                .enumerate()
        {
            let wo = wo.normalize();
            let p = chi_square_p_value(
                N,
                100 + k as u64,
                |rng| bsdf.sample(wo, rng.uniform2(), rng.uniform()).filter(|s| !s.specular).map(|s| s.wi),
                |wi| bsdf.pdf(wo, wi),
            );
            assert!(p > ALPHA, "{name}, wo {wo}: chi-square p-value {p:.2e}");
        }
    }

    #[test]
    fn test_rejects_a_wrong_density() {
        // Cosine sampling checked against a uniform hemisphere density must fail.
        let lambert = Lambertian { albedo: Vec3::ONE };
        let p = chi_square_p_value(
            N,
            1,
            |rng| lambert.sample(Vec3::Z, rng.uniform2(), 0.0).map(|s| s.wi),
            |w| if w.z > 0.0 { 1.0 / (2.0 * std::f32::consts::PI) } else { 0.0 },
        );
        assert!(p < 1e-9, "{p}");
        assert!((erfc(0.0) - 1.0).abs() < 1e-7 && (erfc(1.0) - 0.157_299_2).abs() < 1e-6);
        // χ² with k dof has mean k: the survival at the mean is a bit below 1/2.
        let s = chi_square_survival(200.0, 200.0);
        assert!((s - 0.4867).abs() < 0.002, "{s}");
    }

    #[test]
    fn lambertian_and_microfacet_samplers_match_their_densities() {
        check("lambertian", &Lambertian { albedo: Vec3::ONE });
        for (ax, ay) in [(0.3, 0.3), (0.2, 0.6), (0.8, 0.8)] {
            let c = MicrofacetConductor {
                distribution: GgxDistribution { alpha_x: ax, alpha_y: ay },
                eta: Vec3::splat(0.2),
                k: Vec3::splat(3.0),
            };
            check("ggx conductor", &c);
        }
        check("plastic", &SmoothPlastic::new(Vec3::splat(0.7), 1.5));
        for (metallic, roughness, normal) in
            [(0.0, 0.5, Vec3::Z), (1.0, 0.4, Vec3::Z), (0.3, 0.6, Vec3::new(0.3, -0.2, 1.0))]
        {
            let b = crate::bsdf::metallic_roughness::MetallicRoughness::new(
                Vec3::new(0.8, 0.6, 0.3),
                metallic,
                roughness,
                normal,
            );
            check("metallic-roughness", &b);
        }
        let metal = MicrofacetConductor {
            distribution: GgxDistribution { alpha_x: 0.25, alpha_y: 0.25 },
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        };
        let table = crate::bsdf::measured::MerlTable::from_fn(|wo, wi| metal.eval(wo, wi)).leak();
        check("measured", &crate::bsdf::measured::MeasuredBrdf { table });
    }

    #[test]
    fn classic_model_samplers_match_their_densities() {
        check(
            "phong",
            &DiffuseAndLobe { diffuse: Vec3::splat(0.3), lobe: PhongLobe { ks: Vec3::splat(0.6), exponent: 20.0 } },
        );
        check(
            "blinn-phong",
            &DiffuseAndLobe { diffuse: Vec3::splat(0.3), lobe: BlinnPhongLobe::new(Vec3::splat(0.6), 30.0) },
        );
        let lobes = [
            LafortuneTerm { c: Vec3::new(-1.0, -1.0, 1.0), exponent: 15.0, albedo: Vec3::splat(1.0) },
            LafortuneTerm { c: Vec3::new(0.7, 0.7, 0.7), exponent: 5.0, albedo: Vec3::splat(0.2) },
        ];
        check("lafortune", &DiffuseAndLobe { diffuse: Vec3::splat(0.3), lobe: LafortuneLobes::new(&lobes) });
        check(
            "ward",
            &DiffuseAndLobe {
                diffuse: Vec3::splat(0.2),
                lobe: WardLobe { ks: Vec3::splat(0.7), alpha_x: 0.2, alpha_y: 0.45 },
            },
        );
        check(
            "ashikhmin-shirley",
            &AshikhminShirley { rd: Vec3::splat(0.5), rs: Vec3::splat(0.3), nu: 20.0, nv: 60.0 },
        );
        check(
            "cook-torrance",
            &DiffuseAndLobe {
                diffuse: Vec3::splat(0.2),
                lobe: CookTorranceLobe { ks: Vec3::splat(0.7), m: 0.3, eta: 1.5 },
            },
        );
    }

    #[test]
    fn henyey_greenstein_sampler_matches_its_density() {
        for g in [-0.5f32, 0.0, 0.6] {
            let hg = HenyeyGreenstein { g };
            let wo = Vec3::new(0.2, -0.3, 0.93).normalize();
            let p = chi_square_p_value(N, 7, |rng| Some(hg.sample(wo, rng.uniform2()).0), |wi| hg.eval(wo, wi));
            assert!(p > ALPHA, "HG g = {g}: p-value {p:.2e}");
        }
    }
}
