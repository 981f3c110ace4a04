//! Reading the NeRF-synthetic / instant-ngp layout: a committed fixture in the styles real
//! datasets use, a write/read round trip, and every kind of bad input.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use lucid_image::{Image, write_image};
use lucid_scene::dataset::{FrameRecord, SceneBounds, write_transforms};
use lucid_scene::{Camera, Dataset, DatasetError, Intrinsics, Split, look_at};

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/blender_like")
}

#[test]
fn reads_blender_and_instant_ngp_styles() {
    let ds = Dataset::open(fixture()).unwrap();
    assert_eq!(ds.splits.len(), 3);

    // Blender style: `./train/r_0` without extension, camera_angle_x only, size from the image.
    let train = ds.frames(Split::Train);
    assert_eq!(train.len(), 2);
    assert_eq!(train[0].file_path, "./train/r_0");
    assert!(train[0].image_path.ends_with("train/r_0.png"));
    let k = train[0].camera.intrinsics;
    assert_eq!((k.width, k.height), (8, 6));
    assert!((k.fx - 11.111_11).abs() < 1e-4 && k.fx == k.fy);
    assert_eq!((k.cx, k.cy), (4.0, 3.0));
    assert!((train[0].camera.position() - Vec3::new(0.0, 2.737_26, 2.959_292)).length() < 1e-5);

    // Per-frame intrinsics (nerfstudio style), sizes as floats, and a 3x4 pose.
    let val = &ds.frames(Split::Val)[0];
    let k = val.camera.intrinsics;
    assert_eq!((k.fx, k.fy, k.cx, k.cy, k.width, k.height), (9.0, 9.5, 4.25, 2.75, 8, 6));
    assert_eq!(val.camera.position(), Vec3::new(0.5, -0.25, 4.0));
    assert_eq!(ds.splits[1].bounds, Some(SceneBounds::AabbScale(4.0)));

    // instant-ngp style: `test/r_0.png` with extension, fl_x/cx/w/h, our aabb key.
    let test = &ds.frames(Split::Test)[0];
    assert!(test.image_path.ends_with("test/r_0.png"));
    assert_eq!(ds.splits[2].bounds, Some(SceneBounds::Box { min: Vec3::splat(-1.5), max: Vec3::splat(1.5) }));

    let (lo, hi) = ds.camera_bounds().unwrap();
    assert!(lo.x <= -1.396 && hi.z >= 4.0);
}

#[test]
fn camera_angle_x_and_fl_x_give_the_same_rays() {
    // The fixture's train r_0 and test r_0 share a pose; one gives camera_angle_x, the
    // other fl_x = 0.5·W / tan(0.5·camera_angle_x).
    let ds = Dataset::open(fixture()).unwrap();
    let a = &ds.frames(Split::Train)[0].camera;
    let b = &ds.frames(Split::Test)[0].camera;
    for j in 0..6 {
        for i in 0..8 {
            let (ra, rb) = (a.pixel_centre_ray(i, j), b.pixel_centre_ray(i, j));
            assert!((ra.origin - rb.origin).length() < 1e-6);
            assert!((ra.direction - rb.direction).length() < 1e-6, "pixel ({i},{j})");
        }
    }
}

#[test]
fn written_datasets_read_back() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("train")).unwrap();
    let k = Intrinsics::from_fov_x(12, 10, 0.8);
    let image = Image::filled(12, 10, [0.5, 0.25, 0.125, 1.0]);
    write_image(dir.path().join("train/r_0.png"), &image).unwrap();
    write_image(dir.path().join("train/r_0.exr"), &image).unwrap();
    let pose = look_at(Vec3::new(3.0, 1.0, 2.0), Vec3::ZERO, Vec3::Z);
    let frame = FrameRecord {
        file_path: "./train/r_0".into(),
        camera_to_world: pose,
        hdr_file_path: Some("train/r_0.exr".into()),
        exposure_time: Some(0.125),
        light_direction: Some(Vec3::new(0.0, 0.6, 0.8)),
        aperture_radius: Some(0.05),
        focus_distance: Some(3.5),
        ..Default::default()
    };
    let aabb = (Vec3::splat(-1.0), Vec3::splat(1.0));
    write_transforms(&dir.path().join("transforms_train.json"), &k, Some(aabb), &[frame], &[]).unwrap();

    let ds = Dataset::open(dir.path()).unwrap();
    let f = &ds.frames(Split::Train)[0];
    assert!(f.camera.camera_to_world.abs_diff_eq(pose, 1e-6));
    let back = f.camera.intrinsics;
    assert!((back.fx - k.fx).abs() < 1e-4 && (back.cx, back.cy, back.width, back.height) == (6.0, 5.0, 12, 10));
    assert_eq!(f.extras.exposure_time, Some(0.125));
    assert_eq!(f.extras.light_direction, Some(Vec3::new(0.0, 0.6, 0.8)));
    assert_eq!((f.extras.aperture_radius, f.extras.focus_distance), (Some(0.05), Some(3.5)));
    assert!(f.extras.hdr_path.as_ref().unwrap().ends_with("train/r_0.exr"));
    assert!(f.extras.depth_path.is_none());
}

