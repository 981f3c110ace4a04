//! The packet tracer (eight paths in lock-step, with lane loops for diffuse surfaces and
//! triangle lights) against the single-path tracer: given the same random stream, each path
//! must measure the same radiance, auxiliary values and ray count, on every shipped scene
//! without media, on a scene with emissive spheres and delta lights, and under every
//! light-finding strategy.

use glam::{Mat4, Vec2, Vec3};
use lucid_scene::camera::Camera;
use lucid_scene::{Intrinsics, PinholeCamera, Ray, look_at};
use lucid_trace::geometry::procedural::quad;
use lucid_trace::light::Light;
use lucid_trace::sampling::Rng;
use lucid_trace::{
    Emission, LightStrategy, Material, PathTracer, RenderCamera, Scene, SceneBuilder, Texture, load_scene,
};

fn camera_ray(camera: &RenderCamera, px: f32, py: f32, lens: Vec2) -> Ray {
    match camera {
        RenderCamera::Pinhole(c) => c.generate_ray(px, py, lens),
        RenderCamera::ThinLens(c) => c.generate_ray(px, py, lens),
    }
}

/// Traces batches of camera rays over the image both ways and compares path by path.
fn assert_packets_match_single_paths(name: &str, scene: &Scene, camera: &RenderCamera, tracer: &PathTracer) {
    assert!(PathTracer::packet_supports(scene), "{name}");
    let (w, h) = match camera {
        RenderCamera::Pinhole(c) => (c.intrinsics.width, c.intrinsics.height),
        RenderCamera::ThinLens(c) => (c.pinhole.intrinsics.width, c.pinhole.intrinsics.height),
    };
    let mut picker = Rng::new(3, 0);
    let mut lit = 0;
    // Batches of several sizes: lanes take new paths as theirs end, and the last packet of a
    // batch is partly filled.
    for (batch, count) in [1usize, 5, 8, 9, 64, 300].into_iter().enumerate() {
        let rays: Vec<Ray> = (0..count)
            .map(|_| {
                let (px, py) = (picker.uniform() * w as f32, picker.uniform() * h as f32);
                camera_ray(camera, px, py, picker.uniform2())
            })
            .collect();
        let stream = |k: usize| Rng::new(17, (batch * 1000 + k) as u64);
        let mut packed = vec![Default::default(); count];
        tracer.trace_paths(scene, |k| (rays[k], stream(k)), &mut packed);
        for k in 0..count {
            let single = tracer.trace(scene, rays[k], &mut stream(k));
            assert_eq!(packed[k], single, "{name}, batch of {count}, path {k}");
            lit += (single.radiance != Vec3::ZERO) as usize;
        }
    }
    assert!(lit > 50, "{name}: only {lit} paths found light; the comparison would be weak");
}

#[test]
fn packets_trace_the_shipped_scenes_path_for_path() {
    for name in ["cornell", "materials", "object", "spheres", "studio"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../configs/scenes/{name}.toml"));
        let loaded = load_scene(&path).unwrap();
        assert_packets_match_single_paths(name, &loaded.scene, &loaded.camera, &loaded.settings.path);
    }
    // Relit by two directional lights, as one-light-at-a-time captures do.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/studio.toml");
    let loaded = load_scene(&path).unwrap();
    let lights = [Vec3::new(0.3, -0.5, 0.8), Vec3::new(-0.7, 0.2, 0.4)]
        .map(|d| Light::Directional { direction: d.normalize(), irradiance: Vec3::splat(3.0) });
    let relit = loaded.scene.relit(lights.to_vec()).unwrap();
    assert_packets_match_single_paths("studio, relit", &relit, &loaded.camera, &loaded.settings.path);
}

#[test]
fn packets_handle_emissive_spheres_delta_lights_and_every_strategy() {
    let mut b = SceneBuilder::new();
    let floor = b.material(Material::Lambertian {
        albedo: Texture::Checker { a: Vec3::splat(0.8), b: Vec3::new(0.2, 0.4, 0.6), scale: 4.0 },
    });
    let metal = b.material(Material::Conductor {
        eta: Vec3::new(0.2, 0.9, 1.1),
        k: Vec3::new(3.9, 2.4, 2.2),
        alpha: Vec2::splat(0.2),
    });
    let glass = b.material(Material::Dielectric { eta: 1.5, transmittance: Vec3::ONE });
    let white = b.material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.7)) });
    b.mesh(&quad().transformed(&Mat4::from_scale(Vec3::splat(6.0))), floor, None);
    b.sphere(Vec3::new(-0.8, 0.0, 0.6), 0.6, metal, None);
    b.sphere(Vec3::new(0.8, 0.3, 0.5), 0.5, glass, None);
    // An emissive sphere (a non-triangle area light) and a two-sided emissive quad.
    b.sphere(Vec3::new(0.0, 1.5, 2.0), 0.3, white, Some(Emission { radiance: Vec3::splat(6.0), two_sided: false }));
    let panel =
        quad().transformed(&(Mat4::from_translation(Vec3::new(1.5, -1.0, 2.5)) * Mat4::from_scale(Vec3::splat(0.5))));
    b.mesh(&panel, white, Some(Emission { radiance: Vec3::new(4.0, 3.0, 2.0), two_sided: true }));
    b.light(Light::Point { position: Vec3::new(-1.5, -1.0, 2.0), intensity: Vec3::splat(3.0) });
    b.light(Light::Spot {
        position: Vec3::new(0.0, -2.0, 3.0),
        direction: Vec3::new(0.0, 0.5, -1.0).normalize(),
        intensity: Vec3::splat(8.0),
        cos_inner: 0.95,
        cos_outer: 0.85,
    });
    b.light(Light::ConstantEnvironment { radiance: Vec3::splat(0.2) });
    let scene = b.build();
    let camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(64, 48, 0.9),
        look_at(Vec3::new(0.0, -5.0, 2.5), Vec3::new(0.0, 0.0, 0.5), Vec3::Z),
    ));
    for strategy in [LightStrategy::Mis, LightStrategy::NextEventOnly, LightStrategy::BsdfOnly] {
        for hide_emitters in [false, true] {
            let tracer = PathTracer { max_depth: 6, rr_depth: 3, hide_emitters, strategy };
            assert_packets_match_single_paths(&format!("{strategy:?}, hide {hide_emitters}"), &scene, &camera, &tracer);
        }
    }
}
