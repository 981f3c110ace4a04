//! Ward's irradiance records and the octree they are found in. A record at `p` with normal
//! `n`, irradiance `E` and harmonic-mean distance `R` to the surfaces its gather rays hit is
//! reused at `x` with normal `nx` when Ward's error `ε = |x − p|/R + √(1 − n·nx)` is below the
//! threshold `a`, weighted by `(1 − ε/a)²` (a smooth version of Ward's `1/ε`, as pbrt's), and
//! not when `p` lies in front of `x` (it would see light that `x` does not).
//!
//! The octree is written here (pbrt-v2's structure): a record is stored in the deepest nodes
//! whose diagonal is still longer than its sphere of validity's box's, so a lookup reads the
//! nodes on the path from the root to `x`'s leaf.

use glam::Vec3;

use crate::geometry::Aabb;

/// One cached irradiance value.
#[derive(Clone, Copy, Debug)]
pub(crate) struct IrradianceRecord {
    pub(crate) point: Vec3,
    pub(crate) normal: Vec3,
    /// Indirect irradiance (W/m²).
    pub(crate) irradiance: Vec3,
    /// Harmonic-mean distance of the gather rays' hits, clamped to a pixel-footprint range.
    pub(crate) radius: f32,
    /// Camera path segments to the point: records serve points with the same path budget.
    pub(crate) segments: u32,
}

const MAX_DEPTH: u32 = 16;

struct OctreeNode {
    children: Option<Box<[OctreeNode; 8]>>,
    records: Vec<u32>,
}

impl OctreeNode {
    fn empty() -> Self {
        Self { children: None, records: Vec::new() }
    }
}

/// Irradiance records in an octree over the scene's bounds.
pub(crate) struct IrradianceCache {
    bounds: Aabb,
    root: OctreeNode,
    records: Vec<IrradianceRecord>,
    /// Ward's error threshold `a`.
    error: f32,
}

impl IrradianceCache {
    /// An empty cache over `bounds` with error threshold `error` (> 0).
    pub(crate) fn new(bounds: Aabb, error: f32) -> Self {
        // A cube, so that children stay cubes.
        let half = 0.5 * (bounds.max - bounds.min).max_element().max(1e-3);
        let c = bounds.centre();
        let cube = Aabb { min: c - Vec3::splat(half * 1.001), max: c + Vec3::splat(half * 1.001) };
        Self { bounds: cube, root: OctreeNode::empty(), records: Vec::new(), error }
    }

    /// Records stored.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.records.len()
    }

    /// Adds a record.
    pub(crate) fn insert(&mut self, record: IrradianceRecord) {
        let index = self.records.len() as u32;
        let reach = Vec3::splat(self.error * record.radius);
        let data = Aabb { min: record.point - reach, max: record.point + reach };
        self.records.push(record);
        insert(&mut self.root, self.bounds, &data, index, 0);
    }

    /// The interpolated irradiance at `x` (normal `normal`, `segments` from the camera), or
    /// `None` where no record is close enough.
    pub(crate) fn lookup(&self, x: Vec3, normal: Vec3, segments: u32) -> Option<Vec3> {
        let (mut sum, mut weights) = (Vec3::ZERO, 0.0f32);
        let mut node = &self.root;
        let mut bounds = self.bounds;
        if !contains(&bounds, x) {
            return None;
        }
        loop {
            for &r in &node.records {
                let rec = &self.records[r as usize];
                if rec.segments != segments {
                    continue;
                }
                if let Some(w) = self.weight(rec, x, normal) {
                    sum += w * rec.irradiance;
                    weights += w;
                }
            }
            let Some(children) = &node.children else { break };
            let c = bounds.centre();
            let k = child_index(x, c);
            bounds = child_bounds(bounds, k);
            node = &children[k];
        }
        (weights > 0.0).then(|| sum / weights)
    }

    fn weight(&self, rec: &IrradianceRecord, x: Vec3, normal: Vec3) -> Option<f32> {
        let cos = normal.dot(rec.normal);
        if cos < 0.01 {
            return None;
        }
        let d = x - rec.point;
        // In front of the point: the record sees light the point may not.
        if d.dot(0.5 * (normal + rec.normal)) < -1e-3 * rec.radius {
            return None;
        }
        let e = d.length() / rec.radius + (1.0 - cos).max(0.0).sqrt();
        (e < self.error).then(|| (1.0 - e / self.error).powi(2))
    }
}

