//! `lucid lightstage calibrate` on an OLAT capture of `studio` with four chrome reference
//! spheres: every light recovered within a degree of the direction the generator used, and
//! relighting with the recovered directions as good as with the true ones.

use lucid_tests::{lucid_in, temp_dir};

#[test]
fn chrome_spheres_recover_every_light_and_relight_as_the_true_directions_do() {
    let dir = temp_dir();
    let d = dir.path();
    let mut args = vec![
        "gen",
        "studio",
        "--rig",
        "olat",
        "--views",
        "4,0,1",
        "--res",
        "256",
        "--spp",
        "16",
        "--lights",
        "16",
        "--held-out-lights",
        "0",
        "-o",
        "olat",
        "-q",
    ];
    for _ in 0..4 {
        args.extend(["--reference-sphere", "chrome"]);
    }
    lucid_in(d, &args).success();
    let record = std::fs::read_to_string(d.join("olat/dataset.toml")).unwrap();
    assert_eq!(record.matches("kind = \"chrome\"").count(), 4, "{record}");

    let out = lucid_in(d, &["lightstage", "calibrate", "olat", "-o", "directions.json", "--json"]).success().json();
    let lights = out["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 16);
    let mut worst = 0f64;
    for l in lights {
        let error = l["error_degrees"].as_f64().unwrap_or_else(|| panic!("not recovered: {l}"));
        worst = worst.max(error);
    }
    println!("worst angular error {worst:.3}°");
    assert!(worst < 1.0, "a light is {worst}° off");

    let score = |extra: &[&str]| -> Vec<f64> {
        let mut args = vec!["relight", "olat", "--json"];
        args.extend(extra);
        let out = lucid_in(d, &args).success().json();
        out["results"].as_array().unwrap().iter().map(|r| r["psnr"].as_f64().unwrap()).collect()
    };
    let truth = score(&[]);
    let recovered = score(&["--directions", "directions.json"]);
    for (t, r) in truth.iter().zip(&recovered) {
        println!("relit with the recorded directions {t:.2} dB, with the recovered ones {r:.2} dB");
        assert!((t - r).abs() < 1.0, "{t} vs {r}");
    }

    // Refusals: an existing output, a set without spheres, a directions file without a light.
    lucid_in(d, &["lightstage", "calibrate", "olat", "-o", "directions.json"]).failure(&["directions.json", "exists"]);
    lucid_in(
        d,
        &[
            "gen", "studio", "--rig", "olat", "--views", "1,0,0", "--res", "16", "--spp", "1", "--lights", "2", "-o",
            "plain", "-q",
        ],
    )
    .success();
    lucid_in(d, &["lightstage", "calibrate", "plain"]).failure(&["plain", "no chrome reference spheres"]);
    std::fs::write(d.join("partial.json"), r#"{"format":"lucid light directions","version":1,"lights":[]}"#).unwrap();
    lucid_in(d, &["relight", "olat", "--directions", "partial.json"]).failure(&["no direction", "l0"]);
}

/// A ball on a floor, an 8 × 6 projector and a 24 × 18 camera: small enough for one render per
/// projector pixel in a test.
const DUAL_SCENE: &str = r#"
[camera]
position = [-1.5, -3.0, 1.5]
look_at = [0.0, 0.0, -0.2]
up = [0.0, 0.0, 1.0]
fov = 40.0
width = 24
height = 18

[integrator]
spp = 8
max_depth = 3

[materials.white]
type = "lambertian"
albedo = [0.7, 0.7, 0.7]

[[shapes]]
type = "cube"
material = "white"
scale = [3.0, 3.0, 0.05]
translate = [0.0, 0.0, -0.55]

[[shapes]]
type = "sphere"
material = "white"
radius = 0.45

[[lights]]
type = "projector"
position = [1.8, -2.6, 2.0]
look_at = [0.0, 0.0, -0.3]
fov = 35.0
resolution = [8, 6]
intensity = [1.0, 1.0, 1.0]
"#;

#[test]
fn dual_photography_writes_the_dual_image_and_counts_its_renders() {
    let dir = temp_dir();
    let d = dir.path();
    std::fs::write(d.join("dual.toml"), DUAL_SCENE).unwrap();
    let pixelwise = lucid_in(d, &["dual", "dual.toml", "-o", "pixelwise", "--json"]).success().json();
    assert_eq!(pixelwise["renders"], 48);
    let adaptive = lucid_in(
        d,
        &["dual", "dual.toml", "-o", "adaptive", "--adaptive", "--block", "2", "--check-spp", "64", "--json"],
    )
    .success()
    .json();
    let renders = adaptive["renders"].as_u64().unwrap();
    assert!(renders < 48 && adaptive["saved_renders"].as_u64().unwrap() == 48 - renders, "{adaptive}");
    for f in ["dual.exr", "primal.exr", "reciprocal.exr", "dual.json"] {
        assert!(d.join("adaptive").join(f).is_file(), "{f}");
    }
    let dual = lucid_image::read_image(d.join("adaptive/dual.exr")).unwrap();
    assert_eq!(dual.dimensions(), (8, 6));
    let psnr = adaptive["psnr_against_reciprocal"].as_f64().unwrap();
    println!("adaptive dual in {renders} renders of 48: {psnr:.2} dB against the reciprocal render");
    // Measured 23.93 dB (8 spp renders of a 24 × 18 camera; the reference at 64 spp).
    assert!(psnr > 22.0, "{psnr}");

    // Refusals: a folder in use, a scene without a projector, a bad block size.
    lucid_in(d, &["dual", "dual.toml", "-o", "adaptive"]).failure(&["adaptive", "not empty"]);
    let without_lights = DUAL_SCENE.split("[[lights]]").next().unwrap();
    let point = "[[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = [1, 1, 1]\n";
    std::fs::write(d.join("plain.toml"), format!("{without_lights}{point}")).unwrap();
    lucid_in(d, &["dual", "plain.toml", "-o", "p"]).failure(&["plain.toml", "no projector"]);
    lucid_in(d, &["dual", "dual.toml", "-o", "b", "--adaptive", "--block", "0"]).failure(&["--block"]);
}

#[test]
fn fix_sun_restores_a_clipped_sun_from_a_rendered_diffuse_ball() {
    let dir = temp_dir();
    let d = dir.path();
    // A sky with a sun of radiance 2000 (angular radius 0.06) that the capture clips at 20.
    let sun = glam::Vec3::new(0.5, 0.5, 0.7).normalize();
    let (w, h) = (128usize, 64usize);
    let truth = lucid_image::Image::from_fn(w, h, |x, y| {
        let mut v = 0.0;
        for s in 0..16 {
            let (u, t) = (
                (x as f32 + (s % 4) as f32 / 4.0 + 0.125) / w as f32,
                (y as f32 + (s / 4) as f32 / 4.0 + 0.125) / h as f32,
            );
            let (theta, phi) = (t * std::f32::consts::PI, u * std::f32::consts::TAU);
            let dir = glam::Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            v += if dir.dot(sun) > 0.06f32.cos() {
                2000.0
            } else if dir.z > 0.0 {
                0.5 + 0.5 * dir.z
            } else {
                0.2
            };
        }
        [v / 16.0, v / 16.0, v / 16.0, 1.0]
    });
    lucid_image::write_image(d.join("truth.exr"), &truth).unwrap();
    let clipped = truth.map(|p| [p[0].min(20.0), p[1].min(20.0), p[2].min(20.0), 1.0]);
    lucid_image::write_image(d.join("clipped.exr"), &clipped).unwrap();
    let scene = format!(
        "[camera]\nposition = [0.0, 400.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nfov = {}\nwidth = 64\nheight = 64\n\
         [integrator]\nspp = 64\nmax_depth = 2\n[materials.ball]\ntype = \"lambertian\"\nalbedo = [0.8, 0.8, 0.8]\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"ball\"\nradius = 1.0\n[[lights]]\ntype = \"environment\"\nfile = \"truth.exr\"\n",
        2.0 * (1.0f32 / 400.0).asin().to_degrees()
    );
    std::fs::write(d.join("ball.toml"), scene).unwrap();
    lucid_in(d, &["render", "ball.toml", "-o", "ball.exr", "-q"]).success();
    let report = lucid_in(
        d,
        &["envmap", "fix-sun", "clipped.exr", "--sphere", "ball.exr", "--albedo", "0.8", "-o", "fixed.exr", "--json"],
    )
    .success()
    .json();
    // The clipped pixels' mean radiance in the truth and in the fixed map.
    let fixed = lucid_image::read_image(d.join("fixed.exr")).unwrap();
    let (mut t, mut f, mut n) = (0.0f64, 0.0f64, 0);
    for (i, p) in clipped.pixels().iter().enumerate() {
        if p[0] >= 0.99 * 20.0 {
            t += truth.pixels()[i][0] as f64;
            f += fixed.pixels()[i][0] as f64;
            n += 1;
        }
    }
    println!("{report}\nclipped pixels' mean radiance: truth {:.1}, restored {:.1}", t / n as f64, f / n as f64);
    // Measured: truth 1300.3, restored 1293.1 (−0.55 %); the issue asks for 5 %.
    assert!((f / t - 1.0).abs() < 0.05, "{f} vs {t}");
    assert_eq!(report["clipped_pixels"].as_u64().unwrap(), n as u64);

    lucid_in(d, &["envmap", "fix-sun", "clipped.exr", "--sphere", "ball.exr", "--albedo", "0.8", "-o", "fixed.exr"])
        .failure(&["fixed.exr", "exists"]);
    lucid_in(d, &["envmap", "fix-sun", "clipped.exr", "--sphere", "truth.exr", "--albedo", "0.8", "-o", "x.exr"])
        .failure(&["square"]);
    lucid_image::write_image(d.join("flat.exr"), &lucid_image::Image::from_fn(64, 32, |_, _| [1.0; 4])).unwrap();
    lucid_in(d, &["envmap", "fix-sun", "flat.exr", "--sphere", "ball.exr", "--albedo", "0.8", "-o", "x.exr"])
        .failure(&["flat.exr", "not a clipped sun"]);
    assert!(!d.join("x.exr").exists());
}

/// One camera, as a light stage usually has: a light seen as a single highlight near a
/// sphere's rim, or as highlights that disagree, was once reported as calmly as the rest
/// (one 15° off here). Every light the calibration trusts is within 2° of the truth; the
/// others are flagged and left out of the directions file.
#[test]
fn one_camera_flags_the_lights_it_cannot_confirm() {
    let dir = temp_dir();
    let d = dir.path();
    let mut args = vec!["gen", "studio", "--rig", "olat", "--views", "1,0,0", "--res", "256", "--spp", "16"];
    args.extend(["--lights", "16", "--held-out-lights", "0", "-o", "one", "-q"]);
    for _ in 0..4 {
        args.extend(["--reference-sphere", "chrome"]);
    }
    lucid_in(d, &args).success();
    let out = lucid_in(d, &["lightstage", "calibrate", "one", "-o", "directions.json", "--json"]).success().json();
    let lights = out["lights"].as_array().unwrap();
    let mut trusted = 0;
    for l in lights {
        if l["trusted"].as_bool().unwrap() {
            trusted += 1;
            let error = l["error_degrees"].as_f64().unwrap();
            assert!(error < 2.0, "a trusted light is {error}° off: {l}");
        }
    }
    assert!(trusted >= 10, "{trusted} of 16 lights trusted");
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("directions.json")).unwrap()).unwrap();
    assert_eq!(file["lights"].as_array().unwrap().len(), trusted, "only trusted lights are written");
}
