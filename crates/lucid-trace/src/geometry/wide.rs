//! The BVH collapsed to eight children per node (an 8-wide BVH, after the QBVH of Dammertz et
//! al. 2008), with the children's boxes and the leaves' triangles stored eight to a row of
//! lanes, so one ray tests eight boxes or eight triangles with one set of vector instructions:
//! the lane loops below are plain Rust that the compiler vectorises, and both queries run
//! compiled for AVX2 where the CPU has it ([`wide`]: one 8-wide register per row; two SSE
//! registers otherwise, with the same numbers). A subtree of at most eight triangles becomes
//! one leaf packet, so a small scene is a root and a few packets. Closest-hit queries visit
//! children front to back in an order stored per octant of ray directions (a ray's own entry
//! distances sorted cost more in mispredicted branches than they saved) and skip any whose
//! entry distance is beyond the best hit so far.
//! Written by hand for the reason `bvh.rs` gives.

use std::mem::MaybeUninit;

use glam::{Vec3A, Vec4};
use lucid_scene::Ray;
use lucid_scene::simd::{sign_mask8, wide};

use super::bvh::{CompactShape, Node};

/// Lanes per node and per triangle packet.
pub(super) const W: usize = 8;
/// Marks a child reference as a leaf (the rest is the leaf's index).
pub(super) const LEAF: u32 = 1 << 31;
/// An unused child slot (its box is empty, so no ray enters it).
pub(super) const EMPTY: u32 = u32::MAX;
/// Traversal stack entries: each level of the tree leaves at most seven more on the stack, so
/// this serves 36 levels (a tree of 8³⁶ leaves; indexing past it panics, it cannot corrupt).
const STACK: usize = 256;

/// Eight children: `bounds[0]` their minimum corners, `bounds[1]` their maximum corners, one
/// row of lanes per axis.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Node8 {
    pub(super) bounds: [[[f32; W]; 3]; 2],
    pub(super) children: [u32; W],
    /// Per octant of ray directions ([`octant`]), the children front to back: slot numbers of
    /// three bits each from the lowest, and how many children there are in bits 24 and up.
    pub(super) order: [u32; W],
}

/// The octant of direction `d`: bit `a` set where its coordinate `a` is negative.
#[inline(always)]
pub(super) fn octant(d: [f32; 3]) -> usize {
    (d[0] < 0.0) as usize | ((d[1] < 0.0) as usize) << 1 | ((d[2] < 0.0) as usize) << 2
}

/// The child slots of one [`Node8::order`] word, front to back.
#[inline(always)]
pub(super) fn order_slots(order: u32) -> impl DoubleEndedIterator<Item = usize> {
    (0..(order >> 24) as usize).map(move |k| (order >> (3 * k)) as usize & 7)
}

/// [`Node8::order`] for `centres`, the children's box centres: in each octant, ordered by the
/// centre's distance along the octant's diagonal (a ray of that octant meets a box further
/// along it later, where the boxes do not overlap much along it).
fn child_orders(centres: &[glam::Vec3]) -> [u32; W] {
    std::array::from_fn(|oct| {
        let diagonal = glam::Vec3::new(
            if oct & 1 != 0 { -1.0 } else { 1.0 },
            if oct & 2 != 0 { -1.0 } else { 1.0 },
            if oct & 4 != 0 { -1.0 } else { 1.0 },
        );
        let mut slots: Vec<usize> = (0..centres.len()).collect();
        slots.sort_by(|&a, &b| centres[a].dot(diagonal).total_cmp(&centres[b].dot(diagonal)));
        slots.iter().enumerate().fold((centres.len() as u32) << 24, |order, (k, &c)| order | (c as u32) << (3 * k))
    })
}

