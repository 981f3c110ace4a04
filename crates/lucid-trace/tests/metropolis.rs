//! Primary-sample-space Metropolis light transport: the Cornell box mean within its
//! statistical error, per-pixel error falling like 1/√time, the door scene's light found, and
//! renders deterministic per seed whatever the thread count.

use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::pssmlt::Metropolis;
use lucid_trace::{Integrator, LoadedScene, RenderCamera, RenderSettings, load_scene, render};

fn scene(name: &str, width: u32, height: u32) -> LoadedScene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes").join(name);
    let mut loaded = load_scene(&path).unwrap();
    let RenderCamera::Pinhole(c) = loaded.camera else { panic!("{name}: pinhole expected") };
    loaded.camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(width, height, c.intrinsics.fov_x()),
        c.camera_to_world,
    ));
    loaded
}

fn run(loaded: &LoadedScene, integrator: Integrator, spp: u32, seed: u64) -> lucid_image::Image {
    let settings = RenderSettings { spp, seed, integrator, ..loaded.settings };
    render(&loaded.scene, &loaded.camera, &settings, &|_| {}).unwrap().colour
}

fn mean(image: &lucid_image::Image) -> f64 {
    let m = image.mean();
    (m[0] + m[1] + m[2]) / 3.0
}

const MLT: Integrator = Integrator::Pssmlt(Metropolis::DEFAULT);

#[test]
fn metropolis_keeps_the_cornell_box_mean_within_its_statistical_error() {
    let loaded = scene("cornell.toml", 32, 32);
    // The image's luminance is the bootstrap's mean, whose error the seeds measure.
    let means: Vec<f64> = (0..8).map(|seed| mean(&run(&loaded, MLT, 16, seed))).collect();
    let m = means.iter().sum::<f64>() / means.len() as f64;
    let se = (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() * (means.len() - 1)) as f64).sqrt();
    eprintln!("Cornell box mean {m} ± {se}");
    assert!(se < 0.01 * 0.1470, "statistical error {se}");
    assert!((m - 0.1470).abs() < (3.0 * se).max(0.002 * 0.1470), "Cornell box mean {m} ± {se}");
}

/// Mean squared difference of two renders with different seeds: twice the per-pixel variance.
fn squared_difference(a: &lucid_image::Image, b: &lucid_image::Image) -> f64 {
    let n = a.pixels().len() as f64;
    a.pixels()
        .iter()
        .zip(b.pixels())
        .map(|(x, y)| (0..3).map(|c| ((x[c] - y[c]) as f64).powi(2)).sum::<f64>() / 3.0)
        .sum::<f64>()
        / n
}

#[test]
fn metropolis_per_pixel_error_falls_like_one_over_root_time() {
    let loaded = scene("door.toml", 32, 24);
    let noise = |spp| squared_difference(&run(&loaded, MLT, spp, 1), &run(&loaded, MLT, spp, 2));
    let (few, many) = (noise(16), noise(64));
    let ratio = many / few;
    eprintln!("door: squared difference {few} at 16 mutations per pixel, {many} at 64 ({ratio:.2}×)");
    // 1/√time per pixel: a quarter of the variance for four times the mutations.
    assert!((0.12..0.45).contains(&ratio), "{ratio}");
}

#[test]
fn metropolis_agrees_with_the_path_tracer_on_the_door_scene() {
    let loaded = scene("door.toml", 32, 24);
    let reference = mean(&run(&loaded, Integrator::Path, 2048, 3));
    let means: Vec<f64> = (0..4).map(|seed| mean(&run(&loaded, MLT, 64, seed))).collect();
    let m = means.iter().sum::<f64>() / means.len() as f64;
    eprintln!("door: metropolis {means:?}, path tracer {reference}");
    assert!((m - reference).abs() < 0.02 * reference, "metropolis {m}, path tracer {reference}");
}

#[test]
fn metropolis_renders_do_not_depend_on_the_thread_count() {
    let loaded = scene("cornell.toml", 24, 24);
    let params = Integrator::Pssmlt(Metropolis { bootstrap: 5000, chains: 16, ..Metropolis::DEFAULT });
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| run(&loaded, params, 4, 1));
    let b = three.install(|| run(&loaded, params, 4, 1));
    assert_eq!(a.pixels(), b.pixels());
    assert_ne!(a.pixels(), run(&loaded, params, 4, 2).pixels(), "the seed must matter");
}

#[test]
fn metropolis_agrees_with_the_path_tracer_on_glossy_materials() {
    // materials.toml: Phong, Blinn-Phong, Ward, Lafortune, Ashikhmin-Shirley, Cook-Torrance,
    // metals and plastics.
    let loaded = scene("materials.toml", 32, 24);
    let reference = mean(&run(&loaded, Integrator::Path, 1024, 3));
    let means: Vec<f64> = (0..6).map(|seed| mean(&run(&loaded, MLT, 32, seed))).collect();
    let m = means.iter().sum::<f64>() / means.len() as f64;
    let se = (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() * (means.len() - 1)) as f64).sqrt();
    eprintln!("materials: metropolis {m} ± {se}, path tracer {reference}");
    assert!(se < 0.01 * reference, "statistical error {se}");
    assert!(
        (m - reference).abs() < (3.0 * se).max(0.003 * reference),
        "metropolis {m} ± {se}, path tracer {reference}"
    );
}
