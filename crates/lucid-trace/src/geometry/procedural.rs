//! Procedural triangle meshes: quads, boxes, tori and torus knots, and transforms of meshes.

use glam::{Mat4, Vec2, Vec3};

/// An indexed triangle mesh with optional normals and texture coordinates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex normals (empty if none).
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates (empty if none).
    pub uvs: Vec<Vec2>,
    /// Triangles as vertex index triples, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The mesh transformed by `m` (normals by its inverse transpose).
    pub fn transformed(&self, m: &Mat4) -> Self {
        let normal_matrix = m.inverse().transpose();
        let flip = m.determinant() < 0.0;
        Self {
            positions: self.positions.iter().map(|&p| m.transform_point3(p)).collect(),
            normals: self.normals.iter().map(|&n| normal_matrix.transform_vector3(n).normalize()).collect(),
            uvs: self.uvs.clone(),
            // A mirroring transform reverses the winding; swap to keep fronts in front.
            indices: self.indices.iter().map(|&[a, b, c]| if flip { [a, c, b] } else { [a, b, c] }).collect(),
        }
    }

    /// Appends another mesh.
    pub fn append(&mut self, other: &TriangleMesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.uvs.extend_from_slice(&other.uvs);
        self.indices.extend(other.indices.iter().map(|t| t.map(|i| i + base)));
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        self.indices
            .iter()
            .map(|&[a, b, c]| {
                let p = |i: u32| self.positions[i as usize];
                0.5 * (p(b) - p(a)).cross(p(c) - p(a)).length()
            })
            .sum()
    }
}

/// The square `[-1,1]²` in the z = 0 plane, facing +Z, with uv in `[0,1]²`.
pub fn quad() -> TriangleMesh {
    TriangleMesh {
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// The cube `[-1,1]³`, faces pointing outward, flat-shaded.
pub fn cube() -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    let q = quad();
    // Rotations taking +Z to each face normal.
    let faces = [
        Mat4::IDENTITY,
        Mat4::from_rotation_x(std::f32::consts::PI),
        Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2),
        Mat4::from_rotation_y(-std::f32::consts::FRAC_PI_2),
        Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2),
    ];
    for r in faces {
        mesh.append(&q.transformed(&(r * Mat4::from_translation(Vec3::Z))));
    }
    mesh
}

/// A torus around the z axis with major radius `major` and tube radius `minor`.
pub fn torus(major: f32, minor: f32, segments: u32, sides: u32) -> TriangleMesh {
    tube(segments, sides, minor, |t| {
        let a = t * std::f32::consts::TAU;
        Vec3::new(major * a.cos(), major * a.sin(), 0.0)
    })
}

/// A (p, q) torus knot of the given radii, swept by a tube.
pub fn torus_knot(p: u32, q: u32, radius: f32, tube_radius: f32, segments: u32, sides: u32) -> TriangleMesh {
    tube(segments, sides, tube_radius, move |t| {
        let a = t * std::f32::consts::TAU;
        let r = radius * (2.0 + (q as f32 * a).cos()) / 3.0;
        Vec3::new(r * (p as f32 * a).cos(), r * (p as f32 * a).sin(), -radius * (q as f32 * a).sin() / 3.0)
    })
}

/// A closed tube of radius `r` around the closed curve `c(t)`, `t ∈ [0,1)`, with smooth normals.
fn tube(segments: u32, sides: u32, r: f32, c: impl Fn(f32) -> Vec3) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    for i in 0..segments {
        let t = i as f32 / segments as f32;
        let centre = c(t);
        let tangent = (c(t + 1e-3) - c(t - 1e-3)).normalize();
        // A normal that does not flip: project a fixed axis, falling back near tangency.
        let reference = if tangent.z.abs() < 0.9 { Vec3::Z } else { Vec3::X };
        let normal = (reference - tangent * tangent.dot(reference)).normalize();
        let binormal = tangent.cross(normal);
        for j in 0..sides {
            let a = j as f32 / sides as f32 * std::f32::consts::TAU;
            let n = a.cos() * normal + a.sin() * binormal;
            mesh.positions.push(centre + r * n);
            mesh.normals.push(n);
            mesh.uvs.push(Vec2::new(t, j as f32 / sides as f32));
        }
    }
    for i in 0..segments {
        for j in 0..sides {
            let i1 = (i + 1) % segments;
            let j1 = (j + 1) % sides;
            let v = |a: u32, b: u32| a * sides + b;
            mesh.indices.push([v(i, j), v(i1, j), v(i1, j1)]);
            mesh.indices.push([v(i, j), v(i1, j1), v(i, j1)]);
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn areas_match_closed_forms() {
        assert!((quad().area() - 4.0).abs() < 1e-5);
        assert!((cube().area() - 24.0).abs() < 1e-4);
        // Torus area 4π²Rr, approached from below by the polygonal mesh.
        let t = torus(1.0, 0.25, 128, 64);
        let exact = 4.0 * std::f32::consts::PI.powi(2) * 0.25;
        assert!((t.area() - exact).abs() / exact < 2e-3, "{} vs {exact}", t.area());
    }

    #[test]
    fn cube_faces_point_outward_and_mirroring_keeps_them_so() {
        let check = |mesh: &TriangleMesh| {
            for &[a, b, c] in &mesh.indices {
                let p = |i: u32| mesh.positions[i as usize];
                let n = (p(b) - p(a)).cross(p(c) - p(a));
                let centre = (p(a) + p(b) + p(c)) / 3.0;
                assert!(n.dot(centre) > 0.0);
            }
        };
        check(&cube());
        check(&cube().transformed(&Mat4::from_scale(Vec3::new(-1.0, 2.0, 1.0))));
    }

    #[test]
    fn torus_normals_point_away_from_the_core_circle() {
        // Stepping back along the normal by the tube radius lands on the core circle.
        let t = torus(1.5, 0.2, 32, 12);
        for (p, n) in t.positions.iter().zip(&t.normals) {
            let core = *p - 0.2 * *n;
            assert!(core.z.abs() < 1e-5 && (core.truncate().length() - 1.5).abs() < 1e-5, "{p} {n}");
        }
        let knot = torus_knot(2, 3, 1.0, 0.1, 64, 8);
        assert_eq!(knot.indices.len(), 64 * 8 * 2);
        assert!(knot.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
    }
}
