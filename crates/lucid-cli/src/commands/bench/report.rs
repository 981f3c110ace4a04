//! The HTML report of `lucid bench`: per benchmark, its PSNR-vs-time curve (trainers) and a
//! table of every number it measured, then the machine.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::report::Report;
use crate::report::machine::MachineInfo;
use crate::report::plot::{Series, line_plot};

/// Every numeric leaf of `value` with its dotted path (curves and configurations skipped:
/// they are plotted or in the JSON).
fn numbers(prefix: &str, value: &Value, out: &mut Vec<(String, f64)>) {
    match value {
        Value::Number(n) => {
            if let Some(v) = n.as_f64() {
                out.push((prefix.to_string(), v));
            }
        }
        Value::Object(map) => {
            for (k, v) in map {
                if k == "curve" || k == "config" {
                    continue;
                }
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                numbers(&key, v, out);
            }
        }
        _ => {}
    }
}

/// A number for a table: integers as such, large and small values in scientific notation.
fn format_number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e9 {
        format!("{v:.0}")
    } else if v.abs() >= 1e5 || v.abs() < 1e-3 {
        format!("{v:.4e}")
    } else {
        format!("{v:.4}")
    }
}

/// The `(seconds, psnr)` points of a trainer benchmark's curve.
fn curve(result: &Value) -> Vec<(f64, f64)> {
    result["curve"]
        .as_array()
        .map(|points| points.iter().filter_map(|p| Some((p["seconds"].as_f64()?, p["psnr"].as_f64()?))).collect())
        .unwrap_or_default()
}

/// Writes `dir/report.html` for the results of one or several benchmarks.
pub fn write_report(results: &[Value], quick: bool, dir: &Path) -> anyhow::Result<PathBuf> {
    let mut r = Report::new(&format!("Lucid benchmarks{}", if quick { " (quick smoke run)" } else { "" }));
    r.note("Fixed seeds; every number below was measured by this run (results.json holds them all).");
    let trainers: Vec<Series> = results
        .iter()
        .filter(|v| !curve(v).is_empty())
        .map(|v| {
            let name = v["benchmark"].as_str().unwrap_or("?");
            let name = match v["scene"].as_str() {
                Some(scene) => format!("{name} ({scene})"),
                None => name.to_string(),
            };
            Series { name, points: curve(v) }
        })
        .collect();
    if !trainers.is_empty() {
        let svg =
            line_plot("Held-out PSNR over training time", "training time (s)", "PSNR (dB)", &trainers, (620, 380))?;
        r.heading("Training curves").plots(&[svg]);
    }
    for result in results {
        let name = result["benchmark"].as_str().unwrap_or("benchmark");
        let mut rows = Vec::new();
        numbers("", result, &mut rows);
        r.heading(name);
        if let Some(dataset) = result["dataset"].as_str() {
            r.note(&format!("dataset {dataset}"));
        }
        if let Some(c) = result.get("ceiling").filter(|c| !c.is_null()) {
            r.note(&format!(
                "noise ceiling {:.2} dB: the set's {} spp truth against {} spp renders of {} test views; no model can be measured above it",
                c["mean_psnr"].as_f64().unwrap_or(f64::NAN),
                c["spp"],
                c["reference_spp"],
                c["psnr"].as_array().map_or(0, Vec::len)
            ));
        }
        if let Some(last) = result.get("final") {
            r.note(&format!(
                "final held-out PSNR {:.2} dB, SSIM {:.4}",
                last["psnr"].as_f64().unwrap_or(f64::NAN),
                last["ssim"].as_f64().unwrap_or(f64::NAN)
            ));
        }
        if let Some(val) = result.get("final_val").filter(|v| !v.is_null()) {
            r.note(&format!(
                "validation split (settings are chosen on it): PSNR {:.2} dB, SSIM {:.4}",
                val["psnr"].as_f64().unwrap_or(f64::NAN),
                val["ssim"].as_f64().unwrap_or(f64::NAN)
            ));
        }
        if let Some(random) = result.get("random_init") {
            r.note(&format!(
                "from {} instead of the exact-depth point cloud: test PSNR {:.2} dB, SSIM {:.4}",
                random["init"].as_str().unwrap_or("random points"),
                random["final"]["psnr"].as_f64().unwrap_or(f64::NAN),
                random["final"]["ssim"].as_f64().unwrap_or(f64::NAN)
            ));
        }
        let table: Vec<Vec<String>> = rows.into_iter().map(|(k, v)| vec![k, format_number(v)]).collect();
        r.table(&["measure", "value"], &table);
    }
    r.heading("Machine").table(&["", ""], &MachineInfo::read().rows());
    let path = dir.join("report.html");
    r.write(&path)?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numeric_leaves_are_listed_with_their_paths_and_curves_are_plotted() {
        let v = serde_json::json!({
            "benchmark": "splat", "steps": 10, "rasterizer": {"images_per_second": 21.5},
            "curve": [{"seconds": 1.0, "psnr": 20.0}, {"seconds": 2.0, "psnr": 25.0}], "config": {"lr": 1.0},
        });
        let mut out = Vec::new();
        numbers("", &v, &mut out);
        assert_eq!(out, vec![("rasterizer.images_per_second".to_string(), 21.5), ("steps".to_string(), 10.0)]);
        assert_eq!(curve(&v), vec![(1.0, 20.0), (2.0, 25.0)]);
        assert_eq!(format_number(3.0), "3");
        assert_eq!(format_number(2.5e7 + 0.5), "2.5000e7");
        assert_eq!(format_number(0.25), "0.2500");
    }
}
