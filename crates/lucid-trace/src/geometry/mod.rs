//! Geometry: primitives (spheres and triangles), their intersection, bounding boxes and the
//! BVH over them, and procedural meshes.

pub mod bvh;
pub mod fibres;
pub mod mesh_file;
pub mod procedural;
mod wide;
mod wide_packet;

use glam::{Vec2, Vec3};
use lucid_scene::Ray;

pub use bvh::Bvh;
pub use wide_packet::{PacketHits, RAYS, RayPacket};

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The union of two boxes.
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// The box grown to contain `p`.
    pub fn include(self, p: Vec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    /// Centre point.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area (0 for the empty box).
    pub fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Slab test: the entry distance if the ray meets the box within `(0, t_max)`.
    #[inline]
    pub fn hit(&self, origin: Vec3, inv_dir: Vec3, t_max: f32) -> Option<f32> {
        let t0 = (self.min - origin) * inv_dir;
        let t1 = (self.max - origin) * inv_dir;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element().min(t_max);
        (near <= far).then_some(near)
    }
}

/// The shape of one primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A sphere.
    Sphere {
        /// Centre.
        centre: Vec3,
        /// Radius.
        radius: f32,
    },
    /// A triangle, with optional per-vertex shading normals and texture coordinates.
    Triangle {
        /// Vertex positions.
        p: [Vec3; 3],
        /// Per-vertex shading normals.
        n: Option<[Vec3; 3]>,
        /// Per-vertex texture coordinates.
        uv: Option<[Vec2; 3]>,
    },
    /// One straight segment of a fibre (hair): the side of a cylinder from `a` to `b`, which
    /// rays hit only where they enter it. A fibre's scattering function describes everything
    /// that happens inside it, so a ray leaving through the fibre (transmission) must not
    /// meet it again on its way out.
    Fibre {
        /// Start of the axis.
        a: Vec3,
        /// End of the axis.
        b: Vec3,
        /// Radius.
        radius: f32,
        /// Texture coordinate u (along the whole fibre, root 0, tip 1) at `a` and at `b`.
        u: Vec2,
    },
}

/// A primitive of the scene: a shape, its material and, if it emits, its light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primitive {
    /// Geometry.
    pub shape: Shape,
    /// Index into the scene's materials.
    pub material: u32,
    /// Index into the scene's lights when the primitive is part of an area light.
    pub light: Option<u32>,
    /// Index into the scene's media for the inside of a closed mesh, if any.
    pub interior_medium: Option<u32>,
    /// The medium outside such a mesh (the scene's global medium, if any).
    pub exterior_medium: Option<u32>,
}

/// Where a ray meets a primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intersection {
    /// Ray parameter (distance, as rays have unit directions).
    pub t: f32,
    /// The point.
    pub point: Vec3,
    /// Geometric unit normal (for triangles, from the winding order; for spheres, outward).
    pub geometric_normal: Vec3,
    /// Shading unit normal (interpolated where the mesh has normals), on the same side as the
    /// geometric normal.
    pub shading_normal: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Unit surface tangent (direction of increasing u where the shape has texture
    /// coordinates): orients anisotropic BSDFs.
    pub tangent: Vec3,
    /// Which primitive.
    pub primitive: u32,
}

impl Shape {
    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        match *self {
            Shape::Sphere { centre, radius } => {
                Aabb { min: centre - Vec3::splat(radius), max: centre + Vec3::splat(radius) }
            }
            Shape::Triangle { p, .. } => Aabb::EMPTY.include(p[0]).include(p[1]).include(p[2]),
            Shape::Fibre { a, b, radius, .. } => {
                // The caps' discs are within `radius` of their centres along the other two axes.
                let axis = (b - a).normalize_or_zero();
                let extent = radius * (Vec3::ONE - axis * axis).max(Vec3::ZERO).powf(0.5);
                Aabb { min: a.min(b) - extent, max: a.max(b) + extent }
            }
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match *self {
            Shape::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
            Shape::Triangle { p, .. } => 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length(),
            Shape::Fibre { a, b, radius, .. } => std::f32::consts::TAU * radius * (b - a).length(),
        }
    }

    /// The nearest intersection with `t` in `(t_min, t_max)`, as `(t, u, v)`: barycentrics for
    /// triangles, unused for spheres.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        bvh::CompactShape::new(self).intersect(ray.origin.into(), ray.direction.into(), t_min, t_max)
    }

    /// The full record of a hit found by [`Shape::intersect`].
    pub fn interaction(&self, ray: &Ray, t: f32, u: f32, v: f32, primitive: u32) -> Intersection {
        let point = ray.at(t);
        match *self {
            Shape::Sphere { centre, radius } => {
                let n = ((point - centre) / radius).normalize();
                let theta = n.z.clamp(-1.0, 1.0).acos();
                let phi = n.y.atan2(n.x).rem_euclid(std::f32::consts::TAU);
                let uv = Vec2::new(phi / std::f32::consts::TAU, theta / std::f32::consts::PI);
                // ∂p/∂φ: along the parallels; any direction at the poles.
                let tangent = Vec3::new(-n.y, n.x, 0.0).try_normalize().unwrap_or(Vec3::X);
                // Re-project onto the surface to cut the error of the ray parameter.
                Intersection {
                    t,
                    point: centre + radius * n,
                    geometric_normal: n,
                    shading_normal: n,
                    uv,
                    tangent,
                    primitive,
                }
            }
            Shape::Triangle { p, n, uv } => {
                triangle_interaction(&p, n, uv, TriangleFrame::new(&p, uv), t, u, v, primitive)
            }
            Shape::Fibre { a, b, radius, u: along } => {
                let axis = (b - a).normalize();
                let s = (point - a).dot(axis).clamp(0.0, (b - a).length());
                let centre = a + s * axis;
                let n = (point - centre).try_normalize().unwrap_or_else(|| crate::sampling::orthonormal_basis(axis).0);
                let fraction = s / (b - a).length().max(f32::MIN_POSITIVE);
                Intersection {
                    t,
                    point: centre + radius * n,
                    geometric_normal: n,
                    shading_normal: n,
                    uv: Vec2::new(along.x + (along.y - along.x) * fraction, 0.5),
                    tangent: axis,
                    primitive,
                }
            }
        }
    }
}

