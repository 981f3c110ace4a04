//! Lights as sources of light paths: sampling an emitted ray (pbrt's `Sample_Le`), the
//! densities of a given emitted ray (`Pdf_Le`), and a point on a light seen from a scene
//! point together with that point's normal (which light sampling for next-event estimation
//! does not need, but the connection's MIS weight does).
//!
//! Directional and environment lights emit from a disk as wide as the scene's bounding
//! sphere, facing the direction of travel, as in pbrt.

use std::f32::consts::{FRAC_1_PI, PI, TAU};

use glam::{Vec2, Vec3};

use crate::light::{Light, LightSample, point_on_area};
use crate::sampling::{UNIFORM_SPHERE_PDF, cosine_hemisphere, orthonormal_basis, uniform_sphere};

/// The sphere around the scene that infinitely distant lights emit into.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SceneSphere {
    pub(crate) centre: Vec3,
    pub(crate) radius: f32,
}

impl SceneSphere {
    /// The bounding sphere of `scene`'s geometry (the unit origin-centred one when empty).
    pub(crate) fn around(scene: &crate::scene::Scene) -> Self {
        let bounds = scene.bvh.bounds();
        let centre = if bounds.min.x.is_finite() { bounds.centre() } else { Vec3::ZERO };
        Self { centre, radius: scene.radius.max(1e-3) }
    }

    /// Density per area of the disk that distant lights emit from.
    pub(crate) fn disk_pdf(&self) -> f32 {
        1.0 / (PI * self.radius * self.radius)
    }
}

/// An emitted ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EmittedRay {
    pub(crate) origin: Vec3,
    /// Unit direction of travel.
    pub(crate) direction: Vec3,
    /// The surface normal at the origin of an area light, zero for every other light.
    pub(crate) normal: Vec3,
    /// Radiance (area, environment), intensity (point, spot) or irradiance (directional).
    pub(crate) le: Vec3,
    /// Density of the origin per area (1 for point and spot lights, whose origin is fixed).
    pub(crate) pdf_pos: f32,
    /// Density of the direction per solid angle (1 for directional lights).
    pub(crate) pdf_dir: f32,
}

impl EmittedRay {
    /// Its throughput as the start of a light path: Le |cos| / (p_pick p_pos p_dir), the cosine
    /// at an area light's surface (1 for the others).
    pub(crate) fn throughput(&self, pick_pdf: f32) -> Vec3 {
        let cos = if self.normal == Vec3::ZERO { 1.0 } else { self.normal.dot(self.direction).abs() };
        self.le * cos / (pick_pdf * self.pdf_pos * self.pdf_dir)
    }

    /// The ray, started just off an area light's surface.
    pub(crate) fn ray(&self) -> lucid_scene::Ray {
        lucid_scene::Ray {
            origin: crate::integrator::spawn_origin(self.origin, self.normal, self.direction),
            direction: self.direction,
        }
    }
}

/// A point on a light seen from a scene point: the light sample and the point's normal
/// (zero for point-like and distant lights).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointOnLight {
    pub(crate) sample: LightSample,
    pub(crate) point: Vec3,
    pub(crate) normal: Vec3,
}

/// Whether a light is infinitely far away (its rays start on the scene's disk).
pub(crate) fn is_distant(light: &Light) -> bool {
    matches!(light, Light::Directional { .. } | Light::ConstantEnvironment { .. } | Light::EnvironmentMap(_))
}

/// Whether a light's position or direction is a Dirac delta (no path can hit it).
pub(crate) fn is_delta(light: &Light) -> bool {
    matches!(light, Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Projector(_))
}

