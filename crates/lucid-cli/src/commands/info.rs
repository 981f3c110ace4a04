//! `lucid info PATH`: what a dataset folder holds, or what a checkpoint (or the run folder
//! holding one) was trained to.

use anyhow::Context;
use lucid_scene::Dataset;
use lucid_scene::dataset::summary::summarise;
use serde_json::Value;

use crate::cli::InfoArgs;

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let checkpoint = if args.dataset.is_dir() { args.dataset.join("checkpoint.lucid") } else { args.dataset.clone() };
    if lucid_burn::checkpoint::is_checkpoint(&checkpoint) {
        return checkpoint_info(&checkpoint, args.json);
    }
    let dataset = Dataset::open_with(&args.dataset, &args.data.options())
        .with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    let summary = summarise(&dataset);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_text(&dataset, &summary);
    }
    Ok(())
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
            if let Some(lens) = k["lens"].as_str().filter(|l| *l != "pinhole") {
                println!("        lens {lens} (rays through its inverse)");
            }
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
    if let Some(capture) = summary["capture"].as_object() {
        let n = &capture["normalisation"];
        println!(
            "  capture: {} sparse points; normalised about {} with scale {:.4} (the farthest camera at 1)",
            capture["sparse_points"],
            n["centre"],
            n["scale"].as_f64().unwrap_or(0.0)
        );
    }
    if let Some((lo, hi)) = dataset.camera_bounds() {
        println!(
            "  camera centres in [{:.3}, {:.3}, {:.3}] – [{:.3}, {:.3}, {:.3}]",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        );
    }
}

/// The checkpoint's header: kind, steps, training time and the scalars its trainer records
/// (the configuration only with `--json`).
fn checkpoint_info(path: &std::path::Path, json: bool) -> anyhow::Result<()> {
    let header = lucid_burn::checkpoint::read_header(path)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&header)?);
        return Ok(());
    }
    println!("checkpoint {}", path.display());
    println!("  kind {}", header["kind"].as_str().unwrap_or("unknown"));
    println!("  step {}", header["step"].as_u64().unwrap_or(0));
    println!("  trained for {:.1} s", header["elapsed"].as_f64().unwrap_or(0.0));
    for (key, value) in header.as_object().into_iter().flatten() {
        let scalar = value.is_number() || value.is_string() || value.is_boolean();
        if scalar && !["kind", "step", "elapsed"].contains(&key.as_str()) {
            println!("  {key} {value}");
        }
    }
    if let Some(frame) = header["view"]["frame"].as_object() {
        println!(
            "  trained on a capture, normalised (centre {}, scale {}); renders and exports are in the dataset's frame",
            frame["centre"], frame["scale"]
        );
    }
    Ok(())
}
