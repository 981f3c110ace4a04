//! Distances to nearest neighbours for the initial splat sizes, by a k-d tree (kiddo): its
//! cost grows as n log n whatever the points' spread, where a uniform grid turns quadratic
//! once a few points lie far from the rest (an SfM outlier, a capture's background shell) and
//! squeeze the others into a handful of cells.

use std::num::NonZero;

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

/// For each point, the root mean square of its distances to its `k` nearest other points
/// (the 3DGS initial scale); a single point gets 1% of nothing, i.e. a tiny default.
pub fn mean_neighbour_distance(points: &[Vec3], k: usize) -> Vec<f32> {
    let n = points.len();
    if n < 2 || k == 0 {
        return vec![1e-2; n];
    }
    let k = k.min(n - 1);
    let coordinates: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
    let Ok(tree) = ImmutableKdTree::<f32, 3>::new_from_slice(&coordinates) else {
        // Only a tree of more than u32::MAX points fails to build.
        return vec![1e-2; n];
    };
    let wanted = NonZero::new(k + 1).expect("k + 1 > 0");
    coordinates
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let found = tree.query(p).nearest_n::<SquaredEuclidean<f32>>(wanted).execute();
            // The point finds itself (or a copy of itself, equally at 0): leave out one match
            // at its own index if present, else the last.
            let own = found.iter().position(|f| f.item as usize == i).unwrap_or(found.len().saturating_sub(1));
            let sum: f32 = found.iter().enumerate().filter(|(j, _)| *j != own).map(|(_, f)| f.distance).sum();
            (sum / k as f32).sqrt().max(1e-7)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force, for the tests.
    fn brute(pts: &[Vec3], k: usize) -> Vec<f32> {
        (0..pts.len())
            .map(|i| {
                let mut all: Vec<f32> =
                    pts.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, q)| pts[i].distance_squared(*q)).collect();
                all.sort_by(f32::total_cmp);
                (all[..k].iter().sum::<f32>() / k as f32).sqrt()
            })
            .collect()
    }

    /// Points far from the rest (an outlier, a shell around the scene) get and give their
    /// true neighbours, as brute force finds them.
    #[test]
    fn far_points_are_neighbours_as_brute_force_finds_them() {
        let mut rng = lucid_scene::sampling::Rng::new(5, 6);
        let mut pts: Vec<Vec3> = (0..2000).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())).collect();
        pts.push(Vec3::new(1e6, -3e5, 2e4));
        pts.push(Vec3::new(1e6 + 1.0, -3e5, 2e4));
        pts.extend((0..100).map(|k| {
            let a = k as f32 * 0.7;
            Vec3::new(a.cos(), a.sin(), 0.1 * k as f32) * 500.0
        }));
        let d = mean_neighbour_distance(&pts, 3);
        for (i, (got, want)) in d.iter().zip(brute(&pts, 3)).enumerate() {
            assert!((got - want).abs() <= 1e-5 * want.max(1.0), "point {i}: {got} vs {want}");
        }
    }

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