/// A triangle's unit geometric normal and surface tangent: the same at every point, so the
/// BVH computes them once per triangle rather than once per hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TriangleFrame {
    pub(crate) normal: Vec3,
    pub(crate) tangent: Vec3,
}

impl TriangleFrame {
    pub(crate) fn new(p: &[Vec3; 3], uv: Option<[Vec2; 3]>) -> Self {
        Self { normal: triangle_normal(p), tangent: dpdu(p, uv) }
    }
}

/// A triangle's unit geometric normal (counter-clockwise winding faces it).
pub(crate) fn triangle_normal(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0]).normalize()
}

/// The full record of a hit at barycentrics `(u, v)` of a triangle.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn triangle_interaction(
    p: &[Vec3; 3],
    n: Option<[Vec3; 3]>,
    uv: Option<[Vec2; 3]>,
    frame: TriangleFrame,
    t: f32,
    u: f32,
    v: f32,
    primitive: u32,
) -> Intersection {
    let w = 1.0 - u - v;
    let ng = frame.normal;
    let shading = match n {
        Some(n) => {
            let s = (w * n[0] + u * n[1] + v * n[2]).normalize_or_zero();
            if s == Vec3::ZERO {
                ng
            } else if s.dot(ng) < 0.0 {
                -s
            } else {
                s
            }
        }
        None => ng,
    };
    let tex = match uv {
        Some(t) => w * t[0] + u * t[1] + v * t[2],
        None => Vec2::new(u, v),
    };
    Intersection {
        t,
        point: w * p[0] + u * p[1] + v * p[2],
        geometric_normal: ng,
        shading_normal: shading,
        uv: tex,
        tangent: frame.tangent,
        primitive,
    }
}

/// `∂p/∂u` of a triangle from its texture coordinates, or its first edge without them.
fn dpdu(p: &[Vec3; 3], uv: Option<[Vec2; 3]>) -> Vec3 {
    let edge = (p[1] - p[0]).normalize();
    let Some(t) = uv else { return edge };
    let (du1, du2) = (t[1] - t[0], t[2] - t[0]);
    let det = du1.x * du2.y - du1.y * du2.x;
    if det.abs() < 1e-12 {
        return edge;
    }
    ((p[1] - p[0]) * du2.y - (p[2] - p[0]) * du1.y).try_normalize().map(|d| d * det.signum()).unwrap_or(edge)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangents_follow_increasing_u() {
        let p = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0)];
        let uv = [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        assert!((dpdu(&p, Some(uv)) - Vec3::X).length() < 1e-6);
        // Mirrored texture coordinates flip it.
        let flipped = [Vec2::new(1.0, 0.0), Vec2::ZERO, Vec2::new(1.0, 1.0)];
        assert!((dpdu(&p, Some(flipped)) + Vec3::X).length() < 1e-6);
    }

    #[test]
    fn sphere_and_triangle_hits() {
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
        let s = Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 };
        let (t, _, _) = s.intersect(&ray, 1e-4, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        // From inside, the far root.
        let inside = Ray::new(Vec3::ZERO, Vec3::X);
        assert!((s.intersect(&inside, 1e-4, f32::INFINITY).unwrap().0 - 1.0).abs() < 1e-5);

        let tri = Shape::Triangle {
            p: [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
            n: None,
            uv: None,
        };
        let (t, u, v) = tri.intersect(&ray, 1e-4, f32::INFINITY).unwrap();
        assert!((t - 5.0).abs() < 1e-5);
        let hit = tri.interaction(&ray, t, u, v, 0);
        assert!((hit.point - Vec3::ZERO).length() < 1e-5);
        assert!((hit.geometric_normal - Vec3::Z).length() < 1e-6, "counter-clockwise winding faces +Z");
        assert!(tri.intersect(&Ray::new(Vec3::new(2.0, 0.0, 5.0), -Vec3::Z), 1e-4, f32::INFINITY).is_none());
        assert!((tri.area() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn slab_test() {
        let b = Aabb { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) };
        let d = Vec3::new(0.0, 0.0, -1.0);
        assert_eq!(b.hit(Vec3::new(0.0, 0.0, 3.0), d.recip(), 10.0), Some(2.0));
        assert_eq!(b.hit(Vec3::new(0.0, 0.0, 3.0), d.recip(), 1.5), None);
        assert_eq!(b.hit(Vec3::new(2.0, 0.0, 3.0), d.recip(), 10.0), None);
        assert!((b.area() - 24.0).abs() < 1e-6);
    }
}
