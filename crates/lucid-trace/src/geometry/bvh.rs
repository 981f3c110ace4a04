//! A bounding volume hierarchy built with the binned surface-area heuristic (Wald 2007),
//! then collapsed to eight children per node for traversal ([`super::wide`]). Written by hand:
//! the crates that exist either own the primitive type or lack any-hit queries for shadow
//! rays, and this is ~200 lines.

use glam::{Vec3, Vec3A};
use lucid_scene::Ray;

use super::wide::WideBvh;
use super::wide_packet::{PacketHits, RAYS, RayPacket};
use super::{Aabb, Intersection, Primitive, Shape, TriangleFrame, triangle_interaction, triangle_normal};

const BINS: usize = 16;
/// The binary tree is split down to pairs: which subtrees become the 8-wide tree's triangle
/// packets is decided when collapsing it ([`super::wide`]), where the cost of a test is per
/// packet, not per primitive.
const MAX_LEAF: usize = 2;

/// A node of the binary tree the builder makes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) bounds: Aabb,
    /// Leaf: first primitive; interior: index of the second child (the first follows).
    pub(super) offset: u32,
    /// Leaf: primitive count; interior: 0.
    pub(super) count: u16,
}

/// The BVH and the primitives, reordered so that each leaf's are contiguous.
#[derive(Clone, Debug)]
pub struct Bvh {
    bounds: Aabb,
    /// What traversal visits and tests: the full primitive records are read only for the
    /// final hit.
    wide: WideBvh,
    primitives: Vec<Primitive>,
    /// Per primitive in BVH order, its triangle's frame (unused for spheres).
    frames: Vec<TriangleFrame>,
}

/// Intersection data in SIMD-friendly form: a triangle as a vertex and two edges.
#[derive(Clone, Copy, Debug)]
pub(super) enum CompactShape {
    Triangle { p0: Vec3A, e1: Vec3A, e2: Vec3A },
    Sphere { centre: Vec3A, radius2: f32 },
    Fibre { a: Vec3A, axis: Vec3A, length: f32, radius2: f32 },
}

impl CompactShape {
    pub(super) fn new(shape: &Shape) -> Self {
        match *shape {
            Shape::Triangle { p, .. } => {
                CompactShape::Triangle { p0: p[0].into(), e1: (p[1] - p[0]).into(), e2: (p[2] - p[0]).into() }
            }
            Shape::Sphere { centre, radius } => {
                CompactShape::Sphere { centre: centre.into(), radius2: radius * radius }
            }
            Shape::Fibre { a, b, radius, .. } => CompactShape::Fibre {
                a: a.into(),
                axis: (b - a).normalize_or_zero().into(),
                length: (b - a).length(),
                radius2: radius * radius,
            },
        }
    }

    /// `(t, u, v)` of the nearest hit in `(t_min, t_max)`: barycentrics for triangles.
    #[inline(always)]
    pub(super) fn intersect(&self, origin: Vec3A, dir: Vec3A, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        match *self {
            CompactShape::Triangle { p0, e1, e2 } => {
                let pv = dir.cross(e2);
                let det = e1.dot(pv);
                if det.abs() < 1e-12 {
                    return None;
                }
                let inv = 1.0 / det;
                let tv = origin - p0;
                let u = tv.dot(pv) * inv;
                if !(0.0..=1.0).contains(&u) {
                    return None;
                }
                let qv = tv.cross(e1);
                let v = dir.dot(qv) * inv;
                if v < 0.0 || u + v > 1.0 {
                    return None;
                }
                let t = e2.dot(qv) * inv;
                (t > t_min && t < t_max).then_some((t, u, v))
            }
            CompactShape::Sphere { centre, radius2 } => {
                let oc = origin - centre;
                let b = oc.dot(dir);
                let disc = b * b - (oc.length_squared() - radius2);
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                let (t0, t1) = (-b - sq, -b + sq);
                if t0 > t_min && t0 < t_max {
                    Some((t0, 0.0, 0.0))
                } else if t1 > t_min && t1 < t_max {
                    Some((t1, 0.0, 0.0))
                } else {
                    None
                }
            }
            CompactShape::Fibre { a, axis, length, radius2 } => {
                // The entering root only: see `Shape::Fibre`.
                let oc = origin - a;
                let (oc_along, dir_along) = (oc.dot(axis), dir.dot(axis));
                let (oc_perp, dir_perp) = (oc - oc_along * axis, dir - dir_along * axis);
                let qa = dir_perp.length_squared();
                if qa < 1e-12 {
                    return None;
                }
                let qb = oc_perp.dot(dir_perp);
                let disc = qb * qb - qa * (oc_perp.length_squared() - radius2);
                if disc < 0.0 {
                    return None;
                }
                let t = (-qb - disc.sqrt()) / qa;
                let along = oc_along + t * dir_along;
                (t > t_min && t < t_max && (0.0..=length).contains(&along)).then_some((t, 0.0, 0.0))
            }
        }
    }
}

