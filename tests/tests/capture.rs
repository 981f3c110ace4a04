//! Captures end to end: `lucid gen garden --rig capture` writes photographs and a COLMAP model
//! that Lucid (and COLMAP's conventions) read back as the scene that was rendered, and the
//! trainers learn the unbounded scene from it.

use std::path::Path;

use glam::Vec2;
use lucid_scene::{Camera, Dataset, Split};
use lucid_tests::{lucid_in, temp_dir};

fn capture(d: &Path, name: &str, extra: &[&str]) {
    let args = [
        &["gen", "garden", "--rig", "capture", "-o", name, "--res", "64", "--height", "48"][..],
        &["--images", "16", "--spp", "4", "--points", "3000", "-q"][..],
        extra,
    ]
    .concat();
    lucid_in(d, &args).success();
}

/// A capture big enough to learn from: 40 photographs of 96×72.
fn learnable_capture(d: &Path, name: &str, extra: &[&str]) {
    let args = [
        &["gen", "garden", "--rig", "capture", "-o", name, "--res", "96", "--height", "72"][..],
        &["--images", "40", "--spp", "8", "--points", "5000", "--fov", "60", "-q"][..],
        extra,
    ]
    .concat();
    lucid_in(d, &args).success();
}

/// Trains `kind` on `dataset` into `out` with `args` and returns the held-out PSNR.
fn trained_psnr(d: &Path, kind: &str, dataset: &str, out: &str, args: &[&str]) -> f64 {
    lucid_in(d, &[&["train", kind, dataset, "-o", out][..], args].concat()).success();
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join(out).join("eval_test/metrics.json")).unwrap()).unwrap();
    metrics["summary"]["psnr"].as_f64().unwrap()
}

/// The nearest training photograph as the prediction of each test photograph.
fn baseline(dataset: &Path) -> f64 {
    use lucid_scene::dataset::images::ImageSet;
    let ds = Dataset::open(dataset).unwrap();
    let train = ImageSet::load(ds.frames(Split::Train)).unwrap();
    let test = ImageSet::load(ds.frames(Split::Test)).unwrap();
    lucid_scene::evaluation::nearest_view_psnr(&train, &test, [1.0; 3]).unwrap()
}

#[test]
fn nerf_and_splats_learn_an_unbounded_capture_beyond_the_nearest_view() {
    let dir = temp_dir();
    let d = dir.path();
    learnable_capture(d, "cap", &[]);
    let floor = baseline(&d.join("cap"));
    let splat = trained_psnr(d, "splat", "cap", "s", &["--steps", "1500"]);
    let nerf = trained_psnr(d, "nerf", "cap", "n", &NERF_STEPS);
    println!("nearest training view {floor:.2} dB, 3DGS {splat:.2} dB, NeRF {nerf:.2} dB");
    assert!(splat > floor + SPLAT_MARGIN, "3DGS {splat:.2} dB against the nearest view's {floor:.2} dB");
    assert!(nerf > floor + NERF_MARGIN, "NeRF {nerf:.2} dB against the nearest view's {floor:.2} dB");
}

// Measured on this 2-core machine (deterministic step budgets): nearest view 14.96 dB,
// 3DGS 22.62 dB (+7.66), NeRF 18.58 dB (+3.62; 300 steps is a short run for a field).
const SPLAT_MARGIN: f64 = 7.2;
const NERF_MARGIN: f64 = 3.2;
/// The NeRF's budget in these tests: 300 steps of 2^15 samples, the batch their floors were
/// measured with (the default batch halved when rays began to be cut where they stop, which
/// early in training, before surfaces are sharp, leaves fewer rays per step).
const NERF_STEPS: [&str; 4] = ["--steps", "300", "--set", "train.batch_samples=32768"];
// Measured: 23.48 dB through the lens, 21.75 dB with the camera rewritten as a pinhole.
const LENS_MARGIN: f64 = 1.2;

