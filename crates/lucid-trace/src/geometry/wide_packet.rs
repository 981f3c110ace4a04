//! Eight rays at once through the 8-wide BVH: the closest-hit and shadow queries of a packet
//! of paths ([`crate::packet`]) traverse the tree together, each box and each triangle tested
//! against the eight rays with one set of vector instructions (the rays in the lanes, the box
//! or triangle broadcast).
//!
//! A single ray's query ([`WideBvh::closest`]) tests eight boxes or eight triangles against
//! one ray, but most of its time goes to the branches between those tests — which children
//! the ray entered, in which order, leaf or node, hit or not — which differ from ray to ray
//! and mispredict. A packet takes those branches once for its eight rays. Rays that scatter
//! in different directions share fewer subtrees, so a subtree entered by fewer than
//! [`MIN_PACKET`] rays of the packet is finished by those rays one at a time: a packet then
//! does little more work than its rays would alone, in a large scene as in a small one. The
//! hits are the single-ray query's: the same triangle test, operation for operation, and the
//! nearest hit per ray. Written by hand for the reason `bvh.rs` gives.

use glam::Vec3;
use lucid_scene::Ray;
use lucid_scene::simd::{sign_mask8, wide};

use super::wide::{
    EMPTY, LEAF, Leaf, Node8, Stack, Triangle8, W, WideBvh, moller_trumbore, octant, order_slots, range,
};

/// Rays per packet.
pub const RAYS: usize = W;

type Lanes = [f32; RAYS];

/// Rays of a packet entering a subtree below which they traverse it one at a time.
const MIN_PACKET: u32 = 3;

/// Eight rays, one row of lanes per coordinate.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayPacket {
    /// Origins: x, y and z rows.
    pub origin: [Lanes; 3],
    /// Directions, of unit length (as [`Ray`] requires).
    pub direction: [Lanes; 3],
}

impl RayPacket {
    /// Up to eight rays in lanes `0..`; lanes past them keep a zero ray (leave them out of a
    /// query's live mask).
    pub fn from_rays<'a>(rays: impl IntoIterator<Item = &'a Ray>) -> Self {
        let mut packet = Self::default();
        for (l, ray) in rays.into_iter().take(RAYS).enumerate() {
            for a in 0..3 {
                (packet.origin[a][l], packet.direction[a][l]) = (ray.origin[a], ray.direction[a]);
            }
        }
        packet
    }

    /// Lane `l`'s ray.
    pub fn ray(&self, l: usize) -> Ray {
        Ray {
            origin: Vec3::new(self.origin[0][l], self.origin[1][l], self.origin[2][l]),
            direction: Vec3::new(self.direction[0][l], self.direction[1][l], self.direction[2][l]),
        }
    }
}

/// A packet's closest hits: lane `l` hit something where bit `l` of `mask` is set, at
/// distance `t[l]`, barycentrics (or sphere coordinates) `u[l]`, `v[l]`, on `primitive[l]`.
/// Each row of lanes aligned to a vector register: the traversal loads and stores them whole.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct PacketHits {
    /// Hit distances (the query's `t_max` where missed).
    pub t: Lanes,
    /// First surface coordinate.
    pub u: Lanes,
    /// Second surface coordinate.
    pub v: Lanes,
    /// Primitive hit.
    pub primitive: [u32; RAYS],
    /// The lanes that hit.
    pub mask: u32,
}

impl PacketHits {
    /// Lane `l`'s hit as `(t, u, v, primitive)`, if any.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Option<(f32, f32, f32, u32)> {
        (self.mask >> l & 1 != 0).then(|| (self.t[l], self.u[l], self.v[l], self.primitive[l]))
    }
}

/// The packet prepared for box and triangle tests.
struct PacketQuery {
    o: [Lanes; 3],
    d: [Lanes; 3],
    inv: [Lanes; 3],
}

impl PacketQuery {
    #[inline(always)]
    fn new(rays: &RayPacket) -> Self {
        Self { o: rays.origin, d: rays.direction, inv: rays.direction.map(|row| row.map(|d| 1.0 / d)) }
    }

