//! `lucid eval CHECKPOINT DATASET` for an ITM checkpoint: the network against the analytic
//! baseline and the plain inverse response on a split's bracket frames; writes each
//! prediction as EXR and metrics.json.

use std::path::Path;

use anyhow::Context;
use lucid_image::{Image, write_image};
use lucid_itm::data::load;
use lucid_itm::eval::{ItmReport, analytic, evaluate, predict};
use lucid_scene::Split;

use crate::cli::EvalArgs;

/// Prints the report as a table.
pub fn print_report(r: &ItmReport) {
    println!("ITM on {} held-out exposures ({:.2} % of pixels clipped)", r.images, 100.0 * r.clipped_fraction);
    println!("{:<18} {:>18} {:>14} {:>20}", "method", "log-PSNR clipped", "log-PSNR all", "tone-mapped PSNR");
    for (name, s) in [("network", &r.network), ("analytic", &r.analytic), ("inverse response", &r.inverse_response)] {
        println!("{name:<18} {:>18.2} {:>14.2} {:>20.2}", s.log_psnr_clipped, s.log_psnr, s.tonemapped_psnr);
    }
}

fn planar_image(v: &[f32], w: usize, h: usize) -> Image {
    let n = w * h;
    Image::from_fn(w, h, |x, y| {
        let i = y * w + x;
        [v[i], v[n + i], v[2 * n + i], 1.0]
    })
}

pub fn run(args: &EvalArgs, split: Split) -> anyhow::Result<()> {
    let device = lucid_burn::backend::default_device();
    let loaded = lucid_itm::checkpoint::load(&args.checkpoint, &device)?;
    let threshold = loaded.trainer.config.model.mask_threshold;
    let mut images = load(std::slice::from_ref(&args.dataset), split, threshold)
        .with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    if let Some(limit) = args.limit {
        images.truncate(limit);
    }
    let net = &loaded.trainer.net;
    let report = evaluate(net, &images, &device);
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.checkpoint.parent().unwrap_or(Path::new(".")).join(format!("eval_{}", split.name())));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    for (k, img) in images.iter().enumerate() {
        let (w, h) = (img.width, img.height);
        write_image(out.join(format!("{k:03}_network.exr")), &planar_image(&predict(net, img, &device), w, h))?;
        write_image(out.join(format!("{k:03}_analytic.exr")), &planar_image(&analytic(img), w, h))?;
        write_image(out.join(format!("{k:03}_truth.exr")), &planar_image(&img.truth, w, h))?;
    }
    let json = serde_json::to_string_pretty(&report)?;
    super::write_text(&out.join("metrics.json"), &json)?;
    if args.json {
        println!("{json}");
    } else {
        print_report(&report);
    }
    Ok(())
}
