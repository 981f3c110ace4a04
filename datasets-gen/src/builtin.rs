//! What Lucid ships to generate without any file: the scenes of `configs/scenes/` compiled in,
//! and the `object` orbit set that the demo and the benchmarks render.

use std::path::Path;

use glam::Vec3;
use lucid_image::tonemap::ToneCurve;
use lucid_scene::{Dataset, Split};
use lucid_trace::{LoadedScene, load_scene, parse_scene};

use crate::PathTracedScene;
use crate::rig::{OrbitRig, Rig};
use crate::writer::{DatasetSpec, GenError, Shard, generate_dataset};

/// The scenes of `configs/scenes/`, so `lucid gen NAME` works anywhere.
const SCENES: [(&str, &str); 7] = [
    ("cornell", include_str!("../../configs/scenes/cornell.toml")),
    ("spheres", include_str!("../../configs/scenes/spheres.toml")),
    ("materials", include_str!("../../configs/scenes/materials.toml")),
    ("media", include_str!("../../configs/scenes/media.toml")),
    ("object", include_str!("../../configs/scenes/object.toml")),
    ("studio", include_str!("../../configs/scenes/studio.toml")),
    ("garden", include_str!("../../configs/scenes/garden.toml")),
];

/// The built-in scenes' names.
pub const SCENE_NAMES: [&str; 7] = ["cornell", "spheres", "materials", "media", "object", "studio", "garden"];

/// A scene by file path, or by built-in name.
pub fn load_named_scene(scene: &str) -> Result<LoadedScene, GenError> {
    let path = Path::new(scene);
    if path.is_file() {
        return Ok(load_scene(path)?);
    }
    match SCENES.iter().find(|(name, _)| *name == scene) {
        Some((name, text)) => Ok(parse_scene(text, Path::new(&format!("configs/scenes/{name}.toml")))?),
        None => Err(GenError::UnknownScene { name: scene.to_string() }),
    }
}

/// The `object` orbit set: cameras on the upper hemisphere at distance 4 with a 40° field of
/// view, the NeRF-synthetic `[-1.5, 1.5]³` box, the ACES tone curve for the PNGs.
pub fn object_orbit_spec(size: u32, counts: [usize; 3], seed: u64) -> DatasetSpec {
    DatasetSpec {
        width: size,
        height: size,
        fov_x: 40f32.to_radians(),
        counts,
        rig: Rig::Orbit(OrbitRig { radius: 4.0, target: Vec3::ZERO, upper_hemisphere: true, seed }),
        aabb: (Vec3::splat(-1.5), Vec3::splat(1.5)),
        exposure: 0.0,
        tone_curve: ToneCurve::Aces,
    }
}

/// Renders the benchmarks' `object` set into `root` unless it is complete there (generation
/// resumes): 200×200, 100 training, 50 validation and 200 test views at 32 spp, or with
/// `quick` 48×48, 12, 3 and 3 views at 8 spp. Settings are chosen on the validation views;
/// the test views only report. `progress` gets the frames done and to do.
pub fn ensure_benchmark_set(
    root: &Path,
    quick: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(), GenError> {
    let (size, counts, spp) = if quick { (48, [12, 3, 3], 8) } else { (200, [100, 50, 200], 32) };
    if Dataset::open(root).is_ok_and(|d| Split::ALL.iter().zip(counts).all(|(&s, n)| d.frames(s).len() == n)) {
        return Ok(());
    }
    let mut loaded = load_named_scene("object")?;
    loaded.settings.spp = spp;
    let renderer = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    generate_dataset(root, &object_orbit_spec(size, counts, 0), &renderer, Shard::ALL, progress)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scene_parses_and_unknown_names_list_them() {
        assert_eq!(SCENES.map(|s| s.0), SCENE_NAMES);
        for name in SCENE_NAMES {
            load_named_scene(name).unwrap();
        }
        let err = load_named_scene("nowhere").err().unwrap().to_string();
        assert!(err.contains("nowhere") && err.contains("cornell, spheres"), "{err}");
    }
}