struct BuildItem {
    bounds: Aabb,
    centre: Vec3,
    index: usize,
}

impl Bvh {
    /// Builds the hierarchy.
    pub fn new(primitives: Vec<Primitive>) -> Self {
        let mut items: Vec<BuildItem> = primitives
            .iter()
            .enumerate()
            .map(|(index, p)| {
                let bounds = p.shape.bounds();
                BuildItem { bounds, centre: bounds.centre(), index }
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * items.len().max(1));
        if !items.is_empty() {
            build(&mut items, 0, &mut nodes);
        }
        let ordered: Vec<Primitive> = items.iter().map(|it| without_flat_normals(primitives[it.index])).collect();
        let compact: Vec<CompactShape> = ordered.iter().map(|p| CompactShape::new(&p.shape)).collect();
        let bounds = nodes.first().map(|n: &Node| n.bounds).unwrap_or(Aabb::EMPTY);
        let frames = ordered
            .iter()
            .map(|p| match p.shape {
                Shape::Triangle { p, uv, .. } => TriangleFrame::new(&p, uv),
                Shape::Sphere { .. } | Shape::Fibre { .. } => TriangleFrame { normal: Vec3::Z, tangent: Vec3::X },
            })
            .collect();
        Self { bounds, wide: WideBvh::new(&nodes, &compact), primitives: ordered, frames }
    }

    /// The primitives in BVH order: [`Intersection::primitive`] indexes this slice.
    pub fn primitives(&self) -> &[Primitive] {
        &self.primitives
    }

    /// Bounds of everything.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The nearest intersection with `t` in `(t_min, t_max)`.
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Intersection> {
        let (t, u, v, i) = self.closest(ray, t_min, t_max)?;
        Some(self.interaction(ray, t, u, v, i))
    }

    /// The nearest hit with `t` in `(t_min, t_max)` as `(t, u, v, primitive)`, without its
    /// record ([`Bvh::interaction`] makes it).
    #[inline]
    pub fn closest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32, u32)> {
        self.wide.closest(ray, t_min, t_max)
    }

    /// The full record of the hit [`Bvh::closest`] found.
    #[inline]
    pub fn interaction(&self, ray: &Ray, t: f32, u: f32, v: f32, primitive: u32) -> Intersection {
        self.triangle_interaction(t, u, v, primitive)
            .unwrap_or_else(|| self.primitives[primitive as usize].shape.interaction(ray, t, u, v, primitive))
    }

    /// [`Bvh::interaction`] where the hit is on a triangle, whose record needs no ray: the
    /// caller then builds a ray only for other shapes (one built for every hit was stored
    /// field by field and reloaded whole, a stall of a tenth of the packet tracer's surface
    /// stage).
    #[inline(always)]
    pub fn triangle_interaction(&self, t: f32, u: f32, v: f32, primitive: u32) -> Option<Intersection> {
        match &self.primitives[primitive as usize].shape {
            Shape::Triangle { p, n, uv } => {
                Some(triangle_interaction(p, *n, *uv, self.frames[primitive as usize], t, u, v, primitive))
            }
            Shape::Sphere { .. } | Shape::Fibre { .. } => None,
        }
    }

    /// Whether anything blocks the ray within `(t_min, t_max)` (for shadow rays).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.wide.occluded(ray, t_min, t_max)
    }

    /// [`Bvh::closest`] for each ray of `rays` whose bit is set in `live`, the eight traced
    /// together.
    #[inline]
    pub fn closest_packet(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: f32) -> PacketHits {
        self.wide.closest_packet(rays, live, t_min, t_max)
    }

    /// [`Bvh::occluded`] for each ray of `rays` whose bit is set in `live` (ray `l` within
    /// `(t_min, t_max[l])`), the eight traced together: the blocked rays as a bit mask.
    #[inline]
    pub fn occluded_packet(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: &[f32; RAYS]) -> u32 {
        self.wide.occluded_packet(rays, live, t_min, t_max)
    }
}

