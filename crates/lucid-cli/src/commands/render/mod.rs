//! `lucid render SCENE.toml -o OUT`: path-traces a scene file.

mod model;
mod video;

use std::path::{Path, PathBuf};

use anyhow::bail;
use lucid_image::tonemap::ToneCurve;
use lucid_image::{ImageFormat, WriteOptions, write_image, write_image_with};
use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::{RenderCamera, load_scene, render};

use crate::cli::RenderArgs;

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    if args.scene.extension().is_some_and(|e| e == "lucid") || lucid_nerf::checkpoint::is_checkpoint(&args.scene) {
        return model::run(args);
    }
    if args.camera_path.is_some() || args.video.is_some() {
        bail!(
            "{}: --camera-path and --video render trained models (checkpoints), not scene files",
            args.scene.display()
        );
    }
    let format = ImageFormat::from_path(&args.output)?;
    if !matches!(format, ImageFormat::Exr | ImageFormat::Png) {
        bail!("{}: render writes .exr or .png (with the other beside it)", args.output.display());
    }
    let mut loaded = load_scene(&args.scene)?;
    crate::commands::override_samples(&mut loaded.settings, args.spp, args.seed)?;
    crate::commands::override_integrator(&mut loaded, args.integrator, &args.scene.display().to_string())?;
    if let Some(depth) = args.max_depth {
        if depth == 0 {
            bail!("--max-depth must be at least 1");
        }
        loaded.settings.path.max_depth = depth;
    }
    if args.width.is_some() || args.height.is_some() {
        loaded.camera = resized(&loaded.camera, args.width, args.height)?;
    }
    let k = match &loaded.camera {
        RenderCamera::Pinhole(c) => c.intrinsics,
        RenderCamera::ThinLens(c) => c.pinhole.intrinsics,
    };
    tracing::info!(
        "rendering {} at {}x{}, {} spp, {} integrator",
        args.scene.display(),
        k.width,
        k.height,
        loaded.settings.spp,
        loaded.settings.integrator.name()
    );
    crate::commands::check_image_memory(k.width, k.height, 160.0, "--width/--height, or the scene's camera")?;
    // One writer per output (a missing folder is reported when the images are written).
    let parent = args.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    let _lock = parent.is_dir().then(|| lucid_image::output::OutputLock::file(&args.output)).transpose()?;
    let bar = crate::progress::bar(k.height as u64, "rendering");
    let started = std::time::Instant::now();
    let out = render(&loaded.scene, &loaded.camera, &loaded.settings, &|rows| bar.set_position(rows as u64))
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene.display()))?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();

    let paths = OutputPaths::new(&args.output);
    write_image(&paths.exr, &out.colour)?;
    write_image(&paths.png, &ToneCurve::Clip.map_image(&out.colour, 0.0))?;
    write_image_with(&paths.depth, &out.depth, WriteOptions { single_channel: true, ..Default::default() })?;
    write_image(&paths.normal, &out.normal)?;
    write_image(&paths.albedo, &out.albedo)?;
    let mean = out.colour.mean();
    let samples = k.width as f64 * k.height as f64 * loaded.settings.spp as f64;
    println!(
        "rendered {}x{} at {} spp ({}) in {seconds:.2} s ({:.2} M samples/s); image mean {:.5} (r {:.5} g {:.5} b {:.5})",
        k.width,
        k.height,
        loaded.settings.spp,
        loaded.settings.integrator.name(),
        samples / seconds / 1e6,
        (mean[0] + mean[1] + mean[2]) / 3.0,
        mean[0],
        mean[1],
        mean[2]
    );
    println!("wrote {} (+ .png, _depth, _normal, _albedo)", paths.exr.display());
    Ok(())
}

/// The camera at another resolution with the same horizontal field of view.
fn resized(camera: &RenderCamera, width: Option<u32>, height: Option<u32>) -> anyhow::Result<RenderCamera> {
    let pinhole = match camera {
        RenderCamera::Pinhole(c) => c,
        RenderCamera::ThinLens(c) => &c.pinhole,
    };
    let k = pinhole.intrinsics;
    let (w, h) = (width.unwrap_or(k.width), height.unwrap_or(k.height));
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("image size {w}x{h} must be 1..=16384 pixels per side");
    }
    let p = PinholeCamera::new(Intrinsics::from_fov_x(w, h, k.fov_x()), pinhole.camera_to_world);
    Ok(match camera {
        RenderCamera::Pinhole(_) => RenderCamera::Pinhole(p),
        RenderCamera::ThinLens(c) => RenderCamera::ThinLens(lucid_scene::ThinLensCamera { pinhole: p, ..*c }),
    })
}

struct OutputPaths {
    exr: PathBuf,
    png: PathBuf,
    depth: PathBuf,
    normal: PathBuf,
    albedo: PathBuf,
}

impl OutputPaths {
    fn new(output: &Path) -> Self {
        let stem = output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "render".into());
        let sibling = |suffix: &str, ext: &str| output.with_file_name(format!("{stem}{suffix}.{ext}"));
        Self {
            exr: sibling("", "exr"),
            png: sibling("", "png"),
            depth: sibling("_depth", "exr"),
            normal: sibling("_normal", "exr"),
            albedo: sibling("_albedo", "exr"),
        }
    }
}
