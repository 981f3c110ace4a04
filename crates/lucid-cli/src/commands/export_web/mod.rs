//! `lucid export web CHECKPOINT -o DIR`: a trained splat cloud as a self-contained web page
//! (`index.html`, `splats.js`, `splats.bin`, `scene.json`) that any static file server
//! serves and any WebGL2 browser renders, so a result can be shared without Lucid.
//!
//! `splats.bin` holds 52 bytes per Gaussian, little-endian: the centre as three f32, the
//! standard deviations as three f16, the rotation quaternion `(w, x, y, z)` as four f16, the
//! opacity (after its sigmoid) as one f16, and the colour's spherical harmonics to degree 1 as
//! twelve f16 (the DC term's r, g, b, then coefficients 1 to 3, r, g, b each). Coordinates are
//! the model's (a capture's normalised frame), as `lucid view` shows them. Each file is
//! written under a temporary name and renamed into place, into a new or empty folder or over
//! an earlier export; files a user added beside an export stay.

use std::io::Write;
use std::path::Path;

use anyhow::bail;
use half::f16;
use lucid_image::ImageError;
use lucid_image::owned_folder::OwnedFolder;
use lucid_splat::cloud::SplatCloud;
use serde_json::{Value, json};

use crate::cli::ExportWebArgs;
use lucid_splat::trained::TrainedSplats;

const PAGE: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/splats.js");
/// Bytes per Gaussian in `splats.bin`.
pub const BYTES_PER_SPLAT: usize = 52;
/// What `scene.json` says wrote it, and the writer its folder's record names.
const GENERATOR: &str = "lucid export web";

pub fn run(args: ExportWebArgs) -> anyhow::Result<()> {
    let model = lucid_session::registry::open(&args.checkpoint)?;
    let Some(splats) = model.as_any().downcast_ref::<TrainedSplats>() else {
        bail!(
            "{}: a {} checkpoint; the web export draws 3D Gaussian splats (lucid train splat)",
            args.checkpoint.display(),
            model.kind()
        );
    };
    let cloud = splats.cloud();
    let mut scene = lucid_view::view_fields(&*model, splats.settings().background);
    let more = json!({
        "generator": GENERATOR,
        "version": env!("CARGO_PKG_VERSION"),
        "checkpoint": args.checkpoint.display().to_string(),
        "step": model.step(),
        "count": cloud.len(),
        "bytes_per_splat": BYTES_PER_SPLAT,
        "sh_degree": 1,
    });
    if let (Some(scene), Value::Object(more)) = (scene.as_object_mut(), more) {
        scene.extend(more);
    }
    write_folder(&args.output, &args.checkpoint, &scene, &encode(cloud))?;
    println!(
        "exported {} Gaussians ({:.1} MB) to {}: serve the folder (python3 -m http.server -d {}) and open it",
        cloud.len(),
        (cloud.len() * BYTES_PER_SPLAT) as f64 / 1e6,
        args.output.display(),
        args.output.display()
    );
    Ok(())
}

/// `splats.bin` of a cloud (see the module's description).
pub fn encode(cloud: &SplatCloud) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(cloud.len() * BYTES_PER_SPLAT);
    let half = |bytes: &mut Vec<u8>, v: f32| bytes.extend(f16::from_f32(v).to_le_bytes());
    for i in 0..cloud.len() {
        for v in &cloud.means[3 * i..3 * i + 3] {
            bytes.extend(v.to_le_bytes());
        }
        for v in &cloud.log_scales[3 * i..3 * i + 3] {
            half(&mut bytes, v.exp());
        }
        let q = &cloud.rotations[4 * i..4 * i + 4];
        let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt().max(f32::MIN_POSITIVE);
        for v in q {
            half(&mut bytes, v / norm);
        }
        half(&mut bytes, 1.0 / (1.0 + (-cloud.opacities[i]).exp()));
        for v in &cloud.sh_dc[3 * i..3 * i + 3] {
            half(&mut bytes, *v);
        }
        let rest = lucid_splat::project::SH_REST;
        for v in &cloud.sh_rest[rest * i..rest * i + 9] {
            half(&mut bytes, *v);
        }
    }
    bytes
}