/// Eight triangles as a vertex and two edges per lane, one row per coordinate.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Triangle8 {
    pub(super) p0: [[f32; W]; 3],
    pub(super) e1: [[f32; W]; 3],
    pub(super) e2: [[f32; W]; 3],
    /// Each lane's primitive; lanes past the leaf's last triangle repeat it (the same hit twice
    /// changes nothing).
    pub(super) primitive: [u32; W],
}

/// A leaf's triangles (packets of eight) and curved shapes (spheres, fibres), as ranges of [`WideBvh`]'s arrays.
#[derive(Clone, Copy, Debug)]
pub(super) struct Leaf {
    pub(super) packets: (u32, u32),
    pub(super) curved: (u32, u32),
    /// Triangles and curved shapes in all.
    pub(super) shapes: u32,
}

/// A ray prepared for box and packet tests.
struct RayQuery {
    o: [f32; 3],
    d: [f32; 3],
    /// Per axis, 1 where the direction is negative: which box corner the ray enters by.
    sign: [usize; 3],
    /// The direction's [`octant`].
    octant: usize,
    origin: Vec3A,
    direction: Vec3A,
    /// The origin and inverse direction per axis, in every lane.
    o4: [Vec4; 3],
    inv4: [Vec4; 3],
}

impl RayQuery {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.direction));
        let inv = d.recip();
        Self {
            o: o.to_array(),
            d: d.to_array(),
            sign: [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize],
            octant: octant(d.to_array()),
            origin: o,
            direction: d,
            o4: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv4: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
        }
    }

    /// Which of the node's eight boxes the ray meets within `(t_min, t_max)`, as a bit mask,
    /// and the entry distances. An empty slot's ±∞ bounds give `near = +∞ > far`; a zero
    /// direction component gives ±∞ slabs, and a NaN (origin on the slab plane) fails the
    /// comparison like the 4-wide SSE test did.
    #[inline(always)]
    fn boxes(&self, node: &Node8, t_min: f32, t_max: f32) -> (u32, [f32; W]) {
        let [sx, sy, sz] = self.sign;
        let b = &node.bounds;
        // Two explicit 4-wide halves (glam's SSE vectors): written as an 8-lane loop, the
        // compiler vectorised it into 4-, 2- and 1-lane pieces joined by shuffles, three times
        // the instructions. `Vec4::max`/`min` are the x86 instructions (`a > b ? a : b`),
        // where `f32::max` would add NaN handling to every lane.
        let mut near = [0f32; W];
        let mut mask = 0u32;
        for half in 0..2 {
            let row = |r: &[f32; W]| Vec4::from_slice(&r[4 * half..4 * half + 4]);
            let slab = |corner: usize, a: usize| (row(&b[corner][a]) - self.o4[a]) * self.inv4[a];
            let n = slab(sx, 0).max(slab(sy, 1)).max(slab(sz, 2).max(Vec4::splat(t_min)));
            let f = slab(1 - sx, 0).min(slab(1 - sy, 1)).min(slab(1 - sz, 2).min(Vec4::splat(t_max)));
            n.write_to_slice(&mut near[4 * half..4 * half + 4]);
            mask |= n.cmple(f).bitmask() << (4 * half);
        }
        (mask, near)
    }

    /// Möller–Trumbore on eight triangles: which lanes are hit within `(t_min, t_max)` (a bit
    /// mask), with their `t` (+∞ where missed) and barycentrics. The same operations in the
    /// same order as [`CompactShape::intersect`], so both give the same numbers.
    #[inline(always)]
    fn triangles(&self, tri: &Triangle8, t_min: f32, t_max: f32) -> (u32, [f32; W], [f32; W], [f32; W]) {
        let ([dx, dy, dz], [ox, oy, oz]) = (self.d, self.o);
        let (mut ts, mut us, mut vs) = ([0f32; W], [0f32; W], [0f32; W]);
        // Negative where hit: the mask is the sign bits (see `sign_mask8`).
        let mut hits = [0f32; W];
        for l in 0..W {
            let corner = |v: &[[f32; W]; 3]| [v[0][l], v[1][l], v[2][l]];
            let (hit, t, u, v) = moller_trumbore(
                [dx, dy, dz],
                [ox, oy, oz],
                corner(&tri.p0),
                corner(&tri.e1),
                corner(&tri.e2),
                t_min,
                t_max,
            );
            ts[l] = if hit { t } else { f32::INFINITY };
            us[l] = u;
            vs[l] = v;
            hits[l] = 0.0 - hit as u32 as f32;
        }
        (sign_mask8(&hits), ts, us, vs)
    }
}

