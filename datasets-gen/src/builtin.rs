//! What Lucid ships to generate without any file: the scenes of `configs/scenes/` compiled in,
//! and the `object` orbit set that the demo and the benchmarks render.

use std::path::Path;

use glam::Vec3;
use lucid_image::tonemap::ToneCurve;
use lucid_scene::{Dataset, Split};
use lucid_trace::{LoadedScene, parse_scene};

use crate::PathTracedScene;
use crate::rig::{OrbitRig, Rig};
use crate::writer::{DatasetSpec, GenError, Shard, ViewRenderer, generate_dataset};

/// The scenes of `configs/scenes/`, so `lucid gen NAME` works anywhere.
const SCENES: [(&str, &str); 13] = [
    ("cornell", include_str!("../../configs/scenes/cornell.toml")),
    ("spheres", include_str!("../../configs/scenes/spheres.toml")),
    ("materials", include_str!("../../configs/scenes/materials.toml")),
    ("media", include_str!("../../configs/scenes/media.toml")),
    ("object", include_str!("../../configs/scenes/object.toml")),
    ("studio", include_str!("../../configs/scenes/studio.toml")),
    ("garden", include_str!("../../configs/scenes/garden.toml")),
    ("trophy", include_str!("../../configs/scenes/trophy.toml")),
    ("toys", include_str!("../../configs/scenes/toys.toml")),
    ("caustic", include_str!("../../configs/scenes/caustic.toml")),
    ("door", include_str!("../../configs/scenes/door.toml")),
    ("many-lights", include_str!("../../configs/scenes/many-lights.toml")),
    ("materials2", include_str!("../../configs/scenes/materials2.toml")),
];

/// The built-in scenes' names.
pub const SCENE_NAMES: [&str; 13] = [
    "cornell",
    "spheres",
    "materials",
    "media",
    "object",
    "studio",
    "garden",
    "trophy",
    "toys",
    "caustic",
    "door",
    "many-lights",
    "materials2",
];

/// The scenes of the NeRF and 3DGS benchmarks: object-centred like the NeRF-synthetic set and lit
/// without delta lights, so that their truth converges (see [`ensure_benchmark_set`]).
pub const BENCHMARK_SCENES: [&str; 2] = ["trophy", "toys"];

/// A scene by file path, or by built-in name.
pub fn load_named_scene(scene: &str) -> Result<LoadedScene, GenError> {
    let (text, path) = named_scene_text(scene)?;
    Ok(parse_scene(&text, &path)?)
}