fn contains(b: &Aabb, p: Vec3) -> bool {
    p.cmpge(b.min).all() && p.cmple(b.max).all()
}

fn child_index(p: Vec3, centre: Vec3) -> usize {
    usize::from(p.x > centre.x) | (usize::from(p.y > centre.y) << 1) | (usize::from(p.z > centre.z) << 2)
}

fn child_bounds(b: Aabb, k: usize) -> Aabb {
    let c = b.centre();
    let pick = |bit: usize, axis: usize| if k & bit != 0 { (c[axis], b.max[axis]) } else { (b.min[axis], c[axis]) };
    let (x, y, z) = (pick(1, 0), pick(2, 1), pick(4, 2));
    Aabb { min: Vec3::new(x.0, y.0, z.0), max: Vec3::new(x.1, y.1, z.1) }
}

fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
}

fn insert(node: &mut OctreeNode, bounds: Aabb, data: &Aabb, index: u32, depth: u32) {
    let node_diagonal = (bounds.max - bounds.min).length_squared();
    let data_diagonal = (data.max - data.min).length_squared();
    if depth == MAX_DEPTH || node_diagonal < data_diagonal {
        node.records.push(index);
        return;
    }
    let children = node.children.get_or_insert_with(|| Box::new(std::array::from_fn(|_| OctreeNode::empty())));
    for (k, child) in children.iter_mut().enumerate() {
        let cb = child_bounds(bounds, k);
        if overlaps(&cb, data) {
            insert(child, cb, data, index, depth + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn record(point: Vec3, normal: Vec3, radius: f32, irradiance: f32) -> IrradianceRecord {
        IrradianceRecord { point, normal, irradiance: Vec3::splat(irradiance), radius, segments: 1 }
    }

    /// The octree finds exactly the records a scan over all of them finds.
    #[test]
    fn lookups_match_a_scan_over_every_record() {
        let bounds = Aabb { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) };
        let mut cache = IrradianceCache::new(bounds, 0.3);
        let mut rng = Rng::new(5, 0);
        let up = Vec3::Y;
        for _ in 0..500 {
            let p = Vec3::new(rng.uniform() * 4.0 - 2.0, 0.0, rng.uniform() * 4.0 - 2.0);
            cache.insert(record(p, up, 0.05 + rng.uniform() * 0.5, rng.uniform()));
        }
        assert_eq!(cache.len(), 500);
        for _ in 0..2000 {
            let x = Vec3::new(rng.uniform() * 4.0 - 2.0, 0.0, rng.uniform() * 4.0 - 2.0);
            let (mut sum, mut w) = (Vec3::ZERO, 0.0);
            for rec in &cache.records {
                if let Some(wt) = cache.weight(rec, x, up) {
                    sum += wt * rec.irradiance;
                    w += wt;
                }
            }
            let scan = (w > 0.0).then(|| sum / w);
            let found = cache.lookup(x, up, 1);
            match (scan, found) {
                (None, None) => {}
                (Some(a), Some(b)) => assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}"),
                other => panic!("scan and octree disagree at {x}: {other:?}"),
            }
        }
    }

    #[test]
    fn records_serve_only_nearby_points_facing_the_same_way() {
        let bounds = Aabb { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) };
        let mut cache = IrradianceCache::new(bounds, 0.5);
        cache.insert(record(Vec3::ZERO, Vec3::Y, 0.2, 2.0));
        assert_eq!(cache.lookup(Vec3::new(0.05, 0.0, 0.0), Vec3::Y, 1), Some(Vec3::splat(2.0)));
        assert_eq!(cache.lookup(Vec3::new(0.11, 0.0, 0.0), Vec3::Y, 1), None, "ε = 0.55 > a");
        assert_eq!(cache.lookup(Vec3::new(0.05, 0.0, 0.0), Vec3::X, 1), None, "normals apart");
        assert_eq!(cache.lookup(Vec3::new(0.0, -0.05, 0.0), Vec3::Y, 1), None, "the record is in front");
        assert_eq!(cache.lookup(Vec3::new(0.05, 0.0, 0.0), Vec3::Y, 2), None, "another path budget");
    }
}