/// Möller–Trumbore for one ray (direction `d`, origin `o`) and one triangle (vertex `p0`,
/// edges `e1`, `e2`): whether it is hit within `(t_min, t_max)`, and `t` and the barycentrics.
/// The operations of [`CompactShape::intersect`] in its order, so every query gets the same
/// numbers; branch-free, for the lane loops of the single-ray and the packet queries.
#[inline(always)]
#[allow(clippy::manual_range_contains)] // `&` of comparisons: no branch in the lane loop
pub(super) fn moller_trumbore(
    [dx, dy, dz]: [f32; 3],
    [ox, oy, oz]: [f32; 3],
    [p0x, p0y, p0z]: [f32; 3],
    [e1x, e1y, e1z]: [f32; 3],
    [e2x, e2y, e2z]: [f32; 3],
    t_min: f32,
    t_max: f32,
) -> (bool, f32, f32, f32) {
    let (pvx, pvy, pvz) = (dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x);
    let det = e1x * pvx + e1y * pvy + e1z * pvz;
    let inv = 1.0 / det;
    let (tvx, tvy, tvz) = (ox - p0x, oy - p0y, oz - p0z);
    let u = (tvx * pvx + tvy * pvy + tvz * pvz) * inv;
    let (qvx, qvy, qvz) = (tvy * e1z - tvz * e1y, tvz * e1x - tvx * e1z, tvx * e1y - tvy * e1x);
    let v = (dx * qvx + dy * qvy + dz * qvz) * inv;
    let t = (e2x * qvx + e2y * qvy + e2z * qvz) * inv;
    let hit = (det.abs() >= 1e-12) & (u >= 0.0) & (u <= 1.0) & (v >= 0.0) & (u + v <= 1.0) & (t > t_min) & (t < t_max);
    (hit, t, u, v)
}

/// The 8-wide hierarchy.
#[derive(Clone, Debug)]
pub(super) struct WideBvh {
    pub(super) nodes: Vec<Node8>,
    pub(super) leaves: Vec<Leaf>,
    pub(super) packets: Vec<Triangle8>,
    pub(super) curved: Vec<(u32, CompactShape)>,
    pub(super) root: u32,
}

impl WideBvh {
    /// Collapses a binary BVH (`nodes`, the first child of an interior node following it)
    /// whose leaves index `shapes`.
    pub(super) fn new(nodes: &[Node], shapes: &[CompactShape]) -> Self {
        let mut wide =
            Self { nodes: Vec::new(), leaves: Vec::new(), packets: Vec::new(), curved: Vec::new(), root: EMPTY };
        if !nodes.is_empty() {
            wide.root = wide.collapse(nodes, &spans(nodes), shapes, 0);
        }
        wide
    }

