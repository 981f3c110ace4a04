//! nerfstudio's captures: a lone `transforms.json` written by `ns-process-data` (or by hand
//! from a capture app) holds SfM poses in whatever frame and scale the reconstruction chose,
//! and may name its sparse points (`ply_file_path`). nerfstudio's own loader re-centres and
//! rescales such poses; Lucid normalises them as it does a COLMAP model
//! ([`SceneNormalisation`]) so that both descriptions of one capture train the same.

use std::path::Path;

use glam::DMat4;
use serde_json::{Map, Value};

use super::capture::{downscaled, is_downscaled};
use super::{DatasetError, SceneNormalisation, SparsePoint, SplitFrames};

/// Whether a lone transforms file describes a capture: nerfstudio's keys name one, and it
/// gives no bounds (instant-ngp's `aabb_scale` and our `aabb` say the poses are already in
/// the frame the box is given in).
pub(super) fn is_capture(value: &Value, splits: &[SplitFrames]) -> bool {
    let has = |key: &str| value.get(key).is_some_and(|v| !v.is_null());
    let nerfstudio = has("camera_model") || has("applied_transform") || has("ply_file_path");
    nerfstudio && splits.iter().all(|s| s.bounds.is_none())
}

/// The points of `ply_file_path`, relative to the transforms file's folder (none without the
/// key).
pub(super) fn sparse_points(json: &Path, root: Option<&Map<String, Value>>) -> Result<Vec<SparsePoint>, DatasetError> {
    let Some(value) = root.and_then(|r| r.get("ply_file_path")).filter(|v| !v.is_null()) else {
        return Ok(Vec::new());
    };
    let invalid =
        |reason: String| DatasetError::Invalid { path: json.to_path_buf(), key: "ply_file_path".into(), reason };
    let Some(name) = value.as_str() else { return Err(invalid(format!("{value} is not a path"))) };
    let file = json.parent().unwrap_or(Path::new(".")).join(name);
    if !file.is_file() {
        return Err(invalid(format!("{} not found", file.display())));
    }
    let points = crate::point_cloud::read_point_cloud(&file).map_err(|e| invalid(e.to_string()))?;
    let byte = |c: f32| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
    Ok(points.into_iter().map(|(position, c)| SparsePoint { position, colour: c.map(byte) }).collect())
}

/// Normalises the frames' poses and the points in place, as a COLMAP capture's are, and
/// returns the normalisation.
pub(super) fn normalise(splits: &mut [SplitFrames], points: &mut [SparsePoint]) -> SceneNormalisation {
    let poses: Vec<DMat4> =
        splits.iter().flat_map(|s| &s.frames).map(|f| f.camera.camera_to_world.as_dmat4()).collect();
    let n = SceneNormalisation::from_cameras(&poses);
    for frame in splits.iter_mut().flat_map(|s| &mut s.frames) {
        frame.camera.camera_to_world = n.pose_to_scene(frame.camera.camera_to_world.as_dmat4()).as_mat4();
    }
    for p in points {
        p.position = n.to_scene(p.position.as_dvec3()).as_vec3();
    }
    n
}

/// Reads every frame's image at 1/`factor` of its size: from the sibling folder nerfstudio
/// writes (`images_2/` beside `images/`, the same file names) where it holds the image, else
/// resized on reading. The intrinsics follow the size actually read.
pub(super) fn downscale(splits: &mut [SplitFrames], factor: u32) -> Result<(), DatasetError> {
    if factor <= 1 {
        return Ok(());
    }
    for split in splits.iter_mut() {
        for (i, frame) in split.frames.iter_mut().enumerate() {
            let k = frame.camera.intrinsics;
            let target = (downscaled(k.width, factor), downscaled(k.height, factor));
            let scaled = frame.image_path.parent().zip(frame.image_path.file_name()).and_then(|(dir, name)| {
                let folder = dir.file_name()?.to_str()?;
                Some(dir.with_file_name(format!("{folder}_{factor}")).join(name)).filter(|p| p.is_file())
            });
            let Some(scaled) = scaled else {
                frame.camera.intrinsics = k.resized(target.0, target.1);
                frame.resize_to = Some(target);
                continue;
            };
            let (w, h) = lucid_image::image_dimensions(&scaled).map_err(|source| DatasetError::Image {
                path: split.source.clone(),
                key: format!("frames[{i}]"),
                source,
            })?;
            let (w, h) = (w as u32, h as u32);
            if !is_downscaled(w, k.width, factor) || !is_downscaled(h, k.height, factor) {
                return Err(DatasetError::Invalid {
                    path: split.source.clone(),
                    key: format!("frames[{i}].file_path"),
                    reason: format!(
                        "{} is {w}x{h}, but the image downscaled {factor} times is {}x{}",
                        scaled.display(),
                        target.0,
                        target.1
                    ),
                });
            }
            frame.camera.intrinsics = k.resized(w, h);
            frame.image_path = scaled;
        }
    }
    Ok(())
}
