//! One module per subcommand; each exposes `run(args) -> anyhow::Result<()>`.

mod bench;
mod brdf;
pub(crate) mod brdf_neural;
mod convert;
pub mod demo;
mod dual;
mod envmap;
mod eval;
mod export_web;
pub mod generate;
mod hdr;
mod info;
mod lightstage;
mod metrics;
mod refocus;
mod relight;
mod render;
mod tonemap;
mod train;
mod train_relight;
mod view;

use anyhow::{Context, bail};

use lucid_session::methods;

use crate::cli::{Command, TrainModel};

/// Runs one subcommand.
/// `matches` are the parsed arguments, for commands that need to know which options were
/// given explicitly.
pub fn run(command: Command, matches: &clap::ArgMatches) -> anyhow::Result<()> {
    match command {
        Command::Demo(args) => demo::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Metrics(args) => metrics::run(args),
        Command::Info(args) => info::run(args),
        Command::Render(args) => render::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Gen(args) => generate::run(args, matches.subcommand_matches("gen").expect("gen was parsed")),
        Command::Refocus(args) => refocus::run(args),
        Command::Train(args) => match args.model {
            TrainModel::Nerf(args) => train::run::<methods::Nerf>(args.request(), args.view),
            TrainModel::Splat(args) => train::run::<methods::Splat>(args.request(), args.view),
            TrainModel::Itm(args) => train::run::<methods::Itm>(args.request(), None),
            TrainModel::Relight(args) => train_relight::run_relight(args),
        },
        Command::Eval(args) => eval::run(args),
        Command::Hdr(args) => hdr::run(args),
        Command::Tonemap(args) => tonemap::run(args),
        Command::Relight(args) => relight::run(args),
        Command::Envmap(args) => envmap::run(args),
        Command::View(args) => view::run(args),
        Command::Export(args) => match args.command {
            crate::cli::ExportCommand::Web(args) => export_web::run(args),
        },
        Command::Brdf(args) => brdf::run(args.command),
        Command::Lightstage(args) => lightstage::run(args.command),
        Command::Dual(args) => dual::run(args),
    }
}

/// Applies `--spp` and `--seed` overrides to a scene's render settings.
/// Refuses to write over `path`: outputs that are files go to new names.
pub(crate) fn refuse_existing(path: &std::path::Path) -> anyhow::Result<()> {
    anyhow::ensure!(!path.exists(), "{}: already exists (give a new file)", path.display());
    Ok(())
}

/// Refuses an output file that is one of the command's inputs (the same file under any name):
/// a conversion never replaces what it reads.
pub(crate) fn refuse_output_over_input(output: &std::path::Path, inputs: &[&std::path::Path]) -> anyhow::Result<()> {
    let Ok(out) = output.canonicalize() else { return Ok(()) };
    for input in inputs {
        anyhow::ensure!(
            input.canonicalize().ok().as_deref() != Some(out.as_path()),
            "{}: is this command's input too; give another output file",
            output.display()
        );
    }
    Ok(())
}

pub fn override_samples(
    settings: &mut lucid_trace::RenderSettings,
    spp: Option<u32>,
    seed: Option<u64>,
) -> anyhow::Result<()> {
    if let Some(spp) = spp {
        if spp == 0 {
            bail!("--spp must be at least 1");
        }
        settings.spp = spp;
    }
    if let Some(seed) = seed {
        settings.seed = seed;
    }
    Ok(())
}

/// Applies an `--integrator` override to a loaded scene, refusing one that cannot render it.
pub fn override_integrator(
    loaded: &mut lucid_trace::LoadedScene,
    integrator: Option<lucid_trace::Integrator>,
    scene: &str,
) -> anyhow::Result<()> {
    if let Some(integrator) = integrator {
        integrator
            .supports(&loaded.scene)
            .map_err(|e| anyhow::anyhow!("{scene}: --integrator {}: {e}", integrator.name()))?;
        // A scene that already uses this integrator keeps its own parameters (photons, VPLs).
        if std::mem::discriminant(&integrator) != std::mem::discriminant(&loaded.settings.integrator) {
            loaded.settings.integrator = integrator;
        }
    }
    Ok(())
}

/// Parses a background colour: `white`, `black`, `grey`, or `R,G,B` with components in [0,1].
pub fn parse_background(text: &str) -> anyhow::Result<[f32; 3]> {
    match text.to_ascii_lowercase().as_str() {
        "white" => return Ok([1.0; 3]),
        "black" => return Ok([0.0; 3]),
        "grey" | "gray" => return Ok([0.5; 3]),
        _ => {}
    }
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        bail!("background {text:?}: expected white, black, grey or R,G,B");
    }
    let mut rgb = [0.0f32; 3];
    for (c, part) in rgb.iter_mut().zip(&parts) {
        let v: f32 = part.parse().with_context(|| format!("background {text:?}: {part:?} is not a number"))?;
        if !(0.0..=1.0).contains(&v) {
            bail!("background {text:?}: components must be in [0, 1]");
        }
        *c = v;
    }
    Ok(rgb)
}

/// Refuses an image of `width`×`height` pixels whose buffers (`bytes_per_pixel` in all) would
/// not fit in the memory this process may use; `what` names the flags that set the size.
pub fn check_image_memory(width: u32, height: u32, bytes_per_pixel: f64, what: &str) -> anyhow::Result<()> {
    let mut estimate = lucid_burn::memory::MemoryEstimate::new();
    estimate.add(format!("a {width}x{height} image ({what})"), f64::from(width) * f64::from(height) * bytes_per_pixel);
    let available = lucid_burn::memory::available().map_err(anyhow::Error::msg)?;
    estimate.check(available).map_err(anyhow::Error::msg)
}

/// Writes a text file atomically (temporary name, then rename); errors name the file.
pub fn write_text(path: &std::path::Path, text: &str) -> anyhow::Result<()> {
    lucid_image::output::write_text(path, text).with_context(|| path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backgrounds_parse_and_bad_ones_are_rejected() {
        assert_eq!(parse_background("White").unwrap(), [1.0; 3]);
        assert_eq!(parse_background("0.1, 0.2,0.3").unwrap(), [0.1, 0.2, 0.3]);
        for bad in ["blue", "1,2", "0.5,0.5,NaN", "0.5,0.5,1.5", "a,b,c"] {
            assert!(parse_background(bad).is_err(), "{bad}");
        }
    }
}
