//! `lucid tonemap IN -o OUT --op ...`: HDR radiance to a display image.

use std::time::Instant;

use anyhow::Context;
use lucid_hdr::tonemap::{ToneMapper, tone_map};
use lucid_image::{ImageFormat, read_image, write_image};

use crate::cli::{TonemapArgs, TonemapOp};

/// The operator with the command line's parameters over its defaults.
fn operator(args: &TonemapArgs) -> ToneMapper {
    let exposure = args.exposure.unwrap_or(0.0);
    let key = args.key.unwrap_or(0.18);
    match args.op {
        TonemapOp::Linear => ToneMapper::Linear { exposure },
        TonemapOp::Reinhard => ToneMapper::Reinhard { key, white: args.white },
        TonemapOp::Drago => ToneMapper::Drago { bias: args.bias.unwrap_or(0.85), exposure },
        TonemapOp::Aces => ToneMapper::Aces { exposure },
        TonemapOp::Photographic => ToneMapper::Photographic {
            key,
            sharpening: args.sharpening.unwrap_or(8.0),
            threshold: args.threshold.unwrap_or(0.05),
        },
        TonemapOp::Bilateral => ToneMapper::Bilateral {
            contrast: args.contrast.unwrap_or(5.0),
            spatial_sigma: args.spatial_sigma.unwrap_or(0.02),
            range_sigma: args.range_sigma.unwrap_or(0.4),
        },
    }
}

pub fn run(args: TonemapArgs) -> anyhow::Result<()> {
    ImageFormat::from_path(&args.output)?;
    super::refuse_output_over_input(&args.output, &[&args.input])?;
    let op = operator(&args);
    op.validate().context("bad tone-mapping parameters")?;
    let image = read_image(&args.input)?;
    if !image.is_finite() {
        anyhow::bail!("{}: the image has NaN or infinite values", args.input.display());
    }
    let start = Instant::now();
    let display = tone_map(&image, &op, args.saturation).context("bad tone-mapping parameters")?;
    let seconds = start.elapsed().as_secs_f64();
    write_image(&args.output, &display)?;
    tracing::info!(
        "tone mapped {} ({}x{}) with {:?} in {:.3} s -> {}",
        args.input.display(),
        image.width(),
        image.height(),
        op,
        seconds,
        args.output.display()
    );
    Ok(())
}
