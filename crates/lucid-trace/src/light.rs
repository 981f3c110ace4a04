//! Light sources and their sampling from a shading point: point, spot and directional
//! lights (deltas), area lights (emissive meshes, sampled uniformly by area) and a constant
//! environment.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use crate::environment::EnvironmentMap;
use crate::geometry::{Primitive, Shape, triangle_normal};
use crate::projector::Projector;
use crate::sampling::{UNIFORM_SPHERE_PDF, uniform_sphere, uniform_triangle};

/// A light source.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light of radiant intensity `intensity` (W/sr).
    Point {
        /// Position.
        position: Vec3,
        /// Intensity.
        intensity: Vec3,
    },
    /// Spot light: a point light restricted to a cone with a smooth falloff.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit axis of the cone.
        direction: Vec3,
        /// Intensity on the axis.
        intensity: Vec3,
        /// Cosine of the angle where the falloff starts.
        cos_inner: f32,
        /// Cosine of the angle where the light ends.
        cos_outer: f32,
    },
    /// Parallel light from `direction` (unit, pointing towards the light), giving `irradiance`
    /// on a surface facing it.
    Directional {
        /// Towards the light.
        direction: Vec3,
        /// Irradiance.
        irradiance: Vec3,
    },
    /// An emissive mesh: one-sided (front = geometric normal) unless `two_sided`.
    Area {
        /// Cumulative areas for picking a primitive proportionally to its area, from a leading
        /// 0 (primitive `k`'s share is `cdf[k]..cdf[k + 1]`).
        cdf: Vec<f32>,
        /// Each primitive's shape, copied here with its unit normal (for triangles; a sphere's
        /// depends on the point) so that sampling reads neither the BVH's records nor a cross
        /// product per sample.
        shapes: Vec<(Shape, Vec3)>,
        /// Total area.
        area: f32,
        /// Emitted radiance.
        radiance: Vec3,
        /// Emit from both sides.
        two_sided: bool,
    },
    /// Radiance arriving from every direction not blocked by the scene.
    ConstantEnvironment {
        /// Radiance.
        radiance: Vec3,
    },
    /// A lat-long radiance map around the scene, importance-sampled.
    EnvironmentMap(Box<EnvironmentMap>),
    /// A pinhole projector: a point light whose intensity is an image over its frustum.
    Projector(Box<Projector>),
}

/// A direction towards a light and what arrives along it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Radiance (or, for delta lights, the irradiance-like weight `I/d²`) arriving.
    pub li: Vec3,
    /// Density in solid angle (1 for delta lights).
    pub pdf: f32,
    /// Distance to the light point (∞ for directional and environment lights).
    pub distance: f32,
    /// A point/spot/directional light: no MIS with BSDF sampling.
    pub delta: bool,
}

impl Light {
    /// Builds an area light over `primitives` (indices into `all`).
    pub fn area(all: &[Primitive], primitives: Vec<u32>, radiance: Vec3, two_sided: bool) -> Self {
        let mut cdf = Vec::with_capacity(primitives.len() + 1);
        cdf.push(0.0);
        let mut area = 0.0;
        let mut shapes = Vec::with_capacity(primitives.len());
        for &i in &primitives {
            let shape = all[i as usize].shape;
            area += shape.area();
            cdf.push(area);
            let normal = match shape {
                Shape::Triangle { p, .. } => triangle_normal(&p),
                Shape::Sphere { .. } | Shape::Fibre { .. } => Vec3::ZERO,
            };
            shapes.push((shape, normal));
        }
        Light::Area { cdf, shapes, area, radiance, two_sided }
    }

