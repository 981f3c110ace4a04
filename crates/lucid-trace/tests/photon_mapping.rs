//! Stochastic progressive photon mapping: consistent (its bias shrinks as passes shrink the
//! radii), close to the path tracer on the Cornell box, finds the caustic, and deterministic
//! per seed whatever the thread count.

use lucid_scene::{Intrinsics, PinholeCamera};
use lucid_trace::sppm::PhotonMapping;
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

fn sppm(loaded: &LoadedScene, passes: u32, seed: u64, params: PhotonMapping) -> lucid_image::Image {
    let settings = RenderSettings { spp: passes, seed, integrator: Integrator::Sppm(params), ..loaded.settings };
    render(&loaded.scene, &loaded.camera, &settings, &|_| {}).unwrap().colour
}

fn grey(p: [f32; 4]) -> f64 {
    ((p[0] + p[1] + p[2]) / 3.0) as f64
}

/// Root-mean-square relative difference of `block`² block means: averaging a block's pixels
/// removes most of the noise, so what is left is mostly bias.
fn block_error(image: &lucid_image::Image, reference: &lucid_image::Image, block: usize) -> f64 {
    let (w, h) = image.dimensions();
    let (mut sum, mut n) = (0.0, 0.0);
    for by in 0..h / block {
        for bx in 0..w / block {
            let (mut a, mut b) = (0.0, 0.0);
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    a += grey(image.get(x, y));
                    b += grey(reference.get(x, y));
                }
            }
            sum += ((a - b) / (b + 1e-3 * (block * block) as f64)).powi(2);
            n += 1.0;
        }
    }
    (sum / n).sqrt()
}

#[test]
fn sppm_converges_to_the_path_tracer_as_its_radii_shrink() {
    let loaded = scene("cornell.toml", 64, 64);
    let hidden = RenderSettings {
        spp: 1024,
        path: lucid_trace::PathTracer { hide_emitters: true, ..loaded.settings.path },
        ..loaded.settings
    };
    let hidden_scene = LoadedScene { settings: hidden, ..loaded.clone() };
    let reference = render(&loaded.scene, &loaded.camera, &hidden, &|_| {}).unwrap().colour;
    let mut errors = Vec::new();
    for passes in [4, 16, 64] {
        let image = sppm(&hidden_scene, passes, 7, PhotonMapping::DEFAULT);
        errors.push(block_error(&image, &reference, 8));
    }
    eprintln!("block error after 4, 16, 64 passes: {errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    assert!(errors[2] < 0.5 * errors[0], "{errors:?}");

    let image = sppm(&loaded, 64, 3, PhotonMapping::DEFAULT);
    let m = image.mean();
    let mean = (m[0] + m[1] + m[2]) / 3.0;
    assert!((mean - 0.1470).abs() < 0.003, "Cornell box mean {mean} after 64 passes");
}

#[test]
fn sppm_renders_do_not_depend_on_the_thread_count() {
    let loaded = scene("caustic.toml", 32, 24);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| sppm(&loaded, 4, 1, PhotonMapping::DEFAULT));
    let b = three.install(|| sppm(&loaded, 4, 1, PhotonMapping::DEFAULT));
    assert_eq!(a, b);
    assert_ne!(a, sppm(&loaded, 4, 2, PhotonMapping::DEFAULT), "the seed matters");
}
