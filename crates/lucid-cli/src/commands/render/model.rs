//! `lucid render CHECKPOINT -o DIR --path orbit|spiral --frames N`: novel views of a trained
//! model along a camera path, as numbered PNGs with depth EXRs; `--aperture A --focus D`
//! renders through a thin lens (depth of field) by averaging rays over the aperture.

use std::f32::consts::TAU;

use anyhow::{Context, bail};
use glam::Vec3;
use lucid_image::{WriteOptions, write_image, write_image_with};
use lucid_scene::{Intrinsics, PinholeCamera, look_at};

use crate::cli::{CameraPathArg, RenderArgs};
use crate::loaded_model::LoadedModel;

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if let (Some(a), Some(f)) = (args.aperture, args.focus)
        && !(a.is_finite() && a >= 0.0 && f.is_finite() && f > 0.0)
    {
        bail!("--aperture must be zero or positive and --focus positive, got {a} and {f}");
    }
    let loaded = LoadedModel::load(&args.scene)?;
    let view = loaded.view();
    let (w, h) = (args.width.unwrap_or(view.width), args.height.unwrap_or(view.height));
    if w == 0 || h == 0 {
        bail!("--width and --height must be positive");
    }
    let radius = args.radius.unwrap_or(view.radius);
    if !(radius.is_finite() && radius > 0.0) {
        bail!("--radius must be positive, got {radius}");
    }
    let centre = loaded.centre();
    let intrinsics = Intrinsics::from_fov_x(w, h, view.fov_x);
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    let lens = args.aperture.zip(args.focus);
    let bar = crate::progress::bar(args.frames as u64, "rendering");
    let started = std::time::Instant::now();
    loaded.with_renderer(|renderer| -> anyhow::Result<()> {
        for k in 0..args.frames {
            let u = k as f32 / args.frames as f32;
            let (azimuth, elevation) = match args.path {
                CameraPathArg::Orbit => (TAU * u, args.elevation),
                CameraPathArg::Spiral => (2.0 * TAU * u, args.elevation + 20.0 * (TAU * u).sin()),
            };
            let e = elevation.to_radians();
            let eye = centre + radius * Vec3::new(e.cos() * azimuth.cos(), e.cos() * azimuth.sin(), e.sin());
            let camera = PinholeCamera::new(intrinsics, look_at(eye, centre, Vec3::Z));
            let out = renderer.render_view(&camera, lens, args.lens_rays, k as u64);
            write_image(args.output.join(format!("frame_{k:04}.png")), &out.linear_colour())?;
            let depth_options = WriteOptions { single_channel: true, ..Default::default() };
            write_image_with(args.output.join(format!("frame_{k:04}_depth.exr")), &out.depth_image(), depth_options)?;
            bar.inc(1);
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    println!(
        "rendered {} frames of {w}x{h} in {seconds:.1} s ({:.3} s per frame) -> {}",
        args.frames,
        seconds / args.frames as f64,
        args.output.display()
    );
    Ok(())
}
