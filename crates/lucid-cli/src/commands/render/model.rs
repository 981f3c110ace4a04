//! `lucid render CHECKPOINT -o DIR --path orbit|spiral --frames N`, or `--camera-path FILE`:
//! novel views of a trained model along a camera path, as numbered PNGs with depth EXRs and
//! the path itself (`camera_path.json`, nerfstudio's format), and with `--video FILE` as one
//! animated PNG that plays in a browser, or a video ffmpeg encodes (see [`super::video`]).
//! `--aperture A --focus D` renders through a thin lens (depth of field) by averaging rays
//! over the aperture; without them, each camera of a path renders through its own lens where
//! the path gives one (`aperture_radius`, `focus_distance`: a refocus pull keyed in `lucid
//! view`).
//!
//! A model trained on a capture works in normalised coordinates; everything this command
//! reads and writes is in the dataset's own frame instead (camera paths, depth, and the
//! lengths `--radius`, `--aperture` and `--focus`), so it lines up with the dataset's cameras.

use std::f32::consts::TAU;

use anyhow::bail;
use glam::Vec3;
use lucid_image::{WriteOptions, write_image_with};
use lucid_scene::camera_path::{CameraPath, read_camera_path, write_camera_path};
use lucid_scene::dataset::SceneNormalisation;
use lucid_scene::{Intrinsics, PinholeCamera, look_at};

use crate::cli::{CameraPathArg, RenderArgs};
use lucid_session::SceneModel;

