//! nerfstudio's and instant-ngp's lens keys in transforms files: honoured in the rays, written
//! back as read, and refused where they cannot be honoured.

use std::path::Path;

use glam::{Vec2, Vec3};
use lucid_image::{Image, write_image};
use lucid_scene::{Camera, Dataset, LensDistortion, Split};
use serde_json::{Value, json};

/// A one-frame transforms.json with `extra` merged into its top level.
fn dataset(dir: &Path, extra: Value) -> Result<Dataset, lucid_scene::DatasetError> {
    write_image(dir.join("a.png"), &Image::black(40, 30)).unwrap();
    let mut root = json!({
        "fl_x": 50.0, "fl_y": 48.0, "cx": 20.5, "cy": 14.5, "w": 40, "h": 30,
        "frames": [{ "file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]] }]
    });
    for (k, v) in extra.as_object().unwrap() {
        root[k] = v.clone();
    }
    std::fs::write(dir.join("transforms.json"), root.to_string()).unwrap();
    Dataset::open(dir)
}

#[test]
fn opencv_keys_bend_the_rays_through_the_lens_inverse() {
    let dir = tempfile::tempdir().unwrap();
    let keys = json!({"camera_model": "OPENCV", "k1": -0.12, "k2": 0.03, "p1": 0.001, "p2": -0.002});
    let ds = dataset(dir.path(), keys).unwrap();
    let camera = ds.frames(Split::Train)[0].camera;
    let lens =
        LensDistortion::OpenCv { radial: [-0.12, 0.03, 0.0, 0.0], rational: [0.0; 3], tangential: [0.001, -0.002] };
    assert_eq!(camera.intrinsics.distortion, lens);
    // A world point projects (through the lens) to a pixel whose ray passes through the point.
    // (A nerfstudio file is a capture: its points are seen in the normalised frame.)
    let n = ds.normalisation.expect("a nerfstudio capture is normalised");
    let to_scene = |p: Vec3| n.to_scene(p.as_dvec3()).as_vec3();
    for p in [Vec3::new(0.4, -0.3, 0.0), Vec3::new(-0.55, 0.35, 0.5), Vec3::new(0.0, 0.0, -1.0)].map(to_scene) {
        let px = camera.project(p).unwrap();
        let ray = camera.generate_ray(px.x, px.y, Vec2::ZERO);
        let t = (p - ray.origin).dot(ray.direction);
        assert!((ray.at(t) - p).length() < 1e-5, "{p} misses the ray through {px}");
    }
    // Away from the centre the lens moves the pixel, so ignoring the keys would be wrong.
    let pinhole = camera.intrinsics.without_distortion();
    let corner = to_scene(Vec3::new(-1.1, 0.85, 0.0));
    let local = camera.camera_to_world.inverse().transform_point3(corner);
    let moved = (camera.intrinsics.project(local).unwrap() - pinhole.project(local).unwrap()).length();
    assert!(moved > 0.4, "the lens moves the corner by {moved} px");
}

#[test]
fn fisheye_and_instant_ngp_styles() {
    let dir = tempfile::tempdir().unwrap();
    let ds =
        dataset(dir.path(), json!({"camera_model": "OPENCV_FISHEYE", "k1": 0.02, "k2": -0.01, "k3": 0.0, "k4": 0.001}))
            .unwrap();
    assert_eq!(
        ds.frames(Split::Train)[0].camera.intrinsics.distortion,
        LensDistortion::Fisheye { k: [0.02, -0.01, 0.0, 0.001] }
    );
    // instant-ngp: coefficients without a model are OpenCV's; is_fisheye switches.
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path(), json!({"k1": 0.05})).unwrap();
    assert_eq!(ds.frames(Split::Train)[0].camera.intrinsics.distortion, LensDistortion::opencv(0.05, 0.0, 0.0, 0.0));
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path(), json!({"is_fisheye": true, "k1": 0.05})).unwrap();
    assert_eq!(
        ds.frames(Split::Train)[0].camera.intrinsics.distortion,
        LensDistortion::Fisheye { k: [0.05, 0.0, 0.0, 0.0] }
    );
    // All-zero coefficients under a distortion model are a pinhole.
    let dir = tempfile::tempdir().unwrap();
    let ds =
        dataset(dir.path(), json!({"camera_model": "OPENCV", "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0})).unwrap();
    assert!(ds.frames(Split::Train)[0].camera.intrinsics.distortion.is_pinhole());
}

#[test]
fn lenses_that_cannot_be_honoured_are_errors_naming_the_file_and_model() {
    for (keys, wanted) in [
        (json!({"camera_model": "EQUIRECTANGULAR"}), "EQUIRECTANGULAR is not supported"),
        (json!({"camera_model": "PINHOLE", "k1": 0.1}), "PINHOLE has no distortion"),
        (json!({"camera_model": "OPENCV_FISHEYE", "k1": 0.1, "p1": 0.01}), "no tangential"),
        (json!({"camera_model": 3}), "expected a string"),
        (json!({"camera_model": "OPENCV", "k1": "big"}), "k1: expected a number"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let message = dataset(dir.path(), keys.clone()).unwrap_err().to_string();
        assert!(message.contains("transforms.json") && message.contains(wanted), "{keys}: {message}");
    }
}

#[test]
fn written_lenses_read_back() {
    use lucid_scene::dataset::{FrameRecord, write_transforms};
    let dir = tempfile::tempdir().unwrap();
    write_image(dir.path().join("a.png"), &Image::black(40, 30)).unwrap();
    for lens in
        [LensDistortion::opencv(-0.1, 0.02, 0.001, 0.0), LensDistortion::Fisheye { k: [0.01, 0.0, -0.002, 0.0] }]
    {
        let k = lucid_scene::Intrinsics {
            distortion: lens,
            ..lucid_scene::Intrinsics::pinhole(40, 30, 50.0, 50.0, 20.0, 15.0)
        };
        let frame =
            FrameRecord { file_path: "a.png".into(), camera_to_world: glam::Mat4::IDENTITY, ..Default::default() };
        write_transforms(&dir.path().join("transforms.json"), &k, None, &[frame], &[]).unwrap();
        let ds = Dataset::open(dir.path()).unwrap();
        assert_eq!(ds.frames(Split::Train)[0].camera.intrinsics, k);
    }
}