/// A one-frame dataset folder with the given transforms text and an 8x6 image.
fn dataset_with(json: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("train")).unwrap();
    write_image(dir.path().join("train/r_0.png"), &Image::black(8, 6)).unwrap();
    std::fs::write(dir.path().join("transforms_train.json"), json).unwrap();
    dir
}

const IDENTITY: &str = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";

fn open_err(dir: &Path) -> String {
    let err: DatasetError = Dataset::open(dir).expect_err("bad input must fail");
    err.to_string()
}

#[test]
fn bad_datasets_give_errors_that_name_the_file_and_key() {
    let cases: Vec<(String, &[&str])> = vec![
        (
            format!(r#"{{"camera_angle_x": 0.7, "frames": [{{"file_path": "./train/r_9", "transform_matrix": {IDENTITY}}}]}}"#),
            &["transforms_train.json", "frames[0].file_path", "not found"],
        ),
        (
            r#"{"camera_angle_x": 0.7, "frames": [{"file_path": "./train/r_0", "transform_matrix": [[1,0],[0,1]]}]}"#
                .to_string(),
            &["frames[0].transform_matrix", "4x4"],
        ),
        (
            r#"{"camera_angle_x": 0.7, "frames": [{"file_path": "./train/r_0", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0]]}]}"#
                .to_string(),
            &["frames[0].transform_matrix", "row 3 has 3 entries"],
        ),
        (
            format!(r#"{{"camera_angle_x": 0.7, "w": 16, "h": 6, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#),
            &["frames[0].file_path", "is 8x6 but the transforms say 16x6"],
        ),
        (
            format!(r#"{{"frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#),
            &["no focal length"],
        ),
        (
            format!(r#"{{"camera_angle_x": -1, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#),
            &["camera_angle_x", "positive"],
        ),
        (
            format!(r#"{{"camera_angle_x": 0.7, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}, "depth_file_path": "train/d.exr"}}]}}"#),
            &["frames[0].depth_file_path", "not found"],
        ),
        (r#"{"camera_angle_x": 0.7, "frames": [{"file_path": 3}]}"#.to_string(), &["frames[0].file_path", "string"]),
        (r#"{"camera_angle_x": 0.7}"#.to_string(), &["frames", "missing"]),
        (r#"{"camera_angle_x": 0.7, "frames": [ {"#.to_string(), &["malformed JSON", "line 1"]),
    ];
    for (json, needles) in cases {
        let dir = dataset_with(&json);
        let msg = open_err(dir.path());
        assert!(msg.contains("transforms_train.json"), "{msg:?} does not name the file");
        for needle in needles {
            assert!(msg.contains(needle), "{msg:?} lacks {needle:?}");
        }
    }
}

#[test]
fn missing_and_empty_folders_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    assert!(open_err(&dir.path().join("nope")).contains("no such directory"));
    assert!(open_err(dir.path()).contains("not a dataset"));
}

#[test]
fn single_instant_ngp_transforms_json_is_the_training_split() {
    let dir = dataset_with("{}");
    std::fs::remove_file(dir.path().join("transforms_train.json")).unwrap();
    let json = format!(
        r#"{{"fl_x": 10, "w": 8, "h": 6, "frames": [{{"file_path": "train/r_0.png", "transform_matrix": {IDENTITY}}}]}}"#
    );
    std::fs::write(dir.path().join("transforms.json"), json).unwrap();
    let ds = Dataset::open(dir.path()).unwrap();
    assert_eq!(ds.frames(Split::Train).len(), 1);
    assert_eq!(ds.frames(Split::Train)[0].camera.camera_to_world, Mat4::IDENTITY);
}

/// Frames `r_0..r_n` in `train/`, each as a PNG and an EXR (as Lucid writes them), with
/// extension-less `file_path`s and the given poses.
fn extensionless_dataset(centres: &[Vec3]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("train")).unwrap();
    let mut frames = Vec::new();
    for (i, c) in centres.iter().enumerate() {
        for ext in ["png", "exr"] {
            write_image(dir.path().join(format!("train/r_{i}.{ext}")), &Image::black(8, 6)).unwrap();
        }
        // look_at normalises the offset, which overflows for the absurd centres.
        let pose = if c.length() < 1e20 { look_at(*c, Vec3::ZERO, Vec3::Z) } else { Mat4::from_translation(*c) };
        let m = pose.transpose().to_cols_array_2d();
        frames.push(format!(r#"{{"file_path": "./train/r_{i}", "transform_matrix": {m:?}}}"#));
    }
    let json = format!(r#"{{"camera_angle_x": 0.7, "frames": [{}]}}"#, frames.join(","));
    std::fs::write(dir.path().join("transforms_train.json"), json).unwrap();
    dir
}

fn ring(n: usize) -> Vec<Vec3> {
    (0..n).map(|i| Vec3::new((i as f32).cos() * 4.0, (i as f32).sin() * 4.0, 1.0)).collect()
}

#[test]
fn extensionless_paths_take_one_extension_for_the_whole_dataset() {
    let dir = extensionless_dataset(&ring(4));
    let ds = Dataset::open(dir.path()).unwrap();
    assert!(ds.frames(Split::Train).iter().all(|f| f.image_path.extension().unwrap() == "png"));
    // A missing PNG is reported, not replaced by the EXR of the same stem.
    std::fs::remove_file(dir.path().join("train/r_2.png")).unwrap();
    let msg = open_err(dir.path());
    assert!(msg.contains("frames[2].file_path") && msg.contains("r_2.png") && msg.contains("not found"), "{msg}");
    // A dataset whose frames are all EXR reads them.
    for i in [0, 1, 3] {
        std::fs::remove_file(dir.path().join(format!("train/r_{i}.png"))).unwrap();
    }
    let ds = Dataset::open(dir.path()).unwrap();
    assert!(ds.frames(Split::Train).iter().all(|f| f.image_path.extension().unwrap() == "exr"));
}

#[test]
fn absurd_cameras_are_refused_at_load() {
    // One camera a million units away among cameras 4 units from the centre.
    let mut centres = ring(6);
    centres[3] = Vec3::new(0.0, 1e6, 0.0);
    let msg = open_err(extensionless_dataset(&centres).path());
    assert!(msg.contains("frames[3].transform_matrix") && msg.contains("broken pose"), "{msg}");
    // A translation beyond any capture's coordinates, even alone.
    let msg = open_err(extensionless_dataset(&[Vec3::new(1e30, 0.0, 0.0)]).path());
    assert!(msg.contains("frames[0].transform_matrix") && msg.contains("beyond"), "{msg}");
    // Real spreads pass: a walk of cameras along a 100-unit path with a cluster at its start.
    let mut walk: Vec<Vec3> = (0..20).map(|i| Vec3::new(i as f32 * 5.0, 10.0, 1.5)).collect();
    walk.extend(ring(20));
    if let Err(e) = Dataset::open(extensionless_dataset(&walk).path()) {
        panic!("a walk is a real capture: {e}");
    }

    let cases: [(String, &[&str]); 3] = [
        // 0.5·8 / tan(0.35) = 10.96, not 30.
        (
            format!(
                r#"{{"camera_angle_x": 0.7, "fl_x": 30, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#
            ),
            &["fl_x", "contradicts camera_angle_x", "10.96"],
        ),
        (
            format!(
                r#"{{"camera_angle_x": 0.7, "frames": [{{"file_path": "./train/r_0", "fl_x": 30, "camera_angle_x": 0.7, "transform_matrix": {IDENTITY}}}]}}"#
            ),
            &["frames[0].fl_x", "contradicts"],
        ),
        (
            format!(r#"{{"fl_x": 0, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#),
            &["fl_x", "positive"],
        ),
    ];
    for (json, needles) in cases {
        let msg = open_err(dataset_with(&json).path());
        for needle in needles {
            assert!(msg.contains(needle), "{msg:?} lacks {needle:?}");
        }
    }
    // Within 1% (an angle rounded by a converter) is the same camera.
    let json = format!(
        r#"{{"camera_angle_x": 0.7, "fl_x": 11.0, "frames": [{{"file_path": "./train/r_0", "transform_matrix": {IDENTITY}}}]}}"#
    );
    assert!(Dataset::open(dataset_with(&json).path()).is_ok());
}
