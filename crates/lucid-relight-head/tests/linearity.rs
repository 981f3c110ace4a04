//! For fixed geometry, compositing is linear in the colours: the render under an environment
//! (per-Gaussian radiance integrated over light directions, one render) must equal the
//! weighted sum of the renders under each light.

use glam::Vec3;
use lucid_relight_head::config::RelightConfig;
use lucid_relight_head::head::RelightHead;
use lucid_relight_head::render::{Geometry, integrated_radiance};
use lucid_scene::{Intrinsics, PinholeCamera, look_at};
use lucid_splat::cloud::SplatCloud;
use lucid_splat::project::RenderSettings;

#[test]
fn environment_render_is_the_weighted_sum_of_light_renders() {
    let device = lucid_burn::backend::default_device();
    device.seed(7);
    let config = RelightConfig::default();
    let mut cloud = SplatCloud::random_in_box(300, Vec3::splat(-0.5), Vec3::splat(0.5), 3);
    // Opaque enough that Gaussians occlude each other (the compositing's nonlinearity in
    // alpha is what must not leak into the colours).
    cloud.opacities.iter_mut().for_each(|o| *o = 1.5);
    cloud.log_scales.iter_mut().for_each(|s| *s = (0.08f32).ln());
    let geometry = Geometry::new(cloud, RenderSettings::default(), &device);
    let head = RelightHead::new(&config, geometry.len(), &device);
    let camera = PinholeCamera::new(
        Intrinsics::from_fov_x(24, 20, 0.8),
        look_at(Vec3::new(0.3, -2.5, 0.8), Vec3::ZERO, Vec3::Z),
    );
    let dirs = [Vec3::X, Vec3::new(0.2, -0.5, 0.8).normalize(), -Vec3::Z, Vec3::new(-0.6, 0.6, 0.1).normalize()];
    let weights = [[0.5, 0.2, 0.1], [1.5, 1.0, 0.7], [0.0, 0.3, 0.0], [0.25, 0.25, 2.0]];

    let integrated = integrated_radiance(&head, &config, &geometry, &camera, &dirs, &weights, &device);
    let together = lucid_burn::to_host_tensor(geometry.render(integrated, &camera));
    let mut summed = vec![0.0f32; together.len()];
    let view_dirs = geometry.view_directions(&camera);
    for (d, w) in dirs.iter().zip(&weights) {
        let one = lucid_burn::to_host_tensor(geometry.render(head.radiance(&config, &view_dirs, *d, &device), &camera));
        for (i, v) in one.iter().enumerate() {
            if i % 4 < 3 {
                summed[i] += w[i % 4] * v;
            } else {
                summed[i] = *v;
            }
        }
    }
    let scale = summed.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(scale > 0.05, "the scene is visible ({scale})");
    let covered = together.chunks_exact(4).filter(|p| p[3] > 0.5).count();
    assert!(covered > 40, "Gaussians overlap on screen ({covered} covered pixels)");
    for (i, (a, b)) in together.iter().zip(&summed).enumerate() {
        assert!((a - b).abs() <= 1e-4 * scale, "value {i}: {a} vs {b}");
    }
}
