//! Measured BRDFs: a MERL table written from an analytic BRDF and read back through a scene
//! file renders the image of that analytic BRDF.

use lucid_image::Image;
use lucid_trace::bsdf::measured::MerlTable;
use lucid_trace::bsdf::{Bsdf, GgxDistribution, MicrofacetConductor};
use lucid_trace::{RenderSettings, parse_scene, render};

fn scene() -> String {
    lucid_trace::sample_scenes::object_on_floor(lucid_trace::sample_scenes::SPHERE, 48, 32, 4)
}

fn grey(p: [f32; 4]) -> f64 {
    ((p[0] + p[1] + p[2]) / 3.0) as f64
}

fn render_with(ball: &str, dir: &std::path::Path) -> Image {
    let text = format!("{}\n[materials.ball]\n{ball}\n", scene());
    let loaded = parse_scene(&text, &dir.join("scene.toml")).unwrap();
    let settings = RenderSettings { spp: 256, seed: 4, ..loaded.settings };
    render(&loaded.scene, &loaded.camera, &settings, &|_| {}).colour
}

#[test]
fn a_table_of_a_ggx_metal_renders_the_metal() {
    let dir = tempfile::tempdir().unwrap();
    let (eta, k, roughness) = ([0.2f32, 0.9, 1.1], [3.9f32, 2.4, 2.2], 0.55f32);
    let alpha = roughness * roughness;
    let metal = MicrofacetConductor {
        distribution: GgxDistribution { alpha_x: alpha, alpha_y: alpha },
        eta: eta.into(),
        k: k.into(),
    };
    MerlTable::from_fn(|wo, wi| metal.eval(wo, wi)).write(&dir.path().join("metal.binary")).unwrap();
    let measured = render_with("type = \"measured\"\nfile = \"metal.binary\"", dir.path());
    let analytic =
        render_with(&format!("type = \"conductor\"\neta = {eta:?}\nk = {k:?}\nroughness = {roughness}"), dir.path());
    let (w, h) = measured.dimensions();
    // 8×8 blocks: the table's interpolation error and the noise of two renders.
    let mut worst: f64 = 0.0;
    for by in 0..h / 8 {
        for bx in 0..w / 8 {
            let (mut a, mut b) = (0.0, 0.0);
            for y in by * 8..by * 8 + 8 {
                for x in bx * 8..bx * 8 + 8 {
                    a += grey(measured.get(x, y));
                    b += grey(analytic.get(x, y));
                }
            }
            worst = worst.max((a - b).abs() / b.max(1e-3));
        }
    }
    let (ma, mb) = (measured.mean(), analytic.mean());
    let (ma, mb) = ((ma[0] + ma[1] + ma[2]) / 3.0, (mb[0] + mb[1] + mb[2]) / 3.0);
    eprintln!("means: measured {ma}, analytic {mb}; worst 8×8 block {worst:.4}");
    assert!((ma - mb).abs() < 0.01 * mb, "means {ma} vs {mb}");
    assert!(worst < 0.03, "a block differs by {worst}");

    // A missing table is an error naming the material's key and the file.
    let text = format!("{}\n[materials.ball]\ntype = \"measured\"\nfile = \"nothere.binary\"\n", scene());
    let err = parse_scene(&text, &dir.path().join("scene.toml")).unwrap_err().to_string();
    assert!(err.contains("materials.ball.file") && err.contains("nothere.binary"), "{err}");
}
