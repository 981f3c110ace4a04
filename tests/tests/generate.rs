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

fn same_tree(a: &Path, b: &Path) {
    let files = files_under(a);
    assert_eq!(files, files_under(b));
    for f in &files {
        assert!(std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(), "{f} differs");
    }
}

#[test]
fn two_shards_and_a_merge_equal_the_unsharded_set() {
    let dir = temp_dir();
    generate(dir.path(), "whole", "5");
    for shard in ["0/2", "1/2"] {
        let mut args = vec!["gen", "object", "-o", "parts", "--seed", "5", "--shard", shard];
        args.extend_from_slice(&ARGS);
        lucid_in(dir.path(), &args).success();
    }
    let mut args = vec!["gen", "object", "-o", "parts", "--seed", "5", "--merge"];
    args.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &args).success();
    same_tree(&dir.path().join("whole"), &dir.path().join("parts"));

    // Merging an incomplete set is an error; so is reusing a folder with other settings.
    let mut args = vec!["gen", "object", "-o", "half", "--seed", "5", "--shard", "0/2"];
    args.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &args).success();
    let mut args = vec!["gen", "object", "-o", "half", "--seed", "5", "--merge"];
    args.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &args).failure(&["half", "frames are still missing"]);
    let mut args = vec!["gen", "object", "-o", "half", "--seed", "6"];
    args.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &args).failure(&["dataset.toml", "other settings"]);
}

#[test]
fn a_killed_generation_resumes_to_the_same_dataset() {
    let dir = temp_dir();
    let args = ["gen", "object", "-o", "OUT", "--views", "12,0,0", "--res", "96", "--spp", "32", "--seed", "3"];
    fn with_out<'a>(args: &[&'a str], out: &'a str) -> Vec<&'a str> {
        args.iter().map(|a| if *a == "OUT" { out } else { *a }).collect()
    }
    let mut child = std::process::Command::new(lucid_tests::lucid_bin())
        .args(with_out(&args, "killed"))
        .current_dir(dir.path())
        .env("LUCID_LOG", "warn")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let marker = dir.path().join("killed/train/r_1.png");
    let started = std::time::Instant::now();
    while !marker.exists() && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !dir.path().join("killed/transforms_train.json").exists(),
        "the run finished before it could be killed; the test needs a longer job"
    );
    let resumed = lucid_in(dir.path(), &with_out(&args, "killed")).success();
    assert!(resumed.stdout.contains("already there"), "{}", resumed.stdout);
    lucid_in(dir.path(), &with_out(&args, "clean")).success();
    same_tree(&dir.path().join("clean"), &dir.path().join("killed"));
}

#[test]
fn light_field_refocus_is_closer_to_the_thin_lens_truth_than_the_centre_view() {
    let dir = temp_dir();
    let generate_args = [
        "gen",
        "object",
        "--rig",
        "lightfield",
        "-o",
        "lf",
        "--res",
        "48",
        "--spp",
        "8",
        "--grid",
        "7,7",
        "--spacing",
        "0.12",
        "--focus",
        "4.0",
        "--apertures",
        "0.36",
    ];
    lucid_in(dir.path(), &generate_args).success();
    let info = lucid_in(dir.path(), &["info", "lf", "--json"]).success().json();
    assert_eq!(info["splits"][0]["frames"], 49);
    assert_eq!(info["splits"][2]["extras"]["thin_lens"], 1);
    lucid_in(dir.path(), &["refocus", "lf", "--focus", "4.0", "--aperture", "0.36", "-o", "refocused.exr"]).success();
    let metrics = |a: &str| {
        lucid_in(dir.path(), &["metrics", a, "lf/test/r_0.exr", "--background", "black", "--json"]).success().json()["mean"]["psnr"]
            .as_f64()
            .unwrap()
    };
    let (refocused, centre) = (metrics("refocused.exr"), metrics("lf/train/r_24.exr"));
    assert!(refocused > centre + 2.0, "refocused {refocused:.2} dB vs centre view {centre:.2} dB");
    lucid_in(dir.path(), &["refocus", "lf", "--focus", "-1", "--aperture", "0.3", "-o", "bad.exr"]).failure(&["focus"]);
    assert!(!dir.path().join("bad.exr").exists());
}