    /// Samples a direction towards the light from `point`.
    pub fn sample(&self, point: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Point { position, intensity } => {
                let d = *position - point;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                Some(LightSample { wi: d / distance, li: *intensity / dist2, pdf: 1.0, distance, delta: true })
            }
            Light::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                let d = *position - point;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                let wi = d / distance;
                let falloff = spot_falloff(-wi.dot(*direction), *cos_outer, *cos_inner);
                (falloff > 0.0).then(|| LightSample {
                    wi,
                    li: *intensity * falloff / dist2,
                    pdf: 1.0,
                    distance,
                    delta: true,
                })
            }
            Light::Directional { direction, irradiance } => {
                Some(LightSample { wi: *direction, li: *irradiance, pdf: 1.0, distance: f32::INFINITY, delta: true })
            }
            Light::Projector(projector) => {
                let d = projector.position() - point;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                let wi = d / distance;
                let intensity = projector.intensity(-wi);
                (intensity != Vec3::ZERO).then(|| LightSample {
                    wi,
                    li: intensity / dist2,
                    pdf: 1.0,
                    distance,
                    delta: true,
                })
            }
            Light::Area { cdf, shapes, area, radiance, two_sided } => {
                let (p, n) = point_on_area(cdf, shapes, *area, u);
                let (sample, valid) = towards_area_point(point, p, n, *area, *radiance, *two_sided);
                valid.then_some(sample)
            }
            Light::ConstantEnvironment { radiance } => Some(LightSample {
                wi: uniform_sphere(u),
                li: *radiance,
                pdf: UNIFORM_SPHERE_PDF,
                distance: f32::INFINITY,
                delta: false,
            }),
            Light::EnvironmentMap(env) => {
                let (wi, li, pdf) = env.sample(u)?;
                Some(LightSample { wi, li, pdf, distance: f32::INFINITY, delta: false })
            }
        }
    }

    /// For environment lights: the radiance arriving from direction `w` and the density with
    /// which [`Light::sample`] picks `w`. `None` for every other light.
    pub fn environment(&self, w: Vec3) -> Option<(Vec3, f32)> {
        match self {
            Light::ConstantEnvironment { radiance } => Some((*radiance, UNIFORM_SPHERE_PDF)),
            Light::EnvironmentMap(env) => Some((env.eval(w), env.pdf(w))),
            _ => None,
        }
    }

    /// Density (solid angle, from `point`) with which [`Light::sample`] would pick the
    /// direction to `light_point` on this light's surface with normal `light_normal`.
    pub fn pdf_area(&self, point: Vec3, light_point: Vec3, light_normal: Vec3) -> f32 {
        match self {
            Light::Area { area, .. } => {
                let d = light_point - point;
                let dist2 = d.length_squared();
                // dist² / (|cos| A) with cos = d·n / |d|: one square root, no normalised copy.
                let cos_dist = d.dot(light_normal).abs();
                if cos_dist == 0.0 { 0.0 } else { dist2 * dist2.sqrt() / (cos_dist * area) }
            }
            _ => 0.0,
        }
    }

    /// Radiance leaving an area light's surface with geometric normal `n` towards `w`.
    pub fn emitted(&self, n: Vec3, w: Vec3) -> Vec3 {
        match self {
            Light::Area { radiance, two_sided, .. } if *two_sided || n.dot(w) > 0.0 => *radiance,
            _ => Vec3::ZERO,
        }
    }

    /// Total emitted power, for reports and light selection.
    pub fn power(&self, scene_radius: f32) -> Vec3 {
        match self {
            Light::Point { intensity, .. } => 4.0 * PI * *intensity,
            Light::Spot { intensity, cos_inner, cos_outer, .. } => {
                2.0 * PI * *intensity * (1.0 - 0.5 * (cos_inner + cos_outer))
            }
            Light::Directional { irradiance, .. } => PI * scene_radius * scene_radius * *irradiance,
            Light::Projector(projector) => projector.power(),
            Light::Area { area, radiance, two_sided, .. } => {
                PI * *area * *radiance * if *two_sided { 2.0 } else { 1.0 }
            }
            Light::ConstantEnvironment { radiance } => 4.0 * PI * PI * scene_radius * scene_radius * *radiance,
            Light::EnvironmentMap(env) => PI * scene_radius * scene_radius * env.integral(),
        }
    }
}

/// A point of an area light's surface, uniform by area, and its normal.
#[inline]
pub(crate) fn point_on_area(cdf: &[f32], shapes: &[(Shape, Vec3)], area: f32, u: Vec2) -> (Vec3, Vec3) {
    let (k, ux) = pick_by_area(cdf, area, u.x);
    match &shapes[k] {
        (Shape::Triangle { p, .. }, normal) => (point_on_triangle(p, Vec2::new(ux, u.y)), *normal),
        (sphere, _) => sample_shape(sphere, Vec2::new(ux, u.y)),
    }
}

/// The primitive of an area light that `u` picks by area (`cdf`: cumulative areas, `area`:
/// their total), and `u` rescaled to a fresh uniform within that primitive's share.
#[inline]
pub(crate) fn pick_by_area(cdf: &[f32], area: f32, u: f32) -> (usize, f32) {
    let (k, target, lo, hi) = area_share(cdf, area, u);
    (k, rescale_in_share(target, lo, hi))
}

/// The primitive [`pick_by_area`] picks, the point `u · area` that picks it and the bounds of
/// its share of the cumulative areas; the packet tracer rescales in its lane loops.
#[inline(always)]
pub(crate) fn area_share(cdf: &[f32], area: f32, u: f32) -> (usize, f32, f32, f32) {
    let target = u * area;
    // The leading 0 spares the first share a branch on `k == 0`, which went the other way
    // for about half the samples of a two-triangle light.
    let k = cdf[1..].partition_point(|&c| c <= target).min(cdf.len() - 2);
    (k, target, cdf[k], cdf[k + 1])
}