/// Frame rate written into the path of an orbit or spiral.
const FPS: f64 = 30.0;

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // --frames, --width, --height, --aperture and --focus are range-checked as they are parsed.
    let model = crate::loaded_model::open(&args.scene, &args.nerf)?;
    let frame = model.view().frame;
    // Lengths on the command line are the dataset's; the model measures in the scene's.
    let to_scene = |length: f32| frame.map_or(length, |n| length * n.scale as f32);
    // Lenses stay in the dataset's units here (they are written back with the path).
    let (cameras, path_lenses, fps) = match &args.camera_path {
        Some(file) => {
            let path = read_camera_path(file)?;
            let cameras = path.cameras.iter().map(|c| resized(c, args.width, args.height)).collect();
            (in_frame(cameras, frame.as_ref(), SceneNormalisation::pose_to_scene), path.lenses, path.fps)
        }
        None => {
            let cameras = path_cameras(&args, &*model, args.radius.map(to_scene))?;
            let lenses = vec![None; cameras.len()];
            (cameras, lenses, FPS)
        }
    };
    // --aperture and --focus hold for every frame; otherwise each frame has the path's lens.
    let lenses: Vec<Option<(f32, f32)>> = match args.aperture.zip(args.focus) {
        Some(lens) => vec![Some(lens).filter(|(a, _)| *a > 0.0); cameras.len()],
        None => path_lenses,
    };

    let k = cameras[0].intrinsics;
    // Rays, their sums and the frame's images, per pixel.
    crate::commands::check_image_memory(k.width, k.height, 96.0, "--width/--height, or the path's render size")?;
    // Never over the path file or the checkpoint this render reads, nor into someone's folder.
    let mut inputs = vec![args.scene.as_path()];
    inputs.extend(args.camera_path.as_deref());
    let folder = lucid_image::owned_folder::OwnedFolder::claim(&args.output, "lucid render", &inputs)?;
    if let Some(video) = &args.video {
        crate::commands::refuse_output_over_input(video, &inputs)?;
    }
    // Before anything is written: a video format without its encoder fails here.
    let mut video = match &args.video {
        Some(path) => {
            Some(super::video::Video::create(path, k.width as usize, k.height as usize, cameras.len() as u32, fps)?)
        }
        None => None,
    };
    let bar = crate::progress::bar(cameras.len() as u64, "rendering");
    let started = std::time::Instant::now();
    {
        for (k, camera) in cameras.iter().enumerate() {
            let lens = lenses[k].map(|(a, f)| (to_scene(a), to_scene(f)));
            let out = model.render_view(camera, lens, args.lens_rays, k as u64);
            // Written from the encoded colours as the viewer sends them: the same pixels.
            let png = lucid_image::encoded_png(&out.colour, false)?;
            let file = args.output.join(format!("frame_{k:04}.png"));
            lucid_image::write_atomically(&file, |w| {
                std::io::Write::write_all(w, &png).map_err(|e| lucid_image::ImageError::io(&file, e))
            })?;
            if let Some(video) = &mut video {
                video.push(&out.linear_colour())?;
            }
            let depth = out.depth_image(frame.as_ref());
            let depth_options = WriteOptions { single_channel: true, ..Default::default() };
            write_image_with(args.output.join(format!("frame_{k:04}_depth.exr")), &depth, depth_options)?;
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    if let Some(video) = video {
        video.finish(&args.output, fps)?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let path_file = args.output.join("camera_path.json");
    let written = CameraPath {
        cameras: in_frame(cameras.clone(), frame.as_ref(), SceneNormalisation::pose_to_dataset),
        lenses,
        fps,
    };
    write_camera_path(&path_file, &written)?;
    folder.finish()?;
    println!(
        "rendered {} frames of {}x{} in {seconds:.1} s ({:.3} s per frame) -> {} (path: {}{})",
        cameras.len(),
        k.width,
        k.height,
        seconds / cameras.len() as f64,
        args.output.display(),
        path_file.display(),
        if frame.is_some() { ", in the dataset's frame" } else { "" }
    );
    Ok(())
}

/// The orbit or spiral around the model's centre (scene coordinates), at `radius` or the
/// training cameras' distance.
fn path_cameras(args: &RenderArgs, model: &dyn SceneModel, radius: Option<f32>) -> anyhow::Result<Vec<PinholeCamera>> {
    let view = model.view();
    let (w, h) = (args.width.unwrap_or(view.width), args.height.unwrap_or(view.height));
    let radius = radius.unwrap_or(view.radius);
    if !(radius.is_finite() && radius > 0.0) {
        bail!("--radius must be positive, got {radius}");
    }
    let centre = model.centre();
    let intrinsics = Intrinsics::from_fov_x(w, h, view.fov_x);
    Ok((0..args.frames)
        .map(|k| {
            let u = k as f32 / args.frames as f32;
            let (azimuth, elevation) = match args.path {
                CameraPathArg::Orbit => (TAU * u, args.elevation),
                CameraPathArg::Spiral => (2.0 * TAU * u, args.elevation + 20.0 * (TAU * u).sin()),
            };
            let e = elevation.to_radians();
            let eye = centre + radius * Vec3::new(e.cos() * azimuth.cos(), e.cos() * azimuth.sin(), e.sin());
            PinholeCamera::new(intrinsics, look_at(eye, centre, Vec3::Z))
        })
        .collect())
}

/// `camera` at another image size, where one is asked for (focal lengths scale with it).
fn resized(camera: &PinholeCamera, width: Option<u32>, height: Option<u32>) -> PinholeCamera {
    let k = camera.intrinsics;
    PinholeCamera { intrinsics: k.resized(width.unwrap_or(k.width), height.unwrap_or(k.height)), ..*camera }
}

/// The cameras' poses mapped by `map` of the dataset's normalisation, if it has one.
fn in_frame(
    mut cameras: Vec<PinholeCamera>,
    frame: Option<&SceneNormalisation>,
    map: fn(&SceneNormalisation, glam::DMat4) -> glam::DMat4,
) -> Vec<PinholeCamera> {
    if let Some(n) = frame {
        for c in &mut cameras {
            c.camera_to_world = map(n, c.camera_to_world.as_dmat4()).as_mat4();
        }
    }
    cameras
}
