//! `lucid dual`: dual photography of a scene's projector and camera.

use anyhow::{Context, bail};
use lucid_datasets_gen::dual::{DualSettings, capture, linear_psnr, reciprocal_render};
use lucid_trace::RenderCamera;
use lucid_trace::light::Light;
use serde_json::json;

use crate::cli::DualArgs;

pub fn run(args: DualArgs) -> anyhow::Result<()> {
    if args.block == 0 || args.block > 64 {
        bail!("--block {} must be in 1..=64", args.block);
    }
    if !(args.threshold.is_finite() && (0.0..1.0).contains(&args.threshold)) {
        bail!("--threshold {} must be in [0, 1)", args.threshold);
    }
    let mut loaded = lucid_datasets_gen::builtin::load_named_scene(&args.scene)?;
    crate::commands::override_samples(&mut loaded.settings, args.spp, None)?;
    let RenderCamera::Pinhole(camera) = loaded.camera else {
        bail!("{}: dual photography needs a pinhole camera (no aperture)", args.scene)
    };
    let Some(projector) = loaded.scene.lights.iter().find_map(|l| match l {
        Light::Projector(p) => Some(p.as_ref().clone()),
        _ => None,
    }) else {
        bail!("{}: the scene has no projector light ([[lights]] type = \"projector\")", args.scene)
    };
    let (m, n) = projector.resolution();
    if m * n > 65_536 {
        bail!(
            "{}: the projector has {m}×{n} pixels; dual photography renders once per pixel (at most 65536)",
            args.scene
        );
    }
    let out = &args.output;
    if let Ok(mut entries) = std::fs::read_dir(out)
        && entries.next().is_some()
    {
        bail!("{}: not empty (give a new folder)", out.display());
    }
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let _lock = lucid_image::output::OutputLock::folder(out)?;
    let settings = DualSettings { adaptive: args.adaptive, block: args.block, threshold: args.threshold };
    let started = std::time::Instant::now();
    let result = crate::progress::with_bar("rendering patterns", |progress| {
        capture(&loaded.scene, &camera, &loaded.settings, &projector, &settings, progress)
    })
    .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene))?;
    let seconds = started.elapsed().as_secs_f64();
    lucid_image::write_image(out.join("dual.exr"), &result.dual)?;
    lucid_image::write_image(out.join("primal.exr"), &result.primal)?;
    let check = match args.check_spp {
        Some(0) => bail!("--check-spp must be at least 1"),
        Some(spp) => {
            let reference_settings = lucid_trace::RenderSettings { spp, ..loaded.settings };
            let reference = reciprocal_render(&loaded.scene, &camera, &reference_settings, &projector)
                .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene))?;
            lucid_image::write_image(out.join("reciprocal.exr"), &reference)?;
            Some(linear_psnr(&result.dual, &reference))
        }
        None => None,
    };
    let report = json!({
        "scene": args.scene,
        "projector": [m, n],
        "camera": [camera.intrinsics.width, camera.intrinsics.height],
        "adaptive": args.adaptive,
        "block": args.adaptive.then_some(args.block),
        "threshold": args.adaptive.then_some(args.threshold),
        "spp": loaded.settings.spp,
        "renders": result.renders,
        "pixel_renders": result.pixel_renders,
        "saved_renders": result.pixel_renders.saturating_sub(result.renders),
        "seconds": seconds,
        "psnr_against_reciprocal": check,
    });
    let text = serde_json::to_string_pretty(&report)?;
    lucid_image::write_atomically(&out.join("dual.json"), |w| {
        use std::io::Write;
        w.write_all(text.as_bytes()).map_err(|e| anyhow::anyhow!("{}: {e}", out.join("dual.json").display()))
    })?;
    if args.json {
        println!("{text}");
    } else {
        println!(
            "{m}×{n} projector, {} renders ({} one pixel at a time{}) in {seconds:.1} s; wrote {}/dual.exr and primal.exr",
            result.renders,
            result.pixel_renders,
            if args.adaptive {
                format!(", {} saved", result.pixel_renders.saturating_sub(result.renders))
            } else {
                String::new()
            },
            out.display()
        );
        if let Some(p) = check {
            println!("dual image against the reciprocal render: {p:.2} dB (linear, peak = its brightest value)");
        }
    }
    Ok(())
}
