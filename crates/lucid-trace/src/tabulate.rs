//! Tabulating a scene's material as a measured table: what `lucid brdf tabulate` writes and
//! what a `measured` material with `tabulate = {..}` renders with. A MERL table holds one
//! isotropic BRDF without delta parts, so materials that are not one are refused rather than
//! written as a table that renders differently.

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

use crate::bsdf::Bsdf;
use crate::bsdf::measured::MerlTable;
use crate::material::Material;

/// Direction pairs each property is checked on.
const PAIRS: usize = 256;
/// Relative difference beyond which two values differ (well above f32 round-off of the
/// materials' own arithmetic, well below any visible anisotropy or texture contrast).
const TOLERANCE: f32 = 2e-3;

/// Why a material has no table.
#[derive(Debug, thiserror::Error)]
pub enum TabulateError {
    /// A kind of material that is not a surface BRDF.
    #[error("a {0} material is not a surface BRDF that a table can hold")]
    NotABrdf(&'static str),
    /// A delta (mirror or refraction) part.
    #[error("it has a mirror-like (delta) part that a table cannot hold")]
    Specular,
    /// Different BRDFs at different surface points.
    #[error("it varies over the surface (textures or maps); a table holds one BRDF")]
    Varying,
    /// Not invariant under rotation about the normal.
    #[error(
        "it is anisotropic (f changes by {0:.1} % when both directions turn about the normal); MERL tables are isotropic"
    )]
    Anisotropic(f32),
}

/// The pairs `(ωo, ωi)` the checks use: a fixed low-discrepancy set over the upper hemisphere.
fn pairs() -> impl Iterator<Item = (Vec3, Vec3)> {
    let direction = |u: f32, v: f32| {
        let z = 0.05 + 0.95 * u;
        let r = (1.0 - z * z).sqrt();
        let (s, c) = (TAU * v).sin_cos();
        Vec3::new(r * c, r * s, z)
    };
    // Additive recurrences with the plastic number's powers: well spread in four dimensions.
    let a = [0.569_840_3, 0.754_877_7, 0.324_717_96, 0.430_159_7];
    (0..PAIRS).map(move |i| {
        let u = a.map(|x| (0.5 + x * i as f32).fract());
        (direction(u[0], u[1]), direction(u[2], u[3]))
    })
}

fn relative_difference(a: Vec3, b: Vec3) -> f32 {
    let scale = a.abs().max(b.abs()).max_element().max(1e-4);
    (a - b).abs().max_element() / scale
}

fn rotate_z(w: Vec3, phi: f32) -> Vec3 {
    let (s, c) = phi.sin_cos();
    Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z)
}

/// Checks that `material` is one isotropic BRDF without delta parts.
pub fn check_tabulable(material: &Material) -> Result<(), TabulateError> {
    match material {
        Material::Hair { .. } | Material::KajiyaKay { .. } => return Err(TabulateError::NotABrdf("fibre")),
        Material::Subsurface { .. } => return Err(TabulateError::NotABrdf("subsurface")),
        Material::Interface => return Err(TabulateError::NotABrdf("interface")),
        _ => {}
    }
    let bsdf = material.bsdf(Vec2::ZERO);
    if bsdf.is_specular() {
        return Err(TabulateError::Specular);
    }
    let elsewhere = [Vec2::new(0.13, 0.71), Vec2::new(0.87, 0.29), Vec2::new(0.52, 0.46)].map(|uv| material.bsdf(uv));
    let mut anisotropy = 0f32;
    for (i, (wo, wi)) in pairs().enumerate() {
        let u = Vec2::new((0.25 + 0.618_034 * i as f32).fract(), (0.75 + 0.414_213_6 * i as f32).fract());
        if bsdf.sample(wo, u, u.x).is_some_and(|s| s.specular) {
            return Err(TabulateError::Specular);
        }
        let f = bsdf.eval(wo, wi);
        if elsewhere.iter().any(|other| relative_difference(f, other.eval(wo, wi)) > TOLERANCE) {
            return Err(TabulateError::Varying);
        }
        let phi = PI * (0.1 + 1.8 * (0.5 + 0.381_966 * i as f32).fract());
        anisotropy = anisotropy.max(relative_difference(f, bsdf.eval(rotate_z(wo, phi), rotate_z(wi, phi))));
    }
    if anisotropy > TOLERANCE {
        return Err(TabulateError::Anisotropic(100.0 * anisotropy));
    }
    Ok(())
}

/// The table of `material` (90 × 90 × 180 cells, each the BRDF at its centre).
pub fn tabulate(material: &Material) -> Result<MerlTable, TabulateError> {
    check_tabulable(material)?;
    let bsdf = material.bsdf(Vec2::ZERO);
    Ok(MerlTable::from_fn(|wo, wi| bsdf.eval(wo, wi)))
}

/// The table of `material`, made once per process for each `key` (a description of the
/// material that tells tables apart).
pub fn tabulate_shared(key: &str, material: &Material) -> Result<&'static MerlTable, TabulateError> {
    crate::bsdf::shared_file::load_named(&format!("tabulate:{key}"), || tabulate(material))
}

#[cfg(test)]
mod tests;
