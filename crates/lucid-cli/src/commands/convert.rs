//! `lucid convert IN OUT`: any supported image format to any other.

use anyhow::Context;
use lucid_image::tonemap::ToneCurve;
use lucid_image::{ExrPrecision, ImageFormat, PngBitDepth, WriteOptions, read_image, write_image_with};

use crate::cli::{ConvertArgs, ToneCurveArg};

pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    // --exposure is range-checked as it is parsed. Check the output before doing any work.
    let out_format = ImageFormat::from_path(&args.output)?;
    super::refuse_output_over_input(&args.output, &[&args.input])?;
    let background = args.background.as_deref().map(super::parse_background).transpose()?;
    let image = read_image(&args.input)?;
    let bad = image.non_finite_count();
    if bad > 0 && !out_format.stores_non_finite() {
        anyhow::bail!(
            "{}: {bad} values are NaN or infinite, which {} cannot store (they would come out black); nothing written: convert to EXR or PFM, or fix the image",
            args.input.display(),
            out_format.name()
        );
    }
    let image = if out_format.has_alpha() || !image.has_alpha() {
        image
    } else {
        // Straight colour written without its alpha brightens anti-aliased edges; composite.
        if background.is_none() {
            tracing::warn!(
                "{} has transparent pixels and {} stores no alpha: composited over black (choose with --background)",
                args.input.display(),
                out_format.name()
            );
        }
        lucid_image::color::composite_over(&image, background.unwrap_or([0.0; 3]))
    };
    let curve = match args.tone_curve {
        ToneCurveArg::Clip => ToneCurve::Clip,
        ToneCurveArg::Reinhard => ToneCurve::Reinhard,
        ToneCurveArg::Aces => ToneCurve::Aces,
    };
    let converted = if out_format.is_hdr() {
        lucid_image::color::apply_exposure(&image, args.exposure)
    } else {
        curve.map_image(&image, args.exposure)
    };
    // A finite input can still overflow (a bright pixel pushed by many stops, or a half EXR).
    let overflow = converted.non_finite_count() - bad.min(converted.non_finite_count());
    let half_max = f32::from(half::f16::MAX);
    let beyond_half = args.half && converted.pixels().iter().flatten().any(|v| v.is_finite() && v.abs() > half_max);
    if overflow > 0 || beyond_half {
        anyhow::bail!(
            "{}: --exposure {} takes values past what {} can hold; nothing written",
            args.input.display(),
            args.exposure,
            if beyond_half { "a half-float EXR" } else { "a 32-bit float" }
        );
    }
    let options = WriteOptions {
        exr_precision: if args.half { ExrPrecision::Half } else { ExrPrecision::Float },
        png_bit_depth: if args.png16 { PngBitDepth::Sixteen } else { PngBitDepth::Eight },
        single_channel: false,
    };
    write_image_with(&args.output, &converted, options).with_context(|| "conversion failed".to_string())?;
    tracing::info!(
        "wrote {} ({}x{}, {})",
        args.output.display(),
        converted.width(),
        converted.height(),
        out_format.name()
    );
    Ok(())
}
