//! A dataset described as JSON: per split its frames, resolutions, intrinsics, camera
//! distances, scene bounds and the extras its frames carry (`lucid info`, the demo's report).

use glam::Vec4Swizzles;
use serde_json::{Value, json};

use super::{Dataset, SceneBounds, SplitFrames};

/// A JSON description of the dataset.
pub fn summarise(dataset: &Dataset) -> Value {
    let splits: Vec<Value> = dataset.splits.iter().map(split_summary).collect();
    let bounds = dataset.camera_bounds().map(|(lo, hi)| json!({"min": lo.to_array(), "max": hi.to_array()}));
    let capture = dataset.normalisation.map(|n| {
        json!({
            "sparse_points": dataset.points.len(),
            "normalisation": { "centre": n.centre.to_array(), "scale": n.scale, "rotation_xyzw": n.rotation.to_array() },
        })
    });
    json!({ "root": dataset.root.display().to_string(), "splits": splits, "camera_centres": bounds, "capture": capture })
}

/// The lens of a camera, as the file named it.
fn lens_name(k: &crate::Intrinsics) -> &'static str {
    match k.distortion {
        crate::LensDistortion::None => "pinhole",
        crate::LensDistortion::OpenCv { rational: [0.0, 0.0, 0.0], .. } => "opencv",
        crate::LensDistortion::OpenCv { .. } => "full_opencv",
        crate::LensDistortion::Fisheye { .. } => "opencv_fisheye",
    }
}

fn split_summary(split: &SplitFrames) -> Value {
    let mut resolutions: Vec<(u32, u32)> =
        split.frames.iter().map(|f| (f.camera.intrinsics.width, f.camera.intrinsics.height)).collect();
    resolutions.sort();
    resolutions.dedup();
    let first = split.frames.first().map(|f| f.camera.intrinsics);
    let distances: Vec<f32> = split.frames.iter().map(|f| f.camera.camera_to_world.w_axis.xyz().length()).collect();
    let count_with = |pred: &dyn Fn(&super::Frame) -> bool| split.frames.iter().filter(|f| pred(f)).count();
    json!({
        "split": split.split.name(),
        "source": split.source.display().to_string(),
        "frames": split.frames.len(),
        "resolutions": resolutions.iter().map(|(w, h)| format!("{w}x{h}")).collect::<Vec<_>>(),
        "intrinsics": first.map(|k| json!({
            "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
            "fov_x_degrees": k.fov_x().to_degrees(), "fov_y_degrees": k.fov_y().to_degrees(),
            "lens": lens_name(&k),
        })),
        "camera_distance_from_origin": if distances.is_empty() { Value::Null } else { json!({
            "min": distances.iter().cloned().fold(f32::INFINITY, f32::min),
            "max": distances.iter().cloned().fold(0.0, f32::max),
        })},
        "bounds": match split.bounds {
            Some(SceneBounds::Box { min, max }) => json!({"aabb": [min.to_array(), max.to_array()]}),
            Some(SceneBounds::AabbScale(s)) => json!({"aabb_scale": s}),
            None => Value::Null,
        },
        "extras": {
            "hdr": count_with(&|f| f.extras.hdr_path.is_some()),
            "depth": count_with(&|f| f.extras.depth_path.is_some()),
            "normal": count_with(&|f| f.extras.normal_path.is_some()),
            "albedo": count_with(&|f| f.extras.albedo_path.is_some()),
            "exposure_time": count_with(&|f| f.extras.exposure_time.is_some()),
            "light_direction": count_with(&|f| f.extras.light_direction.is_some()),
            "thin_lens": count_with(&|f| f.extras.focus_distance.is_some()),
            "mask": count_with(&|f| f.extras.mask_path.is_some()),
        },
    })
}