#[test]
fn a_distorted_capture_trains_worse_when_its_lens_is_ignored() {
    use lucid_scene::colmap::{ColmapCamera, ColmapModel, binary};
    let dir = temp_dir();
    let d = dir.path();
    learnable_capture(d, "lens", &["--k1", "-0.2"]);
    // The same photographs and poses, the camera written as a pinhole.
    let model = ColmapModel::read(&d.join("lens/sparse/0")).unwrap();
    let k = model.cameras[&1].intrinsics().unwrap().without_distortion();
    std::fs::create_dir_all(d.join("pinhole/sparse/0")).unwrap();
    for file in ["images.bin", "points3D.bin"] {
        std::fs::copy(d.join("lens/sparse/0").join(file), d.join("pinhole/sparse/0").join(file)).unwrap();
    }
    let cameras = std::collections::BTreeMap::from([(1, ColmapCamera::from_intrinsics(1, &k).unwrap())]);
    std::fs::write(d.join("pinhole/sparse/0/cameras.bin"), binary::write::cameras(&cameras)).unwrap();
    std::fs::create_dir(d.join("pinhole/images")).unwrap();
    for f in std::fs::read_dir(d.join("lens/images")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, d.join("pinhole/images").join(f.file_name().unwrap())).unwrap();
    }
    let honoured = trained_psnr(d, "splat", "lens", "honoured", &["--steps", "1500", "--format", "colmap"]);
    let ignored = trained_psnr(d, "splat", "pinhole", "ignored", &["--steps", "1500", "--format", "colmap"]);
    println!("lens honoured {honoured:.2} dB, ignored {ignored:.2} dB");
    assert!(honoured > ignored + LENS_MARGIN, "honoured {honoured:.2} dB, ignored {ignored:.2} dB");
}

#[test]
fn a_generated_capture_reads_back_as_the_scene_rendered() {
    let dir = temp_dir();
    let d = dir.path();
    capture(d, "cap", &["--k1", "-0.06"]);
    assert!(d.join("cap/sparse/0/cameras.bin").is_file() && d.join("cap/images/img_0015.png").is_file());
    let colmap = lucid_scene::dataset::OpenOptions {
        format: Some(lucid_scene::dataset::DatasetFormat::Colmap),
        ..Default::default()
    };
    let ds = Dataset::open_with(d.join("cap"), &colmap).unwrap();
    let names: Vec<&str> = ds.frames(Split::Test).iter().map(|f| f.file_path.as_str()).collect();
    assert_eq!(names, ["img_0000.png", "img_0008.png"], "every 8th photograph is held out");
    assert_eq!(ds.frames(Split::Train).len(), 14);
    let k = ds.frames(Split::Train)[0].camera.intrinsics;
    assert_eq!(k.distortion, lucid_scene::LensDistortion::opencv(-0.06, 0.0, 0.0, 0.0));
    assert!(ds.points.len() > 500, "{} sparse points", ds.points.len());
    // Each point sits on a surface that at least three photographs saw: where it projects
    // into them, their rendered depth is the point's own depth. A pose, lens or
    // normalisation read wrongly would leave points floating off every surface.
    let n = ds.normalisation.unwrap();
    let to_dataset = |q: glam::Vec3| n.to_dataset(q.as_dvec3());
    let views: Vec<_> = ds
        .all_frames()
        .map(|f| {
            let name = f.file_path.trim_end_matches(".png");
            let depth = lucid_image::read_image(d.join(format!("cap/depth/{name}.exr"))).unwrap();
            let eye = to_dataset(f.camera.position());
            let axis = (to_dataset(f.camera.position() + f.camera.forward()) - eye).normalize();
            (f.camera, depth, eye, axis)
        })
        .collect();
    for p in ds.points.iter().step_by(5) {
        let seen_by = views
            .iter()
            .filter(|(camera, depth, eye, axis)| {
                let Some(uv) = camera.project(p.position) else { return false };
                if uv.x < 0.0 || uv.y < 0.0 || uv.x >= 64.0 || uv.y >= 48.0 {
                    return false;
                }
                let seen = f64::from(depth.get(uv.x as usize, uv.y as usize)[0]);
                let z = (to_dataset(p.position) - *eye).dot(*axis);
                (seen - z).abs() < 0.01 * z
            })
            .count();
        assert!(seen_by >= 3, "a point at {} is on a surface in {seen_by} photographs", p.position);
    }
    // And the rays through those pixels pass through the points (lens and pose agree).
    let f = &ds.frames(Split::Train)[3];
    for p in ds.points.iter().take(200) {
        let Some(uv) =
            f.camera.project(p.position).filter(|uv| uv.cmpge(Vec2::ZERO).all() && uv.x < 64.0 && uv.y < 48.0)
        else {
            continue;
        };
        let ray = f.camera.generate_ray(uv.x, uv.y, Vec2::ZERO);
        let t = (p.position - ray.origin).dot(ray.direction);
        assert!((ray.at(t) - p.position).length() < 1e-4 * t.max(1.0));
    }
}

