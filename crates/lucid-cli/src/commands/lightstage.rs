//! `lucid lightstage calibrate`: each OLAT light's direction from chrome reference spheres.

use anyhow::{Context, bail};
use glam::Vec3;
use lucid_relight::lightstage::ChromeSphere;
use lucid_relight::lightstage::angle_degrees;
use lucid_relight::lightstage::capture::{calibrate, chrome_spheres, write_directions};
use serde_json::json;

use crate::cli::LightstageCommand;

pub fn run(command: LightstageCommand) -> anyhow::Result<()> {
    let LightstageCommand::Calibrate { dataset, split, spheres, output, json } = command;
    if let Some(out) = &output {
        super::refuse_existing(out)?;
    }
    let spheres: Vec<ChromeSphere> = if spheres.is_empty() {
        chrome_spheres(&dataset)?
    } else {
        spheres.iter().map(|s| ChromeSphere { centre: Vec3::new(s[0], s[1], s[2]), radius: s[3] }).collect()
    };
    if spheres.is_empty() {
        bail!(
            "{}: dataset.toml records no chrome reference spheres (make the set with --reference-sphere chrome, \
             or give them with --sphere X,Y,Z,R)",
            dataset.display()
        );
    }
    let started = std::time::Instant::now();
    let lights =
        crate::progress::with_bar("calibrating", |progress| calibrate(&dataset, split.into(), &spheres, progress))
            .with_context(|| format!("calibrating {}", dataset.display()))?;
    let errors: Vec<f32> = lights.iter().filter_map(|l| Some(angle_degrees(l.direction?, l.truth?))).collect();
    let missing: Vec<&str> = lights.iter().filter(|l| l.direction.is_none()).map(|l| l.name.as_str()).collect();
    let unconfirmed: Vec<&str> =
        lights.iter().filter(|l| l.direction.is_some() && !l.trusted()).map(|l| l.name.as_str()).collect();
    if json {
        let rows: Vec<_> = lights
            .iter()
            .map(|l| {
                json!({
                    "name": l.name,
                    "direction": l.direction.map(|d| d.to_array()),
                    "estimates": l.estimates,
                    "agreeing": l.agreement.map(|a| a.agreeing),
                    "facing": l.agreement.map(|a| a.facing),
                    "trusted": l.trusted(),
                    "error_degrees": l.direction.zip(l.truth).map(|(d, t)| angle_degrees(d, t)),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&json!({ "spheres": spheres.len(), "lights": rows }))?);
    } else {
        println!(
            "{:<6} {:>9} {:>8} {:>7} {:>28} {:>10}",
            "light", "estimates", "agreeing", "facing", "direction", "error (°)"
        );
        for l in &lights {
            let direction =
                l.direction.map_or("not found".to_string(), |d| format!("[{:+.4}, {:+.4}, {:+.4}]", d.x, d.y, d.z));
            let error =
                l.direction.zip(l.truth).map_or("-".to_string(), |(d, t)| format!("{:.3}", angle_degrees(d, t)));
            let (agreeing, facing) =
                l.agreement.map_or(("-".into(), "-".into()), |a| (a.agreeing.to_string(), format!("{:.2}", a.facing)));
            let flag = if l.direction.is_some() && !l.trusted() { "  unconfirmed" } else { "" };
            println!("{:<6} {:>9} {agreeing:>8} {facing:>7} {direction:>28} {error:>10}{flag}", l.name, l.estimates);
        }
        if !errors.is_empty() {
            let mean = errors.iter().sum::<f32>() / errors.len() as f32;
            let max = errors.iter().copied().fold(0.0, f32::max);
            println!(
                "{} of {} lights recovered from {} chrome spheres in {:.1} s: error against the recorded directions mean {mean:.3}°, max {max:.3}°",
                lights.len() - missing.len(),
                lights.len(),
                spheres.len(),
                started.elapsed().as_secs_f64()
            );
        }
        if !missing.is_empty() {
            println!("no sphere showed {}", missing.join(", "));
        }
        if !unconfirmed.is_empty() {
            println!(
                "unconfirmed (one highlight, near its sphere's rim or beside others that disagree; left out of the \
                 directions file): {}",
                unconfirmed.join(", ")
            );
        }
    }
    if let Some(out) = &output {
        write_directions(out, &lights)?;
        if !json {
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}