#[test]
fn olat_rig_writes_one_frame_per_light_and_environment_truths() {
    let dir = temp_dir();
    let args = [
        "gen",
        "studio",
        "--rig",
        "olat",
        "-o",
        "olat",
        "--views",
        "2,1,1",
        "--res",
        "16",
        "--spp",
        "2",
        "--lights",
        "3",
        "--held-out-lights",
        "4",
    ];
    lucid_in(dir.path(), &args).success();
    let info = lucid_in(dir.path(), &["info", "olat", "--json"]).success().json();
    assert_eq!(info["splits"][0]["frames"], 6, "2 views x 3 lights");
    assert_eq!(info["splits"][0]["extras"]["light_direction"], 6);
    assert_eq!(info["splits"][2]["frames"], 9, "1 view x (3 lights + 4 held-out lights + 2 environments)");
    assert_eq!(info["splits"][1]["frames"], 9, "validation views are lit as test views are");
    let test: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("olat/transforms_test.json")).unwrap()).unwrap();
    let frames = test["frames"].as_array().unwrap();
    let held_out: Vec<&serde_json::Value> = frames.iter().filter(|f| f["held_out_light"] == true).collect();
    assert_eq!(held_out.len(), 4);
    // Held-out directions are new: none within 5° of a training light's.
    let dir_of = |f: &serde_json::Value| -> Vec<f64> {
        f["light_direction"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
    };
    for h in &held_out {
        for f in frames.iter().filter(|f| f["light_direction"].is_array() && f["held_out_light"] != true) {
            let (a, b) = (dir_of(h), dir_of(f));
            let cos: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            assert!(cos < 5f64.to_radians().cos(), "{a:?} vs {b:?}");
        }
    }
    assert!(dir.path().join("olat/envmaps/env_0.exr").is_file() && dir.path().join("olat/envmaps/env_1.exr").is_file());
    // Scenes with emissive shapes cannot be relit.
    let args = [
        "gen", "cornell", "--rig", "olat", "-o", "bad", "--views", "1,0,0", "--res", "8", "--spp", "1", "--lights", "2",
    ];
    lucid_in(dir.path(), &args).failure(&["cornell", "emissive"]);
    assert!(!dir.path().join("bad").exists(), "nothing is written for an impossible request");
}

