//! `lucid eval CHECKPOINT DATASET`: scores a trained model on a dataset split and writes what
//! it rendered beside the scores (`metrics.json`). NeRF and splat checkpoints: renders, depth
//! and error maps, PSNR/SSIM per view and averaged. ITM checkpoints: the network against the
//! analytic baseline and the plain inverse response on the split's bracket frames.
//! Relighting checkpoints: each view under each of its OLAT lights and environment maps.

use std::path::Path;

use anyhow::{Context, bail};
use lucid_relight_head::data::OlatSet;
use lucid_scene::held_out::evaluate_split;
use lucid_scene::{Dataset, Split};

use crate::cli::EvalArgs;

pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    let split = match args.split.as_str() {
        "train" => Split::Train,
        "val" => Split::Val,
        "test" => Split::Test,
        other => bail!("--split must be train, val or test, got {other}"),
    };
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.checkpoint.parent().unwrap_or(Path::new(".")).join(format!("eval_{}", split.name())));
    match lucid_burn::checkpoint::read_kind(&args.checkpoint)?.as_str() {
        lucid_itm::checkpoint::ITM_KIND => return itm(&args, split, &out),
        lucid_relight_head::checkpoint::RELIGHT_KIND => return relight(&args, split, &out),
        _ => {}
    }
    let model = crate::loaded_model::open(&args.checkpoint, &args.nerf)?;
    let dataset = Dataset::open_with(&args.dataset, &args.data.options())
        .with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if dataset.frames(split).is_empty() {
        bail!("{}: the dataset has no {} split", args.dataset.display(), split.name());
    }
    let mut progress = lucid_burn::run::eval_progress();
    let evaluation =
        evaluate_split(&*model, model.step(), &dataset, split, args.limit, args.pinhole, &out, &mut progress)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&evaluation.report)?);
    } else {
        evaluation.lines.iter().for_each(|line| println!("{line}"));
    }
    Ok(())
}

fn itm(args: &EvalArgs, split: Split, out: &Path) -> anyhow::Result<()> {
    let device = lucid_burn::backend::default_device();
    let (header, net) = lucid_itm::checkpoint::load_net(&args.checkpoint, &device)?;
    let threshold = header.config.model.mask_threshold;
    let mut images = lucid_itm::data::load(std::slice::from_ref(&args.dataset), split, threshold)
        .with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if let Some(limit) = args.limit {
        images.truncate(limit);
    }
    // The analytic baseline's boost is tuned on the dataset's training views, never on the
    // scored ones; the network may never have seen this scene at all.
    let tuning = lucid_itm::data::load(std::slice::from_ref(&args.dataset), Split::Train, threshold)
        .with_context(|| format!("reading the training views of {}", args.dataset.display()))?;
    let boost = lucid_itm::eval::best_boost(&tuning);
    let report = lucid_itm::eval::evaluate_into(&net, &images, &device, boost, out)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        report.lines().iter().for_each(|line| println!("{line}"));
    }
    Ok(())
}

fn relight(args: &EvalArgs, split: Split, out: &Path) -> anyhow::Result<()> {
    let device = lucid_burn::backend::default_device();
    let trained = lucid_relight_head::checkpoint::load_model(&args.checkpoint, &device)?;
    let data =
        OlatSet::load(&args.dataset, split).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if data.views.is_empty() {
        bail!(
            "{}: the {} split has no OLAT frames or environment truths to evaluate on",
            args.dataset.display(),
            split.name()
        );
    }
    let views = &data.views[..args.limit.unwrap_or(data.views.len()).min(data.views.len())];
    let report = lucid_relight_head::eval::evaluate_into(&trained, views, out, &device)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        report.lines().iter().for_each(|line| println!("{line}"));
    }
    Ok(())
}