/// Samples a ray leaving `light`, with two uniform pairs.
pub(crate) fn sample_emission(light: &Light, sphere: SceneSphere, u1: Vec2, u2: Vec2) -> Option<EmittedRay> {
    let ray = match light {
        Light::Point { position, intensity } => EmittedRay {
            origin: *position,
            direction: uniform_sphere(u1),
            normal: Vec3::ZERO,
            le: *intensity,
            pdf_pos: 1.0,
            pdf_dir: UNIFORM_SPHERE_PDF,
        },
        Light::Spot { position, direction, intensity, cos_inner, cos_outer } => {
            let local = uniform_cone(u1, *cos_outer);
            let (t, b) = orthonormal_basis(*direction);
            let d = local.x * t + local.y * b + local.z * *direction;
            EmittedRay {
                origin: *position,
                direction: d,
                normal: Vec3::ZERO,
                le: *intensity * crate::light::spot_falloff(local.z, *cos_outer, *cos_inner),
                pdf_pos: 1.0,
                pdf_dir: uniform_cone_pdf(*cos_outer),
            }
        }
        Light::Projector(projector) => {
            let (direction, le, pdf_dir) = projector.sample_emission(u1)?;
            EmittedRay { origin: projector.position(), direction, normal: Vec3::ZERO, le, pdf_pos: 1.0, pdf_dir }
        }
        Light::Directional { direction, irradiance } => EmittedRay {
            origin: disk_point(sphere, *direction, u1),
            direction: -*direction,
            normal: Vec3::ZERO,
            le: *irradiance,
            pdf_pos: sphere.disk_pdf(),
            pdf_dir: 1.0,
        },
        Light::Area { cdf, shapes, area, radiance, two_sided } => {
            let (p, n) = point_on_area(cdf, shapes, *area, u1);
            // A two-sided light picks its side with the first uniform, then reuses it.
            let (n, u, side_pdf) = if *two_sided {
                if u2.x < 0.5 {
                    (n, Vec2::new(u2.x * 2.0, u2.y), 0.5)
                } else {
                    (-n, Vec2::new(u2.x * 2.0 - 1.0, u2.y), 0.5)
                }
            } else {
                (n, u2, 1.0)
            };
            let local = cosine_hemisphere(u);
            let (t, b) = orthonormal_basis(n);
            let d = (local.x * t + local.y * b + local.z * n).normalize();
            EmittedRay {
                origin: p,
                direction: d,
                normal: n,
                le: *radiance,
                pdf_pos: 1.0 / area,
                pdf_dir: side_pdf * local.z * FRAC_1_PI,
            }
        }
        Light::ConstantEnvironment { radiance } => {
            let towards = uniform_sphere(u1);
            EmittedRay {
                origin: disk_point(sphere, towards, u2),
                direction: -towards,
                normal: Vec3::ZERO,
                le: *radiance,
                pdf_pos: sphere.disk_pdf(),
                pdf_dir: UNIFORM_SPHERE_PDF,
            }
        }
        Light::EnvironmentMap(env) => {
            let (towards, le, pdf) = env.sample(u1)?;
            EmittedRay {
                origin: disk_point(sphere, towards, u2),
                direction: -towards,
                normal: Vec3::ZERO,
                le,
                pdf_pos: sphere.disk_pdf(),
                pdf_dir: pdf,
            }
        }
    };
    (ray.pdf_pos > 0.0 && ray.pdf_dir > 0.0 && ray.le != Vec3::ZERO).then_some(ray)
}

/// Densities `(position per area, direction per solid angle)` with which
/// [`sample_emission`] emits the ray from `origin` (normal `normal`, for area lights) along
/// `direction`. Point-like lights have no position density (0), nor distant lights a
/// direction density, as in pbrt: both are deltas that no other strategy samples.
pub(crate) fn emission_pdf(light: &Light, sphere: SceneSphere, normal: Vec3, direction: Vec3) -> (f32, f32) {
    match light {
        Light::Point { .. } => (0.0, UNIFORM_SPHERE_PDF),
        Light::Spot { direction: axis, cos_outer, .. } => {
            (0.0, if direction.dot(*axis) >= *cos_outer { uniform_cone_pdf(*cos_outer) } else { 0.0 })
        }
        Light::Directional { .. } => (0.0, 0.0),
        Light::Projector(projector) => (0.0, projector.emission_pdf(direction)),
        Light::Area { area, two_sided, .. } => {
            let cos = normal.dot(direction);
            let pdf_dir = if *two_sided { 0.5 * cos.abs() * FRAC_1_PI } else { cos.max(0.0) * FRAC_1_PI };
            (1.0 / area, pdf_dir)
        }
        Light::ConstantEnvironment { .. } => (sphere.disk_pdf(), UNIFORM_SPHERE_PDF),
        Light::EnvironmentMap(env) => (sphere.disk_pdf(), env.pdf(-direction)),
    }
}