#[test]
fn rig_files_set_options_and_the_command_line_wins() {
    let dir = temp_dir();
    std::fs::write(
        dir.path().join("small.toml"),
        "type = \"brackets\"\nviews = [2, 0, 1]\nres = 20\nexposures = [-1.0, 1.0]\n",
    )
    .unwrap();
    lucid_in(dir.path(), &["gen", "spheres", "--rig", "small.toml", "-o", "a", "--spp", "1", "--res", "12"]).success();
    let info = lucid_in(dir.path(), &["info", "a", "--json"]).success().json();
    assert_eq!(info["splits"][0]["frames"], 4, "2 views x 2 exposures from the file");
    assert_eq!(info["splits"][0]["resolutions"][0], "12x12", "--res on the command line wins");
    let record = std::fs::read_to_string(dir.path().join("a/dataset.toml")).unwrap();
    assert!(record.contains("rig = \"brackets\""), "{record}");
    // Reference spheres from a rig file, recorded where they were put; a bad one is refused.
    std::fs::write(
        dir.path().join("spheres.toml"),
        "type = \"olat\"\nviews = [1, 0, 0]\nres = 8\nlights = 1\nreference_spheres = [\"chrome@0.9,0.9,-0.7,0.2\", \"diffuse\"]\n",
    )
    .unwrap();
    lucid_in(dir.path(), &["gen", "studio", "--rig", "spheres.toml", "-o", "s", "--spp", "1"]).success();
    let record: toml::Table = std::fs::read_to_string(dir.path().join("s/dataset.toml")).unwrap().parse().unwrap();
    let spheres = record["reference_spheres"].as_array().unwrap();
    assert_eq!(spheres.len(), 2);
    assert_eq!(spheres[0]["kind"].as_str(), Some("chrome"));
    assert!((spheres[0]["radius"].as_float().unwrap() - 0.2).abs() < 1e-6);
    assert_eq!(spheres[1]["kind"].as_str(), Some("diffuse"));
    // A capture records its spheres too.
    let args = ["gen", "studio", "--rig", "capture", "--images", "2", "--res", "16", "--spp", "1", "-o", "c"];
    lucid_in(dir.path(), &[&args[..], &["--reference-sphere", "diffuse"]].concat()).success();
    let record = std::fs::read_to_string(dir.path().join("c/dataset.toml")).unwrap();
    assert!(record.contains("kind = \"diffuse\""), "{record}");
    std::fs::write(dir.path().join("bad.toml"), "type = \"olat\"\nreference_spheres = [\"glass\"]\n").unwrap();
    lucid_in(dir.path(), &["gen", "studio", "--rig", "bad.toml", "-o", "b"]).failure(&["bad.toml", "glass"]);
    // Every shipped rig file works (shrunk from the command line to stay quick).
    for (rig, extra) in [("orbit", "--res"), ("brackets", "--res"), ("lightfield", "--grid"), ("olat", "--lights")] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../configs/rigs/{rig}.toml"));
        let path = path.to_string_lossy().into_owned();
        let value = match extra {
            "--grid" => "2,2",
            "--lights" => "1",
            _ => "8",
        };
        let out = format!("shipped_{rig}");
        let args = [
            "gen",
            "studio",
            "--rig",
            path.as_str(),
            "-o",
            out.as_str(),
            "--views",
            "1,0,1",
            "--spp",
            "1",
            extra,
            value,
        ];
        lucid_in(dir.path(), &args).success();
        let record = std::fs::read_to_string(dir.path().join(&out).join("dataset.toml")).unwrap();
        assert!(record.contains(&format!("rig = \"{rig}\"")), "{record}");
    }
    std::fs::write(dir.path().join("typo.toml"), "type = \"orbit\"\nresolution = 20\n").unwrap();
    lucid_in(dir.path(), &["gen", "spheres", "--rig", "typo.toml", "-o", "b"]).failure(&["typo.toml", "resolution"]);
    lucid_in(dir.path(), &["gen", "spheres", "--rig", "nope", "-o", "b"]).failure(&["nope", "not a rig"]);
    assert!(!dir.path().join("b").exists());
}

#[test]
fn the_integrator_is_chosen_on_the_command_line_and_recorded() {
    let dir = temp_dir();
    let mut bdpt = vec!["gen", "caustic", "-o", "bdpt", "--integrator", "bdpt"];
    bdpt.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &bdpt).success();
    let mut path = vec!["gen", "caustic", "-o", "path"];
    path.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &path).success();
    let record = |name: &str| std::fs::read_to_string(dir.path().join(name).join("dataset.toml")).unwrap();
    assert!(record("bdpt").contains("integrator = \"bdpt\""), "{}", record("bdpt"));
    // The default is not written, so folders generated before the key existed still resume.
    assert!(!record("path").contains("integrator"), "{}", record("path"));
    // A scene the integrator cannot render is refused before anything is written.
    let mut media = vec!["gen", "media", "-o", "media", "--integrator", "sppm"];
    media.extend_from_slice(&ARGS);
    lucid_in(dir.path(), &media).failure(&["media", "sppm"]);
    assert!(!dir.path().join("media").exists());
}
