//! Bidirectional path tracing and light tracing against the path tracer: the same images in
//! expectation (scene means and block means), on diffuse, glossy and specular scenes, with
//! pinhole and thin-lens cameras; deterministic per seed whatever the thread count.

use lucid_scene::{Intrinsics, PinholeCamera, ThinLensCamera};
use lucid_trace::{Integrator, LoadedScene, RenderCamera, RenderSettings, load_scene, render};

fn scene(name: &str, width: u32, height: u32) -> LoadedScene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes").join(name);
    let mut loaded = load_scene(&path).unwrap();
    let pinhole = match loaded.camera {
        RenderCamera::Pinhole(c) => c,
        RenderCamera::ThinLens(c) => c.pinhole,
    };
    let resized =
        PinholeCamera::new(Intrinsics::from_fov_x(width, height, pinhole.intrinsics.fov_x()), pinhole.camera_to_world);
    loaded.camera = match loaded.camera {
        RenderCamera::Pinhole(_) => RenderCamera::Pinhole(resized),
        RenderCamera::ThinLens(c) => RenderCamera::ThinLens(ThinLensCamera { pinhole: resized, ..c }),
    };
    loaded
}

fn render_with(loaded: &LoadedScene, integrator: Integrator, settings: RenderSettings) -> lucid_image::Image {
    render(&loaded.scene, &loaded.camera, &RenderSettings { integrator, ..settings }, &|_| {}).unwrap().colour
}

fn mean(image: &lucid_image::Image) -> f32 {
    let m = image.mean();
    ((m[0] + m[1] + m[2]) / 3.0) as f32
}

/// Means of `block`² pixel blocks (grey).
fn block_means(image: &lucid_image::Image, block: usize) -> Vec<f32> {
    let (w, h) = image.dimensions();
    let mut out = Vec::new();
    for by in 0..h / block {
        for bx in 0..w / block {
            let mut sum = 0.0;
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let p = image.get(x, y);
                    sum += (p[0] + p[1] + p[2]) / 3.0;
                }
            }
            out.push(sum / (block * block) as f32);
        }
    }
    out
}

/// Every block of `a` within `tolerance` (relative, plus `floor` absolute) of `b`'s.
fn assert_blocks_agree(what: &str, a: &lucid_image::Image, b: &lucid_image::Image, tolerance: f32, floor: f32) {
    for (k, (x, y)) in block_means(a, 8).into_iter().zip(block_means(b, 8)).enumerate() {
        assert!((x - y).abs() <= tolerance * y + floor, "{what}: block {k}: {x} against {y}");
    }
}

#[test]
fn bidirectional_integrators_keep_the_cornell_box_mean() {
    // The reference mean is 0.1470 (256², 64 spp, depth 8; `lucid bench trace`); the issue
    // asks every integrator to stay within 1 %. At 96² and 64 spp we measured BDPT 0.14706
    // and light tracing 0.14708 (the Cornell box is diffuse, so light tracing reaches every
    // path). Blocks of 8² pixels agree with the path tracer's within 10 % + 0.01 (the noise
    // of a block of 4096 samples is a few per cent; a misplaced splat moves a block by far
    // more), compared with the light itself hidden: a block on its edge has the noise of a
    // coin flip between 0 and 18 per sample, 20 % at these samples.
    let loaded = scene("cornell.toml", 96, 96);
    let hidden = RenderSettings {
        path: lucid_trace::PathTracer { hide_emitters: true, ..loaded.settings.path },
        ..loaded.settings
    };
    let reference = render_with(&loaded, Integrator::Path, hidden);
    for integrator in [Integrator::Bdpt, Integrator::LightTracing] {
        let image = render_with(&loaded, integrator, loaded.settings);
        let m = mean(&image);
        assert!((m - 0.1470).abs() < 0.0015, "{integrator:?}: Cornell box mean {m}");
        assert!(image.is_finite());
        let image = render_with(&loaded, integrator, hidden);
        assert_blocks_agree(&format!("{integrator:?}"), &image, &reference, 0.1, 0.01);
    }
}

#[test]
fn light_tracing_alone_reproduces_direct_lighting() {
    // Two segments: emitters seen directly and light that bounced once. Light tracing splats
    // every such path from the light's side; the path tracer gathers them from the camera's.
    let loaded = scene("cornell.toml", 64, 64);
    let settings =
        RenderSettings { path: lucid_trace::PathTracer { max_depth: 2, ..loaded.settings.path }, ..loaded.settings };
    let direct = render_with(&loaded, Integrator::Path, settings);
    let traced = render_with(&loaded, Integrator::LightTracing, RenderSettings { spp: 128, ..settings });
    let (a, b) = (mean(&traced), mean(&direct));
    assert!((a - b).abs() < 0.01 * b, "light tracing {a} against path tracing {b}");
    assert_blocks_agree("light tracing, direct light", &traced, &direct, 0.1, 0.01);
}