/// Writes the four files into `out`, each under a temporary name and renamed into place:
/// a new or empty folder, or an earlier export, whose other files (a user's) stay.
fn write_folder(out: &Path, checkpoint: &Path, scene: &Value, splats: &[u8]) -> anyhow::Result<()> {
    if is_unrecorded_export(out) {
        adopt_export(out)?;
    }
    let folder = OwnedFolder::claim(out, GENERATOR, &[checkpoint])?;
    let write = |name: &str, bytes: &[u8]| -> anyhow::Result<()> {
        let path = folder.path(name);
        lucid_image::write_atomically(&path, |w| w.write_all(bytes).map_err(|e| ImageError::io(&path, e)))?;
        Ok(())
    };
    write("index.html", PAGE.as_bytes())?;
    write("splats.js", SCRIPT.as_bytes())?;
    write("splats.bin", splats)?;
    write("scene.json", serde_json::to_string_pretty(scene).expect("serialises").as_bytes())?;
    folder.finish()?;
    Ok(())
}

/// Whether `dir` is an export written before exports kept a record: its `scene.json` names
/// this command as its writer.
fn is_unrecorded_export(dir: &Path) -> bool {
    if lucid_image::owned_folder::is_owned(dir) {
        return false;
    }
    let Ok(text) = std::fs::read_to_string(dir.join("scene.json")) else { return false };
    let Ok(scene) = serde_json::from_str::<Value>(&text) else { return false };
    scene["generator"] == GENERATOR
}

/// Records the four files of an export that has no record, so it can be replaced like one.
fn adopt_export(dir: &Path) -> anyhow::Result<()> {
    let files = ["index.html", "splats.js", "splats.bin", "scene.json"].into_iter().filter(|f| dir.join(f).is_file());
    Ok(lucid_image::owned_folder::write_record(dir, GENERATOR, files)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes decode (as splats.js decodes them) to the cloud, to f16 precision.
    #[test]
    fn the_binary_layout_round_trips() {
        let mut cloud = SplatCloud::default();
        cloud.push(glam::Vec3::new(0.25, -1.5, 3.0), 0.02, 0.7, [0.9, 0.1, 0.4]);
        cloud.push(glam::Vec3::new(-2.0, 0.5, 0.125), 0.5, 0.05, [0.2, 0.6, 0.3]);
        cloud.rotations[4..8].copy_from_slice(&[2.0, 0.0, 2.0, 0.0]);
        cloud.sh_rest[lucid_splat::project::SH_REST + 4] = 0.3;
        let bytes = encode(&cloud);
        assert_eq!(bytes.len(), 2 * BYTES_PER_SPLAT);
        let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let f16_at = |o: usize, k: usize| f16::from_le_bytes(bytes[o + 12 + 2 * k..o + 14 + 2 * k].try_into().unwrap());
        let second = BYTES_PER_SPLAT;
        assert_eq!([f32_at(second), f32_at(second + 4), f32_at(second + 8)], [-2.0, 0.5, 0.125]);
        assert!((f16_at(0, 0).to_f32() - 0.02).abs() < 1e-5, "scale as a standard deviation");
        let rotation: Vec<f32> = (3..7).map(|k| f16_at(second, k).to_f32()).collect();
        let half_turn = std::f32::consts::FRAC_1_SQRT_2;
        assert!((rotation[0] - half_turn).abs() < 1e-3 && (rotation[2] - half_turn).abs() < 1e-3, "{rotation:?}");
        assert!((f16_at(0, 7).to_f32() - 0.7).abs() < 1e-3, "opacity after the sigmoid");
        let dc = (f16_at(0, 8).to_f32() * lucid_splat::sh::C0) + 0.5;
        assert!((dc - 0.9).abs() < 2e-3, "DC colour {dc}");
        // Coefficient 2's green of the second splat (rest index 1·3 + 1 = 4).
        assert!((f16_at(second, 8 + 3 + 4).to_f32() - 0.3).abs() < 1e-3);
    }
}
