//! Every file reader against damaged input: valid files with bytes changed, cut, inserted or
//! numbers replaced by extreme values, and random bytes. No input may panic, hang or allocate
//! without bound; each either reads or fails with an error that names the file.
//!
//! A fixed number of cases from a fixed seed per reader (`FUZZ_CASES`, default 128), so that
//! CI runs the same cases in well under a minute; set it higher for a longer local run.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

fn cases() -> u32 {
    std::env::var("FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(128)
}

/// Values that break careless readers: zero, negative, huge, non-numbers.
const EXTREMES: [&str; 10] =
    ["0", "-1", "-0", "1e30", "nan", "inf", "4294967297", "99999999999999999999", "0.5", "-1e-30"];

/// Damaged versions of `seed`.
fn damaged(seed: Vec<u8>) -> BoxedStrategy<Vec<u8>> {
    let n = seed.len();
    let (a, b, c, d) = (seed.clone(), seed.clone(), seed.clone(), seed);
    prop_oneof![
        // Bytes changed.
        3 => prop::collection::vec((0..n, any::<u8>()), 1..6).prop_map(move |edits| {
            let mut bytes = a.clone();
            for (i, v) in edits {
                bytes[i] = v;
            }
            bytes
        }),
        // Cut.
        1 => (0..n).prop_map(move |cut| b[..cut].to_vec()),
        // Bytes inserted.
        1 => (0..=n, prop::collection::vec(any::<u8>(), 1..40)).prop_map(move |(at, ins)| {
            let mut bytes = c.clone();
            bytes.splice(at..at, ins);
            bytes
        }),
        // A number (of a header, a size, a count) replaced by an extreme one.
        3 => (any::<prop::sample::Index>(), 0..EXTREMES.len()).prop_map(move |(which, e)| {
            replace_number(&d, which, EXTREMES[e])
        }),
        // Random bytes.
        1 => prop::collection::vec(any::<u8>(), 0..200),
    ]
    .boxed()
}

/// `bytes` with its `which`-th run of ASCII digits replaced by `with`.
fn replace_number(bytes: &[u8], which: prop::sample::Index, with: &str) -> Vec<u8> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i].is_ascii_digit() {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                i += 1;
            }
            runs.push(start..i);
        } else {
            i += 1;
        }
    }
    if runs.is_empty() {
        return bytes.to_vec();
    }
    let run = runs[which.index(runs.len())].clone();
    let mut out = bytes[..run.start].to_vec();
    out.extend_from_slice(with.as_bytes());
    out.extend_from_slice(&bytes[run.end..]);
    out
}

