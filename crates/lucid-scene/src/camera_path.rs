//! Camera paths in nerfstudio's `camera_path.json` format, the one its viewer exports and
//! `ns-render` reads:
//!
//! ```json
//! { "camera_type": "perspective", "render_width": 640, "render_height": 480, "fps": 30,
//!   "seconds": 2, "camera_path": [ { "camera_to_world": [16 numbers, row-major],
//!   "fov": 50.0, "aspect": 1.333 } ] }
//! ```
//!
//! Poses are OpenGL camera-to-world matrices (as in `transforms.json`); `fov` is the vertical
//! field of view in degrees, with square pixels and the principal point at the centre. A
//! camera may also carry a thin lens in Lucid's keys of `transforms.json`, `aperture_radius`
//! and `focus_distance` (in the path's units), for refocus pulls; other tools ignore them.
//! Lucid writes the path of every novel-view render beside its frames, so a render can be
//! reproduced or continued in another tool.

use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4};
use serde_json::{Value, json};

use crate::{Intrinsics, PinholeCamera};

/// A file that is not a camera path Lucid can render.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct CameraPathError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub reason: String,
}

/// Cameras to render, in order, and the frame rate they are meant to play at.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// The cameras, in the path's own coordinates.
    pub cameras: Vec<PinholeCamera>,
    /// Each camera's thin lens, `(aperture radius, focus distance)` in the path's units, or
    /// `None` for a pinhole.
    pub lenses: Vec<Option<(f32, f32)>>,
    /// Frames per second.
    pub fps: f64,
}

impl CameraPath {
    /// Pinhole cameras at `fps`.
    pub fn pinholes(cameras: Vec<PinholeCamera>, fps: f64) -> Self {
        let lenses = vec![None; cameras.len()];
        Self { cameras, lenses, fps }
    }
}

/// Reads a `camera_path.json`.
pub fn read_camera_path(path: &Path) -> Result<CameraPath, CameraPathError> {
    let fail = |reason: String| CameraPathError { path: path.to_path_buf(), reason };
    let text = crate::text_file::read_text(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    let root: Value = serde_json::from_str(&text).map_err(|e| fail(format!("malformed JSON: {e}")))?;
    let size = |key: &str| -> Result<u32, CameraPathError> {
        root.get(key)
            .and_then(Value::as_u64)
            .filter(|&v| (1..=16384).contains(&v))
            .map(|v| v as u32)
            .ok_or_else(|| fail(format!("'{key}' must be an image size of 1..=16384 pixels")))
    };
    let (width, height) = (size("render_width")?, size("render_height")?);
    if let Some(kind) = root.get("camera_type") {
        match kind.as_str() {
            Some(k) if k.eq_ignore_ascii_case("perspective") => {}
            _ => return Err(fail(format!("camera_type {kind} is not rendered here (only \"perspective\")"))),
        }
    }
    let fps = match root.get("fps") {
        None => 30.0,
        Some(v) => {
            v.as_f64().filter(|f| f.is_finite() && *f > 0.0).ok_or_else(|| fail(format!("fps {v} must be positive")))?
        }
    };
    let Some(frames) = root.get("camera_path").and_then(Value::as_array) else {
        return Err(fail("no 'camera_path' list of cameras".into()));
    };
    if frames.is_empty() {
        return Err(fail("'camera_path' holds no camera".into()));
    }
    let mut cameras = Vec::with_capacity(frames.len());
    let mut lenses = Vec::with_capacity(frames.len());
    for (i, frame) in frames.iter().enumerate() {
        let at = |reason: String| fail(format!("camera {i}: {reason}"));
        cameras.push(camera(frame, width, height).map_err(at)?);
        lenses.push(lens(frame).map_err(at)?);
    }
    Ok(CameraPath { cameras, lenses, fps })
}

/// A camera's thin lens: `aperture_radius` (0 or absent: a pinhole) and `focus_distance`.
fn lens(frame: &Value) -> Result<Option<(f32, f32)>, String> {
    let number = |key: &str| -> Result<Option<f64>, String> {
        frame
            .get(key)
            .map(|v| {
                v.as_f64().filter(|f| f.is_finite() && *f >= 0.0).ok_or(format!("'{key}' {v} must be a length ≥ 0"))
            })
            .transpose()
    };
    match (number("aperture_radius")?, number("focus_distance")?) {
        (None | Some(0.0), _) => Ok(None),
        (Some(a), Some(f)) if f > 0.0 => Ok(Some((a as f32, f as f32))),
        (Some(_), _) => Err("'aperture_radius' is open but 'focus_distance' is missing or zero".into()),
    }
}

/// The widest vertical field of view a pinhole camera is built with, in degrees.
pub const MAX_FOV_DEGREES: f32 = 179.0;

fn camera(frame: &Value, width: u32, height: u32) -> Result<PinholeCamera, String> {
    let numbers: Vec<f32> = frame
        .get("camera_to_world")
        .and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_f64).map(|v| v as f32).collect())
        .unwrap_or_default();
    let fov = frame.get("fov").and_then(Value::as_f64).unwrap_or(f64::NAN);
    camera_from_pose(&numbers, fov, width, height)
}

