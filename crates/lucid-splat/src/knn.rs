//! Distances to nearest neighbours for the initial splat sizes.
//!
//! Hand-written because it is one query shape on a few hundred thousand points at most, once
//! per training run: a uniform grid (counting sort into cells) searched in growing shells, in
//! parallel over points, is short and needs no further dependency.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// For each point, the root mean square of its distances to its `k` nearest other points
/// (the 3DGS initial scale); a single point gets 1% of nothing, i.e. a tiny default.
pub fn mean_neighbour_distance(points: &[Vec3], k: usize) -> Vec<f32> {
    let n = points.len();
    if n < 2 {
        return vec![1e-2; n];
    }
    let (lo, hi) =
        points.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
    let extent = (hi - lo).max(Vec3::splat(1e-6));
    let cell = (extent.x * extent.y * extent.z / n as f32).cbrt().max(extent.max_element() / 256.0);
    let dims = ((extent / cell).ceil().as_ivec3()).max(IVec3::ONE);
    let cell_of = |p: Vec3| ((p - lo) / cell).floor().as_ivec3().clamp(IVec3::ZERO, dims - 1);
    let index = |c: IVec3| (c.z as usize * dims.y as usize + c.y as usize) * dims.x as usize + c.x as usize;
    let cells = dims.x as usize * dims.y as usize * dims.z as usize;
    let mut offsets = vec![0usize; cells + 1];
    for p in points {
        offsets[index(cell_of(*p)) + 1] += 1;
    }
    for i in 1..offsets.len() {
        offsets[i] += offsets[i - 1];
    }
    let mut cursor = offsets.clone();
    let mut sorted = vec![0u32; n];
    for (i, p) in points.iter().enumerate() {
        let c = index(cell_of(*p));
        sorted[cursor[c]] = i as u32;
        cursor[c] += 1;
    }
    let k = k.min(n - 1);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let p = points[i];
            let home = cell_of(p);
            let mut best: Vec<f32> = Vec::with_capacity(k + 1);
            let max_ring = dims.max_element();
            for ring in 0..=max_ring {
                let r = IVec3::splat(ring);
                let (a, b) = ((home - r).max(IVec3::ZERO), (home + r).min(dims - 1));
                for z in a.z..=b.z {
                    for y in a.y..=b.y {
                        for x in a.x..=b.x {
                            let c = IVec3::new(x, y, z);
                            if (c - home).abs().max_element() != ring {
                                continue;
                            }
                            let ci = index(c);
                            for &j in &sorted[offsets[ci]..offsets[ci + 1]] {
                                if j as usize == i {
                                    continue;
                                }
                                let d2 = p.distance_squared(points[j as usize]);
                                if best.len() < k || d2 < best[k - 1] {
                                    let at = best.partition_point(|&v| v <= d2);
                                    best.insert(at, d2);
                                    best.truncate(k);
                                }
                            }
                        }
                    }
                }
                // Everything within `ring` cells of the point's own cell has been seen.
                let covered = ring as f32 * cell;
                if best.len() == k && best[k - 1] <= covered * covered {
                    break;
                }
            }
            (best.iter().sum::<f32>() / best.len().max(1) as f32).sqrt().max(1e-7)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a regular lattice every interior point's three nearest neighbours are at the
    /// spacing; a brute-force search agrees on random points.
    #[test]
    fn lattice_and_brute_force() {
        let mut pts = Vec::new();
        for z in 0..6 {
            for y in 0..6 {
                for x in 0..6 {
                    pts.push(Vec3::new(x as f32, y as f32, z as f32) * 0.25);
                }
            }
        }
        let d = mean_neighbour_distance(&pts, 3);
        assert!((d[6 * 6 * 2 + 6 * 2 + 2] - 0.25).abs() < 1e-6);

        let mut rng = lucid_scene::sampling::Rng::new(3, 4);
        let pts: Vec<Vec3> = (0..500).map(|_| Vec3::new(rng.uniform(), rng.uniform() * 0.1, rng.uniform())).collect();
        let d = mean_neighbour_distance(&pts, 3);
        for (i, p) in pts.iter().enumerate() {
            let mut all: Vec<f32> =
                pts.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, q)| p.distance_squared(*q)).collect();
            all.sort_by(f32::total_cmp);
            let want = ((all[0] + all[1] + all[2]) / 3.0).sqrt();
            assert!((d[i] - want).abs() < 1e-6, "point {i}: {} vs {want}", d[i]);
        }
    }
}