/// A triangle whose three vertex normals are one and the same, along the face's own normal
/// (either way), shades as the face: interpolating and normalising them at every hit gives
/// the geometric normal to rounding, for a square root and a division per hit (the faces of
/// procedural quads and boxes, a flat-shaded mesh's).
fn without_flat_normals(mut primitive: Primitive) -> Primitive {
    if let Shape::Triangle { p, n: normals @ Some(_), .. } = &mut primitive.shape
        && let Some([a, b, c]) = *normals
        && a == b
        && b == c
        && a.normalize_or_zero().dot(triangle_normal(p)).abs() >= 1.0 - 1e-6
    {
        *normals = None;
    }
    primitive
}

/// Builds the subtree of `items` into `nodes`, returning its index. Items are reordered.
fn build(items: &mut [BuildItem], first: usize, nodes: &mut Vec<Node>) -> u32 {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
    let index = nodes.len() as u32;
    nodes.push(Node { bounds, offset: first as u32, count: items.len() as u16 });
    if items.len() <= MAX_LEAF {
        return index;
    }
    let centres = items.iter().fold(Aabb::EMPTY, |b, it| b.include(it.centre));
    let Some((axis, split)) = best_split(items, &centres) else {
        if items.len() <= u16::MAX as usize / 2 {
            return index; // the centres coincide: nothing to split
        }
        // Too many for a leaf: split at the median instead.
        let axis = (centres.max - centres.min).max_position();
        items.sort_unstable_by(|a, b| a.centre[axis].total_cmp(&b.centre[axis]));
        return split_at(items, first, items.len() / 2, index, nodes);
    };
    let mid = partition(items, |it| bin_of(it.centre[axis], &centres, axis) < split);
    if mid == 0 || mid == items.len() {
        return index;
    }
    split_at(items, first, mid, index, nodes)
}

fn split_at(items: &mut [BuildItem], first: usize, mid: usize, index: u32, nodes: &mut Vec<Node>) -> u32 {
    let (left, right) = items.split_at_mut(mid);
    build(left, first, nodes);
    let right_index = build(right, first + mid, nodes);
    let node = &mut nodes[index as usize];
    node.offset = right_index;
    node.count = 0;
    index
}

fn bin_of(c: f32, centres: &Aabb, axis: usize) -> usize {
    let extent = centres.max[axis] - centres.min[axis];
    if extent <= 0.0 {
        return 0;
    }
    (((c - centres.min[axis]) / extent * BINS as f32) as usize).min(BINS - 1)
}

/// The axis and bin boundary of the cheapest SAH split, if the centres can be split at all.
fn best_split(items: &[BuildItem], centres: &Aabb) -> Option<(usize, usize)> {
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if centres.max[axis] - centres.min[axis] <= 0.0 {
            continue;
        }
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for it in items {
            let b = bin_of(it.centre[axis], centres, axis);
            bin_bounds[b] = bin_bounds[b].union(it.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right to get the suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(bin_bounds[i]);
            count += bin_count[i];
            right_area[i] = acc.area();
            right_count[i] = count;
        }
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        for split in 1..BINS {
            acc = acc.union(bin_bounds[split - 1]);
            count += bin_count[split - 1];
            if count == 0 || right_count[split] == 0 {
                continue;
            }
            let cost = acc.area() * count as f32 + right_area[split] * right_count[split] as f32;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, split));
            }
        }
    }
    best.map(|(_, axis, split)| (axis, split))
}