    #[inline(always)]
    fn ray(&self, l: usize) -> Ray {
        Ray {
            origin: Vec3::new(self.o[0][l], self.o[1][l], self.o[2][l]),
            direction: Vec3::new(self.d[0][l], self.d[1][l], self.d[2][l]),
        }
    }

    /// Which rays meet child `c`'s box within `(t_min, t_max)` (a bit mask), and their entry
    /// distances. Where a slab distance is NaN (an origin on a slab plane of a ray parallel
    /// to it) the other bound decides, so such a ray is kept rather than lost.
    #[inline(always)]
    fn boxes(&self, node: &Node8, c: usize, t_min: f32, t_max: &Lanes) -> (u32, Lanes) {
        let lo = [node.bounds[0][0][c], node.bounds[0][1][c], node.bounds[0][2][c]];
        let hi = [node.bounds[1][0][c], node.bounds[1][1][c], node.bounds[1][2][c]];
        let mut entry = [0f32; RAYS];
        // Negative where entered: the mask is the sign bits (see `sign_mask8`).
        let mut entered = [0f32; RAYS];
        for l in 0..RAYS {
            let (mut near, mut far) = (t_min, t_max[l]);
            for a in 0..3 {
                let t0 = (lo[a] - self.o[a][l]) * self.inv[a][l];
                let t1 = (hi[a] - self.o[a][l]) * self.inv[a][l];
                let (first, last) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
                near = if first > near { first } else { near };
                far = if last < far { last } else { far };
            }
            entry[l] = near;
            entered[l] = 0.0 - (near <= far) as u32 as f32;
        }
        (sign_mask8(&entered), entry)
    }

    /// Möller–Trumbore of triangle `j` of `tri` against every ray ([`moller_trumbore`], as
    /// the single-ray query): which rays hit it within `(t_min, t_max)` (negative lanes: the
    /// sign bit is the mask, see `sign_mask8`, and what a blend instruction selects by), with
    /// `t`, `u`, `v`.
    #[inline(always)]
    fn triangle(&self, tri: &Triangle8, j: usize, t_min: f32, t_max: &Lanes) -> (Lanes, Lanes, Lanes, Lanes) {
        let corner = |v: &[[f32; W]; 3]| [v[0][j], v[1][j], v[2][j]];
        let (p0, e1, e2) = (corner(&tri.p0), corner(&tri.e1), corner(&tri.e2));
        let (mut ts, mut us, mut vs) = ([0f32; RAYS], [0f32; RAYS], [0f32; RAYS]);
        let mut hits = [0f32; RAYS];
        for l in 0..RAYS {
            let d = [self.d[0][l], self.d[1][l], self.d[2][l]];
            let o = [self.o[0][l], self.o[1][l], self.o[2][l]];
            let (hit, t, u, v) = moller_trumbore(d, o, p0, e1, e2, t_min, t_max[l]);
            ts[l] = t;
            us[l] = u;
            vs[l] = v;
            hits[l] = 0.0 - hit as u32 as f32;
        }
        (hits, ts, us, vs)
    }
}

/// `into[l] = from[l]` in the lanes where `mask` is negative. With bit operations: written
/// as a choice per lane, the compiler made it a branch per lane, taken at random.
#[inline(always)]
fn blend(mask: &Lanes, from: &Lanes, into: &mut Lanes) {
    let mut bits = into.map(f32::to_bits);
    blend_bits(mask, &from.map(f32::to_bits), &mut bits);
    *into = bits.map(f32::from_bits);
}

/// [`blend`] of integer lanes.
#[inline(always)]
fn blend_bits(mask: &Lanes, from: &[u32; RAYS], into: &mut [u32; RAYS]) {
    for l in 0..RAYS {
        let m = ((mask[l].to_bits() as i32) >> 31) as u32;
        into[l] = from[l] & m | into[l] & !m;
    }
}

