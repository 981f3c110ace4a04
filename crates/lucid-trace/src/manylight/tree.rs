//! The light tree of lightcuts (Walter et al. 2005): a binary tree over point-like lights
//! whose every node stands for the lights below it by one representative, their summed
//! intensity and bounds (box, and for diffuse VPLs a cone of normals). A cut — a set of nodes
//! covering every light once — estimates a shading point's light as Σ over its nodes of the
//! representative's contribution per unit intensity times the node's intensity; it starts at
//! the roots and refines the node of largest error bound until every bound is below a fraction
//! of the estimate.
//!
//! Point and spot lights form one tree and diffuse VPLs another (their bounds differ); each is
//! split top-down at the median of its box's longest axis (written here: clustering a few
//! thousand points by median split is a few lines, and no crate offers light trees).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::Vec3;

use super::bound::{Cone, geometric_bound, max_cos_to_box, receiver_bound};
use super::virtual_light::{Emitter, VirtualLight};
use crate::geometry::Aabb;
use crate::sampling::{Rng, mix};
use crate::scene::Scene;
use crate::visible::VisiblePoint;

/// Largest cut (Walter et al.'s limit): where bounds stay loose (shadowed points, glossy
/// lobes without a bound) the cut stops here rather than summing every light.
pub(crate) const MAX_CUT: usize = 1000;

const LEAF: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Summed intensity of the lights below.
    intensity: Vec3,
    /// The light standing for them.
    representative: u32,
    children: [u32; 2],
    /// Cone of the normals of diffuse VPLs (`None`: point and spot lights).
    normals: Option<Cone>,
}

/// Light trees over a set of [`VirtualLight`]s (point, spot and diffuse lights).
pub(crate) struct LightTree {
    nodes: Vec<Node>,
    roots: Vec<u32>,
}

impl LightTree {
    /// Trees over `lights`; representatives are drawn in proportion to intensity from `seed`.
    ///
    /// # Panics
    /// On a VPL with a full BSDF (only diffuse VPLs have cluster bounds).
    pub(crate) fn build(lights: &[VirtualLight], seed: u64) -> Self {
        let mut tree = LightTree { nodes: Vec::with_capacity(2 * lights.len()), roots: Vec::new() };
        let (mut diffuse, mut omni): (Vec<u32>, Vec<u32>) =
            (0..lights.len() as u32).partition(|&i| matches!(lights[i as usize].emitter, Emitter::Diffuse { .. }));
        assert!(
            lights.iter().all(|l| !matches!(l.emitter, Emitter::Surface { .. })),
            "light trees hold point, spot and diffuse lights"
        );
        for group in [&mut omni, &mut diffuse] {
            if !group.is_empty() {
                let root = tree.build_node(lights, group, seed);
                tree.roots.push(root);
            }
        }
        tree
    }

    fn build_node(&mut self, lights: &[VirtualLight], indices: &mut [u32], seed: u64) -> u32 {
        if let [single] = indices {
            let light = &lights[*single as usize];
            let normals = match light.emitter {
                Emitter::Diffuse { normal } => Some(Cone { axis: normal, angle: 0.0 }),
                _ => None,
            };
            return self.push(Node {
                bounds: Aabb::EMPTY.include(light.position),
                intensity: light.intensity,
                representative: *single,
                children: [LEAF, LEAF],
                normals,
            });
        }
        // Split by position alone: also splitting diffuse VPLs by orientation (Walter et al.'s
        // metric) gave larger cuts on many-lights (2026-12-04).
        let bounds = indices.iter().fold(Aabb::EMPTY, |b, &i| b.include(lights[i as usize].position));
        let extent = bounds.max - bounds.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = indices.len() / 2;
        indices.select_nth_unstable_by(mid, |&a, &b| {
            lights[a as usize].position[axis].total_cmp(&lights[b as usize].position[axis])
        });
        let (low, high) = indices.split_at_mut(mid);
        let left = self.build_node(lights, low, seed);
        let right = self.build_node(lights, high, seed);
        let (a, b) = (self.nodes[left as usize], self.nodes[right as usize]);
        let (wa, wb) = (weight(a.intensity), weight(b.intensity));
        let mut rng = Rng::new(mix(seed ^ 0x4C43_5554), self.nodes.len() as u64);
        let representative =
            if wa + wb <= 0.0 || rng.uniform() * (wa + wb) < wa { a.representative } else { b.representative };
        let normals = match (a.normals, b.normals) {
            (Some(x), Some(y)) => Some(x.union(y)),
            _ => None,
        };
        self.push(Node {
            bounds: a.bounds.union(b.bounds),
            intensity: a.intensity + b.intensity,
            representative,
            children: [left, right],
            normals,
        })
    }

