//! The path tracer against closed forms (furnace tests) and against the reference Cornell box
//! (`shared/reference/cornell-box.md`: image mean 0.1470 ± 0.0003 at 64 spp, max depth 8).

use glam::{Mat4, Vec3};
use lucid_scene::{Intrinsics, PinholeCamera, look_at};
use lucid_trace::geometry::procedural::quad;
use lucid_trace::light::Light;
use lucid_trace::{
    Integrator, LightStrategy, Material, PathTracer, RenderCamera, RenderSettings, SceneBuilder, Texture, load_scene,
    render,
};

fn lambert(albedo: Vec3) -> Material {
    Material::Lambertian { albedo: Texture::Constant(albedo) }
}

fn mean_rgb(img: &lucid_image::Image) -> Vec3 {
    let m = img.mean();
    Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
}

#[test]
fn convex_diffuse_object_in_a_uniform_environment_reflects_albedo_times_radiance() {
    // A convex Lambertian object sees only the environment: L_o = ρ·L exactly, at every
    // pixel that sees it, for any number of bounces; MIS must not bias it either way.
    for (albedo, env) in [(0.5f32, 1.0f32), (1.0, 0.7)] {
        let mut b = SceneBuilder::new();
        let m = b.material(lambert(Vec3::splat(albedo)));
        b.sphere(Vec3::ZERO, 1.0, m, None);
        b.light(Light::ConstantEnvironment { radiance: Vec3::splat(env) });
        let scene = b.build();
        let cam = PinholeCamera::new(
            Intrinsics::from_fov_x(16, 16, 0.35),
            look_at(Vec3::new(0.0, -4.0, 1.0), Vec3::ZERO, Vec3::Z),
        );
        let settings = RenderSettings {
            spp: 256,
            seed: 1,
            path: PathTracer { max_depth: 16, rr_depth: 5, hide_emitters: true, ..PathTracer::default() },
            integrator: Integrator::Path,
        };
        let out = render(&scene, &RenderCamera::Pinhole(cam), &settings, &|_| {}).unwrap();
        let (mut sum, mut n) = (0.0f64, 0);
        for p in out.colour.pixels() {
            if p[3] == 1.0 {
                sum += p[0] as f64;
                n += 1;
            }
        }
        let mean = sum / n as f64;
        let expected = (albedo * env) as f64;
        assert!((mean - expected).abs() < 0.01 * expected, "ρ {albedo}, L {env}: {mean} vs {expected}");
    }
}

#[test]
fn point_light_on_a_plane_follows_the_inverse_square_law() {
    // Radiance of a Lambertian plane under a point light of intensity I at height h, seen at
    // the foot point: ρ/π · I/h². Direct light only (max depth 2).
    let mut b = SceneBuilder::new();
    let m = b.material(lambert(Vec3::splat(0.8)));
    b.mesh(&quad().transformed(&Mat4::from_scale(Vec3::splat(50.0))), m, None);
    b.light(Light::Point { position: Vec3::new(0.0, 0.0, 2.0), intensity: Vec3::splat(10.0) });
    let scene = b.build();
    let cam =
        PinholeCamera::new(Intrinsics::from_fov_x(9, 9, 0.01), look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y));
    let settings = RenderSettings {
        spp: 4,
        seed: 2,
        path: PathTracer { max_depth: 2, rr_depth: 5, hide_emitters: false, ..PathTracer::default() },
        integrator: Integrator::Path,
    };
    let out = render(&scene, &RenderCamera::Pinhole(cam), &settings, &|_| {}).unwrap();
    let expected = 0.8 / std::f32::consts::PI * 10.0 / 4.0;
    let centre = out.colour.get(4, 4)[0];
    assert!((centre - expected).abs() < 1e-3 * expected, "{centre} vs {expected}");
    // The depth buffer holds the z-distance 5 and the normal faces +Z.
    assert!((out.depth.get(4, 4)[0] - 5.0).abs() < 1e-3);
    assert!(out.normal.get(4, 4)[2] > 0.999);

    // Off axis, at (x, 0, 0): E = I·cos θ / r² with cos θ = h/r (the cosine law).
    for x in [1.0f32, 3.0] {
        let cam = PinholeCamera::new(
            Intrinsics::from_fov_x(9, 9, 0.001),
            look_at(Vec3::new(x, 0.0, 5.0), Vec3::new(x, 0.0, 0.0), Vec3::Y),
        );
        let out = render(&scene, &RenderCamera::Pinhole(cam), &settings, &|_| {}).unwrap();
        let r2 = x * x + 4.0;
        let expected = 0.8 / std::f32::consts::PI * 10.0 * (2.0 / r2.sqrt()) / r2;
        let got = out.colour.get(4, 4)[0];
        assert!((got - expected).abs() < 2e-3 * expected, "x {x}: {got} vs {expected}");
    }
}