impl WideBvh {
    /// A leaf's packets of triangles, each with how many distinct triangles it holds (lanes
    /// past a leaf's last triangle repeat it): counted, so that no repeated lane is tested.
    #[inline(always)]
    fn leaf_triangles(&self, leaf: &Leaf) -> impl Iterator<Item = (&Triangle8, usize)> {
        let triangles = (leaf.shapes - leaf.curved.1) as usize;
        self.packets[range(leaf.packets)].iter().enumerate().map(move |(k, tri)| (tri, (triangles - k * W).min(W)))
    }

    /// Whether the rays in `lanes` should leave the packet for the subtree `node`: a node's
    /// boxes cost the packet eight tests (one per child, all rays at once) where one ray tests
    /// them in one, so only a few rays go on alone; a leaf costs the packet one test per shape
    /// and a ray one per packet of eight triangles plus its own setup, about three tests (the
    /// inverse direction, the reduction to the nearest hit, the branches a ray takes alone:
    /// with a setup of one test, leaves of eight triangles went to rays alone and the Cornell
    /// box rendered 2 % slower): a leaf of up to four triangles is tested by the packet whatever
    /// its rays, one of eight unless a single ray enters it.
    #[inline(always)]
    fn one_at_a_time(&self, node: u32, lanes: u32) -> bool {
        let rays = lanes.count_ones();
        if node & LEAF == 0 {
            return rays < MIN_PACKET;
        }
        let leaf = &self.leaves[(node & !LEAF) as usize];
        leaf.shapes > rays * (leaf.packets.1 + leaf.curved.1 + 3)
    }

    /// The nearest hit within `(t_min, t_max)` of each ray of `rays` whose bit is set in
    /// `live`.
    #[inline]
    pub(super) fn closest_packet(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: f32) -> PacketHits {
        wide(
            #[inline(always)]
            || self.closest_packet_in(rays, live, t_min, t_max),
        )
    }

    /// Which rays of `rays` whose bit is set in `live` are blocked within `(t_min, t_max[l])`,
    /// as a bit mask.
    #[inline]
    pub(super) fn occluded_packet(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: &Lanes) -> u32 {
        wide(
            #[inline(always)]
            || self.occluded_packet_in(rays, live, t_min, t_max),
        )
    }

    #[inline(always)]
    fn closest_packet_in(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: f32) -> PacketHits {
        let mut best = PacketHits { mask: 0, t: [t_max; RAYS], u: [0.0; RAYS], v: [0.0; RAYS], primitive: [0; RAYS] };
        if self.root == EMPTY || live == 0 {
            return best;
        }
        let q = PacketQuery::new(rays);
        let mut stack = Stack::<(u32, u32)>::new();
        stack.push((self.root, live));
        while let Some((node, lanes)) = stack.pop() {
            if self.one_at_a_time(node, lanes) {
                let mut pending = lanes;
                while pending != 0 {
                    let l = pending.trailing_zeros() as usize;
                    pending &= pending - 1;
                    if let Some((t, u, v, i)) = self.closest_from(&q.ray(l), node, t_min, best.t[l]) {
                        (best.t[l], best.u[l], best.v[l], best.primitive[l]) = (t, u, v, i);
                        best.mask |= 1 << l;
                    }
                }
                continue;
            }
            if node & LEAF != 0 {
                self.closest_packet_leaf(&q, node, t_min, lanes, &mut best);
                continue;
            }
            let n = &self.nodes[node as usize];
            // The children entered, pushed back to front for the first of the rays' direction
            // (the packet's rays mostly go the same way near their common origin), so that the
            // nearest is tested first and its hits narrow the boxes of those behind it. Without
            // a branch per child: sorted by where the first ray enters them, and pushed only
            // where entered, the branches went either way at random (the Cornell box renders
            // 7 % faster without them, and the grid of cubes of `scripts/traversal-scenes.py`,
            // many boxes deep along every ray, 6 % faster than with the children unordered).
            let leader = lanes.trailing_zeros() as usize;
            for c in order_slots(n.order[octant([q.d[0][leader], q.d[1][leader], q.d[2][leader]])]).rev() {
                let mask = q.boxes(n, c, t_min, &best.t).0 & lanes;
                stack.push_if((n.children[c], mask), mask != 0);
            }
        }
        best
    }