/// Writes each damaged version of `seed` to `path` and reads it with `read`, which must
/// return `Ok` or an error whose message names the file.
fn fuzz<T, E: std::fmt::Display>(name: &str, path: &Path, seed: Vec<u8>, read: impl Fn(&Path) -> Result<T, E>) {
    let config =
        Config { cases: cases(), rng_seed: RngSeed::Fixed(0x1ce_b00c), failure_persistence: None, ..Config::default() };
    let file_name = path.file_name().unwrap().to_string_lossy().into_owned();
    let mut runner = TestRunner::new(config);
    let result = runner.run(&damaged(seed), |bytes| {
        std::fs::write(path, &bytes).unwrap();
        if let Err(e) = read(path) {
            let message = e.to_string();
            prop_assert!(message.contains(&file_name), "{name}: the error does not name {file_name}: {message}");
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
}

fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn small_image() -> lucid_image::Image {
    lucid_image::Image::from_fn(5, 4, |x, y| [0.1 * x as f32, 0.2 * y as f32, 0.7, if x == 0 { 0.5 } else { 1.0 }])
}

#[test]
fn image_readers_survive_damaged_files() {
    let dir = temp();
    for ext in ["pfm", "hdr", "exr", "png"] {
        let valid = dir.path().join(format!("valid.{ext}"));
        lucid_image::write_image(&valid, &small_image()).unwrap();
        let seed = std::fs::read(&valid).unwrap();
        let case = dir.path().join(format!("case.{ext}"));
        fuzz(ext, &case, seed.clone(), |p: &Path| lucid_image::read_image(p));
        fuzz(ext, &case, seed, |p: &Path| lucid_image::image_dimensions(p));
    }
}

/// A multi-part file whose parts hold Blender-style layers: the layer chooser and the part
/// reader against damaged headers and channel lists.
#[test]
fn multi_layer_exr_readers_survive_damaged_files() {
    use exr::prelude::*;
    let layer = |name: &str, channels: &[&str]| {
        let list: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            channels.iter().map(|c| AnyChannel::new(*c, FlatSamples::F32(vec![0.25; 20]))).collect();
        Layer::new((5, 4), LayerAttributes::named(name), Encoding::UNCOMPRESSED, AnyChannels::sort(list))
    };
    let dir = temp();
    let valid = dir.path().join("valid.exr");
    let layers = vec![
        layer("depth", &["Z"]),
        layer("ViewLayer", &["Combined.R", "Combined.G", "Combined.B", "Combined.A", "AO.R", "AO.G", "AO.B"]),
    ];
    Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((5, 4))), layers)
        .write()
        .to_file(&valid)
        .unwrap();
    assert_eq!(lucid_image::read_image(&valid).unwrap().pixels()[0], [0.25; 4], "the Combined layer");
    let seed = std::fs::read(&valid).unwrap();
    let case = dir.path().join("case.exr");
    fuzz("layered exr", &case, seed.clone(), |p: &Path| lucid_image::read_image(p));
    fuzz("layered exr depth", &case, seed.clone(), |p: &Path| lucid_image::read_depth_image(p));
    fuzz("layered exr size", &case, seed, |p: &Path| lucid_image::image_dimensions(p));
}

#[test]
fn ply_readers_survive_damaged_files() {
    let dir = temp();
    let cloud = lucid_splat::cloud::SplatCloud::random_in_box(6, glam::Vec3::splat(-1.0), glam::Vec3::ONE, 3);
    let valid = dir.path().join("splats.ply");
    lucid_splat::ply::write_splat_ply(&valid, &cloud).unwrap();
    let case = dir.path().join("case.ply");
    fuzz("splat ply", &case, std::fs::read(&valid).unwrap(), lucid_splat::ply::read_splat_ply);
    let points = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
                  0.1 0.2 0.3 255 0 0\n-1 2.5 0 0 128 0\n3 3 3 1 2 3\n";
    fuzz("point ply", &case, points.as_bytes().to_vec(), lucid_scene::point_cloud::read_point_cloud);
}

#[test]
fn the_transforms_reader_survives_damaged_files() {
    let dir = temp();
    std::fs::create_dir(dir.path().join("train")).unwrap();
    for i in 0..3 {
        lucid_image::write_image(dir.path().join(format!("train/r_{i}.png")), &small_image()).unwrap();
    }
    let json = r#"{"camera_angle_x": 0.69, "aabb": [[-1.5,-1.5,-1.5],[1.5,1.5,1.5]], "frames": [
        {"file_path": "./train/r_0", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
        {"file_path": "./train/r_1", "fl_x": 6.5, "cx": 2.5, "transform_matrix": [[0,0,1,4],[1,0,0,0],[0,1,0,0],[0,0,0,1]]},
        {"file_path": "train/r_2.png", "w": 5, "h": 4, "exposure_time": 0.25, "transform_matrix": [[1,0,0,0],[0,0,-1,-4],[0,1,0,0]]}]}"#;
    let case = dir.path().join("transforms_train.json");
    fuzz("transforms", &case, json.as_bytes().to_vec(), |p: &Path| lucid_scene::Dataset::open(p.parent().unwrap()));
}

