//! A uniform grid over the visible points of one pass, hashed into as many buckets as there
//! are points, each point listed in every cell its search sphere overlaps (pbrt's SPPM grid,
//! stored as one sorted array instead of linked lists): a photon looks in the one cell that
//! holds it. Written here because the query is tied to SPPM's per-point radii, which a k-d
//! tree crate's fixed-radius query would have to check again.

use glam::{IVec3, Vec3};

/// Cells hashed into buckets; `entries[starts[b]..starts[b + 1]]` are bucket `b`'s points.
pub(crate) struct PointGrid {
    origin: Vec3,
    inverse_cell: f32,
    starts: Vec<u32>,
    entries: Vec<u32>,
}

impl PointGrid {
    /// The grid over points (`centre`, `radius`): cells as wide as the largest radius.
    pub(crate) fn new(points: &[(Vec3, f32)]) -> Self {
        let buckets = points.len().max(1);
        let max_radius = points.iter().map(|p| p.1).fold(0.0f32, f32::max);
        let origin = points.iter().fold(Vec3::splat(f32::INFINITY), |m, p| m.min(p.0 - Vec3::splat(p.1)));
        let inverse_cell = if max_radius > 0.0 { 1.0 / max_radius } else { 1.0 };
        let mut grid = Self { origin, inverse_cell, starts: vec![0; buckets + 1], entries: Vec::new() };
        // Counting sort by bucket: count, prefix-sum, fill.
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(points.len() * 8);
        for (k, &(centre, radius)) in points.iter().enumerate() {
            let lo = grid.cell(centre - Vec3::splat(radius));
            let hi = grid.cell(centre + Vec3::splat(radius));
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        pairs.push((grid.bucket(IVec3::new(x, y, z)), k as u32));
                    }
                }
            }
        }
        for &(b, _) in &pairs {
            grid.starts[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut next = grid.starts.clone();
        grid.entries = vec![0; pairs.len()];
        for (b, k) in pairs {
            grid.entries[next[b as usize] as usize] = k;
            next[b as usize] += 1;
        }
        grid
    }

    fn cell(&self, p: Vec3) -> IVec3 {
        ((p - self.origin) * self.inverse_cell).floor().as_ivec3()
    }

    fn bucket(&self, c: IVec3) -> u32 {
        // Teschner et al.'s spatial hash.
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        h % (self.starts.len() as u32 - 1)
    }

    /// The points whose cells include `p` (a superset of those within their radius of it).
    pub(crate) fn candidates(&self, p: Vec3) -> &[u32] {
        let b = self.bucket(self.cell(p)) as usize;
        &self.entries[self.starts[b] as usize..self.starts[b + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn every_point_within_its_radius_is_a_candidate() {
        let mut rng = Rng::new(4, 4);
        let points: Vec<(Vec3, f32)> = (0..500)
            .map(|_| (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0, 0.05 + 0.2 * rng.uniform()))
            .collect();
        let grid = PointGrid::new(&points);
        for _ in 0..5000 {
            let q = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0;
            let found = grid.candidates(q);
            for (k, &(c, r)) in points.iter().enumerate() {
                if (c - q).length() <= r {
                    assert!(found.contains(&(k as u32)), "point {k} at {c} (radius {r}) missed from {q}");
                }
            }
        }
    }
}
