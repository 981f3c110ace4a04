//! `lucid eval CHECKPOINT DATASET`: renders every view of a split, writes the renders, depth
//! and error maps, and reports PSNR/SSIM per view and averaged (text and metrics.json).

use std::path::Path;

use anyhow::{Context, bail};
use lucid_image::color::srgb_decode;
use lucid_image::{Image, WriteOptions, write_image, write_image_with};
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::{ViewModel, evaluate};
use lucid_scene::{Dataset, Split};
use serde_json::json;

use super::model::LoadedModel;
use crate::cli::EvalArgs;

pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    let split = match args.split.as_str() {
        "train" => Split::Train,
        "val" => Split::Val,
        "test" => Split::Test,
        other => bail!("--split must be train, val or test, got {other}"),
    };
    match lucid_burn::checkpoint::read_kind(&args.checkpoint)?.as_str() {
        lucid_itm::checkpoint::ITM_KIND => return super::eval_itm::run(&args, split),
        lucid_relight_head::checkpoint::RELIGHT_KIND => return super::eval_relight::run(&args, split),
        _ => {}
    }
    let loaded = LoadedModel::load(&args.checkpoint)?;
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if dataset.frames(split).is_empty() {
        bail!("{}: the dataset has no {} split", args.dataset.display(), split.name());
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.checkpoint.parent().unwrap_or(Path::new(".")).join(format!("eval_{}", split.name())));
    loaded.with_renderer(|renderer| {
        evaluate_model(renderer, loaded.step(), &dataset, split, args.limit, &out, args.json, args.pinhole)
    })
}

/// Evaluates a model (trained for `step` steps) on a split, writing `out/` and printing the
/// results.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_model(
    renderer: &dyn ViewModel,
    step: usize,
    dataset: &Dataset,
    split: Split,
    limit: Option<usize>,
    out: &Path,
    json_out: bool,
    pinhole: bool,
) -> anyhow::Result<()> {
    let frames = dataset.frames(split);
    let frames = &frames[..limit.unwrap_or(frames.len()).min(frames.len())];
    let mut set = ImageSet::load(frames).with_context(|| format!("loading the {} images", split.name()))?;
    if pinhole {
        set.lenses.iter_mut().for_each(|l| *l = None);
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bar = crate::progress::bar(set.len() as u64, "eval");
    let mut failure = None;
    let (scores, summary) = evaluate(renderer, &set, None, |i, view, truth, score| {
        bar.inc(1);
        if failure.is_some() {
            return;
        }
        let stem = frames[i].image_path.file_stem().and_then(|s| s.to_str()).unwrap_or("view").to_string();
        if let Err(e) = write_view(out, &stem, view, truth) {
            failure = Some(e);
        }
        tracing::debug!("{stem}: {:.2} dB, SSIM {:.4}, {:.3} s", score.psnr, score.ssim, score.seconds);
    });
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(e);
    }
    let report = json!({
        "split": split.name(),
        "step": step,
        "summary": summary,
        "views": scores,
        "metric_space": "sRGB-encoded, composited on the background",
        "thin_lens_views": set.lenses.iter().filter(|l| l.is_some()).count(),
    });
    super::write_text(&out.join("metrics.json"), &serde_json::to_string_pretty(&report)?)?;
    if json_out {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        for (f, s) in frames.iter().zip(&scores) {
            println!("{:<40} {:>7.2} dB  SSIM {:.4}  {:.3} s", f.file_path, s.psnr, s.ssim, s.seconds);
        }
        println!(
            "{} {} views: PSNR {:.2} dB, SSIM {:.4}, {:.3} s per view (background {:?}) -> {}",
            split.name(),
            summary.views,
            summary.psnr,
            summary.ssim,
            summary.seconds_per_view,
            summary.background,
            out.display()
        );
    }
    Ok(())
}

/// `stem.png` (render), `stem_depth.exr`, `stem_error.png` (|error| × 4, grey).
fn write_view(
    out: &Path,
    stem: &str,
    view: &lucid_scene::evaluation::RenderedView,
    truth: &Image,
) -> anyhow::Result<()> {
    // Renders are in sRGB-encoded space; the PNG writer encodes linear values, so decode.
    let linear = view.colour.map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), 1.0]);
    write_image(out.join(format!("{stem}.png")), &linear)?;
    let (w, h) = view.colour.dimensions();
    let depth = Image::from_pixels(w, h, view.depth.iter().map(|&d| [d, d, d, 1.0]).collect());
    write_image_with(
        out.join(format!("{stem}_depth.exr")),
        &depth,
        WriteOptions { single_channel: true, ..Default::default() },
    )?;
    let error = Image::from_pixels(
        w,
        h,
        view.colour
            .pixels()
            .iter()
            .zip(truth.pixels())
            .map(|(a, b)| {
                let e =
                    srgb_decode(((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0 * 4.0).min(1.0);
                [e, e, e, 1.0]
            })
            .collect(),
    );
    write_image(out.join(format!("{stem}_error.png")), &error)?;
    Ok(())
}
