//! A mirror ball rendered by the path tracer from far out on +Y, converted to a lat-long map,
//! gives back the environment it reflects: patches on +X, +Y and −X land where they were
//! (the tool once mirrored left and right).

use glam::Vec3;
use lucid_image::Image;
use lucid_relight::envmap::{direction, mirror_ball_to_latlong, pixel_direction};
use lucid_trace::{parse_scene, render};

/// Grey with three coloured patches on the horizon: red towards +X, green +Y, blue −X.
fn environment(w: usize) -> Image {
    Image::from_fn(w, w / 2, |x, y| {
        let d = direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / (w / 2) as f32);
        let near = |a: Vec3| d.dot(a) > 0.95;
        let c = if near(Vec3::X) {
            [5.0, 0.0, 0.0]
        } else if near(Vec3::Y) {
            [0.0, 5.0, 0.0]
        } else if near(-Vec3::X) {
            [0.0, 0.0, 5.0]
        } else {
            [0.2, 0.2, 0.2]
        };
        [c[0], c[1], c[2], 1.0]
    })
}

#[test]
fn a_rendered_mirror_ball_converts_back_to_its_environment() {
    let dir = tempfile::tempdir().unwrap();
    let env = dir.path().join("env.exr");
    lucid_image::write_image(&env, &environment(128)).unwrap();
    let text = format!(
        r#"
[camera]
position = [0.0, 400.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = {}
width = 96
height = 96

[integrator]
spp = 16
max_depth = 3

[materials.mirror]
type = "conductor"
eta = [0.2, 0.2, 0.2]
k = [10.0, 10.0, 10.0]
roughness = 0.0

[[shapes]]
type = "sphere"
material = "mirror"
radius = 1.0

[[lights]]
type = "environment"
file = "{}"
"#,
        2.0 * (1.0f32 / 400.0).asin().to_degrees(),
        env.display()
    );
    let loaded = parse_scene(&text, std::path::Path::new("ball.toml")).unwrap();
    let ball = render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap().colour;
    let map = mirror_ball_to_latlong(&ball, 128);
    // Each patch's mean direction in the converted map.
    for (channel, expected) in [(0, Vec3::X), (1, Vec3::Y), (2, -Vec3::X)] {
        let mut sum = Vec3::ZERO;
        for y in 0..64 {
            for x in 0..128 {
                let p = map.get(x, y);
                if p[channel] > 1.0 && p[(channel + 1) % 3] < 0.5 {
                    sum += pixel_direction(x, y, 128, 64);
                }
            }
        }
        let found = sum.normalize_or_zero();
        assert!(found.dot(expected) > 0.99, "patch {channel}: found towards {found}, expected {expected}");
    }
}