#[test]
fn bdpt_agrees_with_the_path_tracer_on_glossy_and_specular_materials_and_a_thin_lens() {
    // materials.toml: Phong, Blinn-Phong, Ward, Lafortune, Ashikhmin-Shirley, Cook-Torrance,
    // plastic, a rough conductor and glass under a directional light and an environment;
    // the path tracer at 4× the samples is the reference. Measured at 64×48, 64 spp (2026-12-04):
    // BDPT within 0.3 % of it.
    let loaded = scene("materials.toml", 64, 48);
    let settings = RenderSettings { spp: 64, ..loaded.settings };
    let reference = render_with(&loaded, Integrator::Path, RenderSettings { spp: 256, ..settings });
    let bdpt = render_with(&loaded, Integrator::Bdpt, settings);
    let (a, b) = (mean(&bdpt), mean(&reference));
    assert!((a - b).abs() < 0.01 * b, "materials: BDPT {a} against path tracing {b}");
    assert_blocks_agree("materials", &bdpt, &reference, 0.1, 0.01);

    // A thin lens focused on the back wall: light paths reach the camera through the whole
    // aperture (t = 1), camera paths start on it.
    let mut lens = scene("cornell.toml", 64, 64);
    let RenderCamera::Pinhole(pinhole) = lens.camera else { panic!("the Cornell camera is a pinhole") };
    lens.camera = RenderCamera::ThinLens(ThinLensCamera::new(pinhole, 0.15, 4.9));
    // The light hidden: blocks on its edge are too noisy to compare (see the Cornell test).
    lens.settings.path.hide_emitters = true;
    let reference = render_with(&lens, Integrator::Path, RenderSettings { spp: 256, ..lens.settings });
    let bdpt = render_with(&lens, Integrator::Bdpt, lens.settings);
    let (a, b) = (mean(&bdpt), mean(&reference));
    assert!((a - b).abs() < 0.01 * b, "thin lens: BDPT {a} against path tracing {b}");
    assert_blocks_agree("thin lens", &bdpt, &reference, 0.1, 0.01);
}

#[test]
fn bidirectional_renders_do_not_depend_on_the_thread_count() {
    let loaded = scene("toys.toml", 24, 24);
    let settings = RenderSettings { spp: 4, ..loaded.settings };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    for integrator in [Integrator::Bdpt, Integrator::LightTracing] {
        let a = one.install(|| render_with(&loaded, integrator, settings));
        let b = three.install(|| render_with(&loaded, integrator, settings));
        assert_eq!(a, b, "{integrator:?}");
        let c = render_with(&loaded, integrator, RenderSettings { seed: settings.seed + 1, ..settings });
        assert_ne!(a, c, "{integrator:?}: the seed matters");
        assert!(block_means(&a, 8).iter().all(|v| v.is_finite()) && a.mean()[0] > 0.0);
    }
}

#[test]
fn the_error_of_bidirectional_integrators_falls_like_one_over_the_samples() {
    // Two renders with independent seeds differ per pixel by twice the estimator's variance
    // over the samples; with 4× the samples (4× the time) the squared difference is a
    // quarter: per-pixel RMSE falls like 1/√time, as an unbiased estimator's does. The light
    // is hidden: pixels on its edge (0 or 18 per sample) would make the measured ratio a
    // matter of a handful of pixels.
    let mut loaded = scene("cornell.toml", 48, 48);
    loaded.settings.path.hide_emitters = true;
    let squared_difference = |integrator, spp: u32| {
        let settings = RenderSettings { spp, ..loaded.settings };
        let a = render_with(&loaded, integrator, RenderSettings { seed: 100, ..settings });
        let b = render_with(&loaded, integrator, RenderSettings { seed: 200, ..settings });
        let mut sum = 0.0f64;
        for (p, q) in a.pixels().iter().zip(b.pixels()) {
            for c in 0..3 {
                sum += ((p[c] - q[c]) as f64).powi(2);
            }
        }
        sum / (3 * a.pixels().len()) as f64
    };
    for integrator in [Integrator::Bdpt, Integrator::LightTracing] {
        let ratio = squared_difference(integrator, 32) / squared_difference(integrator, 8);
        assert!((0.17..0.35).contains(&ratio), "{integrator:?}: 4× the samples scaled the squared error by {ratio}");
    }
}
