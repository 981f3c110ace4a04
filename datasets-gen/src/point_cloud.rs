//! `points3d.ply`: a sparse coloured point cloud on the visible surfaces, back-projected from
//! the training views' depth buffers, in the layout 3D Gaussian splatting initialises from
//! (binary little-endian PLY with `x y z nx ny nz red green blue`, as COLMAP-converted scenes).

use std::io::Write;
use std::path::Path;

use glam::{Mat4, Vec3};
use lucid_image::read_image;
use lucid_scene::Intrinsics;

use crate::writer::GenError;

/// One point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColouredPoint {
    /// World position.
    pub position: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// sRGB colour, 8 bits per channel.
    pub colour: [u8; 3],
}

/// Back-projects covered pixels of the views `(stem, camera_to_world)` at a stride chosen so
/// that about `target` points result, and writes `root/points3d.ply` atomically.
pub fn write_point_cloud(
    root: &Path,
    k: &Intrinsics,
    views: &[(String, Mat4)],
    target: usize,
) -> Result<usize, GenError> {
    let pixels = k.width as usize * k.height as usize * views.len().max(1);
    // Sample every `stride`-th covered pixel (in a fixed order): deterministic and even.
    let stride = (pixels / target.max(1)).max(1);
    let mut points = back_project(root, k, views, stride, true)?;
    // In views of a few pixels nearly every pixel lies on an edge: take them all rather
    // than write a cloud of no points (which seeds nothing).
    if points.is_empty() {
        points = back_project(root, k, views, 1, false)?;
    }
    if points.is_empty() {
        // Nothing was covered: no file, so a trainer starts from random points.
        return Ok(0);
    }
    write_ply(&root.join("points3d.ply"), &points)?;
    Ok(points.len())
}

/// Every `stride`-th covered pixel of the views, back-projected; with `skip_edges`, not those
/// on a depth edge.
fn back_project(
    root: &Path,
    k: &Intrinsics,
    views: &[(String, Mat4)],
    stride: usize,
    skip_edges: bool,
) -> Result<Vec<ColouredPoint>, GenError> {
    let mut points = Vec::new();
    let mut counter = 0usize;
    for (stem, pose) in views {
        let depth = read_image(root.join(format!("{stem}_depth.exr")))?;
        let normal = read_image(root.join(format!("{stem}_normal.exr")))?;
        let colour = read_image(root.join(format!("{stem}.png")))?;
        for y in 0..k.height as usize {
            for x in 0..k.width as usize {
                let d = depth.get(x, y);
                // Fully covered pixels away from depth edges only: pixels that straddle two
                // surfaces average their depths and would float between them.
                if d[3] < 0.999 || d[0] <= 0.0 || (skip_edges && on_depth_edge(&depth, x, y)) {
                    continue;
                }
                counter += 1;
                if !counter.is_multiple_of(stride) {
                    continue;
                }
                // Camera directions have z = −1, so scaling by the z-depth gives the point.
                let p_camera = k.camera_direction(x as f32 + 0.5, y as f32 + 0.5) * d[0];
                let n = normal.get(x, y);
                let c = colour.get(x, y);
                let encode = |v: f32| (lucid_image::color::srgb_encode(v) * 255.0).round() as u8;
                points.push(ColouredPoint {
                    position: pose.transform_point3(p_camera),
                    normal: Vec3::new(n[0], n[1], n[2]).normalize_or_zero(),
                    colour: [encode(c[0]), encode(c[1]), encode(c[2])],
                });
            }
        }
    }
    Ok(points)
}

/// Whether the pixel sits on a depth discontinuity: a neighbour is background, or the depth
/// bends sharply (second difference above 2% of the depth) along a row or a column, which
/// smooth surfaces do not do at any slope.
fn on_depth_edge(depth: &lucid_image::Image, x: usize, y: usize) -> bool {
    let (w, h) = depth.dimensions();
    if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
        return true;
    }
    let at = |x: usize, y: usize| depth.get(x, y);
    let neighbours = [at(x - 1, y), at(x + 1, y), at(x, y - 1), at(x, y + 1)];
    if neighbours.iter().any(|n| n[3] < 0.999) {
        return true;
    }
    let d = at(x, y)[0];
    let bend_x = (neighbours[0][0] + neighbours[1][0] - 2.0 * d).abs();
    let bend_y = (neighbours[2][0] + neighbours[3][0] - 2.0 * d).abs();
    bend_x.max(bend_y) > 0.02 * d
}

/// Writes points as a binary little-endian PLY. The header is a few fixed lines, so it is
/// written directly rather than through a PLY library's generic element maps.
pub fn write_ply(path: &Path, points: &[ColouredPoint]) -> Result<(), GenError> {
    lucid_image::write_atomically(path, |out| {
        let io = |e| lucid_image::ImageError::Io { path: path.to_path_buf(), source: e };
        write!(
            out,
            "ply\nformat binary_little_endian 1.0\ncomment written by lucid\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
            points.len()
        )
        .map_err(io)?;
        for p in points {
            for v in p.position.to_array().into_iter().chain(p.normal.to_array()) {
                out.write_all(&v.to_le_bytes()).map_err(io)?;
            }
            out.write_all(&p.colour).map_err(io)?;
        }
        Ok(())
    })
    .map_err(GenError::Image)
}