    fn collapse(&mut self, nodes: &[Node], spans: &[(u32, u32)], shapes: &[CompactShape], index: u32) -> u32 {
        let (first, count) = spans[index as usize];
        // A leaf, or a subtree small enough for one packet (its primitives are contiguous).
        let fits = |i: u32| nodes[i as usize].count > 0 || spans[i as usize].1 as usize <= W;
        if fits(index) {
            return self.leaf(shapes, first, count);
        }
        // Fill the eight slots by opening, one at a time, the child whose opening saves the
        // most by the surface-area heuristic (cost per ray entering a box: a packet test 1, a
        // node's box test `NODE_COST`). A child too large for a packet left closed costs one
        // more level of box tests. A child that fits is opened if its parts, each as its own
        // packet, cost no more than it does: two walls of a room in one packet would make
        // every ray entering their common box test both, and the SAH's tie there does not see
        // that a closest-hit query visiting children nearest first skips the far wall.
        let area = |i: u32| nodes[i as usize].bounds.area();
        let halves = |i: u32| (i + 1, nodes[i as usize].offset);
        let saving = |i: u32| {
            if nodes[i as usize].count > 0 {
                None
            } else if !fits(i) {
                Some(NODE_COST * area(i))
            } else {
                let (a, b) = halves(i);
                let saved = area(i) - split_cost(nodes, a) - split_cost(nodes, b);
                (saved >= -1e-6 * area(i)).then_some(saved + NODE_COST * area(i))
            }
        };
        let mut kids = vec![index + 1, nodes[index as usize].offset];
        while kids.len() < W {
            let Some(k) = (0..kids.len())
                .filter_map(|k| saving(kids[k]).map(|s| (k, s)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k)
            else {
                break;
            };
            let (a, b) = halves(kids.swap_remove(k));
            kids.extend([a, b]);
        }
        let slot = self.nodes.len();
        let centres: Vec<glam::Vec3> = kids.iter().map(|&kid| nodes[kid as usize].bounds.centre()).collect();
        self.nodes.push(Node8 {
            bounds: [[[f32::INFINITY; W]; 3], [[f32::NEG_INFINITY; W]; 3]],
            children: [EMPTY; W],
            order: child_orders(&centres),
        });
        for (lane, &kid) in kids.iter().enumerate() {
            let b = nodes[kid as usize].bounds;
            let child = self.collapse(nodes, spans, shapes, kid);
            let n = &mut self.nodes[slot];
            for a in 0..3 {
                n.bounds[0][a][lane] = b.min[a];
                n.bounds[1][a][lane] = b.max[a];
            }
            n.children[lane] = child;
        }
        slot as u32
    }

    fn leaf(&mut self, shapes: &[CompactShape], first: u32, count: u32) -> u32 {
        let first_packet = self.packets.len() as u32;
        let first_curved = self.curved.len() as u32;
        let mut triangles = Vec::new();
        for i in first..first + count {
            match shapes[i as usize] {
                CompactShape::Triangle { p0, e1, e2 } => triangles.push((i, [p0, e1, e2])),
                other => self.curved.push((i, other)),
            }
        }
        for chunk in triangles.chunks(W) {
            let lane = |l: usize| chunk[l.min(chunk.len() - 1)];
            let coord = |v: usize| std::array::from_fn(|a| std::array::from_fn(|l| lane(l).1[v][a]));
            self.packets.push(Triangle8 {
                p0: coord(0),
                e1: coord(1),
                e2: coord(2),
                primitive: std::array::from_fn(|l| lane(l).0),
            });
        }
        self.leaves.push(Leaf {
            packets: (first_packet, self.packets.len() as u32 - first_packet),
            curved: (first_curved, self.curved.len() as u32 - first_curved),
            shapes: count,
        });
        LEAF | (self.leaves.len() as u32 - 1)
    }

    /// The nearest hit within `(t_min, t_max)`: `(t, u, v, primitive)`.
    #[inline]
    pub(super) fn closest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32, u32)> {
        wide(
            #[inline(always)]
            || self.closest_in(ray, t_min, t_max),
        )
    }

