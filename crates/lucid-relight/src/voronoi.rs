//! Solid angles of spherical Voronoi cells: how much of the sphere of directions each light
//! of a free-form light stage stands for.
//!
//! The spherical Delaunay triangulation of the lights is computed with `spade`'s planar one,
//! through a stereographic projection: it maps circles on the sphere to circles in the plane,
//! so a triangle whose circumcircle holds no other light on the sphere holds none in the plane
//! either, and the planar Delaunay triangles are the spherical ones. The exception is a circle
//! through the projection pole, which becomes a line; so each hemisphere's cells are taken from
//! the projection from the *opposite* pole (where the projection is least distorted and the
//! lights of the hemisphere lie inside the unit disc, far from the pole's image at infinity).
//! Each cell is then the spherical polygon of the circumcentres of the triangles around its
//! light, in the triangulation's order, and its solid angle the sum of the spherical
//! triangles (light, vᵢ, vᵢ₊₁) (Van Oosterom and Strackee's formula). A light whose fan is
//! not closed (lights only on one side of the sphere, so that a cell reaches the projection
//! pole) falls back to integrating its cell on a fine grid of directions.

use glam::DVec3;
use spade::{DelaunayTriangulation, Point2, Triangulation};

use crate::RelightError;

/// Solid angle of the spherical triangle `(a, b, c)` of unit vectors.
fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// The solid angle (steradians) of each direction's Voronoi cell on the unit sphere; they
/// sum to 4π. Directions must be distinct (after normalising).
pub fn voronoi_solid_angles(directions: &[glam::Vec3]) -> Result<Vec<f64>, RelightError> {
    let dirs: Vec<DVec3> = directions.iter().map(|d| d.as_dvec3().normalize()).collect();
    if dirs.iter().any(|d| !d.is_finite()) {
        return Err(RelightError::Invalid("a light direction is zero or not finite".into()));
    }
    if dirs.len() < 4 {
        // Too few lights for a triangulation: integrate.
        return Ok(grid_solid_angles(&dirs, &(0..dirs.len()).collect::<Vec<_>>(), None));
    }
    let mut angles = vec![f64::NAN; dirs.len()];
    for north in [true, false] {
        // Project from the opposite pole; mirror y for the south so both keep orientation.
        let project = |d: DVec3| {
            if north {
                Point2::new(d.x / (1.0 + d.z), d.y / (1.0 + d.z))
            } else {
                Point2::new(d.x / (1.0 - d.z), -d.y / (1.0 - d.z))
            }
        };
        let mut t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
        // Lights at the projection pole itself go to infinity: leave them out of this pass
        // (they belong to the other hemisphere anyway).
        let mut index_of = std::collections::HashMap::new();
        for (k, &d) in dirs.iter().enumerate() {
            if (north && d.z <= -1.0 + 1e-9) || (!north && d.z >= 1.0 - 1e-9) {
                continue;
            }
            let handle = t
                .insert(project(d))
                .map_err(|e| RelightError::Invalid(format!("light {k} cannot be triangulated: {e:?}")))?;
            if index_of.insert(handle.index(), k).is_some() {
                return Err(RelightError::Invalid(format!("light {k} repeats another light's direction")));
            }
        }
        for v in t.vertices() {
            let k = index_of[&v.fix().index()];
            if (dirs[k].z >= 0.0) != north {
                continue;
            }
            let mut corners = Vec::new();
            let mut closed = true;
            for edge in v.out_edges() {
                match edge.face().as_inner() {
                    Some(face) => {
                        let [a, b, c] = face.vertices().map(|h| dirs[index_of[&h.fix().index()]]);
                        let mut centre = (b - a).cross(c - a).normalize();
                        if centre.dot(a) < 0.0 {
                            centre = -centre;
                        }
                        corners.push(centre);
                    }
                    None => closed = false,
                }
            }
            if !closed || corners.len() < 3 {
                continue;
            }
            let site = dirs[k];
            angles[k] = (0..corners.len())
                .map(|i| triangle_solid_angle(site, corners[i], corners[(i + 1) % corners.len()]))
                .sum();
        }
    }
    let open: Vec<usize> = (0..dirs.len()).filter(|&k| angles[k].is_nan()).collect();
    if !open.is_empty() {
        let known: f64 = angles.iter().filter(|a| !a.is_nan()).sum();
        for (k, a) in open.iter().zip(grid_solid_angles(&dirs, &open, Some(4.0 * std::f64::consts::PI - known))) {
            angles[*k] = a;
        }
    }
    Ok(angles)
}

