//! Scene files: a valid one builds what it says; every kind of mistake is an error naming
//! the file and the key.

use std::path::Path;

use glam::Vec3;
use lucid_trace::light::Light;
use lucid_trace::{RenderCamera, parse_scene};

const CAMERA: &str = r#"
[camera]
position = [0.0, -4.0, 1.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
width = 32
height = 24
"#;

fn scene(rest: &str) -> String {
    format!("{CAMERA}\n{rest}")
}

#[test]
fn a_valid_scene_builds_materials_shapes_and_lights() {
    let text = scene(
        r#"
[integrator]
spp = 3
max_depth = 4
seed = 9

[materials.matte]
type = "lambertian"
albedo = { a = [0.8, 0.8, 0.8], b = [0.1, 0.1, 0.1], scale = 4.0 }

[materials.gold]
type = "conductor"
eta = [0.143, 0.374, 1.442]
k = [3.983, 2.385, 1.603]
roughness = 0.3

[materials.glass]
type = "dielectric"
ior = 1.5

[[shapes]]
type = "sphere"
material = "glass"
radius = 0.5
translate = [0.0, 0.0, 0.5]

[[shapes]]
type = "torus_knot"
material = "gold"
scale = 0.5

[[shapes]]
type = "quad"
material = "matte"
scale = 3.0
emission = [0.0, 0.0, 0.0]

[[lights]]
type = "directional"
direction = [0.3, -0.2, 1.0]
irradiance = [3.0, 3.0, 3.0]

[[lights]]
type = "environment"
radiance = [0.2, 0.25, 0.3]
"#,
    );
    let loaded = parse_scene(&text, Path::new("ok.toml")).unwrap();
    assert_eq!((loaded.settings.spp, loaded.settings.path.max_depth, loaded.settings.seed), (3, 4, 9));
    assert_eq!(loaded.scene.materials.len(), 3);
    assert_eq!(loaded.scene.lights.len(), 2);
    assert!(matches!(loaded.scene.lights[1], Light::ConstantEnvironment { .. }));
    assert_eq!(loaded.scene.environment, Some(1));
    let RenderCamera::Pinhole(cam) = loaded.camera else { panic!("pinhole expected") };
    assert_eq!((cam.intrinsics.width, cam.intrinsics.height), (32, 24));
    assert!((cam.position() - Vec3::new(0.0, -4.0, 1.0)).length() < 1e-6);
    // A zero emission is not a light; the sphere is analytic, the rest triangles.
    let spheres = loaded
        .scene
        .bvh
        .primitives()
        .iter()
        .filter(|p| matches!(p.shape, lucid_trace::geometry::Shape::Sphere { .. }))
        .count();
    assert_eq!(spheres, 1);
}

#[test]
fn thin_lens_when_the_aperture_is_open() {
    let text = CAMERA.replace("height = 24", "height = 24\naperture_radius = 0.1\nfocus_distance = 3.0");
    let loaded = parse_scene(&text, Path::new("lens.toml")).unwrap();
    let RenderCamera::ThinLens(c) = loaded.camera else { panic!("thin lens expected") };
    assert_eq!((c.aperture_radius, c.focus_distance), (0.1, 3.0));
}

#[test]
fn mistakes_name_the_file_and_key() {
    let cases: Vec<(String, &[&str])> = vec![
        ("[camera]\nposition = [0.0, 0.0, 1.0]".to_string(), &["missing field", "look_at"]),
        (scene("[integrator]\nspp = 0"), &["integrator", "at least 1"]),
        (scene("[integrator]\nsamples = 4"), &["unknown field", "samples"]),
        (CAMERA.replace("fov = 40.0", "fov = nan"), &["camera.fov"]),
        (CAMERA.replace("fov = 40.0", "fov = 200.0"), &["camera.fov", "(0, 180)"]),
        (scene("[materials.a]\ntype = \"lambertian\"\nalbedo = [1.5, 0.5, 0.5]"), &["materials.a.albedo", "energy"]),
        (scene("[materials.a]\ntype = \"lambertian\"\nalbedo = [-0.1, 0.5, 0.5]"), &["materials.a.albedo", "negative"]),
        (scene("[materials.a]\ntype = \"velvet\""), &["unknown variant", "velvet"]),
        (scene("[materials.a]\ntype = \"dielectric\"\nior = 0.5"), &["materials.a.ior"]),
        (scene("[[shapes]]\ntype = \"quad\"\nmaterial = \"nope\""), &["shapes[0].material", "no material named"]),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"teapot\"\nmaterial = \"a\"",
            ),
            &["shapes[0].type", "unknown shape"],
        ),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"quad\"\nmaterial = \"a\"\nradius = 2.0",
            ),
            &["shapes[0].radius", "a quad takes no radius"],
        ),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"a\"\nsides = 8",
            ),
            &["shapes[0].sides", "its parameters: radius"],
        ),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"torus_knot\"\nmaterial = \"a\"\np = 0",
            ),
            &["shapes[0].p", "1..=1024"],
        ),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"quad\"\nmaterial = \"a\"\nscale = 0.0",
            ),
            &["shapes[0].scale", "zero"],
        ),
        (
            scene(
                "[materials.a]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"a\"\nscale = [1.0, 2.0, 1.0]",
            ),
            &["shapes[0].scale", "uniform"],
        ),
        (
            scene("[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 1.0]\nintensity = [-1.0, 1.0, 1.0]"),
            &["lights[0].intensity"],
        ),
        (
            scene("[[lights]]\ntype = \"directional\"\ndirection = [0.0, 0.0, 0.0]\nirradiance = [1.0, 1.0, 1.0]"),
            &["lights[0].direction"],
        ),
        (scene("this is = not toml ["), &["bad.toml"]),
    ];
    for (text, needles) in cases {
        let err = parse_scene(&text, Path::new("bad.toml")).expect_err("must fail").to_string();
        assert!(err.starts_with("bad.toml: "), "{err}");
        for needle in needles {
            assert!(err.contains(needle), "{err:?} lacks {needle:?}");
        }
        assert!(!err.contains('\n'), "one line: {err:?}");
    }
}

