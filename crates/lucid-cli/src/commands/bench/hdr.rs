//! `lucid bench hdr`: the HDR toolkit on a 1-megapixel stack of 5 brackets (±4 EV in 2 EV
//! steps) made from a procedural radiance image through the sRGB response: time of the
//! response recovery, the merge, fusion and each tone-mapping operator, and the merge's
//! error against the radiance it came from.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use lucid_hdr::fusion::{FusionSettings, mertens};
use lucid_hdr::merge::merge_radiance;
use lucid_hdr::response::{DebevecSettings, RobertsonSettings, debevec_malik, robertson};
use lucid_hdr::stack::ExposureStack;
use lucid_hdr::tonemap::{ToneMapper, tone_map};
use lucid_image::Image;
use lucid_image::color::srgb_encode;
use serde_json::json;

/// Radiance over five decades: a smooth gradient with bright discs (light sources) and a
/// fine texture, deterministic.
fn scene(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
        let base = 10f32.powf(-2.0 + 3.0 * u) * (1.0 + 0.3 * (40.0 * v).sin() * (23.0 * u).cos());
        let disc = |cx: f32, cy: f32, r: f32| if (u - cx).powi(2) + (v - cy).powi(2) < r * r { 50.0 } else { 0.0 };
        let l = base + disc(0.3, 0.3, 0.05) + disc(0.7, 0.6, 0.03);
        [l, l * (0.6 + 0.4 * v), l * (1.0 - 0.5 * v), 1.0]
    })
}

pub fn run(quick: bool, write_stack: Option<&Path>) -> anyhow::Result<serde_json::Value> {
    let (w, h) = if quick { (256, 256) } else { (1000, 1000) };
    let hdr = scene(w, h);
    let times = [1.0 / 16.0, 0.25, 1.0, 4.0, 16.0];
    let frames: Vec<Image> = times
        .iter()
        .map(|&t| {
            hdr.map(|p| {
                let q = |v: f32| lucid_image::color::srgb_decode((srgb_encode(v * t) * 255.0).round() / 255.0);
                [q(p[0]), q(p[1]), q(p[2]), 1.0]
            })
        })
        .collect();
    let timed = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    let mut stack = None;
    let t_stack = timed(&mut || stack = Some(ExposureStack::new(&frames, &times).expect("a valid stack")));
    let stack = stack.expect("built");
    let mut curve = None;
    let t_debevec = timed(&mut || curve = Some(debevec_malik(&stack, DebevecSettings::default()).expect("solvable")));
    let curve = curve.expect("recovered");
    let t_robertson = timed(&mut || {
        std::hint::black_box(robertson(&stack, RobertsonSettings::default()).expect("recovered"));
    });
    let mut merged = None;
    let t_merge = timed(&mut || merged = Some(merge_radiance(&stack, &curve)));
    let merged = merged.expect("merged");
    // Warm: the median of five runs after two untimed ones. The first runs in a process pay
    // for faulting in fresh memory (0.2–0.5 s on this machine), which a tool fusing many
    // stacks, or OpenCV timed in a warm process, does not.
    let mut fused = None;
    let mut fusion_times: Vec<f64> =
        (0..7).map(|_| timed(&mut || fused = Some(mertens(&stack, FusionSettings::default())))).skip(2).collect();
    fusion_times.sort_by(f64::total_cmp);
    let t_fusion = fusion_times[2];
    if let Some(dir) = write_stack {
        write_bracket(dir, &frames, &fused.expect("fused"))?;
    }
    // Merge error against the truth, up to the recovered curve's scale.
    let mut ratios: Vec<f32> =
        merged.pixels().iter().zip(hdr.pixels()).flat_map(|(m, t)| (0..3).map(move |c| m[c] / t[c])).collect();
    ratios.sort_by(f32::total_cmp);
    let scale = ratios[ratios.len() / 2];
    let error = ratios.iter().map(|r| (r / scale - 1.0).abs() as f64).sum::<f64>() / ratios.len() as f64;
    let mut tonemaps = serde_json::Map::new();
    for name in ToneMapper::NAMES {
        let op = ToneMapper::by_name(name)?;
        let t = timed(&mut || {
            std::hint::black_box(tone_map(&merged, &op, 1.0).expect("valid defaults"));
        });
        tonemaps.insert(name.to_string(), json!(t));
    }
    let mp = (w * h) as f64 / 1e6;
    println!(
        "lucid bench hdr{}: {} brackets at {w}x{h} ({mp:.2} MP)",
        if quick { " --quick" } else { "" },
        times.len()
    );
    println!("{:<34} {:>10}", "stage", "seconds");
    println!("{:<34} {:>10.3}", "stack (decode to codes)", t_stack);
    println!("{:<34} {:>10.3}", "response: Debevec-Malik", t_debevec);
    println!("{:<34} {:>10.3}", "response: Robertson", t_robertson);
    println!("{:<34} {:>10.3}", "merge (log-domain, weighted)", t_merge);
    println!("{:<34} {:>10.3}", "Mertens fusion (warm, median of 5)", t_fusion);
    for (name, t) in &tonemaps {
        println!("{:<34} {:>10.3}", format!("tone map: {name}"), t.as_f64().unwrap_or(0.0));
    }
    println!("merge error against the radiance (up to scale): {:.2} % mean", 100.0 * error);
    Ok(json!({
        "benchmark": "hdr", "quick": quick, "width": w, "height": h, "frames": times.len(),
        "threads": rayon::current_num_threads(),
        "seconds": {
            "stack": t_stack, "debevec": t_debevec, "robertson": t_robertson, "merge": t_merge,
            "mertens": t_fusion, "tonemap": tonemaps,
        },
        "merge_mean_relative_error": error,
    }))
}

/// The bracket as 8-bit PNGs and the fusion as display values in a PFM, into a folder that is
/// filled under a temporary name and renamed when complete.
fn write_bracket(dir: &Path, frames: &[Image], fused: &Image) -> anyhow::Result<()> {
    let name = dir.file_name().ok_or_else(|| anyhow::anyhow!("--write-stack {}: not a folder name", dir.display()))?;
    let tmp = dir.with_file_name(format!(".{}.partial-{}", name.to_string_lossy(), std::process::id()));
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let written = (|| -> anyhow::Result<()> {
        for (k, frame) in frames.iter().enumerate() {
            lucid_image::io::write_image(tmp.join(format!("frame_{k}.png")), frame)?;
        }
        let display = fused.map(|p| [srgb_encode(p[0]), srgb_encode(p[1]), srgb_encode(p[2]), 1.0]);
        lucid_image::io::write_image(tmp.join("fused.pfm"), &display)?;
        Ok(())
    })();
    if let Err(e) =
        written.and_then(|()| std::fs::rename(&tmp, dir).with_context(|| format!("renaming to {}", dir.display())))
    {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    println!("bracket and fusion written to {}", dir.display());
    Ok(())
}
