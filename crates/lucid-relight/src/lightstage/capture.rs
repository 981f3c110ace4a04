//! Calibrating an OLAT dataset: every frame's chrome spheres give their highlights, the
//! highlights of each light (named by the frame's `_l<k>` suffix, as the photographs of one
//! light in a sweep) are combined into its direction, and the directions are written for
//! `lucid relight --directions`.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use glam::Vec3;
use lucid_image::read_image;
use lucid_scene::{Dataset, Split};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Agreement, ChromeSphere, Highlight, combine_with_agreement, find_highlight};
use crate::RelightError;

/// Estimates farther than this from their light's consensus are outliers.
pub const OUTLIER_DEGREES: f32 = 3.0;

/// A light's recovered direction.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibratedLight {
    /// The light's name (`l<k>`; `h<k>` for held-out lights).
    pub name: String,
    /// The recovered direction (towards the light), if any sphere showed it.
    pub direction: Option<Vec3>,
    /// Highlights found, over spheres and views.
    pub estimates: usize,
    /// How well they agree on the direction (`None` without one).
    pub agreement: Option<Agreement>,
    /// The direction the dataset records, if it does (to report the error; never used to
    /// find the direction).
    pub truth: Option<Vec3>,
}

impl CalibratedLight {
    /// Whether its direction was found and can be trusted (there is an agreement exactly
    /// where there is a direction).
    pub fn trusted(&self) -> bool {
        self.agreement.is_some_and(|a| a.trusted())
    }
}

/// The light of an OLAT frame, from its file name: `./train/r_3_l12` is `l12`, `_h2` is `h2`.
pub fn light_name(file_path: &str) -> Option<String> {
    let stem = file_path.rsplit('/').next()?;
    let (_, last) = stem.rsplit_once('_')?;
    let digits = last.strip_prefix('l').or_else(|| last.strip_prefix('h'))?;
    (!digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())).then(|| last.to_string())
}

/// The chrome reference spheres that `dataset.toml` in `root` records.
pub fn chrome_spheres(root: &Path) -> Result<Vec<ChromeSphere>, RelightError> {
    #[derive(Deserialize)]
    struct Record {
        #[serde(default)]
        reference_spheres: Vec<SphereRecord>,
    }
    #[derive(Deserialize)]
    struct SphereRecord {
        kind: String,
        centre: [f32; 3],
        radius: f32,
    }
    let path = root.join("dataset.toml");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| RelightError::Invalid(format!("{}: {e} (give the spheres with --sphere)", path.display())))?;
    let record: Record =
        toml::from_str(&text).map_err(|e| RelightError::Invalid(format!("{}: {}", path.display(), e.message())))?;
    Ok(record
        .reference_spheres
        .iter()
        .filter(|s| s.kind == "chrome")
        .map(|s| ChromeSphere { centre: Vec3::from(s.centre), radius: s.radius })
        .collect())
}

/// Recovers the direction of every light of `split` from `spheres`; `progress` hears of each
/// frame done (frames done, frames).
pub fn calibrate(
    root: &Path,
    split: Split,
    spheres: &[ChromeSphere],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<CalibratedLight>, RelightError> {
    if spheres.is_empty() {
        return Err(RelightError::Invalid(format!(
            "{}: no chrome reference spheres to calibrate with",
            root.display()
        )));
    }
    let dataset = Dataset::open(root)?;
    let frames: Vec<_> =
        dataset.frames(split).iter().filter_map(|f| light_name(&f.file_path).map(|name| (name, f))).collect();
    if frames.is_empty() {
        return Err(RelightError::Invalid(format!(
            "{}: no OLAT frame (named …_l<k>) in the {} split",
            root.display(),
            split.name()
        )));
    }
    let done = std::sync::atomic::AtomicUsize::new(0);
    let found: Vec<(String, Vec<Highlight>, Option<Vec3>)> = frames
        .par_iter()
        .map(|(name, f)| {
            // OLAT frames are linear: the HDR image, not the tone-mapped PNG.
            let path = f.extras.hdr_path.as_ref().ok_or_else(|| {
                RelightError::Invalid(format!("{}: the frame has no HDR image to calibrate from", f.file_path))
            })?;
            let image = read_image(path)?;
            let depth = f.extras.depth_path.as_ref().map(lucid_image::read_depth_image).transpose()?;
            let highlights: Vec<Highlight> =
                spheres.iter().filter_map(|s| find_highlight(&image, depth.as_ref(), &f.camera, s)).collect();
            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, frames.len());
            Ok((name.clone(), highlights, f.extras.light_direction))
        })
        .collect::<Result<_, RelightError>>()?;
    // Each light's name, recorded direction and highlights, in order of kind and number.
    let mut by_light = BTreeMap::new();
    for (name, found, truth) in found {
        let key = (name.as_bytes()[0] as char, name[1..].parse().unwrap_or(u32::MAX));
        by_light.entry(key).or_insert_with(|| (name, truth, Vec::new())).2.extend(found);
    }
    Ok(by_light
        .into_values()
        .map(|(name, truth, highlights)| {
            let combined = combine_with_agreement(&highlights, OUTLIER_DEGREES);
            CalibratedLight {
                name,
                direction: combined.map(|(d, _)| d),
                estimates: highlights.len(),
                agreement: combined.map(|(_, a)| a),
                truth,
            }
        })
        .collect())
}

/// The directions file's format name.
pub const FORMAT: &str = "lucid light directions";

#[derive(Serialize, Deserialize)]
struct DirectionsFile {
    format: String,
    version: u32,
    lights: Vec<DirectionRecord>,
}

#[derive(Serialize, Deserialize)]
struct DirectionRecord {
    name: String,
    direction: [f32; 3],
    estimates: usize,
}

/// Writes the recovered directions as JSON, through a temporary name; lights without one, or
/// whose direction is not trusted (see [`Agreement::trusted`]), are left out, so that relighting
/// with the file names them as missing rather than using a wrong direction.
pub fn write_directions(path: &Path, lights: &[CalibratedLight]) -> Result<(), RelightError> {
    let file = DirectionsFile {
        format: FORMAT.into(),
        version: 1,
        lights: lights
            .iter()
            .filter(|l| l.trusted())
            .filter_map(|l| {
                l.direction.map(|d| DirectionRecord {
                    name: l.name.clone(),
                    direction: d.into(),
                    estimates: l.estimates,
                })
            })
            .collect(),
    };
    let text = serde_json::to_string_pretty(&file).expect("plain data serialises");
    lucid_image::write_atomically(path, |out| {
        use std::io::Write;
        out.write_all(text.as_bytes()).map_err(|e| RelightError::Invalid(format!("{}: {e}", path.display())))
    })
}

/// Reads a directions file: each light's name and unit direction.
pub fn read_directions(path: &Path) -> Result<HashMap<String, Vec3>, RelightError> {
    let bad = |reason: String| RelightError::Invalid(format!("{}: {reason}", path.display()));
    let text = lucid_scene::text_file::read_text(path).map_err(|e| bad(e.to_string()))?;
    let file: DirectionsFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    if file.format != FORMAT || file.version != 1 {
        return Err(bad(format!("format {:?} version {}, expected {FORMAT:?} version 1", file.format, file.version)));
    }
    file.lights
        .into_iter()
        .map(|l| {
            let d = Vec3::from(l.direction);
            match d.try_normalize() {
                Some(unit) if d.is_finite() => Ok((l.name, unit)),
                _ => Err(bad(format!("light {}: {d} is not a direction", l.name))),
            }
        })
        .collect()
}
