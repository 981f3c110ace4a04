//! nerfstudio's captures: a lone `transforms.json` naming its camera model is normalised like
//! a COLMAP model, its `ply_file_path` points are read into the same frame, and `--downscale`
//! reads `images_N/` beside `images/`.

use std::path::Path;

use glam::Vec3;
use lucid_image::{Image, write_image};
use lucid_scene::dataset::OpenOptions;
use lucid_scene::{Dataset, Split};
use serde_json::{Value, json};

/// Two photographs in `images/` seen from either side of the origin, with `extra` merged into
/// the file's top level.
fn write(dir: &Path, extra: Value) {
    std::fs::create_dir_all(dir.join("images")).unwrap();
    for name in ["a", "b"] {
        write_image(dir.join(format!("images/{name}.png")), &Image::black(40, 30)).unwrap();
    }
    let mut root = json!({
        "fl_x": 50.0, "fl_y": 50.0, "cx": 20.0, "cy": 15.0, "w": 40, "h": 30,
        "frames": [
            { "file_path": "images/a.png", "transform_matrix": [[1,0,0,10],[0,1,0,20],[0,0,1,34],[0,0,0,1]] },
            { "file_path": "images/b.png", "transform_matrix": [[-1,0,0,10],[0,1,0,20],[0,0,-1,26],[0,0,0,1]] }
        ]
    });
    for (k, v) in extra.as_object().unwrap() {
        root[k] = v.clone();
    }
    std::fs::write(dir.join("transforms.json"), root.to_string()).unwrap();
}

fn open(dir: &Path) -> Result<Dataset, lucid_scene::DatasetError> {
    Dataset::open_with(dir, &OpenOptions { holdout_every: 0, ..Default::default() })
}

#[test]
fn a_nerfstudio_capture_is_normalised_with_its_points() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, json!({"camera_model": "OPENCV", "ply_file_path": "sparse_pc.ply"}));
    let ply = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\n\
               property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
               10 20 30 255 0 0\n11 20 30 0 0 255\n";
    std::fs::write(d.join("sparse_pc.ply"), ply).unwrap();
    let ds = open(d).unwrap();
    let n = ds.normalisation.expect("normalised");
    // The cameras face each other across (10, 20, 30): the centre, and each is 4 from it.
    assert!(n.centre.distance(glam::DVec3::new(10.0, 20.0, 30.0)) < 1e-6, "{n:?}");
    assert!((n.scale - 0.25).abs() < 1e-9);
    for f in ds.frames(Split::Train) {
        assert!((f.camera.position().length() - 1.0).abs() < 1e-5);
    }
    assert_eq!(ds.points.len(), 2);
    assert!(ds.points[0].position.length() < 1e-6 && ds.points[0].colour == [255, 0, 0]);
    assert!((ds.points[1].position.length() - 0.25).abs() < 1e-6 && ds.points[1].colour == [0, 0, 255]);
}

#[test]
fn other_lone_files_keep_their_frame() {
    for extra in [
        json!({}),
        json!({"camera_model": "OPENCV", "aabb_scale": 4}),
        json!({"aabb": [[-1, -1, -1], [1, 1, 1]], "camera_model": "OPENCV"}),
    ] {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), extra.clone());
        let ds = open(dir.path()).unwrap();
        assert!(ds.normalisation.is_none(), "{extra}");
        assert_eq!(ds.frames(Split::Train)[0].camera.position(), Vec3::new(10.0, 20.0, 34.0));
    }
}

#[test]
fn a_missing_point_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), json!({"ply_file_path": "sparse_pc.ply"}));
    let err = open(dir.path()).unwrap_err().to_string();
    assert!(err.contains("transforms.json") && err.contains("ply_file_path") && err.contains("not found"), "{err}");
}

#[test]
fn downscaled_folders_are_read_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, json!({"camera_model": "OPENCV"}));
    let half = OpenOptions { holdout_every: 0, downscale: Some(2), ..Default::default() };
    // Without images_2/, resized on reading.
    let ds = Dataset::open_with(d, &half).unwrap();
    let f = &ds.frames(Split::Train)[0];
    assert_eq!(
        (f.resize_to, f.camera.intrinsics.fx, f.image_path.clone()),
        (Some((20, 15)), 25.0, d.join("images/a.png"))
    );
    // With it, read from there.
    std::fs::create_dir(d.join("images_2")).unwrap();
    for name in ["a", "b"] {
        write_image(d.join(format!("images_2/{name}.png")), &Image::black(20, 15)).unwrap();
    }
    let ds = Dataset::open_with(d, &half).unwrap();
    let f = &ds.frames(Split::Train)[0];
    assert_eq!((f.resize_to, f.camera.intrinsics.fx, f.image_path.clone()), (None, 25.0, d.join("images_2/a.png")));
    // A downscaled image of the wrong size is named.
    write_image(d.join("images_2/b.png"), &Image::black(10, 10)).unwrap();
    let err = Dataset::open_with(d, &half).unwrap_err().to_string();
    assert!(err.contains("images_2/b.png") && err.contains("20x15"), "{err}");
}

/// nerfstudio's masks: dark pixels are ignored; a mask is checked against its image and
/// follows it when the image is read downscaled.
#[test]
fn masks_say_which_pixels_count() {
    use lucid_scene::dataset::images::ImageSet;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, json!({}));
    let mut root: Value = serde_json::from_str(&std::fs::read_to_string(d.join("transforms.json")).unwrap()).unwrap();
    root["frames"][0]["mask_path"] = json!("masks/a.png");
    std::fs::write(d.join("transforms.json"), root.to_string()).unwrap();
    let err = open(d).unwrap_err().to_string();
    assert!(err.contains("frames[0].mask_path") && err.contains("not found"), "{err}");

    // The left quarter is masked out.
    std::fs::create_dir(d.join("masks")).unwrap();
    let mask = Image::from_fn(40, 30, |x, _| if x < 10 { [0.0; 4] } else { [1.0; 4] });
    write_image(d.join("masks/a.png"), &mask).unwrap();
    let ds = open(d).unwrap();
    let set = ImageSet::load(ds.frames(Split::Train)).unwrap();
    assert!(set.masks[1].is_none() && set.keeps(1, 0));
    let kept = set.masks[0].as_ref().unwrap();
    assert_eq!(kept.iter().filter(|k| !**k).count(), 10 * 30);
    assert!(!set.keeps(0, 9) && set.keeps(0, 10) && !set.keeps(0, 40 * 29));
    assert_eq!(set.mask_weights(0).unwrap()[10], 1.0);

    // Read at half size, the full-size mask is resized with its image.
    let half = OpenOptions { holdout_every: 0, downscale: Some(2), ..Default::default() };
    let set = ImageSet::load(Dataset::open_with(d, &half).unwrap().frames(Split::Train)).unwrap();
    let kept = set.masks[0].as_ref().unwrap();
    assert_eq!(kept.len(), 20 * 15);
    assert!(!kept[0] && !kept[4] && kept[5] && kept[19]);

    // A mask of another shape is an error naming it.
    write_image(d.join("masks/a.png"), &Image::black(30, 30)).unwrap();
    let err = ImageSet::load(open(d).unwrap().frames(Split::Train)).unwrap_err().to_string();
    assert!(err.contains("masks/a.png") && err.contains("30x30"), "{err}");
}
