//! Instant radiosity and lightcuts: the VPL clamp's bias vanishes as the clamp goes to 0, both
//! agree with the path tracer on the Cornell box, lightcuts matches brute-force summation over
//! the same lights on every pixel at a fraction of its shadow rays, and renders are
//! deterministic per seed whatever the thread count.

use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::manylight::{InstantRadiosity, Lightcuts};
use lucid_trace::{
    Integrator, LoadedScene, RenderCamera, RenderOutput, RenderSettings, load_scene, parse_scene, render,
};

fn at_size(mut loaded: LoadedScene, width: u32, height: u32) -> LoadedScene {
    let RenderCamera::Pinhole(c) = loaded.camera else { panic!("pinhole expected") };
    loaded.camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(width, height, c.intrinsics.fov_x()),
        c.camera_to_world,
    ));
    loaded
}

fn scene(name: &str, width: u32, height: u32) -> LoadedScene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes").join(name);
    at_size(load_scene(&path).unwrap(), width, height)
}

fn run(loaded: &LoadedScene, integrator: Integrator, spp: u32, seed: u64) -> RenderOutput {
    let settings = RenderSettings { spp, seed, integrator, ..loaded.settings };
    render(&loaded.scene, &loaded.camera, &settings, &|_| {}).unwrap()
}

fn grey(p: [f32; 4]) -> f64 {
    ((p[0] + p[1] + p[2]) / 3.0) as f64
}

fn mean(image: &lucid_image::Image) -> f64 {
    let m = image.mean();
    (m[0] + m[1] + m[2]) / 3.0
}

fn vpl(clamp: f32) -> Integrator {
    Integrator::Vpl(InstantRadiosity { clamp, ..InstantRadiosity::DEFAULT })
}

/// VPLs are shared by every pixel of a pass, so their noise does not average out over the
/// image: an image mean has a statistical error of a few per cent, measured over seeds.
const SEEDS: u64 = 6;

/// Mean and standard error of the mean of `values`.
fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let m = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

#[test]
fn the_vpl_clamp_bias_vanishes_as_the_clamp_goes_to_zero() {
    let loaded = scene("cornell.toml", 24, 24);
    let clamps = [0.3, 0.1, 0.03, 0.0];
    // Per seed, the same VPLs and camera paths for every clamp: the means differ by the clamp
    // alone.
    let mut means = vec![Vec::new(); clamps.len()];
    for seed in 0..SEEDS {
        for (c, &clamp) in clamps.iter().enumerate() {
            let integrator = Integrator::Vpl(InstantRadiosity { clamp, light_paths: 512 });
            means[c].push(mean(&run(&loaded, integrator, 8, seed).colour));
        }
    }
    let unclamped = mean_and_error(&means[3]);
    let gaps: Vec<f64> =
        means[..3].iter().map(|m| m.iter().zip(&means[3]).map(|(a, b)| b - a).sum::<f64>() / SEEDS as f64).collect();
    eprintln!("Cornell box: unclamped mean {unclamped:?}; darkening at clamps 0.3, 0.1, 0.03: {gaps:?}");
    assert!(gaps[0] > gaps[1] && gaps[1] > gaps[2] && gaps[2] >= 0.0, "clamp bias must shrink: {gaps:?}");
    assert!(gaps[0] > 0.01 * unclamped.0, "a large clamp darkens the box: {gaps:?}");
    assert!(unclamped.1 < 0.01 * 0.1470, "statistical error {unclamped:?}");
    assert!((unclamped.0 - 0.1470).abs() < 3.0 * unclamped.1, "unclamped mean {unclamped:?}");
}

#[test]
fn vpl_and_lightcuts_keep_the_cornell_box_mean() {
    let loaded = scene("cornell.toml", 24, 24);
    for integrator in [Integrator::Vpl(InstantRadiosity::DEFAULT), Integrator::Lightcuts(Lightcuts::DEFAULT)] {
        let means: Vec<f64> = (0..SEEDS).map(|seed| mean(&run(&loaded, integrator, 16, seed).colour)).collect();
        let (m, e) = mean_and_error(&means);
        eprintln!("{}: {m} ± {e}", integrator.name());
        assert!(e < 0.01 * 0.1470, "{}: statistical error {e}", integrator.name());
        assert!(
            (m - 0.1470).abs() < (3.0 * e).max(0.002 * 0.1470),
            "{}: Cornell box mean {m} ± {e}",
            integrator.name()
        );
    }
}