/// What a model trained on a capture writes is in the capture's own frame, not the normalised
/// one it trained in: `splats.ply` seen through the COLMAP model's own camera is the
/// evaluation's render, a camera path in the dataset's coordinates renders that view, depth
/// is in the dataset's units, and an orbit's written path renders the orbit again.
#[test]
fn a_capture_models_outputs_are_in_the_datasets_own_frame() {
    use lucid_image::metrics::psnr;
    use lucid_scene::PinholeCamera;
    use lucid_scene::camera_path::{CameraPath, read_camera_path, write_camera_path};
    use lucid_scene::colmap::ColmapModel;
    let dir = temp_dir();
    let d = dir.path();
    capture(d, "cap", &[]);
    lucid_in(d, &["train", "splat", "cap", "-o", "s", "--steps", "1500"]).success();
    let frame = Dataset::open(d.join("cap")).unwrap().normalisation.unwrap();
    let model = ColmapModel::read(&d.join("cap/sparse/0")).unwrap();
    let image = model.images.iter().find(|im| im.name == "img_0000.png").expect("a test view");
    let k = model.cameras[&image.camera_id].intrinsics().unwrap();
    assert!(k.fx == k.fy && k.cx == 32.0 && k.cy == 24.0, "a camera a camera path can hold: {k:?}");
    let camera = PinholeCamera::new(k, image.camera_to_world().as_mat4());
    let evaluated = lucid_image::read_image(d.join("s/eval_test/img_0000.png")).unwrap();

    // The exported cloud through the dataset's camera, with the evaluation's settings (the
    // near plane in the dataset's units).
    let header = lucid_in(d, &["info", "s/checkpoint.lucid", "--json"]).success().json();
    let near = header["config"]["render"]["near"].as_f64().unwrap() * header["extent"].as_f64().unwrap() / frame.scale;
    let cloud = lucid_splat::ply::read_splat_ply(&d.join("s/splats.ply")).unwrap();
    let settings = lucid_splat::RenderSettings { near: near as f32, background: [1.0; 3], ..Default::default() };
    let (rgba, _) = lucid_splat::render(&cloud.params(), &lucid_splat::SplatCamera::from_pinhole(&camera), &settings);
    let decode = lucid_image::color::srgb_decode;
    let pixels = rgba.chunks_exact(4).map(|p| [decode(p[0]), decode(p[1]), decode(p[2]), 1.0]).collect();
    let exported = lucid_image::Image::from_pixels(64, 48, pixels);
    let agreement = psnr(&exported, &evaluated, None).unwrap();
    assert!(agreement > 40.0, "splats.ply through the dataset's camera: {agreement:.1} dB from the evaluation");

    // The same camera as a camera path.
    write_camera_path(&d.join("view.json"), &CameraPath::pinholes(vec![camera], 30.0)).unwrap();
    lucid_in(d, &["render", "s/checkpoint.lucid", "--camera-path", "view.json", "-o", "v"]).success();
    let rendered = lucid_image::read_image(d.join("v/frame_0000.png")).unwrap();
    let agreement = psnr(&rendered, &evaluated, None).unwrap();
    assert!(agreement > 40.0, "the camera path's view: {agreement:.1} dB from the evaluation");
    // Depth in the dataset's units: the evaluation's and the render's agree, and both are
    // near the renderer's true depth (depth in the scene's units would be 0.23 of it here).
    let depth = |p: &str| lucid_image::read_image(d.join(p)).unwrap().pixels().iter().map(|p| p[0]).collect::<Vec<_>>();
    let (ours, evals, truth) =
        (depth("v/frame_0000_depth.exr"), depth("s/eval_test/img_0000_depth.exr"), depth("cap/depth/img_0000.exr"));
    for (a, b) in ours.iter().zip(&evals) {
        assert!((a - b).abs() <= 1e-3 * b.abs().max(1.0), "render depth {a}, evaluation depth {b}");
    }
    let mut ratios: Vec<f32> =
        ours.iter().zip(&truth).filter(|(_, t)| t.is_finite() && **t > 0.0).map(|(a, t)| a / t).collect();
    ratios.sort_by(f32::total_cmp);
    let median = ratios[ratios.len() / 2];
    // Measured 1.03 after 1500 steps (after 400, the far sphere behind still-thin surfaces
    // pulls the expected depth up: 3.9).
    assert!((0.85..1.15).contains(&median), "median depth / true depth {median} (scale {})", frame.scale);

    // An orbit circles the capture's centre at the cameras' mean distance, in its units, and
    // its written path renders it again.
    lucid_in(d, &["render", "s/checkpoint.lucid", "-o", "orbit", "--frames", "3", "--video", "orbit.apng"]).success();
    let video = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(d.join("orbit.apng")).unwrap()));
    assert_eq!(video.read_info().unwrap().info().animation_control.map(|a| a.num_frames), Some(3));
    let path = read_camera_path(&d.join("orbit/camera_path.json")).unwrap();
    let mean = model.images.iter().map(|im| im.camera_to_world().w_axis.truncate().distance(frame.centre)).sum::<f64>()
        / model.images.len() as f64;
    for c in &path.cameras {
        let r = c.position().as_dvec3().distance(frame.centre);
        assert!((r / mean - 1.0).abs() < 0.02, "orbit radius {r} against the cameras' {mean}");
    }
    lucid_in(d, &["render", "s/checkpoint.lucid", "--camera-path", "orbit/camera_path.json", "-o", "again"]).success();
    for k in 0..3 {
        let name = format!("frame_{k:04}.png");
        let (a, b) = (d.join("orbit").join(&name), d.join("again").join(&name));
        let agreement = psnr(&lucid_image::read_image(a).unwrap(), &lucid_image::read_image(b).unwrap(), None).unwrap();
        assert!(agreement > 45.0, "orbit frame {k} rendered again from its path: {agreement:.1} dB");
    }
}