#[test]
fn cornell_box_matches_the_reference_mean() {
    // configs/scenes/cornell.toml is the reference layout. Rendered here at a quarter of the
    // reference's pixel count with the same 64 spp: the image mean does not depend on the
    // resolution beyond the filter's border effect. At 256² (`lucid bench trace`) we measured
    // 0.14699 (0.14689 without Russian roulette). A quarter of the samples doubles the noise
    // of the mean; the 0.002 floor (1.4%) leaves room for it and for the reference's ±0.0003.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/cornell.toml");
    let mut loaded = load_scene(&path).unwrap();
    assert_eq!((loaded.settings.spp, loaded.settings.path.max_depth), (64, 8));
    let RenderCamera::Pinhole(cam) = loaded.camera else { panic!("the Cornell camera is a pinhole") };
    loaded.camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(128, 128, cam.intrinsics.fov_x()),
        cam.camera_to_world,
    ));
    let out = render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap();
    let m = mean_rgb(&out.colour);
    let mean = (m.x + m.y + m.z) / 3.0;
    assert!((mean - 0.1470).abs() < 0.002, "Cornell box mean {mean} (reference 0.1470 ± 0.0003)");
    assert!(out.colour.is_finite());
    // Left wall red, right wall green: mean colour of a band of pixels on each wall.
    let band = |x0: usize| {
        let mut sum = Vec3::ZERO;
        for y in 40..88 {
            for x in x0..x0 + 4 {
                let p = out.colour.get(x, y);
                sum += Vec3::new(p[0], p[1], p[2]);
            }
        }
        sum
    };
    let (left, right) = (band(2), band(122));
    assert!(left.x > 3.0 * left.y && right.y > 1.5 * right.x, "{left} {right}");
}

#[test]
fn renders_do_not_depend_on_the_thread_count() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/cornell.toml");
    let loaded = load_scene(&path).unwrap();
    let RenderCamera::Pinhole(cam) = loaded.camera else { panic!() };
    let camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(24, 24, cam.intrinsics.fov_x()),
        cam.camera_to_world,
    ));
    let settings = RenderSettings { spp: 4, ..loaded.settings };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| render(&loaded.scene, &camera, &settings, &|_| {}).unwrap());
    let b = three.install(|| render(&loaded.scene, &camera, &settings, &|_| {}).unwrap());
    assert_eq!(a.colour, b.colour);
    let c = render(&loaded.scene, &camera, &RenderSettings { seed: settings.seed + 1, ..settings }, &|_| {}).unwrap();
    assert_ne!(a.colour, c.colour, "the seed matters");
}

#[test]
fn diffuse_plane_under_an_environment_map_reflects_its_cosine_weighted_integral() {
    // A Lambertian plane facing +Z sees the upper hemisphere of the map: L_o = ρ/π ∫ L cos θ dω,
    // exact per texel: Δφ·(sin²θ₁ − sin²θ₀)/2 for the rows above the horizon.
    let (w, h) = (48usize, 24usize);
    let img = lucid_image::Image::from_fn(w, h, |x, y| {
        let sun = if x == 10 && y == 4 { 200.0 } else { 0.0 };
        [0.2 + 0.02 * y as f32 + sun, 0.5 + 0.01 * x as f32, 0.3 + sun * 0.5, 1.0]
    });
    let mut exact = Vec3::ZERO;
    for y in 0..h / 2 {
        let (t0, t1) = (std::f32::consts::PI * y as f32 / h as f32, std::f32::consts::PI * (y + 1) as f32 / h as f32);
        let weight = std::f32::consts::TAU / w as f32 * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        for x in 0..w {
            let p = img.get(x, y);
            exact += Vec3::new(p[0], p[1], p[2]) * weight;
        }
    }
    let albedo = 0.6;
    let expected = albedo / std::f32::consts::PI * exact;

    let mut b = SceneBuilder::new();
    let m = b.material(lambert(Vec3::splat(albedo)));
    b.mesh(&quad().transformed(&Mat4::from_scale(Vec3::splat(100.0))), m, None);
    b.light(Light::EnvironmentMap(Box::new(lucid_trace::environment::EnvironmentMap::new(
        &img,
        1.0,
        glam::Mat3::IDENTITY,
    ))));
    let scene = b.build();
    let cam =
        PinholeCamera::new(Intrinsics::from_fov_x(4, 4, 0.01), look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y));
    let settings = RenderSettings {
        spp: 20_000,
        seed: 3,
        path: PathTracer { max_depth: 2, rr_depth: 5, hide_emitters: false, ..PathTracer::default() },
        integrator: Integrator::Path,
    };
    let out = render(&scene, &RenderCamera::Pinhole(cam), &settings, &|_| {}).unwrap();
    let got = mean_rgb(&out.colour);
    assert!(((got - expected) / expected).abs().max_element() < 0.01, "{got} vs {expected}");
}

