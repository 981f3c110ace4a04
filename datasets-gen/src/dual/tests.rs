use lucid_trace::{RenderCamera, parse_scene};

use super::*;

/// A ball and a box on a floor, a 16 × 12 projector above and to the right, a 48 × 36 camera
/// to the left: every projector pixel lands on something the camera sees or on the floor
/// outside its view.
const SCENE: &str = r#"
[camera]
position = [-1.6, -3.0, 1.6]
look_at = [0.0, 0.0, -0.2]
up = [0.0, 0.0, 1.0]
fov = 40.0
width = 48
height = 36

[integrator]
spp = 16
max_depth = 3

[materials.white]
type = "lambertian"
albedo = [0.7, 0.7, 0.7]

[materials.red]
type = "lambertian"
albedo = [0.7, 0.2, 0.15]

[[shapes]]
type = "cube"
material = "white"
scale = [3.0, 3.0, 0.05]
translate = [0.0, 0.0, -0.55]

[[shapes]]
type = "sphere"
material = "red"
radius = 0.45
translate = [-0.1, 0.1, -0.05]

[[shapes]]
type = "cube"
material = "white"
scale = [0.3, 0.3, 0.3]
translate = [0.7, -0.5, -0.2]

[[lights]]
type = "projector"
position = [1.8, -2.6, 2.0]
look_at = [0.0, 0.0, -0.3]
up = [0.0, 0.0, 1.0]
fov = 35.0
resolution = [16, 12]
intensity = [1.0, 1.0, 1.0]
"#;

#[test]
fn the_dual_image_is_the_render_from_the_projector_lit_from_the_camera() {
    let loaded = parse_scene(SCENE, std::path::Path::new("dual.toml")).unwrap();
    let RenderCamera::Pinhole(camera) = loaded.camera else { panic!("pinhole expected") };
    let Some(Light::Projector(projector)) = loaded.scene.lights.first() else { panic!("projector expected") };
    let none = |_: usize, _: usize| {};
    let pixelwise =
        capture(&loaded.scene, &camera, &loaded.settings, projector, &DualSettings::default(), &none).unwrap();
    assert_eq!(pixelwise.renders, 192);
    let adaptive_settings = DualSettings { adaptive: true, ..DualSettings::default() };
    let adaptive = capture(&loaded.scene, &camera, &loaded.settings, projector, &adaptive_settings, &none).unwrap();
    let reference_settings = RenderSettings { spp: 256, ..loaded.settings };
    let reference = reciprocal_render(&loaded.scene, &camera, &reference_settings, projector).unwrap();
    let dual_db = linear_psnr(&pixelwise.dual, &reference);
    let (adaptive_db, adaptive_reference_db) =
        (linear_psnr(&adaptive.dual, &pixelwise.dual), linear_psnr(&adaptive.dual, &reference));
    eprintln!(
        "dual against the reciprocal render: {dual_db:.2} dB; adaptive against pixel by pixel: {adaptive_db:.2} dB, \
         against the reciprocal render {adaptive_reference_db:.2} dB, in {} renders of {}",
        adaptive.renders, adaptive.pixel_renders
    );
    // Measured: 32.76, 30.44 and 31.91 dB, 108 renders of 192 (16 spp per render, the
    // reference 256).
    assert!(dual_db > 31.5, "{dual_db}");
    assert!(adaptive_db > 29.0, "{adaptive_db}");
    assert!(adaptive_reference_db > 30.5, "{adaptive_reference_db}");
    assert!(adaptive.renders <= 108, "{} renders", adaptive.renders);
}