/// A floor and a rough metal wall under a grid of 1024 point lights, nothing between the
/// lights (or VPLs) and the surfaces they light: there lightcuts' bound holds on every pixel
/// (its bounds assume visibility; a cut's representative may be shadowed where others are not).
const OPEN_CORNER: &str = r#"
[camera]
position = [0.0, 1.6, 4.5]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov = 60.0
width = 48
height = 36

[integrator]
max_depth = 4

[materials.floor]
type = "lambertian"
albedo = [0.7, 0.6, 0.5]

[materials.metal]
type = "conductor"
eta = [0.2, 0.9, 1.1]
k = [3.9, 2.4, 2.2]
roughness = 0.5

[[shapes]]
type = "quad"
material = "floor"
scale = [3.0, 3.0, 1.0]
rotate = [-90.0, 0.0, 0.0]

[[shapes]]
type = "quad"
material = "metal"
scale = [3.0, 1.5, 1.0]
translate = [0.0, 1.5, -3.0]

[[lights]]
type = "point_grid"
corner = [-2.5, 2.5, -2.5]
edge_u = [5.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 5.0]
count = [32, 32]
intensity = [0.01, 0.01, 0.01]
jitter = 0.8
tint = 0.5
seed = 3
"#;

fn lightcuts(error: f32, light_paths: u32) -> Integrator {
    Integrator::Lightcuts(Lightcuts { vpls: InstantRadiosity { light_paths, clamp: 0.01 }, error })
}

#[test]
fn lightcuts_match_brute_force_within_the_bound_on_every_pixel() {
    let loaded = parse_scene(OPEN_CORNER, std::path::Path::new("open-corner.toml")).unwrap();
    let brute = run(&loaded, lightcuts(0.0, 64), 2, 9);
    let cut = run(&loaded, lightcuts(0.02, 64), 2, 9);
    let (w, h) = brute.colour.dimensions();
    let mut worst: f64 = 0.0;
    for y in 0..h {
        for x in 0..w {
            let (b, c) = (grey(brute.colour.get(x, y)), grey(cut.colour.get(x, y)));
            let relative = (c - b).abs() / b.max(1e-4);
            worst = worst.max(relative);
        }
    }
    eprintln!("largest per-pixel relative difference {worst:.4}; shadow rays {} vs {}", cut.rays, brute.rays);
    assert!(worst <= 0.02, "lightcuts {worst} from brute force");
    assert!(worst > 0.0, "a cut that sums every light is not a cut");
}

#[test]
fn lightcuts_trace_a_fraction_of_brute_forces_shadow_rays_in_the_many_lights_hall() {
    let loaded = scene("many-lights.toml", 48, 36);
    let brute = run(&loaded, lightcuts(0.0, 0), 1, 4);
    let cut = run(&loaded, lightcuts(0.02, 0), 1, 4);
    let ratio = brute.rays as f64 / cut.rays as f64;
    let (a, b) = (mean(&cut.colour), mean(&brute.colour));
    eprintln!("rays: brute force {} lightcuts {} ({ratio:.1}×); means {a} {b}", brute.rays, cut.rays);
    assert!(ratio > 10.0, "lightcuts traced only {ratio:.1}× fewer rays");
    assert!((a - b).abs() < 0.01 * b, "means {a} vs {b}");
}

#[test]
fn many_light_renders_do_not_depend_on_the_thread_count() {
    let loaded = scene("many-lights.toml", 32, 24);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    for integrator in [vpl(0.01), lightcuts(0.02, 32)] {
        let a = one.install(|| run(&loaded, integrator, 2, 1).colour);
        let b = three.install(|| run(&loaded, integrator, 2, 1).colour);
        assert_eq!(a.pixels(), b.pixels(), "{}", integrator.name());
        let c = run(&loaded, integrator, 2, 2).colour;
        assert_ne!(a.pixels(), c.pixels(), "{}: the seed must matter", integrator.name());
    }
}
