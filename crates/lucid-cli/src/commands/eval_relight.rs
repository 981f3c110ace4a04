//! `lucid eval CHECKPOINT DATASET` for a relighting checkpoint: renders each view of a split
//! under each of its OLAT lights and environment maps, writes the renders (EXR) and
//! metrics.json, and reports PSNR/SSIM for both kinds of lighting.

use std::path::Path;

use anyhow::{Context, bail};
use burn::tensor::Device;
use lucid_relight_head::checkpoint::LightSet;
use lucid_relight_head::data::OlatSet;
use lucid_relight_head::eval::{RelightModel, RelightReport};
use lucid_relight_head::trainer::RelightTrainer;
use lucid_scene::Split;

use crate::cli::EvalArgs;

/// Prints the report as a table.
pub fn print_report(r: &RelightReport) {
    println!("{:<34} {:>7} {:>10} {:>8}", "held-out views under", "frames", "PSNR (dB)", "SSIM");
    for (label, m) in [
        ("single training lights", &r.lights),
        ("single held-out lights", &r.held_out_lights),
        ("environment maps", &r.environments),
    ] {
        if let (Some(psnr), Some(ssim)) = (m.psnr, m.ssim) {
            println!("{label:<34} {:>7} {psnr:>10.2} {ssim:>8.4}", m.frames);
        }
    }
    let mut envs: Vec<&std::path::PathBuf> = r.frames.iter().filter_map(|f| f.environment.as_ref()).collect();
    envs.sort();
    envs.dedup();
    for env in envs {
        let s: Vec<f64> = r.frames.iter().filter(|f| f.environment.as_ref() == Some(env)).map(|f| f.psnr).collect();
        println!("  {:<32} {:>7} {:>10.2}", env.display(), s.len(), s.iter().sum::<f64>() / s.len() as f64);
    }
    if r.environments.frames > 0 {
        println!(
            "environments integrated over {} directions, {:.2} s per render",
            r.environment_directions, r.seconds_per_environment
        );
    }
}

/// Evaluates a trained head on `data`, writing `out/`.
pub fn evaluate(
    trainer: &RelightTrainer,
    lights: &LightSet,
    data: &OlatSet,
    out: &Path,
    limit: Option<usize>,
    json: bool,
    device: &Device,
) -> anyhow::Result<RelightReport> {
    let views = &data.views[..limit.unwrap_or(data.views.len()).min(data.views.len())];
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let model = RelightModel {
        config: &trainer.config,
        geometry: &trainer.geometry,
        head: &trainer.head,
        training_directions: &lights.directions,
        irradiance: lights.irradiance,
        device,
    };
    let report = model.evaluate(views, |score, image| {
        let stem = score.truth.file_stem().and_then(|s| s.to_str()).unwrap_or("frame");
        let name = format!("{:03}_{}.exr", score.view, stem.trim_end_matches(".exr"));
        Ok(lucid_image::write_image(out.join(name), image)?)
    })?;
    let text = serde_json::to_string_pretty(&report)?;
    super::write_text(&out.join("metrics.json"), &text)?;
    if json {
        println!("{text}");
    } else {
        print_report(&report);
    }
    Ok(report)
}

pub fn run(args: &EvalArgs, split: Split) -> anyhow::Result<()> {
    let device = lucid_burn::backend::default_device();
    let loaded = lucid_relight_head::checkpoint::load(&args.checkpoint, &device)?;
    let data =
        OlatSet::load(&args.dataset, split).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if data.views.is_empty() {
        bail!(
            "{}: the {} split has no OLAT frames or environment truths to evaluate on",
            args.dataset.display(),
            split.name()
        );
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.checkpoint.parent().unwrap_or(Path::new(".")).join(format!("eval_{}", split.name())));
    evaluate(&loaded.trainer, &loaded.lights, &data, &out, args.limit, args.json, &device)?;
    Ok(())
}
