//! COLMAP captures, checked against files and projections that COLMAP itself wrote
//! (`tests/fixtures/colmap/make_fixture.py`, pycolmap 4.2.1).

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec2};
use lucid_scene::colmap::ColmapModel;
use lucid_scene::dataset::OpenOptions;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::{Camera, Dataset, Split};
use serde_json::Value;

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/colmap")
}

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(fixture().join("expected.json")).unwrap()).unwrap()
}

fn vec3(v: &Value) -> DVec3 {
    DVec3::new(v[0].as_f64().unwrap(), v[1].as_f64().unwrap(), v[2].as_f64().unwrap())
}

/// A copy of the fixture with the text model in `sparse/0` instead of the binary one.
fn text_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("sparse/0")).unwrap();
    std::fs::create_dir(dir.path().join("images")).unwrap();
    for f in std::fs::read_dir(fixture().join("sparse_text/0")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.path().join("sparse/0").join(f.file_name().unwrap())).unwrap();
    }
    for f in std::fs::read_dir(fixture().join("images")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.path().join("images").join(f.file_name().unwrap())).unwrap();
    }
    dir
}

#[test]
fn binary_and_text_models_are_the_same_reconstruction() {
    let binary = ColmapModel::read(&fixture().join("sparse/0")).unwrap();
    let text = ColmapModel::read(&fixture().join("sparse_text/0")).unwrap();
    assert_eq!(binary.cameras, text.cameras);
    assert_eq!(binary.images.len(), 10);
    assert_eq!(binary.points.len(), 4);
    assert!(binary.points.iter().all(|p| p.track_length == 10));
    for (a, b) in binary.images.iter().zip(&text.images) {
        assert_eq!((a.id, a.camera_id, &a.name), (b.id, b.camera_id, &b.name));
        // The text file prints 17 significant digits: the same doubles.
        assert!(a.rotation.abs_diff_eq(b.rotation, 1e-15) && a.translation.abs_diff_eq(b.translation, 1e-15));
    }
    for (a, b) in binary.points.iter().zip(&text.points) {
        assert!(a.position.abs_diff_eq(b.position, 1e-15) && a.colour == b.colour);
    }
    let names: Vec<&str> = binary.cameras.values().map(|c| c.model.name).collect();
    assert_eq!(names, ["SIMPLE_RADIAL", "OPENCV", "PINHOLE"]);
}

#[test]
fn poses_and_lenses_project_as_colmap_projects() {
    let expected = expected();
    for root in [fixture(), text_copy().path().to_path_buf()] {
        let ds = Dataset::open(&root).unwrap();
        let n = ds.normalisation.expect("a capture is normalised");
        // The ring looks at (0, 0, 0.1): that becomes the origin, and +Z stays up.
        assert!(n.centre.abs_diff_eq(DVec3::new(0.0, 0.0, 0.1), 1e-9), "{:?}", n.centre);
        let frames: Vec<_> = ds.all_frames().collect();
        // The cameras' mean up becomes +Z; it is near the world's +Z they were placed with.
        let up: glam::Vec3 = frames.iter().map(|f| f.camera.camera_to_world.y_axis.truncate()).sum();
        assert!(up.normalize().abs_diff_eq(glam::Vec3::Z, 1e-5), "{up}");
        assert!((n.rotation * DVec3::Z).dot(DVec3::Z) > 15f64.to_radians().cos());
        assert_eq!(frames.len(), 10);
        let points: Vec<DVec3> = expected["points"].as_array().unwrap().iter().map(vec3).collect();
        let mut farthest = 0.0f64;
        for image in expected["images"].as_array().unwrap() {
            let name = image["name"].as_str().unwrap();
            let frame = frames.iter().find(|f| f.file_path == name).unwrap();
            assert!(frame.image_path.ends_with(Path::new("images").join(name)));
            let camera = frame.camera;
            let centre = n.to_scene(vec3(&image["centre"]));
            assert!(camera.position().as_dvec3().abs_diff_eq(centre, 1e-5), "{name}");
            farthest = farthest.max(centre.length());
            for (point, pixel) in points.iter().zip(image["pixels"].as_array().unwrap()) {
                let want = Vec2::new(pixel[0].as_f64().unwrap() as f32, pixel[1].as_f64().unwrap() as f32);
                let p = n.to_scene(*point).as_vec3();
                let got = camera.project(p).unwrap();
                assert!((got - want).length() < 1e-4, "{name}: {got} vs COLMAP's {want}");
                let ray = camera.generate_ray(want.x, want.y, Vec2::ZERO);
                let t = (p - ray.origin).dot(ray.direction);
                assert!((ray.at(t) - p).length() < 1e-5, "{name}: the ray through {want} misses the point");
            }
        }
        assert!((farthest - 1.0).abs() < 1e-5, "the farthest camera is 1 from the centre: {farthest}");
        assert_eq!(ds.points.len(), 4);
        assert!(ds.points[0].position.as_dvec3().abs_diff_eq(n.to_scene(DVec3::ZERO), 1e-6));
        assert!(n.to_dataset(n.to_scene(DVec3::new(0.3, -2.0, 1.0))).abs_diff_eq(DVec3::new(0.3, -2.0, 1.0), 1e-12));
    }
}

