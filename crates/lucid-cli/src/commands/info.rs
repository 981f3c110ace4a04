//! `lucid info DATASET`: what a dataset folder holds.

use anyhow::Context;
use glam::Vec4Swizzles;
use lucid_scene::dataset::SceneBounds;
use lucid_scene::{Dataset, SplitFrames};
use serde_json::{Value, json};

use crate::cli::InfoArgs;

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    let summary = summarise(&dataset);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_text(&dataset, &summary);
    }
    Ok(())
}

/// A JSON description of the dataset, also used by the demo's report.
pub fn summarise(dataset: &Dataset) -> Value {
    let splits: Vec<Value> = dataset.splits.iter().map(split_summary).collect();
    let bounds = dataset.camera_bounds().map(|(lo, hi)| json!({"min": lo.to_array(), "max": hi.to_array()}));
    json!({ "root": dataset.root.display().to_string(), "splits": splits, "camera_centres": bounds })
}

fn split_summary(split: &SplitFrames) -> Value {
    let mut resolutions: Vec<(u32, u32)> =
        split.frames.iter().map(|f| (f.camera.intrinsics.width, f.camera.intrinsics.height)).collect();
    resolutions.sort();
    resolutions.dedup();
    let first = split.frames.first().map(|f| f.camera.intrinsics);
    let distances: Vec<f32> = split.frames.iter().map(|f| f.camera.camera_to_world.w_axis.xyz().length()).collect();
    let count_with = |pred: &dyn Fn(&lucid_scene::Frame) -> bool| split.frames.iter().filter(|f| pred(f)).count();
    json!({
        "split": split.split.name(),
        "source": split.source.display().to_string(),
        "frames": split.frames.len(),
        "resolutions": resolutions.iter().map(|(w, h)| format!("{w}x{h}")).collect::<Vec<_>>(),
        "intrinsics": first.map(|k| json!({
            "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
            "fov_x_degrees": k.fov_x().to_degrees(), "fov_y_degrees": k.fov_y().to_degrees(),
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
        },
    })
}

fn print_text(dataset: &Dataset, summary: &Value) {
    println!("dataset {}", dataset.root.display());
    for s in summary["splits"].as_array().into_iter().flatten() {
        let resolutions: Vec<&str> =
            s["resolutions"].as_array().into_iter().flatten().filter_map(|r| r.as_str()).collect();
        println!(
            "  {:<5} {:>4} frames  {}",
            s["split"].as_str().unwrap_or(""),
            s["frames"].as_u64().unwrap_or(0),
            resolutions.join(", ")
        );
        if let Some(k) = s["intrinsics"].as_object() {
            println!(
                "        fx {:.3} fy {:.3} cx {:.2} cy {:.2}  fov {:.2}° x {:.2}°",
                k["fx"].as_f64().unwrap_or(0.0),
                k["fy"].as_f64().unwrap_or(0.0),
                k["cx"].as_f64().unwrap_or(0.0),
                k["cy"].as_f64().unwrap_or(0.0),
                k["fov_x_degrees"].as_f64().unwrap_or(0.0),
                k["fov_y_degrees"].as_f64().unwrap_or(0.0),
            );
        }
        if let Some(d) = s["camera_distance_from_origin"].as_object() {
            println!(
                "        cameras {:.3}–{:.3} from the origin",
                d["min"].as_f64().unwrap_or(0.0),
                d["max"].as_f64().unwrap_or(0.0)
            );
        }
        if !s["bounds"].is_null() {
            println!("        bounds {}", s["bounds"]);
        }
        let extras: Vec<String> = s["extras"]
            .as_object()
            .into_iter()
            .flatten()
            .filter(|(_, v)| v.as_u64().unwrap_or(0) > 0)
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        if !extras.is_empty() {
            println!("        extras: {}", extras.join(", "));
        }
    }
    if let Some((lo, hi)) = dataset.camera_bounds() {
        println!(
            "  camera centres in [{:.3}, {:.3}, {:.3}] – [{:.3}, {:.3}, {:.3}]",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        );
    }
}
