//! `lucid gen`: a path-traced dataset that a standard NeRF-synthetic loader reads, generated
//! deterministically.

use std::path::Path;

use lucid_tests::{files_under, lucid_in, temp_dir};

const ARGS: [&str; 6] = ["--views", "3,1,2", "--res", "24", "--spp", "2"];

fn generate(dir: &Path, out: &str, seed: &str) {
    let mut args = vec!["gen", "object", "-o", out, "--seed", seed];
    args.extend_from_slice(&ARGS);
    lucid_in(dir, &args).success();
}

#[test]
fn generated_object_dataset_reads_like_the_blender_set() {
    let dir = temp_dir();
    generate(dir.path(), "ds", "5");
    let root = dir.path().join("ds");
    for (split, count) in [("train", 3), ("val", 1), ("test", 2)] {
        // What the original NeRF loader does: json.load, camera_angle_x, file_path + '.png',
        // a 4x4 transform_matrix per frame.
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(root.join(format!("transforms_{split}.json"))).unwrap())
                .unwrap();
        assert!(json["camera_angle_x"].as_f64().unwrap() > 0.0);
        let frames = json["frames"].as_array().unwrap();
        assert_eq!(frames.len(), count);
        for f in frames {
            let file = f["file_path"].as_str().unwrap();
            assert!(!Path::new(file).is_absolute() && Path::new(file).extension().is_none(), "{file}");
            let png = root.join(format!("{file}.png"));
            let img = lucid_image::read_image(&png).unwrap();
            assert_eq!(img.dimensions(), (24, 24));
            assert!(img.has_alpha(), "transparent background expected in {}", png.display());
            let m = f["transform_matrix"].as_array().unwrap();
            assert!(m.len() == 4 && m.iter().all(|r| r.as_array().unwrap().len() == 4));
        }
    }
    let record = std::fs::read_to_string(root.join("dataset.toml")).unwrap();
    assert!(
        record.contains("scene = \"object\"") && record.contains("seed = 5") && record.contains("spp = 2"),
        "{record}"
    );
    let info = lucid_in(dir.path(), &["info", "ds", "--json"]).success().json();
    assert_eq!(info["splits"][0]["frames"], 3);
}

#[test]
fn same_seed_same_bytes_other_seed_other_images() {
    let dir = temp_dir();
    generate(dir.path(), "a", "5");
    generate(dir.path(), "b", "5");
    generate(dir.path(), "c", "6");
    let files = files_under(&dir.path().join("a"));
    assert_eq!(files, files_under(&dir.path().join("b")));
    for f in &files {
        let (a, b) = (
            std::fs::read(dir.path().join("a").join(f)).unwrap(),
            std::fs::read(dir.path().join("b").join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs between two runs with the same seed");
    }
    let (a, c) = (
        std::fs::read(dir.path().join("a/train/r_0.exr")).unwrap(),
        std::fs::read(dir.path().join("c/train/r_0.exr")).unwrap(),
    );
    assert_ne!(a, c);
}

#[test]
fn unknown_scenes_and_bad_flags_are_clear_errors() {
    let dir = temp_dir();
    lucid_in(dir.path(), &["gen", "teapot", "-o", "x"]).failure(&["teapot", "built-in scene", "object"]);
    lucid_in(dir.path(), &["gen", "object", "-o", "x", "--res", "0"]).failure(&["--res"]);
    lucid_in(dir.path(), &["gen", "object", "-o", "x", "--views", "0,1,1"]).failure(&["--views"]);
    assert!(!dir.path().join("x").exists());
}