    /// Tests a leaf's shapes against the rays in `lanes`, narrowing their best hits.
    #[inline(always)]
    fn closest_packet_leaf(&self, q: &PacketQuery, node: u32, t_min: f32, lanes: u32, best: &mut PacketHits) {
        let leaf = &self.leaves[(node & !LEAF) as usize];
        // Lanes outside `lanes` are kept from updating by a reach that no hit is below; inside,
        // the reach is the best hit so far.
        let mut reach: Lanes = std::array::from_fn(|l| if lanes >> l & 1 == 0 { t_min } else { best.t[l] });
        for (tri, distinct) in self.leaf_triangles(leaf) {
            for j in 0..distinct {
                let (hit, t, u, v) = q.triangle(tri, j, t_min, &reach);
                blend(&hit, &t, &mut reach);
                blend(&hit, &t, &mut best.t);
                blend(&hit, &u, &mut best.u);
                blend(&hit, &v, &mut best.v);
                blend_bits(&hit, &[tri.primitive[j]; RAYS], &mut best.primitive);
                best.mask |= sign_mask8(&hit);
            }
        }
        for (i, sphere) in &self.curved[range(leaf.curved)] {
            let mut pending = lanes;
            while pending != 0 {
                let l = pending.trailing_zeros() as usize;
                pending &= pending - 1;
                let ray = q.ray(l);
                if let Some((t, u, v)) = sphere.intersect(ray.origin.into(), ray.direction.into(), t_min, best.t[l]) {
                    (best.t[l], best.u[l], best.v[l], best.primitive[l]) = (t, u, v, *i);
                    best.mask |= 1 << l;
                }
            }
        }
    }

    #[inline(always)]
    fn occluded_packet_in(&self, rays: &RayPacket, live: u32, t_min: f32, t_max: &Lanes) -> u32 {
        if self.root == EMPTY || live == 0 {
            return 0;
        }
        let q = PacketQuery::new(rays);
        let mut blocked = 0u32;
        let mut stack = Stack::<(u32, u32)>::new();
        stack.push((self.root, live));
        while let Some((node, lanes)) = stack.pop() {
            let mut lanes = lanes & !blocked;
            if lanes == 0 {
                continue;
            }
            if self.one_at_a_time(node, lanes) {
                while lanes != 0 {
                    let l = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    if self.occluded_from(&q.ray(l), node, t_min, t_max[l]) {
                        blocked |= 1 << l;
                    }
                }
                continue;
            }
            if node & LEAF != 0 {
                // The rays entering the leaf, each dropped from `lanes` once something blocks it.
                let entering = lanes;
                let leaf = &self.leaves[(node & !LEAF) as usize];
                'packets: for (tri, distinct) in self.leaf_triangles(leaf) {
                    for j in 0..distinct {
                        lanes &= !sign_mask8(&q.triangle(tri, j, t_min, t_max).0);
                        if lanes == 0 {
                            break 'packets;
                        }
                    }
                }
                for (_, sphere) in &self.curved[range(leaf.curved)] {
                    let mut pending = lanes;
                    while pending != 0 {
                        let l = pending.trailing_zeros() as usize;
                        pending &= pending - 1;
                        let ray = q.ray(l);
                        if sphere.intersect(ray.origin.into(), ray.direction.into(), t_min, t_max[l]).is_some() {
                            lanes &= !(1 << l);
                        }
                    }
                }
                blocked |= entering & !lanes;
                continue;
            }
            let n = &self.nodes[node as usize];
            for c in 0..W {
                let child = n.children[c];
                if child == EMPTY {
                    break;
                }
                let mask = q.boxes(n, c, t_min, t_max).0 & lanes;
                if mask != 0 {
                    stack.push((child, mask));
                }
            }
        }
        blocked
    }
}
