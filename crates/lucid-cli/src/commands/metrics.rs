//! `lucid metrics A B`: PSNR/SSIM of two images or of two folders matched by file stem.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use lucid_image::ImageFormat;
use lucid_image::metrics::{ImageMetrics, MetricSpace, MetricSummary, compare_files};
use rayon::prelude::*;
use serde_json::json;

use crate::cli::{MetricsArgs, SpaceArg};

pub fn run(args: MetricsArgs) -> anyhow::Result<()> {
    let background = super::parse_background(&args.background)?;
    let space = match args.space {
        SpaceArg::Srgb => MetricSpace::Srgb,
        SpaceArg::Linear => MetricSpace::Linear,
    };
    let pairs = match (args.prediction.is_dir(), args.reference.is_dir()) {
        (true, true) => match_folders(&args.prediction, &args.reference)?,
        (false, false) => vec![(args.prediction.clone(), args.reference.clone())],
        _ => bail!("compare an image with an image or a folder with a folder"),
    };
    let bar = crate::progress::bar(pairs.len() as u64, "comparing");
    let results: Vec<(String, ImageMetrics)> = pairs
        .par_iter()
        .map(|(a, b)| {
            let m = compare_files(a, b, background, space)?;
            bar.inc(1);
            Ok((a.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(), m))
        })
        .collect::<anyhow::Result<_>>()?;
    bar.finish_and_clear();
    let summary = MetricSummary::from_images(&results.iter().map(|r| r.1).collect::<Vec<_>>());
    let space_name = match space {
        MetricSpace::Srgb => "srgb",
        MetricSpace::Linear => "linear",
    };
    if args.json {
        let images: Vec<_> =
            results.iter().map(|(n, m)| json!({"name": n, "psnr": db(m.psnr), "ssim": m.ssim})).collect();
        let out = json!({
            "background": background, "space": space_name, "images": images,
            "mean": {"count": summary.count, "psnr": db(summary.psnr), "ssim": summary.ssim},
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!("{:<32} {:>9} {:>7}", "image", "PSNR dB", "SSIM");
        for (name, m) in &results {
            println!("{name:<32} {:>9.3} {:>7.4}", m.psnr, m.ssim);
        }
        println!("{:<32} {:>9.3} {:>7.4}", format!("mean of {}", summary.count), summary.psnr, summary.ssim);
        println!("(space {space_name}, background {background:?})");
    }
    Ok(())
}

/// A PSNR for JSON, which has no infinity: identical images score the string `"inf"`, so
/// that a reader tells them from a missing value (`null`), which Lucid never writes.
fn db(psnr: f64) -> serde_json::Value {
    if psnr.is_finite() { json!(psnr) } else { json!("inf") }
}

/// Pairs each image in `a` with the image of the same stem in `b` (same extension preferred).
fn match_folders(a: &Path, b: &Path) -> anyhow::Result<Vec<(PathBuf, PathBuf)>> {
    let list = |dir: &Path| -> anyhow::Result<Vec<PathBuf>> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .with_context(|| format!("{}: cannot list folder", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && ImageFormat::from_path(p).is_ok())
            .filter(|p| !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.')))
            .collect();
        files.sort();
        Ok(files)
    };
    let stem = |p: &Path| p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut by_stem: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for p in list(b)? {
        by_stem.entry(stem(&p)).or_default().push(p);
    }
    let mut pairs = Vec::new();
    let mut unmatched = 0;
    for p in list(a)? {
        let Some(candidates) = by_stem.get(&stem(&p)) else {
            unmatched += 1;
            continue;
        };
        let same_ext = candidates.iter().find(|c| c.extension() == p.extension());
        pairs.push((p.clone(), same_ext.unwrap_or(&candidates[0]).clone()));
    }
    if unmatched > 0 {
        tracing::warn!("{unmatched} image(s) in {} have no counterpart in {}", a.display(), b.display());
    }
    if pairs.is_empty() {
        bail!("no images with matching names in {} and {}", a.display(), b.display());
    }
    Ok(pairs)
}