#[test]
fn meshes_and_image_textures_load_relative_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n")
        .unwrap();
    let tex = lucid_image::Image::from_fn(4, 4, |x, _| [x as f32 / 4.0, 0.5, 0.25, 1.0]);
    lucid_image::write_image(dir.path().join("tex.png"), &tex).unwrap();
    let text = scene(
        r#"
[materials.t]
type = "lambertian"
albedo = { file = "tex.png", wrap = "clamp" }

[[shapes]]
type = "mesh"
file = "tri.obj"
material = "t"
"#,
    );
    std::fs::write(dir.path().join("s.toml"), &text).unwrap();
    let loaded = lucid_trace::load_scene(&dir.path().join("s.toml")).unwrap();
    assert_eq!(loaded.scene.bvh.primitives().len(), 1);
    // The texture is sampled in linear space: the left texel column reads back 0.
    let albedo = loaded.scene.materials[0].albedo(glam::Vec2::new(0.01, 0.5));
    assert!(albedo.x < 0.05 && (albedo.y - 0.5).abs() < 0.01, "{albedo}");

    for (body, needle) in [
        ("[[shapes]]\ntype = \"mesh\"\nfile = \"nope.obj\"\nmaterial = \"t\"", "nope.obj"),
        ("[[shapes]]\ntype = \"mesh\"\nmaterial = \"t\"", "needs a file"),
    ] {
        let bad = scene(&format!("[materials.t]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n{body}"));
        std::fs::write(dir.path().join("b.toml"), bad).unwrap();
        let err = lucid_trace::load_scene(&dir.path().join("b.toml")).unwrap_err().to_string();
        assert!(err.contains("b.toml") && err.contains("shapes[0].file") && err.contains(needle), "{err}");
    }
    let bad = scene("[materials.t]\ntype = \"lambertian\"\nalbedo = { file = \"missing.png\" }");
    std::fs::write(dir.path().join("c.toml"), bad).unwrap();
    let err = lucid_trace::load_scene(&dir.path().join("c.toml")).unwrap_err().to_string();
    assert!(err.contains("materials.t.albedo") && err.contains("missing.png"), "{err}");
}