    fn push(&mut self, node: Node) -> u32 {
        self.nodes.push(node);
        (self.nodes.len() - 1) as u32
    }

    /// The light at `vp` from a cut whose nodes' error bounds are each at most `error` times
    /// the point's light — the cut's estimate plus `vp.direct`, the light the cut does not hold
    /// (or [`MAX_CUT`] nodes); shadow rays are counted in `rays`, the cut's size returned beside
    /// the estimate.
    pub(crate) fn estimate(
        &self,
        scene: &Scene,
        lights: &[VirtualLight],
        vp: &VisiblePoint,
        clamp2: f32,
        error: f32,
        rays: &mut u32,
    ) -> (Vec3, usize) {
        let mut heap = BinaryHeap::with_capacity(64);
        let mut total = Vec3::ZERO;
        for &root in &self.roots {
            let node = &self.nodes[root as usize];
            let unit = lights[node.representative as usize].unit_contribution(scene, vp, clamp2, rays);
            total += unit * node.intensity;
            heap.push(CutNode { bound: self.bound(node, vp, clamp2), node: root, unit });
        }
        let mut size = heap.len();
        while let Some(top) = heap.peek() {
            if top.bound <= error * weight(total + vp.direct) || size >= MAX_CUT {
                break;
            }
            let top = heap.pop().expect("peeked");
            let node = self.nodes[top.node as usize];
            total -= top.unit * node.intensity;
            for child in node.children {
                let c = &self.nodes[child as usize];
                // One child keeps the parent's representative, whose contribution is known.
                let unit = if c.representative == node.representative {
                    top.unit
                } else {
                    lights[c.representative as usize].unit_contribution(scene, vp, clamp2, rays)
                };
                total += unit * c.intensity;
                heap.push(CutNode { bound: self.bound(c, vp, clamp2), node: child, unit });
            }
            size += 1;
        }
        (total.max(Vec3::ZERO), size)
    }

    /// A bound on how far the node's estimate can be from the sum over its lights.
    fn bound(&self, node: &Node, vp: &VisiblePoint, clamp2: f32) -> f32 {
        if node.children[0] == LEAF {
            return 0.0;
        }
        let closest = vp.point.clamp(node.bounds.min, node.bounds.max);
        let distance = (closest - vp.point).length();
        // The directions from the cluster to the point, against its normals' axis.
        let normals = node.normals.map(|n| (n, max_cos_to_box(vp.point, -n.axis, &node.bounds)));
        let g = geometric_bound(distance, normals, clamp2);
        if g == 0.0 {
            return 0.0;
        }
        let m =
            receiver_bound(&vp.bsdf, vp.wo, |local| max_cos_to_box(vp.point, vp.frame.to_world(local), &node.bounds));
        match m {
            Some(m) if m == Vec3::ZERO => 0.0,
            Some(m) => weight(m * node.intensity) * g,
            None => f32::INFINITY,
        }
    }
}

/// The scalar of an RGB quantity that bounds and estimates are compared in.
fn weight(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// A node of the current cut.
struct CutNode {
    bound: f32,
    node: u32,
    /// Its representative's contribution per unit intensity.
    unit: Vec3,
}

impl PartialEq for CutNode {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for CutNode {}

impl PartialOrd for CutNode {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for CutNode {
    fn cmp(&self, other: &Self) -> Ordering {
        // Ties by node, so that the cut does not depend on the heap's internal order.
        self.bound.total_cmp(&other.bound).then(other.node.cmp(&self.node))
    }
}
