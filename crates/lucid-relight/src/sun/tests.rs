use glam::Vec3;
use lucid_image::Image;
use lucid_trace::{parse_scene, render};

use super::*;
use crate::envmap::direction;

/// Sun radiance, its angular radius, where it is, and where the capture clips.
const SUN: f32 = 3000.0;
const SUN_RADIUS: f32 = 0.05;
const CLIP: f32 = 30.0;

fn sun_direction() -> Vec3 {
    Vec3::new(-0.4, 0.6, 0.69).normalize()
}

/// A blue sky over a grey ground with a sun disc, each pixel the mean of 4 × 4 sub-samples
/// (the disc's edge pixels are partly covered).
fn true_map(w: usize) -> Image {
    let h = w / 2;
    Image::from_fn(w, h, |x, y| {
        let mut sum = Vec3::ZERO;
        for sy in 0..4 {
            for sx in 0..4 {
                let d = direction(
                    (x as f32 + (sx as f32 + 0.5) / 4.0) / w as f32,
                    (y as f32 + (sy as f32 + 0.5) / 4.0) / h as f32,
                );
                let sky = if d.z > 0.0 { Vec3::new(0.5, 0.65, 1.0) * (0.4 + 0.6 * d.z) } else { Vec3::splat(0.25) };
                let sun = if d.dot(sun_direction()) > SUN_RADIUS.cos() { Vec3::splat(SUN) } else { Vec3::ZERO };
                sum += sky + sun;
            }
        }
        let v = sum / 16.0;
        [v.x, v.y, v.z, 1.0]
    })
}

/// A diffuse ball of `albedo` under `map`, seen from far out on +Y (the ball filling the frame).
fn sphere_image(map_file: &std::path::Path, albedo: f32, size: u32) -> Image {
    let text = format!(
        r#"
[camera]
position = [0.0, 400.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = {}
width = {size}
height = {size}

[integrator]
spp = 64
max_depth = 2

[materials.ball]
type = "lambertian"
albedo = [{albedo}, {albedo}, {albedo}]

[[shapes]]
type = "sphere"
material = "ball"
radius = 1.0

[[lights]]
type = "environment"
file = "{}"
"#,
        2.0 * (1.0f32 / 400.0).asin().to_degrees(),
        map_file.display()
    );
    let loaded = parse_scene(&text, std::path::Path::new("sun.toml")).unwrap();
    render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap().colour
}

#[test]
fn a_diffuse_ball_restores_the_clipped_suns_power_within_five_per_cent() {
    let dir = tempfile::tempdir().unwrap();
    let truth = true_map(256);
    let map_file = dir.path().join("truth.exr");
    lucid_image::write_image(&map_file, &truth).unwrap();
    let clipped = truth.map(|p| [p[0].min(CLIP), p[1].min(CLIP), p[2].min(CLIP), p[3]]);
    let ball = sphere_image(&map_file, 0.8, 96);
    let (fixed, report) = fix_sun(&clipped, &ball, Vec3::splat(0.8)).unwrap();
    // The sun's power (radiance times solid angle over the clipped pixels) before and after.
    let (w, h) = truth.dimensions();
    let power = |map: &Image| -> f64 {
        (0..w * h)
            .filter(|&i| {
                let p = clipped.get(i % w, i / w);
                p[0].max(p[1]).max(p[2]) >= 0.99 * CLIP
            })
            .map(|i| map.get(i % w, i / w)[1] as f64 * pixel_solid_angle(i / w, w, h) as f64)
            .sum()
    };
    let (true_power, fixed_power, clipped_power) = (power(&truth), power(&fixed), power(&clipped));
    eprintln!(
        "{report:?}\nsun power: true {true_power:.4}, clipped {clipped_power:.4}, restored {fixed_power:.4} ({:+.2} %)",
        100.0 * (fixed_power / true_power - 1.0)
    );
    assert!(clipped_power < 0.05 * true_power, "the test's sun must clip hard");
    assert!((fixed_power / true_power - 1.0).abs() < 0.05, "{fixed_power} vs {true_power}");
    assert!(report.direction.dot(sun_direction()) > 0.999);

    // A map that does not clip, a sphere that is not square, a bad albedo.
    assert!(fix_sun(&Image::from_fn(64, 32, |_, _| [1.0, 1.0, 1.0, 1.0]), &ball, Vec3::splat(0.8)).is_err());
    assert!(fix_sun(&clipped, &Image::from_fn(32, 16, |_, _| [0.0; 4]), Vec3::splat(0.8)).is_err());
    assert!(fix_sun(&clipped, &ball, Vec3::splat(1.5)).is_err());
}