    /// Whether anything is hit within `(t_min, t_max)`.
    #[inline]
    pub(super) fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        wide(
            #[inline(always)]
            || self.occluded_in(ray, t_min, t_max),
        )
    }

    #[inline(always)]
    fn closest_in(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32, u32)> {
        if self.root == EMPTY {
            return None;
        }
        self.closest_from(ray, self.root, t_min, t_max)
    }

    /// [`WideBvh::closest`] in the subtree under `start` (a node or leaf reference).
    #[inline(always)]
    pub(super) fn closest_from(&self, ray: &Ray, start: u32, t_min: f32, t_max: f32) -> Option<(f32, f32, f32, u32)> {
        let q = RayQuery::new(ray);
        let mut best = None;
        let mut closest = t_max;
        let mut stack = Stack::<(u32, f32)>::new();
        stack.push((start, t_min));
        while let Some((node, entry)) = stack.pop() {
            if entry >= closest {
                continue;
            }
            if node & LEAF != 0 {
                self.closest_in_leaf(&q, node, t_min, &mut closest, &mut best);
                continue;
            }
            let n = &self.nodes[node as usize];
            let (mask, entries) = q.boxes(n, t_min, closest);
            // The children met, pushed back to front for the ray's direction, the nearest on
            // top; those that turn out to start beyond a hit found first are dropped when
            // popped. Without a branch per child, which went either way at random.
            for c in order_slots(n.order[q.octant]).rev() {
                stack.push_if((n.children[c], entries[c]), mask >> c & 1 != 0);
            }
        }
        best
    }

    /// Tests a leaf's shapes against the ray, narrowing `closest` and `best` to any nearer hit.
    #[inline(always)]
    fn closest_in_leaf(
        &self,
        q: &RayQuery,
        node: u32,
        t_min: f32,
        closest: &mut f32,
        best: &mut Option<(f32, f32, f32, u32)>,
    ) {
        let leaf = &self.leaves[(node & !LEAF) as usize];
        for tri in &self.packets[range(leaf.packets)] {
            let (hit, t, u, v) = q.triangles(tri, t_min, *closest);
            if hit != 0 {
                // Missed lanes hold +∞, so the minimum is a hit's.
                let (lo, hi) = (Vec4::from_slice(&t[..4]), Vec4::from_slice(&t[4..]));
                let nearest = lo.min(hi).min_element();
                let at = lo.cmpeq(Vec4::splat(nearest)).bitmask() | (hi.cmpeq(Vec4::splat(nearest)).bitmask() << 4);
                let lane = at.trailing_zeros() as usize;
                *closest = nearest;
                *best = Some((nearest, u[lane], v[lane], tri.primitive[lane]));
            }
        }
        for (i, sphere) in &self.curved[range(leaf.curved)] {
            if let Some((t, u, v)) = sphere.intersect(q.origin, q.direction, t_min, *closest) {
                *closest = t;
                *best = Some((t, u, v, *i));
            }
        }
    }

    #[inline(always)]
    fn occluded_in(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if self.root == EMPTY {
            return false;
        }
        self.occluded_from(ray, self.root, t_min, t_max)
    }

    /// [`WideBvh::occluded`] in the subtree under `start`.
    #[inline(always)]
    pub(super) fn occluded_from(&self, ray: &Ray, start: u32, t_min: f32, t_max: f32) -> bool {
        let q = RayQuery::new(ray);
        let mut stack = Stack::<u32>::new();
        stack.push(start);
        while let Some(node) = stack.pop() {
            if node & LEAF != 0 {
                let leaf = &self.leaves[(node & !LEAF) as usize];
                if self.packets[range(leaf.packets)].iter().any(|tri| q.triangles(tri, t_min, t_max).0 != 0)
                    || self.curved[range(leaf.curved)]
                        .iter()
                        .any(|(_, s)| s.intersect(q.origin, q.direction, t_min, t_max).is_some())
                {
                    return true;
                }
                continue;
            }
            let n = &self.nodes[node as usize];
            let (mut mask, _) = q.boxes(n, t_min, t_max);
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                stack.push(n.children[lane]);
            }
        }
        false
    }
}

