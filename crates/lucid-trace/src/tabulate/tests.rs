use glam::{Vec2, Vec3};

use super::*;
use crate::bsdf::measured::MeasuredBrdf;
use crate::material::Texture;

fn conductor(alpha: Vec2) -> Material {
    Material::Conductor { eta: Vec3::new(0.2, 0.4, 1.4), k: Vec3::new(3.9, 2.4, 1.8), alpha }
}

#[test]
fn a_lambertian_table_holds_albedo_over_pi_everywhere() {
    let albedo = Vec3::new(0.7, 0.4, 0.1);
    let table = tabulate(&Material::Lambertian { albedo: Texture::Constant(albedo) }).expect("isotropic");
    let brdf = MeasuredBrdf { table: table.leak() };
    for (wo, wi) in pairs() {
        let f = brdf.eval(wo, wi);
        assert!((f - albedo / PI).abs().max_element() < 1e-5, "{f} at {wo} {wi}");
    }
}

#[test]
fn a_rough_isotropic_conductor_tabulates_to_its_own_values() {
    let material = conductor(Vec2::splat(0.3));
    let table = tabulate(&material).expect("isotropic").leak();
    let (analytic, measured) = (material.bsdf(Vec2::ZERO), MeasuredBrdf { table });
    // Away from grazing angles (where trilinear lookups smear the Fresnel rise) a cell-centre
    // table matches within a few per cent.
    let mut worst = 0f32;
    for (wo, wi) in pairs().filter(|(o, i)| o.z > 0.3 && i.z > 0.3) {
        worst = worst.max(relative_difference(analytic.eval(wo, wi), measured.eval(wo, wi)));
    }
    assert!(worst < 0.05, "worst relative difference {worst}");
}

#[test]
fn anisotropic_textured_specular_and_fibre_materials_are_refused() {
    assert!(matches!(check_tabulable(&conductor(Vec2::new(0.1, 0.4))), Err(TabulateError::Anisotropic(p)) if p > 10.0));
    let checker = Texture::Checker { a: Vec3::splat(0.2), b: Vec3::splat(0.8), scale: 4.0 };
    assert!(matches!(check_tabulable(&Material::Lambertian { albedo: checker }), Err(TabulateError::Varying)));
    let glass = Material::Dielectric { eta: 1.5, transmittance: Vec3::ONE };
    assert!(matches!(check_tabulable(&glass), Err(TabulateError::Specular)));
    let plastic = Material::Plastic { albedo: Texture::Constant(Vec3::splat(0.5)), eta: 1.5 };
    assert!(matches!(check_tabulable(&plastic), Err(TabulateError::Specular)));
    assert!(matches!(check_tabulable(&Material::Interface), Err(TabulateError::NotABrdf(_))));
    let grooves = Material::PoulinFournier {
        kd: Texture::Constant(Vec3::splat(0.2)),
        ks: Vec3::splat(0.5),
        d: 2.5,
        h: 0.3,
        sigma: Vec2::new(0.1, 0.4),
    };
    assert!(matches!(check_tabulable(&grooves), Err(TabulateError::Anisotropic(_))));
}
