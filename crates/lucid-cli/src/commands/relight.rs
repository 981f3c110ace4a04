//! `lucid relight DATASET [--env ENV -o OUT]`: a view of an OLAT set relit under an
//! environment map by its light transport matrix; scored against the path-traced truths the
//! dataset holds for that view.

use std::path::Path;

use anyhow::bail;
use lucid_image::metrics::{MetricSpace, prepare_for_metrics, psnr};
use lucid_image::{Image, write_image};
use lucid_relight::transport::{Weighting, light_weights, load_view_with, relight};
use serde_json::json;

use crate::cli::{RelightArgs, WeightingArg};

fn score(relit: &Image, truth: &Image) -> anyhow::Result<f64> {
    let prep = |i: &Image| prepare_for_metrics(i, [0.0; 3], MetricSpace::Srgb);
    Ok(psnr(&prep(relit), &prep(truth), None)?)
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

pub fn run(args: RelightArgs) -> anyhow::Result<()> {
    if args.env.is_some() != args.output.is_some() {
        bail!("--env and -o/--output go together (without them every truth environment is scored)");
    }
    if let Some(out) = &args.output {
        lucid_image::ImageFormat::from_path(out)?;
    }
    let given = args.directions.as_deref().map(lucid_relight::lightstage::capture::read_directions).transpose()?;
    let view = load_view_with(&args.dataset, args.split.into(), args.view, given.as_ref())?;
    let weighting = match args.weights {
        WeightingArg::Cell => Weighting::CellIntegral,
        WeightingArg::Point => Weighting::PointSample,
        WeightingArg::Barycentric => Weighting::Barycentric,
    };
    let envs: Vec<std::path::PathBuf> = match &args.env {
        Some(e) => vec![e.clone()],
        None => view.truths.iter().map(|(p, _)| p.clone()).collect(),
    };
    if envs.is_empty() {
        bail!("{}: view {} has no environment truths; give --env ENV -o OUT", args.dataset.display(), args.view);
    }
    let mut results = Vec::new();
    for env_path in &envs {
        let env = lucid_image::read_finite_image(env_path)?;
        let l = light_weights(&view.directions, view.irradiance, &env, weighting)?;
        let relit = relight(&view.images, &l);
        if let Some(out) = &args.output {
            write_image(out, &relit)?;
        }
        let truth = view.truths.iter().find(|(p, _)| same_file(p, env_path)).map(|(_, t)| t);
        let p = match truth {
            Some(t) => Some(score(&relit, t)?),
            None => None,
        };
        results.push(json!({ "environment": env_path.display().to_string(), "psnr": p }));
        if !args.json {
            match p {
                Some(p) => println!("{}: PSNR {p:.2} dB against the path-traced truth", env_path.display()),
                None => println!("{}: relit (no truth for it in the dataset)", env_path.display()),
            }
        }
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(
                &json!({ "lights": view.directions.len(), "view": args.view, "results": results })
            )?
        );
    }
    Ok(())
}
