//! Projector lights: the image they throw on a wall is the closed form `ρ/π · I cos³θ / D²`,
//! pixel by pixel, and the bidirectional integrators, which start paths on the projector,
//! render its light as the path tracer does.

use std::f32::consts::PI;
use std::path::Path;

use lucid_trace::{Integrator, RenderSettings, parse_scene, render};

/// A camera and a projector both at the origin looking along +y with a 40° field, 4 × 2
/// projector pixels of different intensities (written as a PFM image), a white wall at y = 2,
/// and, with `room`, a floor and side walls that light bounces between.
fn scene(dir: &Path, room: bool) -> String {
    let intensities = [[1.0f32, 2.0, 3.0], [4.0, 0.5, 1.5], [0.0, 2.5, 1.0], [3.0, 3.0, 3.0]];
    let image = lucid_image::Image::from_fn(4, 2, |x, y| {
        let c = intensities[x];
        let f = if y == 0 { 1.0 } else { 0.5 };
        [c[0] * f, c[1] * f, c[2] * f, 1.0]
    });
    lucid_image::write_image(dir.join("slide.pfm"), &image).unwrap();
    let room_shapes = if room {
        r#"
[[shapes]]
type = "cube"
material = "white"
scale = [3.0, 3.0, 0.05]
translate = [0.0, 1.0, -0.8]
[[shapes]]
type = "cube"
material = "white"
scale = [0.05, 3.0, 3.0]
translate = [1.3, 1.0, 0.0]
"#
    } else {
        ""
    };
    format!(
        r#"
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 1.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 40.0
width = 64
height = 32

[integrator]
spp = 16
max_depth = 6

[materials.white]
type = "lambertian"
albedo = [0.8, 0.8, 0.8]

[[shapes]]
type = "cube"
material = "white"
scale = [5.0, 0.05, 5.0]
translate = [0.0, 2.05, 0.0]
{room_shapes}
[[lights]]
type = "projector"
position = [0.0, 0.0, 0.0]
look_at = [0.0, 1.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 40.0
image = "slide.pfm"
intensity = [1.0, 1.0, 1.0]
"#
    )
}

#[test]
fn a_projected_image_lands_on_a_wall_with_the_inverse_square_and_cosine_laws() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = parse_scene(&scene(dir.path(), false), &dir.path().join("scene.toml")).unwrap();
    let image = render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap().colour;
    let slide = lucid_image::read_image(dir.path().join("slide.pfm")).unwrap();
    let tan = (20f32).to_radians().tan();
    let mut worst = 0f32;
    // Every camera pixel away from the projector pixels' edges (filters blur across them).
    for y in 0..32 {
        for x in 0..64 {
            let (fx, fy) = ((x % 16) as f32 + 0.5, (y % 16) as f32 + 0.5);
            if !(3.0..13.0).contains(&fx) || !(3.0..13.0).contains(&fy) {
                continue;
            }
            let px = ((x as f32 + 0.5) / 32.0 - 1.0) * tan;
            let pz = (1.0 - (y as f32 + 0.5) / 16.0) * tan * 0.5;
            let cos = 1.0 / (1.0 + px * px + pz * pz).sqrt();
            let intensity = slide.get(x / 16, y / 16);
            for (c, value) in intensity.iter().take(3).enumerate() {
                let expected = 0.8 / PI * value * cos.powi(3) / 4.0;
                let got = image.get(x, y)[c];
                worst = worst.max((got - expected).abs() / expected.max(0.02));
            }
        }
    }
    assert!(worst < 0.01, "worst relative error {worst}");

    // A single lit pixel: the rest of the wall is dark.
    let one = scene(dir.path(), false).replace("image = \"slide.pfm\"", "image = \"slide.pfm\"\npixel = [1, 0]");
    let loaded = parse_scene(&one, &dir.path().join("scene.toml")).unwrap();
    let image = render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap().colour;
    assert!(image.get(24, 8)[0] > 0.1 && image.get(8, 8)[0] == 0.0 && image.get(24, 24)[0] == 0.0);
}

#[test]
fn bidirectional_integrators_render_projector_light_as_the_path_tracer_does() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = parse_scene(&scene(dir.path(), true), &dir.path().join("scene.toml")).unwrap();
    let mean = |integrator: Integrator, spp: u32| {
        let settings = RenderSettings { integrator, spp, seed: 3, ..loaded.settings };
        let m = render(&loaded.scene, &loaded.camera, &settings, &|_| {}).unwrap().colour.mean();
        (m[0] + m[1] + m[2]) / 3.0
    };
    let path = mean(Integrator::Path, 256);
    for integrator in [Integrator::Bdpt, Integrator::LightTracing] {
        let m = mean(integrator, 256);
        assert!((m - path).abs() < 0.01 * path, "{integrator:?}: {m} against the path tracer's {path}");
    }
}

#[test]
fn bad_projectors_are_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let base = scene(dir.path(), false);
    for (from, to, key) in [
        ("image = \"slide.pfm\"", "", "lights[0]"),
        ("image = \"slide.pfm\"", "image = \"none.png\"", "lights[0].image"),
        ("image = \"slide.pfm\"", "image = \"slide.pfm\"\nresolution = [5, 2]", "lights[0].resolution"),
        ("image = \"slide.pfm\"", "resolution = [4, 2]\npixel = [4, 0]", "lights[0].pixel"),
        ("fov = 40.0\nimage", "fov = 180.0\nimage", "lights[0].fov"),
        ("intensity = [1.0, 1.0, 1.0]", "intensity = [1.0, -1.0, 1.0]", "lights[0].intensity"),
    ] {
        let text = base.replace(from, to);
        assert_ne!(text, base, "{from}");
        let err = match parse_scene(&text, &dir.path().join("scene.toml")) {
            Ok(_) => panic!("{to}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("scene.toml") && err.contains(key), "{key}: {err}");
    }
}