fn partition(items: &mut [BuildItem], pred: impl Fn(&BuildItem) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::sampling::{Rng, uniform_sphere};

    fn primitive(shape: Shape) -> Primitive {
        Primitive { shape, material: 0, light: None, interior_medium: None, exterior_medium: None }
    }

    #[test]
    fn only_flat_vertex_normals_are_dropped() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let normals =
            |n: [Vec3; 3]| match without_flat_normals(primitive(Shape::Triangle { p, n: Some(n), uv: None })).shape {
                Shape::Triangle { n, .. } => n,
                Shape::Sphere { .. } | Shape::Fibre { .. } => unreachable!(),
            };
        // Along the face either way: dropped; the hit then shades with the face normal.
        assert_eq!(normals([Vec3::Z; 3]), None);
        assert_eq!(normals([-Vec3::Z; 3]), None);
        // Smooth shading, or one tilted normal for the whole face: kept.
        let tilted = Vec3::new(0.1, 0.0, 1.0).normalize();
        assert!(normals([Vec3::Z, tilted, Vec3::Z]).is_some());
        assert!(normals([tilted; 3]).is_some());
    }

    /// A point in the cube of side `side` around the origin.
    fn random_point(rng: &mut Rng, side: f32) -> Vec3 {
        (rng.uniform2().extend(rng.uniform()) - 0.5) * side
    }

    fn random_spheres(n: usize) -> Vec<Primitive> {
        let mut rng = Rng::new(9, 0);
        (0..n)
            .map(|_| {
                let centre = random_point(&mut rng, 20.0);
                primitive(Shape::Sphere { centre, radius: 0.05 + 0.4 * rng.uniform() })
            })
            .collect()
    }

    fn random_triangles(n: usize) -> Vec<Primitive> {
        let mut rng = Rng::new(11, 0);
        (0..n)
            .map(|_| {
                let centre = random_point(&mut rng, 20.0);
                let p = [0, 1, 2].map(|_| centre + random_point(&mut rng, 3.0));
                primitive(Shape::Triangle { p, n: None, uv: None })
            })
            .collect()
    }

    #[test]
    #[allow(clippy::needless_range_loop)] // lane loops over several per-lane arrays
    fn packet_queries_agree_with_single_rays() {
        // Small scenes (one packet through every node) and large ones (rays leaving the packet
        // for single-ray traversal); rays from a common point (coherent) and scattered ones;
        // some lanes dead.
        for (triangles, spheres) in [(2, 0), (12, 3), (36, 0), (333, 50), (3000, 0)] {
            let mut prims = random_triangles(triangles);
            prims.extend(random_spheres(spheres));
            let bvh = Bvh::new(prims);
            let mut rng = Rng::new(13, 0);
            let (mut hits, mut blocked) = (0, 0);
            for k in 0..600 {
                let common = random_point(&mut rng, 30.0);
                let mut rays = RayPacket::default();
                let mut reach = [0f32; RAYS];
                for l in 0..RAYS {
                    let o = if k % 2 == 0 { common } else { random_point(&mut rng, 30.0) };
                    let d = uniform_sphere(rng.uniform2());
                    for a in 0..3 {
                        (rays.origin[a][l], rays.direction[a][l]) = (o[a], d[a]);
                    }
                    reach[l] = 40.0 * rng.uniform();
                }
                let live = if k % 3 == 0 { 0xff } else { (rng.uniform() * 256.0) as u32 & 0xff };
                let got = bvh.closest_packet(&rays, live, 1e-4, f32::INFINITY);
                let shadow = bvh.occluded_packet(&rays, live, 1e-4, &reach);
                for l in 0..RAYS {
                    let ray = rays.ray(l);
                    let on = live >> l & 1 != 0;
                    let want = bvh.closest(&ray, 1e-4, f32::INFINITY).filter(|_| on);
                    let have = (got.mask >> l & 1 != 0).then(|| (got.t[l], got.u[l], got.v[l], got.primitive[l]));
                    assert_eq!(have, want, "{triangles} triangles, {spheres} spheres, packet {k}, lane {l}");
                    let occluded = on && bvh.occluded(&ray, 1e-4, reach[l]);
                    assert_eq!(shadow >> l & 1 != 0, occluded, "{triangles} triangles, packet {k}, lane {l}");
                    hits += want.is_some() as u32;
                    blocked += occluded as u32;
                }
            }
            // Both outcomes occur, so the comparison means something.
            assert!(hits >= 5 && (1..4000).contains(&blocked), "{triangles}: {hits} hits, {blocked} blocked");
            if triangles >= 333 {
                assert!(hits > 300 && blocked > 200, "{triangles}: {hits} hits, {blocked} blocked");
            }
        }
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_triangles_and_spheres() {
        // Counts that leave partly filled packets and leaves holding both kinds of shape.
        for (triangles, spheres) in [(1, 0), (3, 0), (7, 2), (12, 3), (40, 0), (333, 50), (0, 500)] {
            let mut prims = random_triangles(triangles);
            prims.extend(random_spheres(spheres));
            let bvh = Bvh::new(prims.clone());
            let mut rng = Rng::new(12, 0);
            for _ in 0..2000 {
                let ray = Ray::new(random_point(&mut rng, 30.0), uniform_sphere(rng.uniform2()));
                let brute = prims
                    .iter()
                    .enumerate()
                    .filter_map(|(i, p)| p.shape.intersect(&ray, 1e-4, f32::INFINITY).map(|h| (h.0, i)))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                let got = bvh.intersect(&ray, 1e-4, f32::INFINITY);
                assert_eq!(got.map(|h| h.t), brute.map(|b| b.0), "{triangles} triangles, {spheres} spheres");
                if let (Some(h), Some((_, i))) = (got, brute) {
                    assert_eq!(bvh.primitives()[h.primitive as usize], prims[i]);
                }
                assert_eq!(bvh.occluded(&ray, 1e-4, f32::INFINITY), brute.is_some());
                if let Some((t, _)) = brute {
                    assert!(!bvh.occluded(&ray, 1e-4, t * 0.999));
                }
            }
        }
    }
}