/// A point on `light` towards which light sampling from `point` goes (distant lights: a
/// point beyond the scene's sphere along the sampled direction).
pub(crate) fn sample_point_on(light: &Light, point: Vec3, sphere: SceneSphere, u: Vec2) -> Option<PointOnLight> {
    match light {
        Light::Area { cdf, shapes, area, radiance, two_sided } => {
            let (p, n) = point_on_area(cdf, shapes, *area, u);
            let (sample, valid) = crate::light::towards_area_point(point, p, n, *area, *radiance, *two_sided);
            valid.then_some(PointOnLight { sample, point: p, normal: n })
        }
        _ => {
            let sample = light.sample(point, u)?;
            let distance = if sample.distance.is_finite() {
                sample.distance
            } else {
                2.0 * (sphere.radius + (point - sphere.centre).length())
            };
            Some(PointOnLight { sample, point: point + sample.wi * distance, normal: Vec3::ZERO })
        }
    }
}

/// A point on the disk of the scene's sphere that faces `towards` (the disk sits on the
/// sphere's far side from where the light comes, one radius out).
fn disk_point(sphere: SceneSphere, towards: Vec3, u: Vec2) -> Vec3 {
    let (t, b) = orthonormal_basis(towards);
    let d = lucid_scene::sampling::concentric_disk(u) * sphere.radius;
    sphere.centre + sphere.radius * towards + d.x * t + d.y * b
}

/// Uniform direction in the cone around +Z with cosine half-angle `cos_max`.
fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos = 1.0 - u.x * (1.0 - cos_max);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (TAU * (1.0 - cos_max))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::sampling::Rng;

    fn lights() -> Vec<Light> {
        let prims: Vec<crate::geometry::Primitive> = [[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::X, Vec3::ONE, Vec3::Y]]
            .iter()
            .map(|p| crate::geometry::Primitive {
                shape: Shape::Triangle { p: *p, n: None, uv: None },
                material: 0,
                light: Some(0),
                interior_medium: None,
                exterior_medium: None,
            })
            .collect();
        vec![
            Light::Point { position: Vec3::ONE, intensity: Vec3::ONE },
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::new(0.0, 0.6, 0.8),
                intensity: Vec3::ONE,
                cos_inner: 0.9,
                cos_outer: 0.8,
            },
            Light::area(&prims, vec![0, 1], Vec3::ONE, false),
            Light::area(&prims, vec![0, 1], Vec3::ONE, true),
            Light::ConstantEnvironment { radiance: Vec3::ONE },
            Light::Projector(Box::new(
                crate::projector::Projector::new(
                    Vec3::ZERO,
                    Vec3::new(0.3, 1.0, 0.2),
                    Vec3::Z,
                    0.9,
                    4,
                    3,
                    (0..12).map(|k| Vec3::splat((k % 5) as f32)).collect(),
                )
                .unwrap(),
            )),
        ]
    }

    #[test]
    fn emitted_rays_have_the_densities_that_emission_pdf_reports() {
        let sphere = SceneSphere { centre: Vec3::ZERO, radius: 2.0 };
        let mut rng = Rng::new(8, 1);
        for light in lights() {
            for _ in 0..500 {
                let Some(ray) = sample_emission(&light, sphere, rng.uniform2(), rng.uniform2()) else { continue };
                let (pos, dir) = emission_pdf(&light, sphere, ray.normal, ray.direction);
                if !is_delta(&light) {
                    assert!((pos - ray.pdf_pos).abs() <= 1e-4 * pos, "{light:?}: {pos} vs {}", ray.pdf_pos);
                }
                assert!((dir - ray.pdf_dir).abs() <= 1e-3 * dir, "{light:?}: {dir} vs {}", ray.pdf_dir);
            }
        }
    }

    #[test]
    fn emitted_power_matches_the_lights_power() {
        // E[Le |cos| / (p_pos p_dir)] over emitted rays is the light's power (flux).
        let sphere = SceneSphere { centre: Vec3::ZERO, radius: 2.0 };
        for light in lights() {
            let mut rng = Rng::new(9, 2);
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                if let Some(r) = sample_emission(&light, sphere, rng.uniform2(), rng.uniform2()) {
                    sum += r.throughput(1.0).x as f64;
                }
            }
            let power = light.power(sphere.radius).x as f64;
            let estimate = sum / n as f64;
            assert!((estimate - power).abs() < 0.01 * power, "{light:?}: {estimate} vs {power}");
        }
    }
}
