//! `lucid envmap ...`: environment-map tools.

use anyhow::{Context, bail};
use glam::Vec3;
use lucid_image::{read_finite_image, read_image, write_image};
use lucid_relight::envmap::{latlong_to_mirror_ball, mirror_ball_to_latlong};
use lucid_relight::median_cut::median_cut;
use lucid_relight::sh::{irradiance_map, project};
use lucid_relight::voronoi::voronoi_solid_angles;
use serde_json::json;

use crate::cli::{EnvmapArgs, EnvmapCommand};

fn parse_directions(text: &str) -> anyhow::Result<Vec<Vec3>> {
    text.split(';')
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            let v: Vec<f32> = s
                .split(',')
                .map(|x| x.trim().parse::<f32>().with_context(|| format!("direction {s:?}: {x:?} is not a number")))
                .collect::<anyhow::Result<_>>()?;
            if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                bail!("direction {s:?}: expected x,y,z with finite numbers");
            }
            let d = Vec3::new(v[0], v[1], v[2]);
            if d.length() == 0.0 {
                bail!("direction {s:?} is zero");
            }
            Ok(d)
        })
        .collect()
}

pub fn run(args: EnvmapArgs) -> anyhow::Result<()> {
    match args.command {
        EnvmapCommand::FromMirrorBall { input, output, width } => {
            let ball = read_image(&input)?;
            if ball.width() != ball.height() {
                bail!("{}: a mirror-ball image is square, this is {}x{}", input.display(), ball.width(), ball.height());
            }
            let width = width.max(2);
            crate::commands::check_image_memory(width as u32, width as u32 / 2, 32.0, "--width")?;
            write_image(&output, &mirror_ball_to_latlong(&ball, width))?;
        }
        EnvmapCommand::ToMirrorBall { input, output, size } => {
            crate::commands::check_image_memory(size as u32, size as u32, 32.0, "--size")?;
            write_image(&output, &latlong_to_mirror_ball(&read_finite_image(&input)?, size))?;
        }
        EnvmapCommand::Sh { input, irradiance, json } => {
            let map = read_finite_image(&input)?;
            let coeffs = project(&map);
            if let Some(out) = irradiance {
                write_image(&out, &irradiance_map(&coeffs, map.width(), map.height()))?;
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&json!({ "coefficients": coeffs }))?);
            } else {
                let names = ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"];
                println!("{:<6} {:>12} {:>12} {:>12}", "coeff", "red", "green", "blue");
                for (n, c) in names.iter().zip(coeffs) {
                    println!("{n:<6} {:>12.5} {:>12.5} {:>12.5}", c[0], c[1], c[2]);
                }
            }
        }
        EnvmapCommand::MedianCut { input, lights, json } => {
            if lights == 0 {
                bail!("--lights must be at least 1");
            }
            let cut = median_cut(&read_finite_image(&input)?, lights);
            if json {
                let v: Vec<_> =
                    cut.iter().map(|l| json!({ "direction": l.direction.to_array(), "energy": l.energy })).collect();
                println!("{}", serde_json::to_string_pretty(&json!({ "lights": v }))?);
            } else {
                println!("{:>4} {:>26} {:>36}", "#", "direction", "energy (∫L dω per channel)");
                for (k, l) in cut.iter().enumerate() {
                    let d = l.direction;
                    println!(
                        "{k:>4} {:>8.4} {:>8.4} {:>8.4} {:>12.5} {:>12.5} {:>12.5}",
                        d.x, d.y, d.z, l.energy[0], l.energy[1], l.energy[2]
                    );
                }
            }
        }
        EnvmapCommand::FixSun { input, sphere, albedo, output, json } => {
            super::refuse_existing(&output)?;
            lucid_image::ImageFormat::from_path(&output)?;
            let map = read_image(&input)?;
            let ball = read_image(&sphere)?;
            let (fixed, report) = lucid_relight::sun::fix_sun(&map, &ball, Vec3::from(albedo))
                .with_context(|| format!("{} with {}", input.display(), sphere.display()))?;
            write_image(&output, &fixed)?;
            let sun = report.added.map(|a| a + report.clip_level);
            if json {
                let value = json!({
                    "clip_level": report.clip_level,
                    "clipped_pixels": report.clipped_pixels,
                    "solid_angle": report.solid_angle,
                    "added": report.added,
                    "sun_radiance": sun,
                    "direction": report.direction.to_array(),
                    "fitted_pixels": report.fitted_pixels,
                    "relative_residual": report.residual,
                });
                println!("{}", serde_json::to_string_pretty(&value)?);
            } else {
                println!(
                    "{} pixels ({:.2e} sr) clip at {:.4}; the ball's {} sun-facing pixels put the sun at [{:.1}, {:.1}, {:.1}] \
                     (fit residual {:.2} %), towards [{:+.3}, {:+.3}, {:+.3}]; wrote {}",
                    report.clipped_pixels,
                    report.solid_angle,
                    report.clip_level,
                    report.fitted_pixels,
                    sun[0],
                    sun[1],
                    sun[2],
                    100.0 * report.residual,
                    report.direction.x,
                    report.direction.y,
                    report.direction.z,
                    output.display()
                );
            }
        }
        EnvmapCommand::Voronoi { directions, json } => {
            let dirs = parse_directions(&directions)?;
            if dirs.is_empty() {
                bail!("no directions given: list them as x,y,z;x,y,z;...");
            }
            let angles = voronoi_solid_angles(&dirs)?;
            let total: f64 = angles.iter().sum();
            if json {
                println!("{}", serde_json::to_string_pretty(&json!({ "solid_angles": angles, "total": total }))?);
            } else {
                for (d, a) in dirs.iter().zip(&angles) {
                    println!("{:>8.4} {:>8.4} {:>8.4}  {a:.6} sr", d.x, d.y, d.z);
                }
                println!("total {total:.6} sr (4π = {:.6})", 4.0 * std::f64::consts::PI);
            }
        }
    }
    Ok(())
}
