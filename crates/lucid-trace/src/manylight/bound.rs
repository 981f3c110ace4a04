//! Upper bounds for lightcuts (Walter et al. 2005): how much a cluster of lights inside a box
//! can send to a shading point, as the product of a bound on the receiver's BSDF times cosine
//! over the directions towards the box and a bound on the geometric term.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::bsdf::Bsdf;
use crate::geometry::Aabb;
use crate::material::SurfaceBsdf;
use crate::sampling::orthonormal_basis;

/// A cone of directions: unit `axis`, half-angle `angle` (π: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cone {
    pub(crate) axis: Vec3,
    pub(crate) angle: f32,
}

impl Cone {
    /// Every direction.
    pub(crate) const FULL: Cone = Cone { axis: Vec3::Z, angle: PI };

    /// The smallest cone containing both.
    pub(crate) fn union(self, other: Cone) -> Cone {
        if self.angle >= PI || other.angle >= PI {
            return Cone::FULL;
        }
        let between = angle_between(self.axis, other.axis);
        if between + other.angle <= self.angle {
            return self;
        }
        if between + self.angle <= other.angle {
            return other;
        }
        let angle = 0.5 * (self.angle + between + other.angle);
        if angle >= PI {
            return Cone::FULL;
        }
        let perpendicular = other.axis - self.axis * self.axis.dot(other.axis);
        if perpendicular.length_squared() < 1e-12 {
            return Cone::FULL;
        }
        let turn = angle - self.angle;
        let axis = self.axis * turn.cos() + perpendicular.normalize() * turn.sin();
        Cone { axis: axis.normalize(), angle }
    }
}

