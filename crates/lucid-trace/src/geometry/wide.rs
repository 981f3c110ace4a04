//! The BVH collapsed to four children per node (a QBVH, Dammertz et al. 2008), with the
//! children's boxes and the leaves' triangles stored four to a SIMD register (glam's `Vec4`:
//! SSE on x86-64, NEON on ARM), so one ray tests four boxes or four triangles with one set of
//! instructions. Closest-hit queries visit children nearest first and skip any whose entry
//! distance is beyond the best hit so far. Written by hand for the reason `bvh.rs` gives.

use std::mem::MaybeUninit;

use glam::{BVec4A, Vec3A, Vec4};
use lucid_scene::Ray;

use super::bvh::{CompactShape, Node};

/// Marks a child reference as a leaf (the rest is the leaf's index).
const LEAF: u32 = 1 << 31;
/// An unused child slot (its box is empty, so no ray enters it).
const EMPTY: u32 = u32::MAX;
/// Traversal stack entries: each level of the tree leaves at most three more on the stack, so
/// this serves 85 levels (a tree of 4⁸⁵ leaves; indexing past it panics, it cannot corrupt).
const STACK: usize = 256;

/// Four children: `bounds[0]` their minimum corners, `bounds[1]` their maximum corners, one
/// register per axis.
#[derive(Clone, Copy, Debug)]
struct Node4 {
    bounds: [[Vec4; 3]; 2],
    children: [u32; 4],
}

/// Four triangles as a vertex and two edges per lane, one register per coordinate.
#[derive(Clone, Copy, Debug)]
struct Triangle4 {
    p0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    /// Each lane's primitive; lanes past the leaf's last triangle repeat it (the same hit twice
    /// changes nothing).
    primitive: [u32; 4],
}

/// A leaf's triangles (packets of four) and spheres, as ranges of [`WideBvh`]'s arrays.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    packets: (u32, u32),
    spheres: (u32, u32),
}

/// A ray prepared for box and packet tests.
struct RayQuery {
    origin: [Vec4; 3],
    dir: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Per axis, 1 where the direction is negative: which box corner the ray enters by.
    sign: [usize; 3],
    o: Vec3A,
    d: Vec3A,
}

impl RayQuery {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.direction));
        let inv = d.recip();
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Self {
            origin: splat(o),
            dir: splat(d),
            inv_dir: splat(inv),
            sign: [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize],
            o,
            d,
        }
    }

    /// Which of the node's four boxes the ray meets within `(t_min, t_max)`, as a bit mask, and
    /// the entry distances.
    #[inline(always)]
    fn boxes(&self, node: &Node4, t_min: f32, t_max: f32) -> (u32, Vec4) {
        let slab = |corner: usize, a: usize| (node.bounds[corner][a] - self.origin[a]) * self.inv_dir[a];
        let [sx, sy, sz] = self.sign;
        let near = slab(sx, 0).max(slab(sy, 1)).max(slab(sz, 2).max(Vec4::splat(t_min)));
        let far = slab(1 - sx, 0).min(slab(1 - sy, 1)).min(slab(1 - sz, 2).min(Vec4::splat(t_max)));
        (near.cmple(far).bitmask(), near)
    }

    /// Möller–Trumbore on four triangles: which lanes are hit within `(t_min, t_max)`, with
    /// their `t` and barycentrics. The same operations in the same order as
    /// [`CompactShape::intersect`], so both give the same numbers.
    #[inline(always)]
    fn triangles(&self, tri: &Triangle4, t_min: f32, t_max: f32) -> (BVec4A, Vec4, Vec4, Vec4) {
        let [dx, dy, dz] = self.dir;
        let [e1x, e1y, e1z] = tri.e1;
        let [e2x, e2y, e2z] = tri.e2;
        let (pvx, pvy, pvz) = (dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x);
        let det = e1x * pvx + e1y * pvy + e1z * pvz;
        let inv = Vec4::ONE / det;
        let (tvx, tvy, tvz) = (self.origin[0] - tri.p0[0], self.origin[1] - tri.p0[1], self.origin[2] - tri.p0[2]);
        let u = (tvx * pvx + tvy * pvy + tvz * pvz) * inv;
        let (qvx, qvy, qvz) = (tvy * e1z - tvz * e1y, tvz * e1x - tvx * e1z, tvx * e1y - tvy * e1x);
        let v = (dx * qvx + dy * qvy + dz * qvz) * inv;
        let t = (e2x * qvx + e2y * qvy + e2z * qvz) * inv;
        let hit = det.abs().cmpge(Vec4::splat(1e-12))
            & u.cmpge(Vec4::ZERO)
            & u.cmple(Vec4::ONE)
            & v.cmpge(Vec4::ZERO)
            & (u + v).cmple(Vec4::ONE)
            & t.cmpgt(Vec4::splat(t_min))
            & t.cmplt(Vec4::splat(t_max));
        (hit, t, u, v)
    }
}

/// The 4-wide hierarchy.
#[derive(Clone, Debug)]
pub(super) struct WideBvh {
    nodes: Vec<Node4>,
    leaves: Vec<Leaf>,
    packets: Vec<Triangle4>,
    spheres: Vec<(u32, CompactShape)>,
    root: u32,
}

impl WideBvh {
    /// Collapses a binary BVH (`nodes`, the first child of an interior node following it)
    /// whose leaves index `shapes`.
    pub(super) fn new(nodes: &[Node], shapes: &[CompactShape]) -> Self {
        let mut wide =
            Self { nodes: Vec::new(), leaves: Vec::new(), packets: Vec::new(), spheres: Vec::new(), root: EMPTY };
        if !nodes.is_empty() {
            wide.root = wide.collapse(nodes, shapes, 0);
        }
        wide
    }