#[test]
fn every_eighth_image_by_sorted_name_is_held_out() {
    let names = |ds: &Dataset, split| ds.frames(split).iter().map(|f| f.file_path.clone()).collect::<Vec<_>>();
    let ds = Dataset::open(fixture()).unwrap();
    assert_eq!(names(&ds, Split::Test), ["img_00.png", "img_08.png"]);
    assert_eq!(names(&ds, Split::Train).len(), 8);
    assert!(ds.frames(Split::Val).is_empty());
    let ds = Dataset::open_with(fixture(), &OpenOptions { holdout_every: 3, ..Default::default() }).unwrap();
    assert_eq!(names(&ds, Split::Test), ["img_00.png", "img_03.png", "img_06.png", "img_09.png"]);
    let ds = Dataset::open_with(fixture(), &OpenOptions { holdout_every: 0, ..Default::default() }).unwrap();
    assert_eq!((ds.frames(Split::Train).len(), ds.frames(Split::Test).len()), (10, 0));
}

#[test]
fn downscaling_reads_images_n_or_resizes() {
    let dir = text_copy();
    let options = OpenOptions { downscale: Some(2), ..Default::default() };
    // No images_2/: the full images are resized on reading, the cameras scaled with them.
    let ds = Dataset::open_with(dir.path(), &options).unwrap();
    let full = Dataset::open(dir.path()).unwrap();
    let (k, k_full) = (ds.frames(Split::Train)[0].camera.intrinsics, full.frames(Split::Train)[0].camera.intrinsics);
    assert_eq!((k.width, k.height), (4, 3));
    assert!((k.fx - 0.5 * k_full.fx).abs() < 1e-6 && (k.cx - 0.5 * k_full.cx).abs() < 1e-6);
    assert_eq!(k.distortion, k_full.distortion);
    let set = ImageSet::load(ds.frames(Split::Train)).unwrap();
    assert_eq!(set.pixels[0].len(), 12);
    // A uniform image stays uniform.
    let original = ImageSet::load(full.frames(Split::Train)).unwrap();
    assert!((set.pixels[0][5][2] - original.pixels[0][20][2]).abs() < 1e-3);
    // images_2/ wins where it exists, and its sizes are checked.
    std::fs::create_dir(dir.path().join("images_2")).unwrap();
    for f in ds.all_frames() {
        lucid_image::write_image(dir.path().join("images_2").join(&f.file_path), &lucid_image::Image::black(4, 3))
            .unwrap();
    }
    let ds = Dataset::open_with(dir.path(), &options).unwrap();
    assert!(ds.frames(Split::Train)[0].image_path.starts_with(dir.path().join("images_2")));
    assert_eq!(ds.frames(Split::Train)[0].resize_to, None);
    lucid_image::write_image(dir.path().join("images_2/img_01.png"), &lucid_image::Image::black(7, 3)).unwrap();
    let message = Dataset::open_with(dir.path(), &options).unwrap_err().to_string();
    assert!(
        message.contains("images.txt") && message.contains("img_01.png") && message.contains("downscaled 2 times"),
        "{message}"
    );
}