/// The generator's two descriptions of one capture, nerfstudio's (`transforms.json` with
/// `sparse_pc.ply`) and COLMAP's, read as the same scene: splits, cameras with their lens,
/// normalisation and sparse points. `--downscale` reads either at half size.
#[test]
fn nerfstudio_and_colmap_descriptions_of_a_capture_agree() {
    use lucid_scene::dataset::{DatasetFormat, OpenOptions};
    let dir = temp_dir();
    let d = dir.path();
    capture(d, "cap", &["--k1", "-0.06", "--pose-noise", "0.5", "--position-noise", "0.01"]);
    assert!(d.join("cap/transforms.json").is_file() && d.join("cap/sparse_pc.ply").is_file());
    let open = |format, downscale| {
        let options = OpenOptions { format: Some(format), downscale, ..Default::default() };
        Dataset::open_with(d.join("cap"), &options).unwrap()
    };
    for downscale in [None, Some(2)] {
        let (ns, colmap) = (open(DatasetFormat::Transforms, downscale), open(DatasetFormat::Colmap, downscale));
        assert_eq!(ns.splits.len(), colmap.splits.len());
        for (a, b) in ns.splits.iter().zip(&colmap.splits) {
            assert_eq!(a.split, b.split);
            assert_eq!(a.frames.len(), b.frames.len());
            for (f, g) in a.frames.iter().zip(&b.frames) {
                assert_eq!(f.image_path, g.image_path);
                assert_eq!(f.resize_to, g.resize_to);
                let (k, l) = (f.camera.intrinsics, g.camera.intrinsics);
                assert_eq!((k.width, k.height, k.distortion), (l.width, l.height, l.distortion));
                assert!((k.fx - l.fx).abs() < 1e-3 && (k.cx - l.cx).abs() < 1e-3 && (k.cy - l.cy).abs() < 1e-3);
                assert!(
                    f.camera.camera_to_world.abs_diff_eq(g.camera.camera_to_world, 1e-4),
                    "{}: {} vs {}",
                    f.file_path,
                    f.camera.camera_to_world,
                    g.camera.camera_to_world
                );
            }
        }
        let (n, m) = (ns.normalisation.expect("normalised"), colmap.normalisation.unwrap());
        assert!(n.centre.distance(m.centre) < 1e-4 && (n.scale / m.scale - 1.0).abs() < 1e-5, "{n:?} vs {m:?}");
        assert_eq!(ns.points.len(), colmap.points.len());
        for (p, q) in ns.points.iter().zip(&colmap.points) {
            assert!(p.position.distance(q.position) < 1e-4 && p.colour == q.colour);
        }
    }
    let half = open(DatasetFormat::Transforms, Some(2));
    assert_eq!(half.frames(Split::Train)[0].resize_to, Some((32, 24)));
    // Without a choice, the transforms file is read (nerfstudio's convention).
    assert_eq!(Dataset::open(d.join("cap")).unwrap().frames(Split::Test)[0].file_path, "images/img_0000.png");
}