/// A pinhole from a camera path's numbers: `camera_to_world` as 16 row-major numbers (an
/// OpenGL pose) and `fov_y`, the vertical field of view in degrees; square pixels, centred
/// principal point. The viewer's requests name cameras the same way.
pub fn camera_from_pose(camera_to_world: &[f32], fov_y: f64, width: u32, height: u32) -> Result<PinholeCamera, String> {
    if camera_to_world.len() != 16 || camera_to_world.iter().any(|v| !v.is_finite()) {
        return Err("'camera_to_world' must be 16 finite numbers (a row-major 4×4 matrix)".into());
    }
    let pose = Mat4::from_cols_slice(camera_to_world).transpose();
    if !pose.row(3).abs_diff_eq(glam::Vec4::W, 1e-6) {
        return Err(format!("the last row of 'camera_to_world' is {}, not [0, 0, 0, 1]", pose.row(3)));
    }
    let r = Mat3::from_mat4(pose);
    if !(r.transpose() * r).abs_diff_eq(Mat3::IDENTITY, 1e-3) || r.determinant() < 0.0 {
        return Err("'camera_to_world' is not a rigid pose (its rotation is not orthonormal)".into());
    }
    // A pinhole's focal length tends to 0 as the angle nears 180°; past 179° (in f32, the
    // precision the camera keeps) it is too short to render by.
    if !(fov_y.is_finite() && fov_y > 0.0 && fov_y as f32 > 0.0 && fov_y as f32 <= MAX_FOV_DEGREES) {
        return Err(format!("'fov' = {fov_y} must be a vertical field of view in degrees, in (0, {MAX_FOV_DEGREES}]"));
    }
    let f = 0.5 * height as f32 / (0.5 * (fov_y as f32).to_radians()).tan();
    if !(f.is_finite() && f > 0.0) {
        return Err(format!("'fov' = {fov_y} gives no usable focal length at a height of {height} pixels"));
    }
    let k = Intrinsics::pinhole(width, height, f, f, 0.5 * width as f32, 0.5 * height as f32);
    Ok(PinholeCamera::new(k, pose))
}