fn angle_between(a: Vec3, b: Vec3) -> f32 {
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// An upper bound on the cosine between `axis` (unit) and the directions from `x` to the
/// points of `bounds`, floored at 0: the box in a frame around the axis, bounded again by an
/// axis-aligned box there, whose nearest radial distance and largest height bound the angle
/// (Walter et al.'s bound; far tighter than a bounding sphere for boxes close to `x`, such as
/// VPLs on the surface being shaded).
#[inline]
pub(crate) fn max_cos_to_box(x: Vec3, axis: Vec3, bounds: &Aabb) -> f32 {
    let (t, b) = orthonormal_basis(axis);
    let centre = bounds.centre() - x;
    let half = 0.5 * (bounds.max - bounds.min);
    let c = Vec3::new(centre.dot(t), centre.dot(b), centre.dot(axis));
    let e = Vec3::new(half.dot(t.abs()), half.dot(b.abs()), half.dot(axis.abs()));
    let z = c.z + e.z;
    if z <= 0.0 {
        return 0.0;
    }
    let nearest = |c: f32, e: f32| (c.abs() - e).max(0.0);
    let radial2 = nearest(c.x, e.x).powi(2) + nearest(c.y, e.y).powi(2);
    z / (radial2 + z * z).sqrt()
}

/// A bound on `f(wo, wi) |cos θi|` over the directions `wi` towards a box, given
/// `max_cos(a)`, an upper bound on the cosine between local direction `a` and those
/// directions (see [`max_cos_to_box`]); `None` where this BSDF has no bound here (glossy lobes
/// other than GGX ones — metals, and metallic–roughness without a normal map: lightcuts then
/// refines the cluster down to single lights, which are exact).
pub(crate) fn receiver_bound(bsdf: &SurfaceBsdf, wo: Vec3, max_cos: impl Fn(Vec3) -> f32) -> Option<Vec3> {
    if wo.z == 0.0 {
        return Some(Vec3::ZERO);
    }
    // Every BSDF here reflects only (smooth glass is a delta that a point light never meets).
    let normal = Vec3::Z * wo.z.signum();
    let cos = max_cos(normal);
    if cos == 0.0 {
        return Some(Vec3::ZERO);
    }
    match bsdf {
        SurfaceBsdf::Lambertian(b) => Some(b.albedo * (FRAC_1_PI * cos)),
        // The diffuse term `(1−F(θi))(1−F(θo)) ρ' / (π η²)`: 1 − F(θi) is largest at normal incidence.
        SurfaceBsdf::Plastic(b) => Some(b.eval(wo, normal) * cos),
        SurfaceBsdf::Dielectric(_) => Some(Vec3::ZERO),
        SurfaceBsdf::Conductor(b) => {
            if b.distribution.is_smooth() {
                return Some(Vec3::ZERO);
            }
            Some(Vec3::splat(ggx_bound(b.distribution, wo, &max_cos)))
        }
        // Without a normal map: the GGX lobe as a metal's (Schlick's F ≤ 1), plus the diffuse
        // base (1 − metallic)·base/π with its coat's transmission ≤ 1. A tilted normal moves
        // both lobes; it has no bound here.
        SurfaceBsdf::MetallicRoughness(b) if b.normal == Vec3::Z => {
            let ggx = crate::bsdf::GgxDistribution { alpha_x: b.alpha, alpha_y: b.alpha };
            let diffuse = b.base_color * ((1.0 - b.metallic) * FRAC_1_PI * cos);
            Some(Vec3::splat(ggx_bound(ggx, wo, &max_cos)) + diffuse)
        }
        _ => None,
    }
}

/// A bound on a GGX lobe's `F D G / (4 cos θo)` (its `f cos θi` with F ≤ 1) over the box.
/// Reflecting `wo` about the half vector gives `wi`, about the normal the mirror direction;
/// reflection is 2-Lipschitz in the mirror's normal, so the half vector is at least half the
/// angle from `wi` to the mirror direction off the normal, and D falls with that angle for
/// α ≤ 1; G ≤ 1.
fn ggx_bound(ggx: crate::bsdf::GgxDistribution, wo: Vec3, max_cos: &impl Fn(Vec3) -> f32) -> f32 {
    let theta_h = 0.5 * max_cos(Vec3::new(-wo.x, -wo.y, wo.z)).acos();
    let alpha_max = ggx.alpha_x.max(ggx.alpha_y);
    let shape = if alpha_max < 1.0 {
        let (s, c) = theta_h.sin_cos();
        1.0 / (c * c + s * s / (alpha_max * alpha_max)).powi(2)
    } else {
        alpha_max.powi(4)
    };
    shape / (PI * ggx.alpha_x * ggx.alpha_y) / (4.0 * wo.z.abs())
}

/// A bound on a cluster's geometric term at distance `distance` from its box: `1/d²` for
/// point and spot lights; for diffuse VPLs (their `d²` floored at `clamp2`) times the largest
/// cosine between the cluster's `normals` and the directions from the box to the point, given
/// `towards`, a bound on the cosine between the cone's axis and those directions
/// ([`max_cos_to_box`] with the axis reversed).
pub(crate) fn geometric_bound(distance: f32, normals: Option<(Cone, f32)>, clamp2: f32) -> f32 {
    let d2 = distance * distance;
    match normals {
        None => 1.0 / d2,
        Some((n, towards)) => {
            // cos(max(0, θ − θn)) for the smallest angle θ the directions make with the axis.
            let (sin_n, cos_n) = n.angle.min(PI).sin_cos();
            let cos = if towards >= cos_n {
                1.0
            } else {
                let sin = (1.0 - towards * towards).max(0.0).sqrt();
                (towards * cos_n + sin * sin_n).max(0.0)
            };
            cos / d2.max(clamp2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, GgxDistribution, Lambertian, MicrofacetConductor, SmoothPlastic};
    use crate::sampling::{Rng, uniform_sphere};

    fn uniform3(rng: &mut Rng) -> Vec3 {
        Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())
    }

    fn random_box(rng: &mut Rng) -> Aabb {
        let centre = (uniform3(rng) - 0.5) * 6.0;
        let half = uniform3(rng) * rng.uniform() * 1.5;
        Aabb { min: centre - half, max: centre + half }
    }

    fn point_in(b: &Aabb, rng: &mut Rng) -> Vec3 {
        b.min + (b.max - b.min) * uniform3(rng)
    }

    #[test]
    fn the_box_cosine_bound_holds_for_every_point_of_the_box() {
        let mut rng = Rng::new(1, 0);
        let mut tight = 0;
        for _ in 0..2000 {
            let b = random_box(&mut rng);
            let x = (uniform3(&mut rng) - 0.5) * 4.0;
            let axis = uniform_sphere(rng.uniform2());
            let bound = max_cos_to_box(x, axis, &b);
            let mut largest = 0.0f32;
            for _ in 0..50 {
                let cos = axis.dot((point_in(&b, &mut rng) - x).normalize());
                assert!(cos <= bound + 1e-5, "cosine {cos} above bound {bound}");
                largest = largest.max(cos);
            }
            tight += usize::from(bound - largest < 0.1);
        }
        // A bound of 1 everywhere would hold too: most are close to what the box reaches.
        assert!(tight > 1200, "only {tight} of 2000 bounds within 0.1");
    }

    #[test]
    fn cone_unions_hold_both_cones() {
        let mut rng = Rng::new(2, 0);
        for _ in 0..2000 {
            let a = Cone { axis: uniform_sphere(rng.uniform2()), angle: rng.uniform() * 1.5 };
            let b = Cone { axis: uniform_sphere(rng.uniform2()), angle: rng.uniform() * 1.5 };
            let u = a.union(b);
            for c in [a, b] {
                for _ in 0..20 {
                    // A direction on the cone's rim, the farthest from any other axis.
                    let (t, s) = orthonormal_basis(c.axis);
                    let phi = rng.uniform() * std::f32::consts::TAU;
                    let w = c.axis * c.angle.cos() + (t * phi.cos() + s * phi.sin()) * c.angle.sin();
                    assert!(angle_between(u.axis, w) <= u.angle + 1e-3, "{a:?} ∪ {b:?} = {u:?} misses {w}");
                }
            }
        }
    }

    /// The receiver bound against the BSDF itself at points sampled in random boxes.
    #[test]
    fn receiver_bounds_hold_over_the_box() {
        let mut rng = Rng::new(3, 0);
        for trial in 0..3000 {
            let bsdf = match trial % 4 {
                3 => SurfaceBsdf::MetallicRoughness(crate::bsdf::metallic_roughness::MetallicRoughness::new(
                    uniform3(&mut rng),
                    rng.uniform(),
                    0.05 + rng.uniform() * 0.95,
                    Vec3::Z,
                )),
                0 => SurfaceBsdf::Lambertian(Lambertian { albedo: uniform3(&mut rng) }),
                1 => SurfaceBsdf::Plastic(SmoothPlastic::new(uniform3(&mut rng), 1.2 + rng.uniform())),
                _ => SurfaceBsdf::Conductor(MicrofacetConductor {
                    distribution: GgxDistribution {
                        alpha_x: 0.03 + rng.uniform() * 0.9,
                        alpha_y: 0.03 + rng.uniform() * 0.9,
                    },
                    eta: Vec3::splat(0.2) + uniform3(&mut rng),
                    k: uniform3(&mut rng) * 4.0,
                }),
            };
            let wo = uniform_sphere(rng.uniform2());
            // The shading point at the origin, its frame the world's.
            let b = random_box(&mut rng);
            let bound = receiver_bound(&bsdf, wo, |axis| max_cos_to_box(Vec3::ZERO, axis, &b)).unwrap();
            for _ in 0..50 {
                let wi = point_in(&b, &mut rng).normalize();
                let value = bsdf.eval(wo, wi) * wi.z.abs();
                assert!(
                    value.cmple(bound * 1.001 + 1e-5).all(),
                    "{bsdf:?}: f cos {value} above bound {bound} (wo {wo}, wi {wi})"
                );
            }
        }
    }

    #[test]
    fn geometric_bounds_hold_for_diffuse_clusters() {
        let mut rng = Rng::new(4, 0);
        for _ in 0..2000 {
            let b = random_box(&mut rng);
            let x = (uniform3(&mut rng) - 0.5) * 8.0;
            let cone = Cone { axis: uniform_sphere(rng.uniform2()), angle: rng.uniform() * 2.0 };
            let closest = x.clamp(b.min, b.max);
            let towards = max_cos_to_box(x, -cone.axis, &b);
            let clamp2 = 0.01;
            let bound = geometric_bound((closest - x).length(), Some((cone, towards)), clamp2);
            for _ in 0..50 {
                let p = point_in(&b, &mut rng);
                // A normal inside the cone.
                let (t, s) = orthonormal_basis(cone.axis);
                let (theta, phi) = (rng.uniform() * cone.angle.min(PI), rng.uniform() * std::f32::consts::TAU);
                let n = cone.axis * theta.cos() + (t * phi.cos() + s * phi.sin()) * theta.sin();
                let d = x - p;
                let value = n.dot(d.normalize()).max(0.0) / d.length_squared().max(clamp2);
                assert!(value <= bound * 1.001 + 1e-6, "cos/d² {value} above bound {bound}");
            }
        }
    }
}
