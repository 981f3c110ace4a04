//! Coloured point clouds in `.ply` files: COLMAP's and nerfstudio's sparse points
//! (`sparse_pc.ply`) and the generator's `points3d.ply`, read through `ply-rs-bw` (ASCII and
//! both binary encodings, `float` or `double` positions, 8-bit or float colours).

use std::path::{Path, PathBuf};

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::Property;

/// A point cloud that could not be read.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct PointCloudError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
}

fn err(path: &Path, message: impl Into<String>) -> PointCloudError {
    PointCloudError { path: path.to_path_buf(), message: message.into() }
}

/// Reads a coloured point cloud (`x y z` and optionally `red green blue` as 8-bit or float,
/// COLMAP's and our generator's `points3d.ply`): positions and colours in `[0,1]` (grey where
/// the file has none).
pub fn read_point_cloud(path: &Path) -> Result<Vec<(glam::Vec3, [f32; 3])>, PointCloudError> {
    use ply_rs_bw::ply::DefaultElement;
    let file = std::fs::File::open(path).map_err(|e| err(path, e.to_string()))?;
    let mut reader = std::io::BufReader::new(file);
    let ply =
        Parser::<DefaultElement>::new().read_ply(&mut reader).map_err(|e| err(path, format!("malformed PLY: {e}")))?;
    let vertices = ply.payload.get("vertex").ok_or_else(|| err(path, "no vertex element"))?;
    let mut out = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let get = |names: &[&str]| names.iter().find_map(|n| v.get(*n));
        let scalar = |names: &[&str]| get(names).and_then(Property::to_f32_lossy);
        let (Some(x), Some(y), Some(z)) = (scalar(&["x"]), scalar(&["y"]), scalar(&["z"])) else {
            return Err(err(path, format!("vertex {i} lacks x, y or z")));
        };
        let channel = |names: &[&str]| match get(names) {
            Some(Property::UChar(c)) => Some(*c as f32 / 255.0),
            Some(p) => p.to_f32_lossy().map(|c| if c > 1.0 { c / 255.0 } else { c }),
            None => None,
        };
        let colour = match (channel(&["red", "r"]), channel(&["green", "g"]), channel(&["blue", "b"])) {
            (Some(r), Some(g), Some(b)) => [r, g, b],
            _ => [0.5; 3],
        };
        if ![x, y, z].iter().all(|v| v.is_finite()) {
            return Err(err(path, format!("vertex {i} has a non-finite position")));
        }
        out.push((glam::Vec3::new(x, y, z), colour));
    }
    if out.is_empty() {
        return Err(err(path, "no points"));
    }
    Ok(out)
}