/// Writes a path (cameras of one image size) as a `camera_path.json`, atomically.
pub fn write_camera_path(path: &Path, camera_path: &CameraPath) -> Result<(), CameraPathError> {
    let fail = |reason: String| CameraPathError { path: path.to_path_buf(), reason };
    let CameraPath { cameras, lenses, fps } = camera_path;
    let fps = *fps;
    let Some(first) = cameras.first() else { return Err(fail("no camera to write".into())) };
    let (width, height) = (first.intrinsics.width, first.intrinsics.height);
    let frames: Vec<Value> = cameras
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut frame = json!({
                "camera_to_world": c.camera_to_world.transpose().to_cols_array(),
                "fov": c.intrinsics.fov_y().to_degrees(),
                "aspect": c.intrinsics.width as f32 / c.intrinsics.height as f32,
            });
            if let Some(Some((aperture, focus))) = lenses.get(i) {
                frame["aperture_radius"] = json!(aperture);
                frame["focus_distance"] = json!(focus);
            }
            frame
        })
        .collect();
    let root = json!({
        "camera_type": "perspective",
        "render_width": width,
        "render_height": height,
        "fps": fps,
        "seconds": cameras.len() as f64 / fps,
        "camera_path": frames,
    });
    let text = serde_json::to_string_pretty(&root).expect("the path serialises");
    lucid_image::output::write_text(path, &text).map_err(|e| fail(format!("cannot write: {e}")))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::look_at;

    fn path() -> Vec<PinholeCamera> {
        let k = Intrinsics::from_fov_x(80, 60, 0.8);
        (0..5)
            .map(|i| {
                let eye = Vec3::new((i as f32).cos() * 3.0, (i as f32).sin() * 3.0, 1.0 + 0.1 * i as f32);
                PinholeCamera::new(k, look_at(eye, Vec3::ZERO, Vec3::Z))
            })
            .collect()
    }

    #[test]
    fn written_paths_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("camera_path.json");
        let cameras = path();
        let mut written = CameraPath::pinholes(cameras.clone(), 24.0);
        written.lenses[2] = Some((0.05, 3.5));
        write_camera_path(&file, &written).unwrap();
        let read = read_camera_path(&file).unwrap();
        assert_eq!(read.fps, 24.0);
        assert_eq!(read.lenses, written.lenses);
        assert_eq!(read.cameras.len(), cameras.len());
        for (a, b) in cameras.iter().zip(&read.cameras) {
            assert!(a.camera_to_world.abs_diff_eq(b.camera_to_world, 1e-6));
            let (ka, kb) = (a.intrinsics, b.intrinsics);
            assert_eq!((ka.width, ka.height), (kb.width, kb.height));
            assert!((ka.fx - kb.fx).abs() < 1e-3 && (ka.fy - kb.fy).abs() < 1e-3, "{ka:?} vs {kb:?}");
            assert_eq!((ka.cx, ka.cy), (kb.cx, kb.cy));
        }
    }

    /// A camera path as nerfstudio's viewer writes it: the vertical field of view sets the
    /// focal length of both axes.
    #[test]
    fn nerfstudio_paths_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("path.json");
        let text = r#"{"keyframes": [], "camera_type": "perspective", "render_height": 480, "render_width": 640,
            "camera_path": [{"camera_to_world": [1,0,0,0.5, 0,1,0,-2, 0,0,1,3, 0,0,0,1], "fov": 90, "aspect": 1.3333}],
            "fps": 24, "seconds": 4, "smoothness_value": 0.5, "is_cycle": false, "crop": null}"#;
        std::fs::write(&file, text).unwrap();
        let read = read_camera_path(&file).unwrap();
        let c = read.cameras[0];
        assert!((c.intrinsics.fy - 240.0).abs() < 1e-3 && (c.intrinsics.fx - 240.0).abs() < 1e-3);
        assert_eq!(c.position(), Vec3::new(0.5, -2.0, 3.0));
    }

    #[test]
    fn bad_paths_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.json");
        let pose = "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";
        let cases = [
            ("{", "malformed JSON"),
            (r#"{"render_width": 10, "camera_path": []}"#, "render_height"),
            (r#"{"render_width": 10, "render_height": 10, "camera_path": []}"#, "no camera"),
            (
                &format!(
                    r#"{{"render_width": 10, "render_height": 10, "camera_type": "fisheye", "camera_path": [{{"camera_to_world": {pose}, "fov": 50}}]}}"#
                ),
                "fisheye",
            ),
            (
                r#"{"render_width": 10, "render_height": 10, "camera_path": [{"camera_to_world": [1,2,3], "fov": 50}]}"#,
                "16 finite",
            ),
            (
                r#"{"render_width": 10, "render_height": 10, "camera_path": [{"camera_to_world": [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "fov": 50}]}"#,
                "rigid",
            ),
            (
                &format!(
                    r#"{{"render_width": 10, "render_height": 10, "camera_path": [{{"camera_to_world": {pose}, "fov": 0}}]}}"#
                ),
                "fov",
            ),
            (
                &format!(
                    r#"{{"render_width": 10, "render_height": 10, "camera_path": [{{"camera_to_world": {pose}, "fov": 50, "aperture_radius": 0.1}}]}}"#
                ),
                "focus_distance",
            ),
            (
                &format!(
                    r#"{{"render_width": 10, "render_height": 10, "camera_path": [{{"camera_to_world": {pose}, "fov": 50, "aperture_radius": -1}}]}}"#
                ),
                "aperture_radius",
            ),
        ];
        for (text, want) in cases {
            std::fs::write(&file, text).unwrap();
            let err = read_camera_path(&file).unwrap_err().to_string();
            assert!(err.contains("p.json") && err.contains(want), "{text}: {err}");
        }
        assert!(read_camera_path(&dir.path().join("missing.json")).unwrap_err().to_string().contains("cannot read"));
    }
}