#[test]
fn light_sampling_bsdf_sampling_and_mis_converge_to_the_same_image() {
    // The Cornell box: a small area light, so each strategy has its own noise profile.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/cornell.toml");
    let loaded = load_scene(&path).unwrap();
    let RenderCamera::Pinhole(cam) = loaded.camera else { panic!() };
    let camera = RenderCamera::Pinhole(PinholeCamera::new(
        Intrinsics::from_fov_x(32, 32, cam.intrinsics.fov_x()),
        cam.camera_to_world,
    ));
    let mean_for = |strategy: LightStrategy, spp: u32| {
        let settings =
            RenderSettings { spp, seed: 11, path: PathTracer { strategy, ..loaded.settings.path }, ..loaded.settings };
        let m = mean_rgb(&render(&loaded.scene, &camera, &settings, &|_| {}).unwrap().colour);
        (m.x + m.y + m.z) / 3.0
    };
    let mis = mean_for(LightStrategy::Mis, 256);
    let nee = mean_for(LightStrategy::NextEventOnly, 256);
    // BSDF sampling alone finds the small light rarely: many more samples for the same noise.
    let bsdf = mean_for(LightStrategy::BsdfOnly, 4096);
    assert!((mis - nee).abs() < 0.01 * mis, "MIS {mis} vs NEE {nee}");
    assert!((mis - bsdf).abs() < 0.015 * mis, "MIS {mis} vs BSDF {bsdf}");
}

#[test]
fn white_furnace_for_every_lossless_bsdf() {
    // A sphere of each non-absorbing material (albedo 1) in a uniform environment of radiance
    // 1 must render 1: it can only redistribute light. The GGX conductor at low roughness loses
    // little to masking (within the 1% floor). The phenomenological models (Phong, Ward,
    // Ashikhmin–Shirley…) reflect less than 1 at oblique angles by design: their bound is
    // checked per BSDF in the unit tests instead (Ashikhmin–Shirley with Rd = 1 renders 0.92).
    use lucid_trace::material::Material as M;
    let white = Texture::Constant(Vec3::ONE);
    let materials = [
        ("lambertian", M::Lambertian { albedo: white.clone() }),
        ("dielectric", M::Dielectric { eta: 1.5, transmittance: Vec3::ONE }),
        ("plastic", M::Plastic { albedo: white.clone(), eta: 1.5 }),
        ("conductor α=0.01", M::Conductor { eta: Vec3::ZERO, k: Vec3::splat(1e4), alpha: glam::Vec2::splat(0.01) }),
        ("interface", M::Interface),
    ];
    for (name, material) in materials {
        let mut b = SceneBuilder::new();
        let m = b.material(material);
        b.sphere(Vec3::ZERO, 1.0, m, None);
        b.light(Light::ConstantEnvironment { radiance: Vec3::ONE });
        let scene = b.build();
        let cam = PinholeCamera::new(
            Intrinsics::from_fov_x(12, 12, 0.35),
            look_at(Vec3::new(0.0, -4.0, 0.5), Vec3::ZERO, Vec3::Z),
        );
        let settings = RenderSettings {
            spp: 256,
            seed: 5,
            path: PathTracer { max_depth: 1000, rr_depth: 1000, hide_emitters: false, ..PathTracer::default() },
            integrator: Integrator::Path,
        };
        let out = render(&scene, &RenderCamera::Pinhole(cam), &settings, &|_| {}).unwrap();
        let got = mean_rgb(&out.colour);
        assert!((got - Vec3::ONE).abs().max_element() < 0.01, "{name}: {got}");
    }
}

#[test]
fn the_caustic_scene_focuses_light_under_the_glass_sphere() {
    // configs/scenes/caustic.toml: a glass ball (n = 1.5, r = 0.5) on the floor under a small
    // light. A ball lens focuses 0.75 from its centre, beyond the floor (0.5 below it), so the
    // light it gathers lands in a spot on the floor where the line from the light through the
    // centre meets it, inside the ball's shadow: brighter than the floor the light reaches
    // directly, which the path tracer finds only through rare paths (the scene is for issue
    // 30's bidirectional methods). Rendered at half size.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/caustic.toml");
    let mut loaded = load_scene(&path).unwrap();
    let RenderCamera::Pinhole(cam) = loaded.camera else { panic!("the caustic camera is a pinhole") };
    let cam = PinholeCamera::new(Intrinsics::from_fov_x(128, 96, cam.intrinsics.fov_x()), cam.camera_to_world);
    loaded.camera = RenderCamera::Pinhole(cam);
    loaded.settings.spp = 128;
    let out = render(&loaded.scene, &loaded.camera, &loaded.settings, &|_| {}).unwrap();
    let (light, centre) = (Vec3::new(0.3, 0.6, 2.6), Vec3::new(0.0, 0.0, 0.5));
    let focus = centre + (centre - light) * (centre.z / (light.z - centre.z));
    let window = |world: Vec3| {
        let p = cam.project(world).expect("in view");
        let (x, y) = (p.x as usize, p.y as usize);
        let mut sum = 0.0;
        for v in y - 1..=y + 1 {
            for u in x - 1..=x + 1 {
                let c = out.colour.get(u, v);
                sum += (c[0] + c[1] + c[2]) / 3.0;
            }
        }
        sum / 9.0
    };
    let (spot, lit) = (window(focus), window(Vec3::new(1.2, -0.6, 0.0)));
    // Measured 8.9× (the scene's seed 0) and 5.1–6.4× with seeds 1–5: the path tracer's
    // estimate of a caustic is that noisy.
    assert!(spot > 4.0 * lit, "caustic {spot}, directly lit floor {lit}");
}