fn open_err(root: &Path) -> String {
    Dataset::open(root).unwrap_err().to_string()
}

#[test]
fn bad_models_are_errors_naming_the_file() {
    // A cut binary file.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("sparse/0")).unwrap();
    std::fs::create_dir(dir.path().join("images")).unwrap();
    for name in ["cameras.bin", "images.bin", "points3D.bin"] {
        std::fs::copy(fixture().join("sparse/0").join(name), dir.path().join("sparse/0").join(name)).unwrap();
    }
    let images = dir.path().join("sparse/0/images.bin");
    let bytes = std::fs::read(&images).unwrap();
    std::fs::write(&images, &bytes[..bytes.len() - 5]).unwrap();
    let message = open_err(dir.path());
    assert!(message.contains("images.bin") && message.contains("truncated"), "{message}");
    // A count no file could hold.
    let mut huge = bytes.clone();
    huge[..8].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&images, &huge).unwrap();
    assert!(open_err(dir.path()).contains("only"), "{}", open_err(dir.path()));
    std::fs::write(&images, &bytes).unwrap();
    // A photograph missing.
    let message = open_err(dir.path());
    assert!(message.contains("images.bin") && message.contains("img_") && message.contains("not found"), "{message}");

    // Text: a model Lucid cannot honour, a model nobody knows, a line cut short.
    let dir = text_copy();
    let cameras = dir.path().join("sparse/0/cameras.txt");
    let text = std::fs::read_to_string(&cameras).unwrap();
    std::fs::write(&cameras, text.replace("PINHOLE 8 6 6 6.5 4 3", "FOV 8 6 6 6.5 4 3 0.9")).unwrap();
    let message = open_err(dir.path());
    assert!(message.contains("cameras.txt") && message.contains("FOV is not supported"), "{message}");
    std::fs::write(&cameras, text.replace("PINHOLE 8 6", "PINHOLEY 8 6")).unwrap();
    assert!(open_err(dir.path()).contains("unknown camera model PINHOLEY"));
    std::fs::write(&cameras, text.replace("PINHOLE 8 6 6 6.5 4 3", "PINHOLE 8 6 6 6.5 4")).unwrap();
    let message = open_err(dir.path());
    assert!(message.contains("cameras.txt") && message.contains("takes 4 parameters"), "{message}");
    std::fs::write(&cameras, &text).unwrap();
    // An image of a camera that does not exist.
    let images = dir.path().join("sparse/0/images.txt");
    let text = std::fs::read_to_string(&images).unwrap();
    let broken: String = text.replacen(" 1 img_03.png", " 9 img_03.png", 1);
    std::fs::write(&images, broken).unwrap();
    let message = open_err(dir.path());
    assert!(message.contains("images.txt") && message.contains("camera 9"), "{message}");
    // No images folder.
    std::fs::write(&images, &text).unwrap();
    std::fs::remove_dir_all(dir.path().join("images")).unwrap();
    assert!(open_err(dir.path()).contains("no images folder"));
}

#[test]
fn of_several_models_the_one_with_most_images_is_read() {
    // COLMAP left a three-image fragment in sparse/0 and the main model in sparse/1.
    let dir = text_copy();
    let main = dir.path().join("sparse/1");
    std::fs::rename(dir.path().join("sparse/0"), &main).unwrap();
    std::fs::create_dir(dir.path().join("sparse/0")).unwrap();
    for file in ["cameras.txt", "points3D.txt"] {
        std::fs::copy(main.join(file), dir.path().join("sparse/0").join(file)).unwrap();
    }
    let images = std::fs::read_to_string(main.join("images.txt")).unwrap();
    let fragment: String = images.lines().take(4 + 2 * 3).map(|l| format!("{l}\n")).collect();
    std::fs::write(dir.path().join("sparse/0/images.txt"), fragment).unwrap();
    assert_eq!(Dataset::open(dir.path()).unwrap().all_frames().count(), 10);
    assert_eq!(ColmapModel::read(&dir.path().join("sparse/0")).unwrap().images.len(), 3);
}
