//! Writing transforms files in the layout other tools read: Blender-style `camera_angle_x`
//! plus instant-ngp-style `fl_x`, `fl_y`, `cx`, `cy`, `w`, `h`, rows of the 4×4 pose, and our
//! extra keys only where a frame has them.

use std::io::Write;
use std::path::Path;

use glam::{Mat4, Vec3};
use serde_json::{Map, Value, json};

use super::DatasetError;
use crate::{Intrinsics, LensDistortion};

/// A frame as written: paths are relative to the JSON file's folder, as they appear in it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameRecord {
    /// The image, e.g. `./train/r_0` (Blender style, `.png` implied) or `train/r_0.png`.
    pub file_path: String,
    /// Camera-to-world pose (OpenGL convention).
    pub camera_to_world: Mat4,
    /// `hdr_file_path`.
    pub hdr_file_path: Option<String>,
    /// `depth_file_path`.
    pub depth_file_path: Option<String>,
    /// `normal_file_path`.
    pub normal_file_path: Option<String>,
    /// `albedo_file_path`.
    pub albedo_file_path: Option<String>,
    /// `environment_file_path`.
    pub environment_file_path: Option<String>,
    /// `exposure_time` in seconds.
    pub exposure_time: Option<f32>,
    /// `light_direction` (towards the light, world space).
    pub light_direction: Option<Vec3>,
    /// `held_out_light`: the light is not one of the training lights.
    pub held_out_light: Option<bool>,
    /// `aperture_radius` in world units.
    pub aperture_radius: Option<f32>,
    /// `focus_distance` in world units.
    pub focus_distance: Option<f32>,
}

/// Writes a transforms file atomically (temporary file, then rename), with `extra` keys at
/// the top level (nerfstudio's `ply_file_path`, or `camera_model` for a pinhole capture).
pub fn write_transforms(
    path: &Path,
    intrinsics: &Intrinsics,
    aabb: Option<(Vec3, Vec3)>,
    frames: &[FrameRecord],
    extra: &[(&str, Value)],
) -> Result<(), DatasetError> {
    let mut root = Map::new();
    root.insert("camera_angle_x".into(), json!(intrinsics.fov_x()));
    root.insert("camera_angle_y".into(), json!(intrinsics.fov_y()));
    root.insert("fl_x".into(), json!(intrinsics.fx));
    root.insert("fl_y".into(), json!(intrinsics.fy));
    root.insert("cx".into(), json!(intrinsics.cx));
    root.insert("cy".into(), json!(intrinsics.cy));
    root.insert("w".into(), json!(intrinsics.width));
    root.insert("h".into(), json!(intrinsics.height));
    match intrinsics.distortion {
        LensDistortion::None => {}
        LensDistortion::OpenCv { radial, rational: [0.0, 0.0, 0.0], tangential } => {
            root.insert("camera_model".into(), json!("OPENCV"));
            for (name, value) in ["k1", "k2", "k3", "k4", "p1", "p2"].iter().zip(radial.iter().chain(&tangential)) {
                root.insert((*name).into(), json!(value));
            }
        }
        LensDistortion::Fisheye { k } => {
            root.insert("camera_model".into(), json!("OPENCV_FISHEYE"));
            for (name, value) in ["k1", "k2", "k3", "k4"].iter().zip(&k) {
                root.insert((*name).into(), json!(value));
            }
        }
        LensDistortion::OpenCv { .. } => {
            return Err(DatasetError::Invalid {
                path: path.to_path_buf(),
                key: "camera_model".into(),
                reason: "nerfstudio's transforms have no rational (FULL_OPENCV) lens model".into(),
            });
        }
    }
    if let Some((min, max)) = aabb {
        root.insert("aabb".into(), json!([min.to_array(), max.to_array()]));
    }
    for (key, value) in extra {
        root.entry(*key).or_insert_with(|| value.clone());
    }
    root.insert("frames".into(), Value::Array(frames.iter().map(frame_json).collect()));
    let text = serde_json::to_string_pretty(&Value::Object(root)).expect("JSON values always serialise");
    lucid_image::write_atomically(path, |out| {
        out.write_all(text.as_bytes())
            .and_then(|()| out.write_all(b"\n"))
            .map_err(|source| lucid_image::ImageError::Io { path: path.to_path_buf(), source })
    })
    .map_err(|e| match e {
        lucid_image::ImageError::Io { path, source } => DatasetError::Io { path, source },
        other => DatasetError::Io { path: path.to_path_buf(), source: std::io::Error::other(other.to_string()) },
    })
}

fn frame_json(frame: &FrameRecord) -> Value {
    let rows: Vec<[f32; 4]> = (0..4).map(|r| frame.camera_to_world.row(r).to_array()).collect();
    let mut obj = Map::new();
    obj.insert("file_path".into(), json!(frame.file_path));
    obj.insert("transform_matrix".into(), json!(rows));
    let mut put = |key: &str, value: Option<Value>| {
        if let Some(v) = value {
            obj.insert(key.into(), v);
        }
    };
    put("hdr_file_path", frame.hdr_file_path.as_ref().map(|p| json!(p)));
    put("depth_file_path", frame.depth_file_path.as_ref().map(|p| json!(p)));
    put("normal_file_path", frame.normal_file_path.as_ref().map(|p| json!(p)));
    put("albedo_file_path", frame.albedo_file_path.as_ref().map(|p| json!(p)));
    put("environment_file_path", frame.environment_file_path.as_ref().map(|p| json!(p)));
    put("exposure_time", frame.exposure_time.map(|v| json!(v)));
    put("light_direction", frame.light_direction.map(|v| json!(v.to_array())));
    put("held_out_light", frame.held_out_light.map(|v| json!(v)));
    put("aperture_radius", frame.aperture_radius.map(|v| json!(v)));
    put("focus_distance", frame.focus_distance.map(|v| json!(v)));
    Value::Object(obj)
}