#[test]
fn every_shipped_scene_loads_and_renders_finite_pixels() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let loaded = lucid_trace::load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        let pinhole = match loaded.camera {
            RenderCamera::Pinhole(c) => c,
            RenderCamera::ThinLens(c) => c.pinhole,
        };
        let small = lucid_scene::Intrinsics::from_fov_x(24, 16, pinhole.intrinsics.fov_x());
        let camera = RenderCamera::Pinhole(lucid_scene::PinholeCamera::new(small, pinhole.camera_to_world));
        let settings = lucid_trace::RenderSettings { spp: 2, ..loaded.settings };
        let out = lucid_trace::render(&loaded.scene, &camera, &settings, &|_| {}).unwrap();
        assert!(out.colour.is_finite(), "{}", path.display());
        let m = out.colour.mean();
        assert!(m[0] + m[1] + m[2] > 0.01, "{} renders black", path.display());
        count += 1;
    }
    assert!(count >= 4, "scenes found: {count}");
}

#[test]
fn the_integrator_is_chosen_by_name_and_refused_where_it_cannot_render() {
    let light = "[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nemission = [1, 1, 1]\n[materials.m]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n";
    for (name, expected) in [
        ("path", lucid_trace::Integrator::Path),
        ("bdpt", lucid_trace::Integrator::Bdpt),
        ("light-tracing", lucid_trace::Integrator::LightTracing),
        ("sppm", lucid_trace::Integrator::Sppm(lucid_trace::sppm::PhotonMapping::DEFAULT)),
        ("vpl", lucid_trace::Integrator::Vpl(lucid_trace::manylight::InstantRadiosity::DEFAULT)),
        ("lightcuts", lucid_trace::Integrator::Lightcuts(lucid_trace::manylight::Lightcuts::DEFAULT)),
        (
            "irradiance-cache",
            lucid_trace::Integrator::IrradianceCache(lucid_trace::irradiance_cache::IrradianceCaching::DEFAULT),
        ),
        ("pssmlt", lucid_trace::Integrator::Pssmlt(lucid_trace::pssmlt::Metropolis::DEFAULT)),
    ] {
        let text = scene(&format!("[integrator]\ntype = \"{name}\"\n{light}"));
        assert_eq!(parse_scene(&text, Path::new("i.toml")).unwrap().settings.integrator, expected);
    }
    // Photon mapping's settings, only with type = "sppm".
    let text = scene(&format!("[integrator]\ntype = \"sppm\"\nphotons = 500\nradius = 0.05\nalpha = 0.5\n{light}"));
    let lucid_trace::Integrator::Sppm(p) = parse_scene(&text, Path::new("s.toml")).unwrap().settings.integrator else {
        panic!("sppm expected")
    };
    assert_eq!((p.photons, p.radius, p.alpha), (500, 0.05, 0.5));
    for (key, text) in [
        ("integrator.alpha", format!("[integrator]\ntype = \"sppm\"\nalpha = 1.5\n{light}")),
        ("integrator.radius", format!("[integrator]\ntype = \"sppm\"\nradius = -1.0\n{light}")),
        ("integrator", format!("[integrator]\ntype = \"bdpt\"\nphotons = 10\n{light}")),
        ("integrator.light_paths", format!("[integrator]\ntype = \"vpl\"\nlight_paths = 0\n{light}")),
        ("integrator.clamp", format!("[integrator]\ntype = \"lightcuts\"\nclamp = nan\n{light}")),
        ("integrator.error", format!("[integrator]\ntype = \"lightcuts\"\nerror = 1.0\n{light}")),
        ("integrator", format!("[integrator]\ntype = \"vpl\"\nerror = 0.01\n{light}")),
        ("integrator", format!("[integrator]\ntype = \"sppm\"\nclamp = 0.1\n{light}")),
        ("integrator.gather", format!("[integrator]\ntype = \"irradiance-cache\"\ngather = 0\n{light}")),
        ("integrator.error", format!("[integrator]\ntype = \"irradiance-cache\"\nerror = -0.1\n{light}")),
        ("integrator", format!("[integrator]\ntype = \"path\"\ngather = 64\n{light}")),
        ("integrator.large_step", format!("[integrator]\ntype = \"pssmlt\"\nlarge_step = 0.0\n{light}")),
        ("integrator.sigma", format!("[integrator]\ntype = \"pssmlt\"\nsigma = inf\n{light}")),
        ("integrator.chains", format!("[integrator]\ntype = \"pssmlt\"\nchains = 2000000\n{light}")),
        ("integrator", format!("[integrator]\ntype = \"bdpt\"\nchains = 4\n{light}")),
    ] {
        let err = parse_scene(&scene(&text), Path::new("s.toml")).unwrap_err().to_string();
        assert!(err.contains(key), "{err}");
    }
    // Many-light settings: light paths and clamp for both, the error bound for lightcuts (whose
    // light paths may be 0: the scene's point lights alone).
    let text =
        scene(&format!("[integrator]\ntype = \"lightcuts\"\nlight_paths = 0\nclamp = 0.05\nerror = 0.0\n{light}"));
    let lucid_trace::Integrator::Lightcuts(c) = parse_scene(&text, Path::new("c.toml")).unwrap().settings.integrator
    else {
        panic!("lightcuts expected")
    };
    assert_eq!((c.vpls.light_paths, c.vpls.clamp, c.error), (0, 0.05, 0.0));
    // Without the key: path tracing.
    let default = parse_scene(&scene(light), Path::new("i.toml")).unwrap();
    assert_eq!(default.settings.integrator, lucid_trace::Integrator::Path);

    let err = parse_scene(&scene(&format!("[integrator]\ntype = \"mlt\"\n{light}")), Path::new("u.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("u.toml") && err.contains("integrator.type") && err.contains("bdpt"), "{err}");

    // Bidirectional integrators do not trace media: a scene with one is refused up front.
    let media = "[media.fog]\nsigma_a = [0.1, 0.1, 0.1]\nsigma_s = [0.5, 0.5, 0.5]\ng = 0.0\n";
    let text = format!("global_medium = \"fog\"\n{}", scene(&format!("[integrator]\ntype = \"bdpt\"\n{light}{media}")));
    let err = parse_scene(&text, Path::new("m.toml")).unwrap_err().to_string();
    assert!(err.contains("m.toml") && err.contains("integrator.type") && err.contains("media"), "{err}");
}

#[test]
fn point_light_grids_expand_to_many_lights_and_bad_ones_are_refused() {
    let grid = |extra: &str| {
        scene(&format!(
            "[[lights]]\ntype = \"point_grid\"\ncorner = [-1, 2, -1]\nedge_u = [2, 0, 0]\nedge_v = [0, 0, 2]\nintensity = [0.1, 0.1, 0.1]\n{extra}"
        ))
    };
    let loaded = parse_scene(&grid("count = [8, 4]\njitter = 0.5\ntint = 0.2\n"), Path::new("g.toml")).unwrap();
    assert_eq!(loaded.scene.lights.len(), 32);
    assert!(loaded.scene.lights.iter().all(|l| matches!(l, lucid_trace::light::Light::Point { .. })));
    for (extra, key) in [
        ("count = [0, 4]\n", "lights[0].count"),
        ("count = [2000, 2000]\n", "lights[0].count"),
        ("count = [2, 2]\njitter = 1.5\n", "lights[0].jitter"),
        ("count = [2, 2]\ntint = -0.1\n", "lights[0].tint"),
    ] {
        let err = parse_scene(&grid(extra), Path::new("g.toml")).unwrap_err().to_string();
        assert!(err.contains("g.toml") && err.contains(key), "{extra}: {err}");
    }
    // The built-in many-lights scene: 4096 of them.
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/many-lights.toml");
    assert_eq!(lucid_trace::load_scene(&file).unwrap().scene.lights.len(), 4096);
}

#[test]
fn layered_materials_stack_kubelka_munk_films_and_bad_ones_are_refused() {
    let material = |layers: &str| {
        scene(&format!(
            "[materials.paint]\ntype = \"layered\"\nbase = [0.8, 0.8, 0.8]\n{layers}\n[[shapes]]\ntype = \"quad\"\nmaterial = \"paint\"\nemission = [0, 0, 0]\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\n"
        ))
    };
    let text = material(
        "[[materials.paint.layers]]\nabsorption = [0.1, 1.0, 3.0]\nscattering = [5.0, 5.0, 5.0]\nthickness = 0.3\n[[materials.paint.layers]]\nreflectance = [0.1, 0.1, 0.1]\ntransmittance = [0.8, 0.8, 0.8]\n",
    );
    let loaded = parse_scene(&text, Path::new("p.toml")).unwrap();
    let lucid_trace::Material::Layered { layers, .. } = &loaded.scene.materials[0] else {
        panic!("layered expected: {:?}", loaded.scene.materials[0])
    };
    assert_eq!(layers.len(), 2);
    // The stack's reflectance: the second film over the base, then the first over both.
    let albedo = loaded.scene.materials[0].albedo(glam::Vec2::ZERO);
    let expected = layers[0].over_base(layers[1].over_base(Vec3::splat(0.8)));
    assert!((albedo - expected).abs().max_element() < 1e-6, "{albedo} vs {expected}");
    // The red channel absorbs least: the paint is reddish.
    assert!(albedo.x > albedo.y && albedo.y > albedo.z, "{albedo}");
    for (layers, key) in [
        ("", "materials.paint"),
        ("[[materials.paint.layers]]\nabsorption = [0.1, 0.1, 0.1]\nthickness = 0.3\n", "materials.paint.layers[0]"),
        (
            "[[materials.paint.layers]]\nabsorption = [0.1, 0.1, 0.1]\nscattering = [1, 1, 1]\nthickness = 0.0\n",
            "materials.paint.layers[0].thickness",
        ),
        (
            "[[materials.paint.layers]]\nabsorption = [-0.1, 0.1, 0.1]\nscattering = [1, 1, 1]\nthickness = 1.0\n",
            "materials.paint.layers[0].absorption",
        ),
        (
            "[[materials.paint.layers]]\nreflectance = [0.6, 0.1, 0.1]\ntransmittance = [0.6, 0.1, 0.1]\n",
            "materials.paint.layers[0]",
        ),
    ] {
        let err = parse_scene(&material(layers), Path::new("p.toml")).unwrap_err().to_string();
        assert!(err.contains("p.toml") && err.contains(key), "{key}: {err}");
    }
}

#[test]
fn svbrdf_materials_read_numbers_textures_and_procedural_maps() {
    let material = |body: &str| {
        scene(&format!(
            "[materials.m]\ntype = \"svbrdf\"\n{body}\n[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\n"
        ))
    };
    let loaded = parse_scene(
        &material("base_color = { procedural = \"tiles\" }\nroughness = 0.4\nnormal = { procedural = \"tiles\", scale = [2, 2] }\n"),
        Path::new("s.toml"),
    )
    .unwrap();
    let lucid_trace::Material::Svbrdf { roughness, metallic, normal, .. } = &loaded.scene.materials[0] else {
        panic!("svbrdf expected")
    };
    assert_eq!(roughness.eval(glam::Vec2::ZERO), Vec3::splat(0.4));
    assert_eq!(metallic.eval(glam::Vec2::ZERO), Vec3::ZERO, "metallic defaults to 0");
    assert!(normal.is_some());
    for (body, key) in [
        ("base_color = [0.5, 0.5, 0.5]\nroughness = 1.5\n", "materials.m.roughness"),
        (
            "base_color = [0.5, 0.5, 0.5]\nroughness = 0.5\nmetallic = { procedural = \"bricks\" }\n",
            "materials.m.metallic",
        ),
        ("base_color = [0.5, 0.5, 0.5]\nroughness = 0.5\nnormal = [0.5, 0.5, 1.0]\n", "materials.m.normal"),
        ("base_color = [1.5, 0.5, 0.5]\nroughness = 0.5\n", "materials.m.base_color"),
    ] {
        let err = parse_scene(&material(body), Path::new("s.toml")).unwrap_err().to_string();
        assert!(err.contains("s.toml") && err.contains(key), "{key}: {err}");
    }
}

#[test]
fn poulin_fournier_grooves_read_their_geometry_and_refuse_impossible_ones() {
    let material = |body: &str| {
        scene(&format!(
            "[materials.g]\ntype = \"poulin_fournier\"\nkd = [0.2, 0.2, 0.2]\n{body}\n[[shapes]]\ntype = \"quad\"\nmaterial = \"g\"\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\n"
        ))
    };
    let loaded = parse_scene(
        &material("ks = [0.7, 0.6, 0.4]\nd = 2.5\nh = 0.2\nsigma_x = 0.05\nsigma_y = 0.3\n"),
        Path::new("g.toml"),
    )
    .unwrap();
    let lucid_trace::Material::PoulinFournier { ks, d, h, sigma, .. } = &loaded.scene.materials[0] else {
        panic!("poulin_fournier expected: {:?}", loaded.scene.materials[0])
    };
    assert_eq!((*ks, *d, *h, *sigma), (Vec3::new(0.7, 0.6, 0.4), 2.5, 0.2, glam::Vec2::new(0.05, 0.3)));
    for (body, key) in [
        ("ks = [0.9, 0.6, 0.4]\nd = 2.5\nh = 0.2\nsigma_x = 0.05\nsigma_y = 0.3\n", "materials.g"),
        ("ks = [0.7, 0.6, 0.4]\nd = 1.5\nh = 0.2\nsigma_x = 0.05\nsigma_y = 0.3\n", "materials.g.d"),
        ("ks = [0.7, 0.6, 0.4]\nd = 2.5\nh = 1.0\nsigma_x = 0.05\nsigma_y = 0.3\n", "materials.g.h"),
        ("ks = [0.7, 0.6, 0.4]\nd = 2.5\nh = 0.2\nsigma_x = 0.0\nsigma_y = 0.3\n", "materials.g.sigma_x"),
        ("ks = [0.7, 0.6, 0.4]\nd = 2.5\nh = 0.2\nsigma_x = 0.05\nsigma_y = nan\n", "materials.g.sigma_y"),
        ("ks = [0.7, 0.6, 0.4]\nd = 2.5\nh = 0.2\nsigma_x = 0.05\n", "sigma_y"),
    ] {
        let err = parse_scene(&material(body), Path::new("g.toml")).unwrap_err().to_string();
        assert!(err.contains("g.toml") && err.contains(key), "{key}: {err}");
    }
}

#[test]
fn hair_shapes_and_fibre_materials_are_read_and_bad_ones_refused() {
    let text = |material: &str, shape: &str| {
        scene(&format!(
            "[materials.h]\n{material}\n[[shapes]]\ntype = \"hair\"\nmaterial = \"h\"\n{shape}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\n"
        ))
    };
    let loaded = parse_scene(
        &text(
            "type = \"hair\"\neumelanin = 1.3\nbeta_m = 0.2",
            "groom = \"tress\"\nfibres = 50\nsegments = 6\nscale = 2.0",
        ),
        Path::new("h.toml"),
    )
    .unwrap();
    // 50 fibres of 6 segments, their radius scaled with the shape.
    let prims = loaded.scene.bvh.primitives();
    assert_eq!(prims.len(), 300);
    let lucid_trace::geometry::Shape::Fibre { radius, .. } = prims[0].shape else { panic!("fibres expected") };
    assert!((radius - 0.008).abs() < 1e-6, "{radius}");
    let lucid_trace::Material::Hair { model, colour } = &loaded.scene.materials[0] else { panic!("hair expected") };
    assert!((model.sigma_a - lucid_trace::bsdf::hair::HairModel::sigma_a_from_melanin(1.3, 0.0)).length() < 1e-6);
    assert!(colour.x > colour.z, "brown: {colour}");
    // A colour maps to an absorption that maps back to it.
    let loaded = parse_scene(&text("type = \"hair\"\ncolor = [0.7, 0.5, 0.2]", ""), Path::new("h.toml")).unwrap();
    let lucid_trace::Material::Hair { colour, .. } = &loaded.scene.materials[0] else { panic!("hair expected") };
    assert!((*colour - Vec3::new(0.7, 0.5, 0.2)).length() < 1e-4, "{colour}");
    for (material, shape, key) in [
        ("type = \"hair\"\ncolor = [0.7, 0.5, 0.2]\nsigma_a = [1, 1, 1]", "", "materials.h"),
        ("type = \"hair\"", "", "materials.h"),
        ("type = \"hair\"\ncolor = [0.7, 0.5, 0.2]\nbeta_m = 0.0", "", "materials.h.beta_m"),
        ("type = \"hair\"\nsigma_a = [-1, 1, 1]", "", "materials.h.sigma_a"),
        ("type = \"hair\"\neumelanin = 1.0\neta = 0.5", "", "materials.h.eta"),
        (
            "type = \"kajiya_kay\"\nkd = [0.5, 0.5, 0.5]\nks = [0.3, 0.3, 0.3]\nexponent = 0.5",
            "",
            "materials.h.exponent",
        ),
        ("type = \"kajiya_kay\"\nkd = [0.8, 0.5, 0.5]\nks = [0.3, 0.3, 0.3]\nexponent = 5", "", "materials.h"),
        ("type = \"hair\"\neumelanin = 1.0", "groom = \"mohawk\"", "shapes[0].groom"),
        ("type = \"hair\"\neumelanin = 1.0", "fibres = 0", "shapes[0].fibres"),
        ("type = \"hair\"\neumelanin = 1.0", "curl = 3.0", "shapes[0].curl"),
        ("type = \"hair\"\neumelanin = 1.0", "radius = -0.1", "shapes[0].radius"),
    ] {
        let err = parse_scene(&text(material, shape), Path::new("h.toml")).unwrap_err().to_string();
        assert!(err.contains("h.toml") && err.contains(key), "{key}: {err}");
    }
}

#[test]
fn subsurface_materials_take_coefficients_or_albedo_and_mean_free_path() {
    let material = |body: &str| {
        scene(&format!(
            "[materials.s]\ntype = \"subsurface\"\n{body}\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"s\"\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\n"
        ))
    };
    // albedo and mfp give σt′ = 1/mfp, σs′ = albedo σt′: the same profile as the coefficients.
    let a = parse_scene(&material("albedo = [0.9, 0.8, 0.5]\nmfp = [0.1, 0.2, 0.5]"), Path::new("s.toml")).unwrap();
    let b =
        parse_scene(&material("sigma_a = [1.0, 1.0, 1.0]\nsigma_s = [9.0, 4.0, 1.0]"), Path::new("s.toml")).unwrap();
    let (lucid_trace::Material::Subsurface { colour: ca, .. }, lucid_trace::Material::Subsurface { colour: cb, .. }) =
        (&a.scene.materials[0], &b.scene.materials[0])
    else {
        panic!("subsurface expected")
    };
    assert!((*ca - *cb).length() < 1e-4, "{ca} vs {cb}");
    assert!(ca.x > ca.y && ca.y > ca.z && ca.x < 0.9, "{ca}");
    assert!(a.scene.has_subsurface());
    for (body, key) in [
        ("sigma_a = [1, 1, 1]", "materials.s"),
        ("sigma_a = [1, 1, 1]\nsigma_s = [1, 1, 1]\nmfp = [1, 1, 1]", "materials.s"),
        ("sigma_a = [-1, 1, 1]\nsigma_s = [1, 1, 1]", "materials.s.sigma_a"),
        ("sigma_a = [0, 1, 1]\nsigma_s = [0, 1, 1]", "materials.s"),
        ("albedo = [0.5, 0.5, 0.5]\nmfp = [0, 1, 1]", "materials.s.mfp"),
        ("albedo = [1.5, 0.5, 0.5]\nmfp = [1, 1, 1]", "materials.s.albedo"),
        ("albedo = [0.5, 0.5, 0.5]\nmfp = [1, 1, 1]\neta = 0.8", "materials.s.eta"),
        ("albedo = [0.5, 0.5, 0.5]\nmfp = [1, 1, 1]\nscale = 0", "materials.s.scale"),
    ] {
        let err = match parse_scene(&material(body), Path::new("s.toml")) {
            Ok(_) => panic!("{body}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("s.toml") && err.contains(key), "{key}: {err}");
    }
}
