//! `lucid bench materials`: the path tracer's time per sample on one scene whose sphere takes
//! each material in turn, against the same sphere as a GGX conductor (the reference):
//! rounds alternate the materials and each keeps its median, so the machine's drift touches
//! all alike.

use std::time::Instant;

use anyhow::Context;
use lucid_trace::bsdf::Bsdf;
use lucid_trace::bsdf::measured::MerlTable;
use lucid_trace::{RenderSettings, parse_scene, render};
use serde_json::{Value, json};

/// The sphere on the floor.
fn sphere_scene() -> String {
    lucid_trace::sample_scenes::object_on_floor(lucid_trace::sample_scenes::SPHERE, WIDTH, HEIGHT, 8)
}

const WIDTH: u32 = 128;
const HEIGHT: u32 = 96;

/// The same view of a hairy ball (3000 fibres of 8 segments) with the fibres' material
/// changing: fibres are timed against fibres of the GGX conductor.
fn hair_scene() -> String {
    let ball = "type = \"hair\"\ngroom = \"ball\"\nmaterial = \"ball\"\nfibres = 3000\nlength = 0.5\nradius = 0.008\nscale = 0.6\ntranslate = [0.0, 0.0, 0.6]";
    lucid_trace::sample_scenes::object_on_floor(ball, WIDTH, HEIGHT, 8)
}

const CONDUCTOR: &str = "type = \"conductor\"\neta = [0.2, 0.9, 1.1]\nk = [3.9, 2.4, 2.2]\nroughness = 0.4";

/// The materials measured, by name and scene: each scene's reference first.
fn materials() -> Vec<(&'static str, String, String)> {
    let sphere = [
        ("conductor (GGX)", CONDUCTOR.into()),
        (
            "layered",
            "type = \"layered\"\nbase = [0.85, 0.85, 0.82]\n[[materials.ball.layers]]\nabsorption = [0.3, 6.0, 9.0]\nscattering = [12.0, 12.0, 12.0]\nthickness = 0.15".into(),
        ),
        ("svbrdf", "type = \"svbrdf\"\nbase_color = [0.9, 0.6, 0.3]\nroughness = 0.4\nmetallic = 0.5".into()),
        (
            "svbrdf (tile maps)",
            "type = \"svbrdf\"\nbase_color = { procedural = \"tiles\" }\nroughness = { procedural = \"tiles\" }\nmetallic = { procedural = \"tiles\" }\nnormal = { procedural = \"tiles\" }".into(),
        ),
        ("measured (MERL)", "type = \"measured\"\nfile = \"ggx.binary\"".into()),
        ("neural", "type = \"neural\"\nfile = \"ggx.json\"".into()),
        (
            "poulin_fournier",
            "type = \"poulin_fournier\"\nkd = [0.1, 0.1, 0.1]\nks = [0.85, 0.8, 0.7]\nd = 2.2\nh = 0.1\nsigma_x = 0.05\nsigma_y = 0.3".into(),
        ),
        (
            "subsurface",
            "type = \"subsurface\"\nalbedo = [0.95, 0.85, 0.7]\nmfp = [0.05, 0.03, 0.02]\neta = 1.33".into(),
        ),
    ];
    let fibres = [
        ("fibres: conductor (GGX)", CONDUCTOR.into()),
        ("fibres: hair (Marschner)", "type = \"hair\"\ncolor = [0.6, 0.4, 0.25]".into()),
        (
            "fibres: kajiya_kay",
            "type = \"kajiya_kay\"\nkd = [0.4, 0.25, 0.15]\nks = [0.3, 0.3, 0.3]\nexponent = 40".into(),
        ),
    ];
    let sphere = sphere.into_iter().map(|(name, m)| (name, sphere_scene(), m));
    sphere.chain(fibres.into_iter().map(|(name, m)| (name, hair_scene(), m))).collect()
}

/// Runs the benchmark: `rounds` alternating renders at `spp`; prints and returns the table.
pub fn run(spp: u32, rounds: usize) -> anyhow::Result<Value> {
    let dir = tempfile::tempdir().context("creating a temporary folder for the MERL table")?;
    // The measured sphere is the reference conductor, tabulated.
    let reference =
        parse_scene(&format!("{}\n[materials.ball]\n{CONDUCTOR}\n", sphere_scene()), &dir.path().join("s.toml"))?;
    let ball = reference.scene.materials.iter().find(|m| matches!(m, lucid_trace::Material::Conductor { .. }));
    let bsdf = ball.context("the reference sphere")?.bsdf(glam::Vec2::ZERO);
    MerlTable::from_fn(|wo, wi| bsdf.eval(wo, wi)).write(&dir.path().join("ggx.binary"))?;
    // The neural row fits that table briefly: its time per sample does not depend on the fit.
    let settings = crate::commands::brdf_neural::FitSettings {
        steps: 300,
        layers: 2,
        width: 21,
        batch: 4096,
        seed: 0,
        progress: false,
    };
    crate::commands::brdf_neural::fit(&dir.path().join("ggx.binary"), &dir.path().join("ggx.json"), &settings)?;

    let list = materials();
    let scenes: Vec<(&str, lucid_trace::LoadedScene)> = list
        .iter()
        .map(|(name, scene, m)| {
            let text = format!("{scene}\n[materials.ball]\n{m}\n");
            Ok((*name, parse_scene(&text, &dir.path().join("s.toml"))?))
        })
        .collect::<anyhow::Result<_>>()?;
    // Each row's reference: the first row of its scene.
    let reference: Vec<usize> =
        list.iter().map(|(_, scene, _)| list.iter().position(|(_, s, _)| s == scene).unwrap_or(0)).collect();
    let mut times = vec![Vec::new(); scenes.len()];
    let mut means = vec![0.0; scenes.len()];
    for _ in 0..rounds.max(1) {
        for (k, (_, loaded)) in scenes.iter().enumerate() {
            let settings = RenderSettings { spp, ..loaded.settings };
            let started = Instant::now();
            let out = render(&loaded.scene, &loaded.camera, &settings, &|_| {})?;
            times[k].push(started.elapsed().as_secs_f64());
            let m = out.colour.mean();
            means[k] = (m[0] + m[1] + m[2]) / 3.0;
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let medians: Vec<f64> = times.iter_mut().map(median).collect();
    let samples = (WIDTH * HEIGHT) as f64 * spp as f64;
    println!("{:<26} {:>14} {:>12} {:>12}", "material", "µs per sample", "vs GGX", "image mean");
    let mut rows = Vec::new();
    for (k, (name, _)) in scenes.iter().enumerate() {
        let per_sample = medians[k] / samples * 1e6;
        let ratio = medians[k] / medians[reference[k]];
        println!("{name:<26} {per_sample:>14.3} {ratio:>11.2}× {:>12.4}", means[k]);
        rows.push(json!({"material": name, "seconds": medians[k], "microseconds_per_sample": per_sample, "vs_ggx": ratio, "image_mean": means[k]}));
    }
    Ok(json!({
        "benchmark": "materials",
        "width": WIDTH,
        "height": HEIGHT,
        "spp": spp,
        "rounds": rounds,
        "threads": rayon::current_num_threads(),
        "materials": rows,
    }))
}
