//! Triangle meshes from files: Wavefront OBJ (through `tobj`) and PLY, ASCII or binary
//! (through `ply-rs-bw`). Polygons are triangulated as fans; normals and texture coordinates
//! are kept where the file has them for every vertex.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use ply_rs_bw::ply::{DefaultElement, Property};

use super::procedural::TriangleMesh;

/// Why a mesh file could not be loaded; names the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct MeshFileError {
    /// The file.
    pub path: PathBuf,
    /// What was wrong.
    pub reason: String,
}

fn error(path: &Path, reason: impl Into<String>) -> MeshFileError {
    MeshFileError { path: path.to_path_buf(), reason: reason.into() }
}

/// Loads an `.obj` or `.ply` mesh.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    if !path.is_file() {
        return Err(error(path, "no such file"));
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let mesh = match ext.as_str() {
        "obj" => load_obj(path)?,
        "ply" => load_ply(path)?,
        other => return Err(error(path, format!("unsupported mesh format {other:?} (expected .obj or .ply)"))),
    };
    if mesh.indices.is_empty() {
        return Err(error(path, "the mesh has no faces"));
    }
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err(error(path, "the mesh has non-finite vertex positions"));
    }
    Ok(mesh)
}

fn load_obj(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    let options = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| error(path, format!("malformed OBJ: {e}")))?;
    let mut mesh = TriangleMesh::default();
    for model in models {
        let m = &model.mesh;
        let n = m.positions.len() / 3;
        let part = TriangleMesh {
            positions: m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect(),
            normals: if m.normals.len() == 3 * n {
                m.normals.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect()
            } else {
                Vec::new()
            },
            uvs: if m.texcoords.len() == 2 * n {
                m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])).collect()
            } else {
                Vec::new()
            },
            indices: m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        };
        if part.indices.iter().flatten().any(|&i| i as usize >= n) {
            return Err(error(path, "a face refers to a vertex that does not exist"));
        }
        mesh.append(&part);
    }
    Ok(mesh)
}

fn load_ply(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    let mut file = std::fs::File::open(path).map_err(|e| error(path, e.to_string()))?;
    let parser = ply_rs_bw::parser::Parser::<DefaultElement>::new();
    let ply = parser.read_ply(&mut file).map_err(|e| error(path, format!("malformed PLY: {e}")))?;
    let vertices = ply.payload.get("vertex").ok_or_else(|| error(path, "no vertex element"))?;
    let scalar =
        |v: &DefaultElement, names: &[&str]| names.iter().find_map(|n| v.get(*n).and_then(Property::to_f32_lossy));
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::with_capacity(vertices.len());
    let mut uvs = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let (Some(x), Some(y), Some(z)) = (scalar(v, &["x"]), scalar(v, &["y"]), scalar(v, &["z"])) else {
            return Err(error(path, format!("vertex {i} lacks x, y or z")));
        };
        mesh.positions.push(Vec3::new(x, y, z));
        if let (Some(nx), Some(ny), Some(nz)) = (scalar(v, &["nx"]), scalar(v, &["ny"]), scalar(v, &["nz"])) {
            normals.push(Vec3::new(nx, ny, nz));
        }
        if let (Some(u), Some(t)) =
            (scalar(v, &["u", "s", "texture_u", "texture_s"]), scalar(v, &["v", "t", "texture_v", "texture_t"]))
        {
            uvs.push(Vec2::new(u, t));
        }
    }
    if normals.len() == mesh.positions.len() {
        mesh.normals = normals;
    }
    if uvs.len() == mesh.positions.len() {
        mesh.uvs = uvs;
    }
    let faces = ply.payload.get("face").ok_or_else(|| error(path, "no face element"))?;
    let n = mesh.positions.len();
    for (f, face) in faces.iter().enumerate() {
        let list = face.get("vertex_indices").or_else(|| face.get("vertex_index"));
        let indices: Vec<i64> = match list {
            Some(Property::ListInt(v)) => v.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUInt(v)) => v.iter().map(|&i| i as i64).collect(),
            Some(Property::ListShort(v)) => v.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUShort(v)) => v.iter().map(|&i| i as i64).collect(),
            Some(Property::ListChar(v)) => v.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUChar(v)) => v.iter().map(|&i| i as i64).collect(),
            _ => return Err(error(path, format!("face {f} has no integer vertex_indices list"))),
        };
        if indices.len() < 3 || indices.iter().any(|&i| i < 0 || i as usize >= n) {
            return Err(error(path, format!("face {f} refers to a vertex that does not exist or has fewer than 3")));
        }
        for k in 1..indices.len() - 1 {
            mesh.indices.push([indices[0] as u32, indices[k] as u32, indices[k + 1] as u32]);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_and_ply_cubes_load_with_the_same_area() {
        let dir = tempfile::tempdir().unwrap();
        // A unit cube as quads, with one normal per vertex in the OBJ.
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                   f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        std::fs::write(dir.path().join("cube.obj"), obj).unwrap();
        let ply = "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n\
                   element face 6\nproperty list uchar int vertex_indices\nend_header\n\
                   0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n\
                   4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
        std::fs::write(dir.path().join("cube.ply"), ply).unwrap();
        for name in ["cube.obj", "cube.ply"] {
            let mesh = load_mesh(&dir.path().join(name)).unwrap();
            assert_eq!(mesh.indices.len(), 12, "{name}");
            assert!((mesh.area() - 6.0).abs() < 1e-5, "{name}: {}", mesh.area());
            // Outward winding: every face normal points away from the centre.
            for t in &mesh.indices {
                let p = t.map(|i| mesh.positions[i as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                assert!(n.dot((p[0] + p[1] + p[2]) / 3.0 - Vec3::splat(0.5)) > 0.0, "{name}");
            }
        }
    }

    #[test]
    fn bad_mesh_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let cases = [
            (
                write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n"),
                "lacks x, y or z",
            ),
            (
                write(
                    "range.ply",
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
                ),
                "does not exist",
            ),
            (write("garbage.ply", "not a ply"), "malformed PLY"),
            (write("empty.obj", "# nothing\n"), "no faces"),
            (write("mesh.stl", "solid"), "unsupported mesh format"),
            (dir.path().join("missing.obj"), "no such file"),
        ];
        for (path, needle) in cases {
            let err = load_mesh(&path).unwrap_err().to_string();
            assert!(err.contains(path.file_name().unwrap().to_str().unwrap()) && err.contains(needle), "{err}");
        }
    }
}
