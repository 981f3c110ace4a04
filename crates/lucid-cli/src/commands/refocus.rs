//! `lucid refocus DATASET --focus D --aperture R -o OUT`: shift-and-add refocusing.

use anyhow::Context;
use lucid_datasets_gen::refocus;
use lucid_image::tonemap::ToneCurve;
use lucid_image::{ImageFormat, write_image};
use lucid_scene::Dataset;

use crate::cli::RefocusArgs;

pub fn run(args: RefocusArgs) -> anyhow::Result<()> {
    let format = ImageFormat::from_path(&args.output)?;
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading light field {}", args.dataset.display()))?;
    let image = refocus(&dataset, args.focus, args.aperture)?;
    let image = if format.is_hdr() { image } else { ToneCurve::Clip.map_image(&image, 0.0) };
    write_image(&args.output, &image)?;
    println!(
        "refocused {} at {} (aperture {}) into {}",
        args.dataset.display(),
        args.focus,
        args.aperture,
        args.output.display()
    );
    Ok(())
}