#[test]
fn the_scene_reader_survives_damaged_files() {
    let dir = temp();
    let seed = std::fs::read(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../configs/scenes/object.toml")).unwrap();
    fuzz("scene", &dir.path().join("case.toml"), seed, lucid_trace::scene_file::load_scene);
}

#[test]
fn checkpoint_readers_survive_damaged_files() {
    let dir = temp();
    let device = lucid_burn::backend::default_device();
    let mut config = lucid_nerf::config::NerfConfig::default();
    config.field.grid.log2_table_size = 8;
    config.field.grid.levels = 2;
    config.field.hidden = 8;
    config.occupancy.resolution = 8;
    let trainer = lucid_nerf::trainer::NerfTrainer::new(
        config,
        (glam::Vec3::splat(-1.0), glam::Vec3::ONE),
        0.01,
        lucid_burn::backend::training_device(),
    );
    let valid = dir.path().join("nerf.lucid");
    lucid_nerf::checkpoint::save(&valid, &trainer, 1.0).unwrap();
    let seed = std::fs::read(&valid).unwrap();
    let case = dir.path().join("case.lucid");
    fuzz("nerf checkpoint", &case, seed.clone(), |p| lucid_nerf::checkpoint::load(p, &device).map(|_| ()));
    // Past the checksum: the sections damaged and written back as a valid container, so that
    // the model's own section parsing is what gets tested.
    let (header, sections) = lucid_burn::checkpoint::read_kind_sections(&valid, "nerf").unwrap();
    let header = serde_json::to_vec_pretty(&header).unwrap();
    let mut all: Vec<Vec<u8>> = vec![header];
    all.extend(sections);
    let joined = all.join(&b"\n--section--\n"[..]);
    fuzz("nerf sections", &case, joined, |p| {
        let bytes = std::fs::read(p).unwrap();
        let parts: Vec<&[u8]> = split_sections(&bytes);
        let rewritten = dir.path().join("rewritten.lucid");
        lucid_burn::checkpoint::write_sections(&rewritten, &parts).unwrap();
        lucid_nerf::checkpoint::load(&rewritten, &device)
            .map(|_| ())
            .map_err(|e| e.to_string().replace("rewritten", "case"))
    });
}

fn split_sections(bytes: &[u8]) -> Vec<&[u8]> {
    let sep = b"\n--section--\n";
    let mut parts = Vec::new();
    let mut rest = bytes;
    while let Some(at) = rest.windows(sep.len()).position(|w| w == sep) {
        parts.push(&rest[..at]);
        rest = &rest[at + sep.len()..];
    }
    parts.push(rest);
    parts
}

#[test]
fn the_colmap_reader_survives_damaged_files() {
    let fixture = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../crates/lucid-scene/tests/fixtures/colmap");
    for (encoding, source) in [("bin", "sparse/0"), ("txt", "sparse_text/0")] {
        let dir = temp();
        std::fs::create_dir_all(dir.path().join("sparse/0")).unwrap();
        std::fs::create_dir(dir.path().join("images")).unwrap();
        for f in std::fs::read_dir(fixture.join("images")).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, dir.path().join("images").join(f.file_name().unwrap())).unwrap();
        }
        for name in ["cameras", "images", "points3D"] {
            let file = format!("{name}.{encoding}");
            std::fs::copy(fixture.join(source).join(&file), dir.path().join("sparse/0").join(&file)).unwrap();
        }
        for name in ["cameras", "images", "points3D"] {
            let case = dir.path().join("sparse/0").join(format!("{name}.{encoding}"));
            let seed = std::fs::read(&case).unwrap();
            let root = dir.path().to_path_buf();
            fuzz(&format!("COLMAP {name}.{encoding}"), &case, seed.clone(), |_: &Path| {
                lucid_scene::Dataset::open(&root)
            });
            std::fs::write(&case, seed).unwrap();
        }
    }
}