/// `target` rescaled to a uniform within the share `[lo, hi)`.
#[inline(always)]
pub(crate) fn rescale_in_share(target: f32, lo: f32, hi: f32) -> f32 {
    ((target - lo) / (hi - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 0.999_999)
}

/// The light sample from `point` towards `light_point` (normal `n`) of an area light of total
/// area `area`, and whether it is valid (not from behind a one-sided light, finite density).
/// Shared by [`Light::sample`] and the packet tracer, which completes its lanes' triangle-light
/// samples with it in one loop after drawing them.
#[inline(always)]
pub(crate) fn towards_area_point(
    point: Vec3,
    light_point: Vec3,
    n: Vec3,
    area: f32,
    radiance: Vec3,
    two_sided: bool,
) -> (LightSample, bool) {
    let d = light_point - point;
    let dist2 = d.length_squared();
    let distance = dist2.sqrt();
    let wi = d / distance;
    let cos_light = -wi.dot(n);
    let pdf = dist2 / (cos_light.abs() * area);
    let valid = (distance != 0.0) & ((cos_light > 0.0) | two_sided) & pdf.is_finite();
    (LightSample { wi, li: radiance, pdf, distance, delta: false }, valid)
}

/// Smoothstep between the outer and inner cone cosines.
pub(crate) fn spot_falloff(cos: f32, cos_outer: f32, cos_inner: f32) -> f32 {
    if cos >= cos_inner {
        return 1.0;
    }
    if cos <= cos_outer {
        return 0.0;
    }
    let t = (cos - cos_outer) / (cos_inner - cos_outer);
    t * t * (3.0 - 2.0 * t)
}

/// A uniformly distributed point on a shape and its geometric normal.
pub fn sample_shape(shape: &Shape, u: Vec2) -> (Vec3, Vec3) {
    match *shape {
        Shape::Sphere { centre, radius } => {
            let n = uniform_sphere(u);
            (centre + radius * n, n)
        }
        Shape::Triangle { p, .. } => (point_on_triangle(&p, u), triangle_normal(&p)),
        Shape::Fibre { a, b, radius, .. } => {
            let axis = (b - a).normalize();
            let (e1, e2) = crate::sampling::orthonormal_basis(axis);
            let (sin, cos) = (std::f32::consts::TAU * u.y).sin_cos();
            let n = cos * e1 + sin * e2;
            (a + u.x * (b - a) + radius * n, n)
        }
    }
}

/// A uniformly distributed point on a triangle.
#[inline(always)]
pub(crate) fn point_on_triangle(p: &[Vec3; 3], u: Vec2) -> Vec3 {
    let (b0, b1) = uniform_triangle(u);
    b0 * p[0] + b1 * p[1] + (1.0 - b0 - b1) * p[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn area_light_sampling_estimates_the_solid_angle_of_a_square() {
        // A unit square at height h above the origin subtends a closed-form solid angle:
        // Ω = 4·asin(a² / (a² + 4h²)) for a square of side a centred on the axis.
        let quad = crate::geometry::procedural::quad();
        let prims: Vec<Primitive> = quad
            .indices
            .iter()
            .map(|t| Primitive {
                shape: Shape::Triangle {
                    p: t.map(|i| quad.positions[i as usize] * 0.5 + Vec3::new(0.0, 0.0, 2.0)),
                    n: None,
                    uv: None,
                },
                material: 0,
                light: Some(0),
                interior_medium: None,
                exterior_medium: None,
            })
            .collect();
        // The quad faces +Z; flip it to face the origin by reversing the winding.
        let prims: Vec<Primitive> = prims
            .into_iter()
            .map(|mut p| {
                if let Shape::Triangle { p: ref mut v, .. } = p.shape {
                    v.swap(1, 2);
                }
                p
            })
            .collect();
        let light = Light::area(&prims, vec![0, 1], Vec3::ONE, false);
        let mut rng = Rng::new(5, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(s) = light.sample(Vec3::ZERO, rng.uniform2()) {
                sum += 1.0 / s.pdf as f64;
            }
        }
        let (a, h) = (1.0f64, 2.0f64);
        let expected = 4.0 * (a * a / (a * a + 4.0 * h * h)).asin();
        assert!(((sum / n as f64) - expected).abs() / expected < 0.01, "{} vs {expected}", sum / n as f64);
        // From behind a one-sided light nothing arrives.
        assert!(light.sample(Vec3::new(0.0, 0.0, 4.0), Vec2::splat(0.3)).is_none());
    }

    #[test]
    fn spot_falloff_is_smooth_and_bounded() {
        assert_eq!(spot_falloff(1.0, 0.8, 0.9), 1.0);
        assert_eq!(spot_falloff(0.5, 0.8, 0.9), 0.0);
        let mid = spot_falloff(0.85, 0.8, 0.9);
        assert!((mid - 0.5).abs() < 1e-5);
    }
}
