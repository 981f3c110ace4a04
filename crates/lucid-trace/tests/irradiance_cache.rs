//! Irradiance caching: its interpolation bias shrinks as Ward's error threshold tightens, it
//! is unbiased without interpolation, and it is deterministic per seed whatever the thread
//! count.

use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::irradiance_cache::IrradianceCaching;
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

fn grey(p: [f32; 4]) -> f64 {
    ((p[0] + p[1] + p[2]) / 3.0) as f64
}

fn mean(image: &lucid_image::Image) -> f64 {
    let m = image.mean();
    (m[0] + m[1] + m[2]) / 3.0
}

/// Root-mean-square relative difference of 8×8 block means (mostly bias: blocks average the
/// noise away).
fn block_error(image: &lucid_image::Image, reference: &lucid_image::Image) -> f64 {
    const B: usize = 8;
    let (w, h) = image.dimensions();
    let (mut sum, mut n) = (0.0, 0.0);
    for by in 0..h / B {
        for bx in 0..w / B {
            let (mut a, mut b) = (0.0, 0.0);
            for y in by * B..(by + 1) * B {
                for x in bx * B..(bx + 1) * B {
                    a += grey(image.get(x, y));
                    b += grey(reference.get(x, y));
                }
            }
            sum += ((a - b) / (b + 0.064)).powi(2);
            n += 1.0;
        }
    }
    (sum / n).sqrt()
}

fn cache(error: f32, gather: u32) -> Integrator {
    Integrator::IrradianceCache(IrradianceCaching { error, gather })
}

#[test]
fn the_interpolation_bias_shrinks_with_the_error_threshold() {
    let loaded = scene("cornell.toml", 32, 32);
    let reference = run(&loaded, Integrator::Path, 4096, 11);
    // Many gather rays: records with little noise, so that what is left is interpolation.
    let errors: Vec<f64> =
        [0.8, 0.4, 0.2, 0.1].iter().map(|&a| block_error(&run(&loaded, cache(a, 4096), 128, 3), &reference)).collect();
    eprintln!("block error at a = 0.8, 0.4, 0.2, 0.1: {errors:?}");
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "{errors:?}");
    assert!(errors[3] < 0.1 * errors[0], "{errors:?}");
    // Without interpolation every point path-traces its indirect light: unbiased. Its light
    // samples have a heavy tail (no MIS), so the mean's error is measured over seeds.
    let means: Vec<f64> = (0..6).map(|seed| mean(&run(&loaded, cache(0.0, 1), 256, seed))).collect();
    let m = means.iter().sum::<f64>() / means.len() as f64;
    let se = (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() * (means.len() - 1)) as f64).sqrt();
    let truth = mean(&reference);
    eprintln!("a = 0: mean {m} ± {se}, path tracer {truth}");
    assert!(se < 0.005 * truth, "statistical error {se}");
    assert!((m - truth).abs() < (3.0 * se).max(0.001 * truth), "a = 0: mean {m} ± {se}, path tracer {truth}");
}

#[test]
fn the_default_cache_keeps_the_cornell_box_mean() {
    let loaded = scene("cornell.toml", 48, 48);
    let m = mean(&run(&loaded, Integrator::IrradianceCache(IrradianceCaching::DEFAULT), 32, 1));
    assert!((m - 0.1470).abs() < 0.01 * 0.1470, "Cornell box mean {m}");
}

#[test]
fn irradiance_cache_renders_do_not_depend_on_the_thread_count() {
    let loaded = scene("cornell.toml", 32, 32);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| run(&loaded, cache(0.2, 64), 2, 1));
    let b = three.install(|| run(&loaded, cache(0.2, 64), 2, 1));
    assert_eq!(a.pixels(), b.pixels());
    assert_ne!(a.pixels(), run(&loaded, cache(0.2, 64), 2, 2).pixels(), "the seed must matter");
}