    fn collapse(&mut self, nodes: &[Node], shapes: &[CompactShape], index: u32) -> u32 {
        let node = &nodes[index as usize];
        if node.count > 0 {
            return self.leaf(shapes, node.offset, node.count as u32);
        }
        // Open the largest interior child until there are four.
        let mut kids = vec![index + 1, node.offset];
        while kids.len() < 4 {
            let Some(k) = (0..kids.len()).filter(|&k| nodes[kids[k] as usize].count == 0).max_by(|&a, &b| {
                nodes[kids[a] as usize].bounds.area().total_cmp(&nodes[kids[b] as usize].bounds.area())
            }) else {
                break;
            };
            let open = kids.swap_remove(k);
            kids.extend([open + 1, nodes[open as usize].offset]);
        }
        let slot = self.nodes.len();
        self.nodes.push(Node4 { bounds: [[Vec4::INFINITY; 3], [Vec4::NEG_INFINITY; 3]], children: [EMPTY; 4] });
        for (lane, &kid) in kids.iter().enumerate() {
            let b = nodes[kid as usize].bounds;
            let child = self.collapse(nodes, shapes, kid);
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
        let first_sphere = self.spheres.len() as u32;
        let mut triangles = Vec::new();
        for i in first..first + count {
            match shapes[i as usize] {
                CompactShape::Triangle { p0, e1, e2 } => triangles.push((i, [p0, e1, e2])),
                sphere @ CompactShape::Sphere { .. } => self.spheres.push((i, sphere)),
            }
        }
        for chunk in triangles.chunks(4) {
            let lane = |l: usize| chunk[l.min(chunk.len() - 1)];
            let coord = |v: usize, a: usize| Vec4::from_array(std::array::from_fn(|l| lane(l).1[v][a]));
            self.packets.push(Triangle4 {
                p0: std::array::from_fn(|a| coord(0, a)),
                e1: std::array::from_fn(|a| coord(1, a)),
                e2: std::array::from_fn(|a| coord(2, a)),
                primitive: std::array::from_fn(|l| lane(l).0),
            });
        }
        self.leaves.push(Leaf {
            packets: (first_packet, self.packets.len() as u32 - first_packet),
            spheres: (first_sphere, self.spheres.len() as u32 - first_sphere),
        });
        LEAF | (self.leaves.len() as u32 - 1)
    }

    /// The nearest hit within `(t_min, t_max)`: `(t, u, v, primitive)`.
    #[inline]
    pub(super) fn closest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32, u32)> {
        if self.root == EMPTY {
            return None;
        }
        let q = RayQuery::new(ray);
        let mut best = None;
        let mut closest = t_max;
        let mut stack = Stack::<(u32, f32)>::new();
        stack.push((self.root, t_min));
        while let Some((node, entry)) = stack.pop() {
            if entry >= closest {
                continue;
            }
            if node & LEAF != 0 {
                let leaf = &self.leaves[(node & !LEAF) as usize];
                for tri in &self.packets[range(leaf.packets)] {
                    let (hit, t, u, v) = q.triangles(tri, t_min, closest);
                    if hit.any() {
                        let t = Vec4::select(hit, t, Vec4::INFINITY);
                        let nearest = t.min_element();
                        let lane = t.cmpeq(Vec4::splat(nearest)).bitmask().trailing_zeros() as usize;
                        closest = nearest;
                        best = Some((nearest, u[lane], v[lane], tri.primitive[lane]));
                    }
                }
                for (i, sphere) in &self.spheres[range(leaf.spheres)] {
                    if let Some((t, u, v)) = sphere.intersect(q.o, q.d, t_min, closest) {
                        closest = t;
                        best = Some((t, u, v, *i));
                    }
                }
                continue;
            }
            let n = &self.nodes[node as usize];
            let (mut mask, entries) = q.boxes(n, t_min, closest);
            // Push the far children first so that the nearest is visited next.
            let mut hits = [(0u32, 0f32); 4];
            let mut k = 0;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let mut j = k;
                while j > 0 && hits[j - 1].1 < entries[lane] {
                    hits[j] = hits[j - 1];
                    j -= 1;
                }
                hits[j] = (n.children[lane], entries[lane]);
                k += 1;
            }
            for &hit in &hits[..k] {
                stack.push(hit);
            }
        }
        best
    }

    /// Whether anything is hit within `(t_min, t_max)`.
    #[inline]
    pub(super) fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if self.root == EMPTY {
            return false;
        }
        let q = RayQuery::new(ray);
        let mut stack = Stack::<u32>::new();
        stack.push(self.root);
        while let Some(node) = stack.pop() {
            if node & LEAF != 0 {
                let leaf = &self.leaves[(node & !LEAF) as usize];
                if self.packets[range(leaf.packets)].iter().any(|tri| q.triangles(tri, t_min, t_max).0.any())
                    || self.spheres[range(leaf.spheres)]
                        .iter()
                        .any(|(_, s)| s.intersect(q.o, q.d, t_min, t_max).is_some())
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

fn range((first, count): (u32, u32)) -> std::ops::Range<usize> {
    first as usize..(first + count) as usize
}

/// A fixed-capacity traversal stack left uninitialised: zeroing 2 KiB per ray cost 6 % of a
/// render (a `memset` per query), more than the traversal of a small scene's top levels.
struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn new() -> Self {
        Self { items: [const { MaybeUninit::uninit() }; STACK], len: 0 }
    }

    #[inline(always)]
    fn push(&mut self, item: T) {
        self.items[self.len].write(item);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        #[allow(unsafe_code)]
        // SAFETY: every slot below `len` was written by `push` (slots are only read below the
        // length they were pushed at, and `len` only grows through `push`).
        Some(unsafe { self.items[self.len].assume_init() })
    }
}
