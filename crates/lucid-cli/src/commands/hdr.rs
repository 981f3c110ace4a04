//! `lucid hdr merge`: exposure brackets to HDR radiance (or a fused display image).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use lucid_hdr::fusion::{FusionSettings, mertens};
use lucid_hdr::merge::merge_radiance;
use lucid_hdr::response::{DebevecSettings, ResponseCurve, RobertsonSettings, debevec_malik, robertson};
use lucid_hdr::stack::ExposureStack;
use lucid_image::{ImageError, ImageFormat, read_image, write_atomically, write_image};
use lucid_scene::{Dataset, Split};

use crate::cli::{HdrArgs, HdrCommand, HdrMergeArgs, MergeMethod};

pub fn run(args: HdrArgs) -> anyhow::Result<()> {
    match args.command {
        HdrCommand::Merge(m) => merge(m),
    }
}

/// The frames and exposure times of one view of a brackets dataset.
fn dataset_brackets(root: &Path, split: Split, view: usize) -> anyhow::Result<(Vec<PathBuf>, Vec<f32>)> {
    let dataset = Dataset::open(root)?;
    let frames = dataset.frames(split);
    // The brackets of a view share its HDR truth file (or, without one, its camera pose).
    let mut views: Vec<(String, Vec<(PathBuf, f32)>)> = Vec::new();
    for f in frames {
        let Some(time) = f.extras.exposure_time else { continue };
        let key = match &f.extras.hdr_path {
            Some(p) => p.display().to_string(),
            None => format!("{:?}", f.camera.camera_to_world),
        };
        match views.iter_mut().find(|(k, _)| *k == key) {
            Some((_, list)) => list.push((f.image_path.clone(), time)),
            None => views.push((key, vec![(f.image_path.clone(), time)])),
        }
    }
    if views.is_empty() {
        bail!(
            "{}: no frame of the {} split has an exposure_time (make one with `lucid gen ... --rig brackets`)",
            root.display(),
            split.name()
        );
    }
    let Some((_, list)) = views.get(view) else {
        bail!(
            "{}: --view {view} is out of range: the {} split has {} bracketed views",
            root.display(),
            split.name(),
            views.len()
        );
    };
    Ok(list.iter().cloned().unzip())
}

fn merge(args: HdrMergeArgs) -> anyhow::Result<()> {
    let out_format = ImageFormat::from_path(&args.output)?;
    if args.method != MergeMethod::Mertens && !out_format.is_hdr() {
        bail!(
            "{}: radiance needs an HDR format (.exr, .hdr, .pfm); use --method mertens for a display image",
            args.output.display()
        );
    }
    if !(args.lambda.is_finite() && args.lambda >= 0.0) {
        bail!("--lambda must be finite and ≥ 0, got {}", args.lambda);
    }
    let (paths, times) = if args.inputs.len() == 1 && args.inputs[0].is_dir() {
        if !args.times.is_empty() {
            bail!("--times is read from the dataset; do not give it with a dataset folder");
        }
        dataset_brackets(&args.inputs[0], args.split.into(), args.view)?
    } else {
        if args.method != MergeMethod::Mertens && args.times.len() != args.inputs.len() {
            bail!("{} frames but {} exposure times (--times t1,t2,...)", args.inputs.len(), args.times.len());
        }
        let times = if args.times.is_empty() { vec![1.0; args.inputs.len()] } else { args.times.clone() };
        (args.inputs.clone(), times)
    };
    let mut frames = Vec::with_capacity(paths.len());
    for p in &paths {
        let format = ImageFormat::from_path(p)?;
        if format.is_hdr() {
            bail!("{}: brackets are LDR frames (PNG/JPEG), this is {}", p.display(), format.name());
        }
        frames.push(read_image(p)?);
    }
    for (p, f) in paths.iter().zip(&frames).skip(1) {
        if f.dimensions() != frames[0].dimensions() {
            bail!(
                "{}: {}x{}, but {} is {}x{}",
                p.display(),
                f.width(),
                f.height(),
                paths[0].display(),
                frames[0].width(),
                frames[0].height()
            );
        }
    }
    let stack = ExposureStack::new(&frames, &times).context("bad exposure stack")?;
    let start = Instant::now();
    let image = match args.method {
        MergeMethod::Mertens => mertens(&stack, FusionSettings::default()),
        method => {
            let curve = match method {
                MergeMethod::Debevec => {
                    debevec_malik(&stack, DebevecSettings { smoothness: args.lambda, samples: args.samples })?
                }
                MergeMethod::Robertson => {
                    robertson(&stack, RobertsonSettings { samples: args.samples.max(1000), ..Default::default() })?
                }
                _ => ResponseCurve::srgb(),
            };
            if let Some(csv) = &args.response_out {
                write_atomically(csv, |w| {
                    std::io::Write::write_all(w, curve.to_csv().as_bytes()).map_err(|e| ImageError::io(csv, e))
                })?;
            }
            merge_radiance(&stack, &curve)
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    if !image.is_finite() {
        bail!(
            "{}: the merge gave NaN or infinite radiance ({:?}); nothing written: check the exposure times and the frames",
            args.output.display(),
            args.method
        );
    }
    write_image(&args.output, &image)?;
    tracing::info!(
        "merged {} frames ({}x{}) with {:?} in {:.3} s -> {}",
        paths.len(),
        stack.width(),
        stack.height(),
        args.method,
        seconds,
        args.output.display()
    );
    Ok(())
}