/// Cells of the lights `which` by integration over a lat-long grid of directions (each
/// direction to its nearest light); with `total`, rescaled to sum to it.
fn grid_solid_angles(dirs: &[DVec3], which: &[usize], total: Option<f64>) -> Vec<f64> {
    let (w, h) = (1024usize, 512usize);
    let mut acc = vec![0.0f64; dirs.len()];
    for y in 0..h {
        let (t0, t1) = (y as f64 / h as f64 * std::f64::consts::PI, (y + 1) as f64 / h as f64 * std::f64::consts::PI);
        let omega = std::f64::consts::TAU / w as f64 * (t0.cos() - t1.cos());
        let theta = 0.5 * (t0 + t1);
        for x in 0..w {
            let phi = (x as f64 + 0.5) / w as f64 * std::f64::consts::TAU;
            let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let nearest = (0..dirs.len()).max_by(|&a, &b| d.dot(dirs[a]).total_cmp(&d.dot(dirs[b]))).expect("lights");
            acc[nearest] += omega;
        }
    }
    let mut out: Vec<f64> = which.iter().map(|&k| acc[k]).collect();
    if let Some(total) = total {
        let sum: f64 = out.iter().sum();
        if sum > 0.0 {
            out.iter_mut().for_each(|a| *a *= total / sum);
        }
    }
    out
}

/// `n` directions spread almost evenly over the sphere (a Fibonacci lattice): a light
/// stage layout for tests and examples.
pub fn fibonacci_directions(n: usize) -> Vec<glam::Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            glam::Vec3::new(r * (golden * i as f32).cos(), r * (golden * i as f32).sin(), z)
        })
        .collect()
}

/// The light nearest to `d` (the Voronoi cell `d` falls in).
pub fn nearest(directions: &[glam::Vec3], d: glam::Vec3) -> usize {
    (0..directions.len()).max_by(|&a, &b| d.dot(directions[a]).total_cmp(&d.dot(directions[b]))).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::f64::consts::PI;

    #[test]
    fn symmetric_layouts_get_equal_cells() {
        let octahedron = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let cube: Vec<Vec3> = (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { 1.0 } else { -1.0 },
                    if k & 2 == 0 { 1.0 } else { -1.0 },
                    if k & 4 == 0 { 1.0 } else { -1.0 },
                )
            })
            .collect();
        for layout in [octahedron, cube] {
            let a = voronoi_solid_angles(&layout).unwrap();
            let each = 4.0 * PI / layout.len() as f64;
            for v in &a {
                assert!((v - each).abs() < 1e-9, "{a:?}");
            }
        }
    }

    #[test]
    fn irregular_layouts_sum_to_the_sphere_and_match_integration() {
        for n in [20, 32, 101] {
            let mut dirs = fibonacci_directions(n);
            // Perturb so the layout is irregular.
            for (k, d) in dirs.iter_mut().enumerate() {
                *d = (*d + 0.15 * Vec3::new((k as f32 * 1.7).sin(), (k as f32 * 2.3).cos(), (k as f32 * 0.9).sin()))
                    .normalize();
            }
            let a = voronoi_solid_angles(&dirs).unwrap();
            let total: f64 = a.iter().sum();
            assert!((total - 4.0 * PI).abs() < 1e-9, "{n}: {total}");
            let dd: Vec<DVec3> = dirs.iter().map(|d| d.as_dvec3()).collect();
            let grid = grid_solid_angles(&dd, &(0..n).collect::<Vec<_>>(), None);
            for (x, g) in a.iter().zip(&grid) {
                assert!((x - g).abs() < 2e-3, "{n}: exact {x} vs integrated {g}");
            }
        }
    }

    /// A dome leaves its lowest ring's cells open (they reach round the lower hemisphere),
    /// and those are filled in to the remainder of 4π, so the sum alone proves nothing: every
    /// cell, exact or filled in, must match a brute-force integration that assigns each of
    /// half a million directions to its nearest light.
    #[test]
    fn a_dome_of_lights_gets_the_cells_that_integration_gives() {
        let dome: Vec<Vec3> = fibonacci_directions(40).into_iter().filter(|d| d.z > 0.05).collect();
        let a = voronoi_solid_angles(&dome).unwrap();
        let dd: Vec<DVec3> = dome.iter().map(|d| d.as_dvec3().normalize()).collect();
        let grid = grid_solid_angles(&dd, &(0..dome.len()).collect::<Vec<_>>(), None);
        for (k, (x, g)) in a.iter().zip(&grid).enumerate() {
            assert!((x - g).abs() < 2e-3 * g.max(1.0), "light {k} at z = {}: {x} vs integrated {g}", dome[k].z);
        }
        // The lower hemisphere (2π) belongs to the lowest ring: its cells are the big ones.
        let low: f64 = a.iter().zip(&dome).filter(|(_, d)| d.z < 0.3).map(|(x, _)| x).sum();
        assert!(low > 2.0 * PI, "the lowest lights hold the lower hemisphere: {low}");
    }
}