/// The SAH cost of a subtree small enough for one packet when split into packets wherever
/// that costs no more: the cheaper of one packet over its box and its two halves' costs.
fn split_cost(nodes: &[Node], index: u32) -> f32 {
    let node = &nodes[index as usize];
    let whole = node.bounds.area();
    if node.count > 0 {
        return whole;
    }
    whole.min(split_cost(nodes, index + 1) + split_cost(nodes, node.offset))
}

/// A node's box test relative to a packet's triangle test (about a quarter of the vector
/// instructions).
const NODE_COST: f32 = 0.25;

/// The primitives under each binary node, `(first, count)`: contiguous, as the builder
/// partitions them in place. Children come after their parent, so one backward pass fills it.
fn spans(nodes: &[Node]) -> Vec<(u32, u32)> {
    let mut spans = vec![(0, 0); nodes.len()];
    for i in (0..nodes.len()).rev() {
        let node = &nodes[i];
        spans[i] = if node.count > 0 {
            (node.offset, node.count as u32)
        } else {
            let ((first, left), (_, right)) = (spans[i + 1], spans[node.offset as usize]);
            (first, left + right)
        };
    }
    spans
}

#[inline(always)]
pub(super) fn range((first, count): (u32, u32)) -> std::ops::Range<usize> {
    first as usize..(first + count) as usize
}

/// A fixed-capacity traversal stack left uninitialised: zeroing 2 KiB per ray cost 6 % of a
/// render (a `memset` per query), more than the traversal of a small scene's top levels.
pub(super) struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub(super) fn new() -> Self {
        Self { items: [const { MaybeUninit::uninit() }; STACK], len: 0 }
    }

    #[inline(always)]
    pub(super) fn push(&mut self, item: T) {
        self.items[self.len].write(item);
        self.len += 1;
    }

    /// Pushes `item` where `keep`, without a branch: it is written either way, and kept only
    /// by counting it.
    #[inline(always)]
    pub(super) fn push_if(&mut self, item: T, keep: bool) {
        self.items[self.len].write(item);
        self.len += keep as usize;
    }

    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        #[allow(unsafe_code)]
        // SAFETY: every slot below `len` was written by `push` (slots are only read below the
        // length they were pushed at, and `len` only grows through `push`).
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn slots(order: u32) -> Vec<usize> {
        order_slots(order).collect()
    }

    #[test]
    fn children_are_ordered_front_to_back_per_octant() {
        // Three boxes along x, slot 0 in the middle; the y and z offsets are smaller than the
        // spacing along x, so the diagonal's x decides.
        let centres = [Vec3::new(0.0, 0.1, 0.0), Vec3::new(-1.0, 0.0, 0.2), Vec3::new(1.0, -0.1, 0.0)];
        let orders = child_orders(&centres);
        for (oct, &order) in orders.iter().enumerate() {
            let want = if oct & 1 == 0 { vec![1, 0, 2] } else { vec![2, 0, 1] };
            assert_eq!(slots(order), want, "octant {oct}");
        }
        assert_eq!(octant([1.0, 2.0, 3.0]), 0);
        assert_eq!(octant([-1.0, 2.0, -3.0]), 0b101);
        // A full node: every slot once, in every octant.
        let eight: Vec<Vec3> = (0..8).map(|i| Vec3::new(i as f32, (i * 5 % 8) as f32, (i * 3 % 8) as f32)).collect();
        for order in child_orders(&eight) {
            let mut s = slots(order);
            s.sort();
            assert_eq!(s, (0..8).collect::<Vec<_>>());
        }
        // Along the diagonal of octant 0b110 (x up, y and z down), the box furthest towards
        // -x, +y, +z comes first.
        let diagonal = [Vec3::new(2.0, -2.0, -2.0), Vec3::new(-2.0, 2.0, 2.0), Vec3::ZERO];
        assert_eq!(slots(child_orders(&diagonal)[0b110]), vec![1, 2, 0]);
    }
}