/// Masks keep what they hide out of training and scoring: a magenta figure walking through the
/// training photographs ruins models trained on every pixel, while models told to ignore it
/// (nerfstudio's `mask_path`) stay close to ones trained on the clean photographs.
#[test]
fn masked_pixels_are_not_learnt() {
    use lucid_image::{Image, read_image, write_image};
    let dir = temp_dir();
    let d = dir.path();
    learnable_capture(d, "clean", &[]);
    let mut root: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("clean/transforms.json")).unwrap()).unwrap();
    for folder in ["painted/images", "masked/images", "masked/masks"] {
        std::fs::create_dir_all(d.join(folder)).unwrap();
    }
    let frames = root["frames"].as_array_mut().unwrap();
    for (i, frame) in frames.iter_mut().enumerate() {
        let name = frame["file_path"].as_str().unwrap().trim_start_matches("images/").to_string();
        let photo = read_image(d.join("clean/images").join(&name)).unwrap();
        // Every 8th photograph (by name) is a test view: those stay clean.
        let (painted, mask) = if i % 8 == 0 {
            (photo, None)
        } else {
            let (cx, cy) = (10.0 + (i * 13 % 76) as f32, 24.0 + (i * 7 % 30) as f32);
            let inside = |x: usize, y: usize, r: f32| ((x as f32 - cx) / 0.6).hypot(y as f32 - cy) < r;
            let painted =
                Image::from_fn(96, 72, |x, y| if inside(x, y, 20.0) { [1.0, 0.0, 1.0, 1.0] } else { photo.get(x, y) });
            let mask = Image::from_fn(96, 72, |x, y| if inside(x, y, 22.0) { [0.0, 0.0, 0.0, 1.0] } else { [1.0; 4] });
            (painted, Some(mask))
        };
        for set in ["painted", "masked"] {
            write_image(d.join(set).join("images").join(&name), &painted).unwrap();
        }
        if let Some(mask) = mask {
            write_image(d.join("masked/masks").join(&name), &mask).unwrap();
            frame["mask_path"] = serde_json::json!(format!("masks/{name}"));
        }
    }
    std::fs::write(d.join("masked/transforms.json"), root.to_string()).unwrap();
    std::fs::copy(d.join("clean/transforms.json"), d.join("painted/transforms.json")).unwrap();
    for set in ["painted", "masked"] {
        std::fs::copy(d.join("clean/sparse_pc.ply"), d.join(set).join("sparse_pc.ply")).unwrap();
    }
    let splat = |set: &str| trained_psnr(d, "splat", set, &format!("{set}-splat"), &["--steps", "1500"]);
    let nerf = |set: &str| trained_psnr(d, "nerf", set, &format!("{set}-nerf"), &NERF_STEPS);
    let (clean, painted, masked) = (splat("clean"), splat("painted"), splat("masked"));
    println!("3DGS: clean {clean:.2} dB, painted {painted:.2} dB, painted and masked {masked:.2} dB");
    let (nclean, npainted, nmasked) = (nerf("clean"), nerf("painted"), nerf("masked"));
    println!("NeRF: clean {nclean:.2} dB, painted {npainted:.2} dB, painted and masked {nmasked:.2} dB");
    // Measured: 3DGS clean 22.62, painted 19.87, masked 22.58 dB; NeRF (squared-error loss)
    // 18.89, 16.48, 18.74 dB (with the earlier Huber loss 18.58, 15.49, 18.77: the painted set
    // scored lower under Huber, so the margin over it was wider); with 8 hash levels of 4
    // features (2026-12-05) NeRF 18.54, 16.02, 18.46 dB and 3DGS 22.63, 19.73, 22.58 dB; with
    // the hash table at 8 times the rate and the random background in closed form (later that
    // day) NeRF 19.15, 15.69, 18.74 dB: the clean set gains more from the faster table than the
    // masked one, whose masked pixels it never sees.
    assert!(masked > painted + 2.2 && masked > clean - 0.4, "3DGS {clean:.2} / {painted:.2} / {masked:.2} dB");
    assert!(nmasked > npainted + 2.5 && nmasked > nclean - 0.6, "NeRF {nclean:.2} / {npainted:.2} / {nmasked:.2} dB");
}
