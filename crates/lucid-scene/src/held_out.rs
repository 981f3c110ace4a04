//! A model's evaluation on one split of a dataset, written to a folder: per view the render
//! (`stem.png`), its expected depth (`stem_depth.exr`, in the dataset's own units) and an error map (`stem_error.png`,
//! |error| × 4 in grey), and `metrics.json` with every view's scores and their means. Used by
//! `lucid eval` and at the end of every training run.

use std::path::Path;

use lucid_image::color::srgb_decode;
use lucid_image::owned_folder::OwnedFolder;
use lucid_image::{Image, ImageError, WriteOptions, write_image, write_image_with};
use serde_json::json;

use crate::dataset::images::ImageSet;
use crate::evaluation::{RenderedView, ViewModel, evaluate};
use crate::{Dataset, Split};

/// What [`evaluate_split`] measured.
#[derive(Clone, Debug)]
pub struct SplitEvaluation {
    /// The content of `metrics.json`.
    pub report: serde_json::Value,
    /// One line per view and a closing line with the means, for a terminal.
    pub lines: Vec<String>,
}

/// Renders and scores the views of `split` (the first `limit`), writing into `out`. With
/// `pinhole`, views that the dataset gives a thin lens are rendered with a pinhole instead.
/// `progress` is called with the views done and the views in all.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_split(
    renderer: &dyn ViewModel,
    step: usize,
    dataset: &Dataset,
    split: Split,
    limit: Option<usize>,
    pinhole: bool,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SplitEvaluation, ImageError> {
    let frames = dataset.frames(split);
    let frames = &frames[..limit.unwrap_or(frames.len()).min(frames.len())];
    let mut set = ImageSet::load(frames)?;
    if pinhole {
        set.lenses.iter_mut().for_each(|l| *l = None);
    }
    // Never over the dataset's own images: the folder must be new, empty or an earlier output.
    lucid_image::owned_folder::adopt_unrecorded_evaluation(out)?;
    let folder = OwnedFolder::claim(out, "the evaluation", &[&dataset.root])?;
    let stems = unique_stems(frames);
    let mut failure = None;
    let mut done = 0;
    let (scores, summary) = evaluate(renderer, &set, None, |i, view, truth, _| {
        done += 1;
        progress(done, frames.len());
        if failure.is_none() {
            failure = write_view(out, &stems[i], view, truth, dataset).err();
        }
    });
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
    let path = out.join("metrics.json");
    lucid_image::output::write_text(&path, &serde_json::to_string_pretty(&report).expect("serialises"))?;
    folder.finish()?;
    let mut lines: Vec<String> = frames
        .iter()
        .zip(&scores)
        .map(|(f, s)| format!("{:<40} {:>7.2} dB  SSIM {:.4}  {:.3} s", f.file_path, s.psnr, s.ssim, s.seconds))
        .collect();
    lines.push(format!(
        "{} {} views: PSNR {:.2} dB, SSIM {:.4}, {:.3} s per view (background {:?}) -> {}",
        split.name(),
        summary.views,
        summary.psnr,
        summary.ssim,
        summary.seconds_per_view,
        summary.background,
        out.display()
    ));
    Ok(SplitEvaluation { report, lines })
}

/// The name each view's files are written under: its image's stem, or, where two images of
/// the split share one (the same name in two folders), its path with `_` for `/`.
fn unique_stems(frames: &[crate::dataset::Frame]) -> Vec<String> {
    let stem =
        |f: &crate::dataset::Frame| f.image_path.file_stem().and_then(|s| s.to_str()).unwrap_or("view").to_string();
    let stems: Vec<String> = frames.iter().map(stem).collect();
    let mut uses = std::collections::HashMap::<&str, usize>::new();
    for s in &stems {
        *uses.entry(s.as_str()).or_default() += 1;
    }
    let mut taken = std::collections::HashSet::new();
    stems
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let shared = uses[s.as_str()] > 1;
            let mut name = if shared {
                let path = frames[i].file_path.trim_start_matches("./");
                let path = Path::new(path).with_extension("");
                path.to_string_lossy().replace(['/', '\\'], "_")
            } else {
                s.clone()
            };
            if !taken.insert(name.clone()) {
                name = format!("{name}_{i}");
                taken.insert(name.clone());
            }
            name
        })
        .collect()
}

fn write_view(out: &Path, stem: &str, view: &RenderedView, truth: &Image, dataset: &Dataset) -> Result<(), ImageError> {
    // Renders are in sRGB-encoded space; the PNG writer encodes linear values, so decode.
    write_image(out.join(format!("{stem}.png")), &view.linear_colour())?;
    write_image_with(
        out.join(format!("{stem}_depth.exr")),
        &view.depth_image(dataset.normalisation.as_ref()),
        WriteOptions { single_channel: true, ..Default::default() },
    )?;
    write_image(out.join(format!("{stem}_error.png")), &error_image(&view.colour, truth))
}

/// The error map written beside each evaluated view: the mean absolute difference of the
/// encoded channels, ×4 and clipped, as linear grey (so a written PNG shows it as encoded).
pub fn error_image(colour: &Image, truth: &Image) -> Image {
    let (w, h) = colour.dimensions();
    Image::from_pixels(
        w,
        h,
        colour
            .pixels()
            .iter()
            .zip(truth.pixels())
            .map(|(a, b)| {
                let e =
                    srgb_decode(((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0 * 4.0).min(1.0);
                [e, e, e, 1.0]
            })
            .collect(),
    )
}

/// The closing evaluation of a training run: the whole test split into `out`; returns the
/// lines for a terminal.
pub fn evaluate_test_split(
    renderer: &dyn ViewModel,
    step: usize,
    dataset: &Dataset,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<String>, ImageError> {
    Ok(evaluate_split(renderer, step, dataset, Split::Test, None, false, out, progress)?.lines)
}