/// A scene's text and the path its relative files resolve against, by file path or by
/// built-in name.
pub fn named_scene_text(scene: &str) -> Result<(String, std::path::PathBuf), GenError> {
    let path = Path::new(scene);
    if path.is_file() {
        let text = std::fs::read_to_string(path)
            .map_err(|source| GenError::Scene(lucid_trace::SceneFileError::Io { path: path.to_path_buf(), source }))?;
        return Ok((text, path.to_path_buf()));
    }
    match SCENES.iter().find(|(name, _)| *name == scene) {
        Some((name, text)) => Ok((text.to_string(), format!("configs/scenes/{name}.toml").into())),
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

/// The noise ceiling is measured against renders this many times longer.
pub const CEILING_SPP_FACTOR: u32 = 8;

/// Test views the noise ceiling is measured on.
pub const CEILING_VIEWS: usize = 5;

/// How close a set's truth is to the converged image: the PSNR, scored as evaluations score
/// (sRGB-encoded, over white), of its first test views' PNGs against renders of the same views
/// with `reference_spp` samples from independent random streams. No model can be measured
/// above it; written to `ceiling.json` beside the set.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct NoiseCeiling {
    /// The scene.
    pub scene: String,
    /// Samples per pixel of the set's images.
    pub spp: u32,
    /// Samples per pixel of the reference renders.
    pub reference_spp: u32,
    /// PSNR (dB) of each measured test view.
    pub psnr: Vec<f64>,
    /// Their mean.
    pub mean_psnr: f64,
    /// CRC-32 of the scene file's text the set was rendered from (absent in sets rendered
    /// before it was recorded), so that a set rendered from an earlier version of its scene is
    /// refused rather than scored as the current one.
    #[serde(default)]
    pub scene_crc32: Option<u32>,
}

impl NoiseCeiling {
    /// The file in a benchmark set's folder.
    pub const FILE: &str = "ceiling.json";

    /// The ceiling stored with the dataset in `root`, if there is one.
    pub fn read(root: &Path) -> Option<Self> {
        serde_json::from_str(&std::fs::read_to_string(root.join(Self::FILE)).ok()?).ok()
    }
}

/// Image size, views per split and spp of the benchmark set of `scene` (see
/// [`ensure_benchmark_set`]), `scene_spp` being its scene file's.
fn benchmark_layout(scene: &str, quick: bool, scene_spp: u32) -> (u32, [usize; 3], u32) {
    match (quick, scene) {
        (true, _) => (48, [12, 3, 3], 8),
        // The first benchmark set, kept as it was so that its numbers can be reproduced.
        (false, "object") => (200, [100, 50, 200], 32),
        (false, _) => (200, [100, 25, 100], scene_spp),
    }
}

/// Renders the benchmark set of `scene` (one of [`BENCHMARK_SCENES`], or `object`) into `root`
/// unless it is complete there (generation resumes), then measures its noise ceiling: 200×200,
/// 100 training, 25 validation and 100 test views at the samples per pixel its scene file sets
/// (each scene's noise differs; they are chosen so that the ceiling is ≥ 45 dB), `object` with
/// 100, 50 and 200 views at 32 spp as the first benchmarks had it, or with `quick` 48×48, 12, 3
/// and 3 views at 8 spp. Settings are chosen on the validation views; the test views only
/// report. A set whose measured ceiling records another spp, or another version of the scene
/// file (its CRC-32), was rendered for other settings and is refused rather than mixed,
/// overwritten or scored as the current set. `progress` gets the frames done and to do.
pub fn ensure_benchmark_set(
    root: &Path,
    scene: &str,
    quick: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<NoiseCeiling, GenError> {
    let (text, path) = named_scene_text(scene)?;
    let scene_crc32 = crc32fast::hash(text.as_bytes());
    let mut loaded = parse_scene(&text, &path)?;
    let (size, counts, spp) = benchmark_layout(scene, quick, loaded.settings.spp);
    loaded.settings.spp = spp;
    let stored = NoiseCeiling::read(root);
    if let Some(other) = stored.as_ref().filter(|c| c.scene != scene || c.spp != spp) {
        return Err(GenError::Spec(format!(
            "{} holds the {} set at {} spp, but the {scene} benchmark renders {spp} spp; \
             remove that folder (or pass another) to render it anew",
            root.display(),
            other.scene,
            other.spp
        )));
    }
    if let Some(other) = stored.as_ref().filter(|c| c.scene_crc32 != Some(scene_crc32)) {
        return Err(GenError::Spec(format!(
            "{} holds the {scene} set rendered from {} version of {} than this Lucid's; remove that folder \
             (or pass another) to render it anew",
            root.display(),
            if other.scene_crc32.is_some() { "another" } else { "an older" },
            path.display()
        )));
    }
    let spec = object_orbit_spec(size, counts, 0);
    let complete =
        Dataset::open(root).is_ok_and(|d| Split::ALL.iter().zip(counts).all(|(&s, n)| d.frames(s).len() == n));
    if !complete {
        let renderer = PathTracedScene { scene: loaded.scene.clone(), settings: loaded.settings };
        generate_dataset(root, &spec, &renderer, Shard::ALL, progress)?;
    }
    if let Some(ceiling) = stored {
        return Ok(ceiling);
    }
    loaded.settings.spp = spp * CEILING_SPP_FACTOR;
    let reference = PathTracedScene { scene: loaded.scene, settings: loaded.settings };
    let ceiling = measure_ceiling(root, scene, spp, scene_crc32, &spec, &reference)?;
    let text = serde_json::to_string_pretty(&ceiling).expect("serialisable");
    lucid_image::output::write_text(&root.join(NoiseCeiling::FILE), &text)?;
    Ok(ceiling)
}

fn measure_ceiling(
    root: &Path,
    scene: &str,
    spp: u32,
    scene_crc32: u32,
    spec: &DatasetSpec,
    reference: &PathTracedScene,
) -> Result<NoiseCeiling, GenError> {
    use lucid_image::color::{composite_over, srgb_encode};
    let dataset = Dataset::open(root)?;
    let frames = dataset.frames(Split::Test);
    let frames = &frames[..frames.len().min(CEILING_VIEWS)];
    // Scored as evaluations score: the truth read and composited by their own functions, the
    // reference encoded and composited over the same white.
    let truth = lucid_scene::dataset::images::ImageSet::load(frames)?;
    let mut psnr = Vec::new();
    for (k, frame) in frames.iter().enumerate() {
        // Streams no view of the set uses (those are numbered split · 10⁶ + index).
        let view = reference.render(&frame.camera, None, (1 << 40) + k as u64).map_err(GenError::Spec)?;
        let long = spec.tone_curve.map_image(&view.colour, spec.exposure);
        let long =
            composite_over(&long.map(|p| [srgb_encode(p[0]), srgb_encode(p[1]), srgb_encode(p[2]), p[3]]), [1.0; 3]);
        let truth = lucid_scene::evaluation::ground_truth(&truth, k, [1.0; 3]);
        psnr.push(
            lucid_image::metrics::psnr(&truth, &long, None)
                .map_err(|e| GenError::Spec(format!("{}: {e}", frame.image_path.display())))?,
        );
    }
    let mean_psnr = psnr.iter().sum::<f64>() / psnr.len().max(1) as f64;
    Ok(NoiseCeiling {
        scene: scene.to_string(),
        spp,
        reference_spp: reference.settings.spp,
        psnr,
        mean_psnr,
        scene_crc32: Some(scene_crc32),
    })
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

    /// No view of a benchmark set sees a light's geometry. Hidden emitters hide their emission
    /// from camera rays, not their shape (as Mitsuba's `hide_emitters` does), and a panel
    /// beyond the scene box is something a NeRF-synthetic set never shows and a bounded model
    /// cannot fit: toys' rim softbox entered 8 of its 225 views (one validation view scored
    /// 23.5 dB against ~36 for the rest) until it was raised out of every camera's frame.
    #[test]
    fn no_benchmark_view_sees_a_light() {
        use lucid_scene::camera::Camera;
        use lucid_scene::{Intrinsics, PinholeCamera};
        use rayon::prelude::*;
        for scene in BENCHMARK_SCENES {
            let loaded = load_named_scene(scene).unwrap();
            let (size, counts, _) = benchmark_layout(scene, false, loaded.settings.spp);
            let spec = object_orbit_spec(size, counts, 0);
            let Rig::Orbit(orbit) = spec.rig else { unreachable!("an orbit") };
            let intrinsics = Intrinsics::from_fov_x(spec.width, spec.height, spec.fov_x);
            let bvh = &loaded.scene.bvh;
            let views: Vec<_> = (0..3)
                .flat_map(|split| {
                    orbit
                        .poses(spec.counts[split], split as u64)
                        .into_iter()
                        .enumerate()
                        .map(move |(i, p)| (split, i, p))
                })
                .collect();
            let seen: Vec<_> = views
                .par_iter()
                .filter_map(|&(split, i, pose)| {
                    let camera = PinholeCamera::new(intrinsics, pose);
                    let (w, h) = (spec.width as usize, spec.height as usize);
                    let pixels = (0..w * h)
                        .filter(|k| {
                            let ray = camera.generate_ray((k % w) as f32 + 0.5, (k / w) as f32 + 0.5, glam::Vec2::ZERO);
                            bvh.closest(&ray, 1e-4, f32::INFINITY)
                                .is_some_and(|(.., p)| bvh.primitives()[p as usize].light.is_some())
                        })
                        .count();
                    (pixels > 0).then_some((Split::ALL[split].name(), i, pixels))
                })
                .collect();
            assert!(seen.is_empty(), "{scene}: views that see a light's geometry (split, view, pixels): {seen:?}");
        }
    }

    /// The benchmark renders each scene at its file's spp, and a folder whose measured ceiling
    /// records another is refused untouched (not mixed with new frames, not overwritten).
    #[test]
    fn benchmark_spp_comes_from_the_scene_and_a_stale_set_is_refused() {
        assert_eq!(load_named_scene("trophy").unwrap().settings.spp, 384);
        assert_eq!(load_named_scene("toys").unwrap().settings.spp, 512);
        let current = crc32fast::hash(named_scene_text("toys").unwrap().0.as_bytes());
        let stale = NoiseCeiling {
            scene: "toys".into(),
            spp: 384,
            reference_spp: 3072,
            psnr: vec![44.0],
            mean_psnr: 44.0,
            scene_crc32: Some(current),
        };
        // Another spp, another version of the scene file, or a set from before the file's
        // checksum was recorded.
        let cases = [
            (stale.clone(), vec!["384 spp", "renders 8 spp"]),
            (
                NoiseCeiling { spp: 8, scene_crc32: Some(current ^ 1), ..stale.clone() },
                vec!["another version", "toys.toml"],
            ),
            (NoiseCeiling { spp: 8, scene_crc32: None, ..stale.clone() }, vec!["an older version", "toys.toml"]),
        ];
        for (ceiling, words) in cases {
            let dir = tempfile::tempdir().unwrap();
            let text = serde_json::to_string(&ceiling).unwrap();
            std::fs::write(dir.path().join(NoiseCeiling::FILE), &text).unwrap();
            let err = ensure_benchmark_set(dir.path(), "toys", true, &|_, _| {}).unwrap_err().to_string();
            assert!(words.iter().all(|w| err.contains(w)), "{err}");
            let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
            assert_eq!(names, [NoiseCeiling::FILE]);
            assert_eq!(std::fs::read_to_string(dir.path().join(NoiseCeiling::FILE)).unwrap(), text);
        }
        // A ceiling of this spp and this version of the file is the set's: its frames are
        // rendered and the stored ceiling kept.
        let dir = tempfile::tempdir().unwrap();
        let text = serde_json::to_string(&NoiseCeiling { spp: 8, ..stale }).unwrap();
        std::fs::write(dir.path().join(NoiseCeiling::FILE), &text).unwrap();
        let ceiling = ensure_benchmark_set(dir.path(), "toys", true, &|_, _| {}).unwrap();
        assert_eq!((ceiling.mean_psnr, ceiling.scene_crc32), (44.0, Some(current)));
        assert_eq!(Dataset::open(dir.path()).unwrap().frames(Split::Test).len(), 3);
    }
}
