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
    for result in results.iter().filter(|r| r["benchmark"] == "integrators") {
        integrator_section(&mut r, result)?;
    }
    for result in results.iter().filter(|r| r["benchmark"] != "integrators") {
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

/// One scene of `lucid bench integrators`: relative MSE over time (log-log) and the table.
fn integrator_section(r: &mut Report, result: &Value) -> anyhow::Result<()> {
    let scene = result["scene"].as_str().unwrap_or("?");
    let entries = result["integrators"].as_array().cloned().unwrap_or_default();
    let series: Vec<Series> = entries
        .iter()
        .map(|e| Series {
            name: e["integrator"].as_str().unwrap_or("?").to_string(),
            points: e["curve"]
                .as_array()
                .map(|c| {
                    c.iter()
                        .filter_map(|p| Some((p["seconds"].as_f64()?.log10(), p["relative_mse"].as_f64()?.log10())))
                        .collect()
                })
                .unwrap_or_default(),
        })
        .collect();
    r.heading(&format!("Integrators on {scene}"));
    r.note(&format!(
        "{}×{} pixels, max depth {}, {} s per integrator on {} threads; reference: {} at {} spp (image mean {:.5}). \
         Relative MSE = mean of (x − ref)² / (ref² + 0.01); a slope of −1 is error ∝ 1/time.",
        result["width"],
        result["height"],
        result["max_depth"],
        result["budget_seconds"],
        result["threads"],
        result["reference"]["integrator"].as_str().unwrap_or("?"),
        result["reference"]["spp"],
        result["reference_mean"].as_f64().unwrap_or(f64::NAN)
    ));
    let svg = line_plot(
        &format!("{scene}: error against render time"),
        "log10 render time (s)",
        "log10 relative MSE",
        &series,
        (620, 380),
    )?;
    r.plots(&[svg]);
    let rows: Vec<Vec<String>> = entries
        .iter()
        .map(|e| {
            let n = |k: &str| e[k].as_f64().map_or("–".into(), format_number);
            vec![
                e["integrator"].as_str().unwrap_or("?").to_string(),
                n("spp"),
                n("seconds"),
                n("relative_mse"),
                n("relative_mse_vs_path"),
                n("log_slope"),
                n("seconds_to_path_error"),
                n("image_mean"),
            ]
        })
        .collect();
    r.table(&["integrator", "spp", "seconds", "relative MSE", "vs path", "slope", "s to path's error", "mean"], &rows);
    Ok(())
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
