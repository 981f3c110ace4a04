//! Rendering every view of a rig and writing the dataset folder.
//!
//! Images are written first, each atomically; the `transforms_*.json` files last, so a
//! generation that is interrupted leaves no transforms file pointing at missing images.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lucid_image::tonemap::ToneCurve;
use lucid_image::{Image, WriteOptions, write_image, write_image_with};
use lucid_scene::dataset::{FrameRecord, write_transforms};
use lucid_scene::{Intrinsics, PinholeCamera, Split};

use crate::brackets::expose;
use crate::lightfield::LightFieldRig;
use crate::olat::Lighting;
use crate::rig::Rig;
use lucid_image::color::srgb_decode;
use lucid_trace::light::Light;

/// The images a renderer produces for one view. All are linear; `colour` has straight
/// alpha (0 where the background shows), the others carry the same alpha.
#[derive(Clone, Debug)]
pub struct RenderedView {
    /// Linear HDR radiance.
    pub colour: Image,
    /// Depth along the camera's viewing axis (z-depth), in all three channels; 0 on the
    /// background.
    pub depth: Image,
    /// World-space unit normals.
    pub normal: Image,
    /// Surface albedo.
    pub albedo: Image,
}

/// A thin lens in front of a camera: depth of field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Aperture radius in world units.
    pub aperture_radius: f32,
    /// Distance to the plane in focus, along the optical axis.
    pub focus_distance: f32,
}

/// Something that renders a view of a scene.
pub trait ViewRenderer: Sync {
    /// Renders the view that `camera` sees, through `lens` if given (else a pinhole); `view`
    /// numbers the views of a dataset so that stochastic renderers can give each its own
    /// random streams. An error says why the scene cannot be rendered (before any work).
    fn render(&self, camera: &PinholeCamera, lens: Option<Lens>, view: u64) -> Result<RenderedView, String>;

    /// Renders the view under other lights than the scene's own (OLAT and relighting ground
    /// truth); renderers that cannot relight say why.
    fn render_lit(&self, _camera: &PinholeCamera, _lights: &[Light], _view: u64) -> Result<RenderedView, String> {
        Err("this renderer cannot relight a scene".into())
    }

    /// Whether [`ViewRenderer::render_lit`] can work, checked before anything is written.
    fn can_relight(&self) -> Result<(), String> {
        Err("this renderer cannot relight a scene".into())
    }
}

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetSpec {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal field of view in radians.
    pub fov_x: f32,
    /// Number of train, val and test views.
    pub counts: [usize; 3],
    /// Where the cameras stand and how the views are lit.
    pub rig: Rig,
    /// Scene bounds written to the transforms files (`aabb`).
    pub aabb: (Vec3, Vec3),
    /// Exposure in stops applied before the PNG's tone curve.
    pub exposure: f32,
    /// Tone curve for the LDR images.
    pub tone_curve: ToneCurve,
}

/// Why generation failed.
#[derive(Debug, thiserror::Error)]
pub enum GenError {
    /// Writing an image failed.
    #[error(transparent)]
    Image(#[from] lucid_image::ImageError),
    /// Writing a transforms file failed.
    #[error(transparent)]
    Dataset(#[from] lucid_scene::DatasetError),
    /// Creating a folder failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The spec is unusable.
    #[error("invalid dataset spec: {0}")]
    Spec(String),
    /// A scene file could not be read.
    #[error(transparent)]
    Scene(#[from] lucid_trace::SceneFileError),
    /// A scene name is neither a file nor a built-in scene.
    #[error("{name}: no such scene file, and not a built-in scene ({})", crate::builtin::SCENE_NAMES.join(", "))]
    UnknownScene {
        /// The name given.
        name: String,
    },
}

/// Which frames this run renders: all of them, or every `count`-th starting at `index`
/// (frames are numbered across the train, val and test splits in that order), so that
/// `count` machines can split one dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// The whole dataset.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    fn owns(&self, frame: usize) -> bool {
        frame % self.count == self.index
    }
}

/// What a generation run did.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedDataset {
    /// The folder.
    pub root: PathBuf,
    /// Views per split (train, val, test).
    pub counts: [usize; 3],
    /// Frames rendered by this run.
    pub rendered: usize,
    /// Frames of this shard found finished and skipped.
    pub skipped: usize,
    /// Whether every frame exists, so the transforms files and the point cloud were written.
    pub complete: bool,
}

/// One frame of the dataset: where it belongs and what it is called.
struct PlannedFrame {
    split: usize,
    index: usize,
    pose: glam::Mat4,
    lens: Option<Lens>,
    lighting: Option<Lighting>,
    stem: String,
}

impl PlannedFrame {
    fn files(&self) -> [String; 5] {
        let s = &self.stem;
        [
            format!("{s}.png"),
            format!("{s}.exr"),
            format!("{s}_depth.exr"),
            format!("{s}_normal.exr"),
            format!("{s}_albedo.exr"),
        ]
    }

    /// The bracket frames' stems (no extension), one per exposure.
    fn bracket_stems(&self, spec: &DatasetSpec) -> Vec<String> {
        let n = spec.rig.brackets().map_or(0, |b| b.exposure_times.len());
        (0..n).map(|k| format!("{}_e{k}", self.stem)).collect()
    }

    fn finished(&self, root: &Path, spec: &DatasetSpec) -> bool {
        self.files().iter().all(|f| root.join(f).is_file())
            && self.bracket_stems(spec).iter().all(|s| root.join(format!("{s}.png")).is_file())
    }

    /// Seed of this frame's sensor noise for bracket `k`, from the rig's seed.
    fn noise_seed(&self, seed: u64, k: usize) -> u64 {
        lucid_trace::sampling::mix(seed ^ ((self.split as u64) << 48) ^ ((self.index as u64) << 16) ^ k as u64)
    }
}

fn plan(spec: &DatasetSpec) -> Vec<PlannedFrame> {
    let mut frames = Vec::new();
    let orbit = match &spec.rig {
        Rig::LightField(lf) => {
            light_field_frames(lf, &mut frames);
            return frames;
        }
        Rig::Orbit(o) | Rig::Brackets(o, _) | Rig::Olat(o, _) => o,
    };
    for (split_index, split) in Split::ALL.into_iter().enumerate() {
        for (i, pose) in orbit.poses(spec.counts[split_index], split_index as u64).into_iter().enumerate() {
            let stem = format!("{}/r_{i}", split.name());
            let Some(olat) = spec.rig.olat() else {
                frames.push(PlannedFrame { split: split_index, index: i, pose, lens: None, lighting: None, stem });
                continue;
            };
            for l in 0..olat.directions.len() {
                let lighting = Some(Lighting::Light { index: l });
                frames.push(PlannedFrame {
                    split: split_index,
                    index: i,
                    pose,
                    lens: None,
                    lighting,
                    stem: format!("{stem}_l{l}"),
                });
            }
            // Validation views get what test views get, so that settings can be chosen on
            // them under the same conditions the test split reports.
            if split != Split::Train {
                for k in 0..olat.held_out.len() {
                    frames.push(PlannedFrame {
                        split: split_index,
                        index: i,
                        pose,
                        lens: None,
                        lighting: Some(Lighting::HeldOutLight { index: k }),
                        stem: format!("{stem}_h{k}"),
                    });
                }
                for e in 0..olat.environments.len() {
                    let lighting = Some(Lighting::Environment { index: e });
                    frames.push(PlannedFrame {
                        split: split_index,
                        index: i,
                        pose,
                        lens: None,
                        lighting,
                        stem: format!("{stem}_env{e}"),
                    });
                }
            }
        }
    }
    frames
}

/// The frames of a light-field rig: its grid's views train, its thin-lens truths test.
fn light_field_frames(lf: &LightFieldRig, frames: &mut Vec<PlannedFrame>) {
    for (i, (_, pose)) in lf.poses().into_iter().enumerate() {
        frames.push(PlannedFrame {
            split: 0,
            index: i,
            pose,
            lens: None,
            lighting: None,
            stem: format!("train/r_{i}"),
        });
    }
    for (i, &(focus_distance, aperture_radius)) in lf.ground_truth.iter().enumerate() {
        let lens = Some(Lens { aperture_radius, focus_distance });
        frames.push(PlannedFrame {
            split: 2,
            index: i,
            pose: lf.centre_pose(),
            lens,
            lighting: None,
            stem: format!("test/r_{i}"),
        });
    }
}

/// Where environment map `k` of an OLAT dataset is stored, relative to the dataset root.
fn environment_file(k: usize) -> String {
    format!("envmaps/env_{k}.exr")
}

/// Renders the frames of `shard` that are not finished yet into `root` (created if needed),
/// each file written atomically; when every frame of the dataset exists, writes the
/// transforms files and `points3d.ply`. Running again after an interruption, or once more
/// without a shard after all shards finished (the merge), completes the dataset.
/// `progress` is called after each rendered frame with `(done, to_do)`.
pub fn generate_dataset(
    root: &Path,
    spec: &DatasetSpec,
    renderer: &dyn ViewRenderer,
    shard: Shard,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<GeneratedDataset, GenError> {
    if spec.width == 0 || spec.height == 0 {
        return Err(GenError::Spec(format!("image size {}x{} is empty", spec.width, spec.height)));
    }
    if !(spec.fov_x > 0.0 && spec.fov_x < std::f32::consts::PI) {
        return Err(GenError::Spec(format!("field of view {} rad must be in (0, π)", spec.fov_x)));
    }
    if shard.count == 0 || shard.index >= shard.count {
        return Err(GenError::Spec(format!("shard {}/{} does not exist", shard.index, shard.count)));
    }
    if spec.rig.olat().is_some() {
        renderer.can_relight().map_err(GenError::Spec)?;
    }
    let intrinsics = Intrinsics::from_fov_x(spec.width, spec.height, spec.fov_x);
    let frames = plan(spec);
    for split in Split::ALL {
        let folder = root.join(split.name());
        std::fs::create_dir_all(&folder).map_err(|source| GenError::Io { path: folder.clone(), source })?;
        remove_stale_temporaries(&folder);
    }
    if let Some(olat) = spec.rig.olat() {
        let folder = root.join("envmaps");
        std::fs::create_dir_all(&folder).map_err(|source| GenError::Io { path: folder.clone(), source })?;
        for (k, (_, image)) in olat.environments.iter().enumerate() {
            write_image(root.join(environment_file(k)), image)?;
        }
    }
    let mine: Vec<&PlannedFrame> = frames.iter().enumerate().filter(|(g, _)| shard.owns(*g)).map(|(_, f)| f).collect();
    let to_do: Vec<&&PlannedFrame> = mine.iter().filter(|f| !f.finished(root, spec)).collect();
    let skipped = mine.len() - to_do.len();
    for (done, frame) in to_do.iter().enumerate() {
        let camera = PinholeCamera::new(intrinsics, frame.pose);
        let view_number = (frame.split * 1_000_000 + frame.index) as u64;
        let view = match (&frame.lighting, spec.rig.olat()) {
            (Some(lighting), Some(olat)) => {
                // Each light gets its own random streams too.
                let salt = match lighting {
                    Lighting::Light { index } => 1 + *index as u64,
                    Lighting::Environment { index } => 100_000 + *index as u64,
                    Lighting::HeldOutLight { index } => 200_000 + *index as u64,
                };
                renderer
                    .render_lit(&camera, &olat.lights(lighting), view_number ^ (salt << 32))
                    .map_err(GenError::Spec)?
            }
            _ => renderer.render(&camera, frame.lens, view_number).map_err(GenError::Spec)?,
        };
        let [png, exr, depth, normal, albedo] = frame.files();
        // The PNG last: a frame counts as finished only when all its files exist.
        write_image(root.join(&exr), &view.colour)?;
        let grey = WriteOptions { single_channel: true, ..Default::default() };
        write_image_with(root.join(&depth), &view.depth, grey)?;
        write_image(root.join(&normal), &view.normal)?;
        write_image(root.join(&albedo), &view.albedo)?;
        write_image(root.join(&png), &spec.tone_curve.map_image(&view.colour, spec.exposure))?;
        if let Rig::Brackets(orbit, b) = &spec.rig {
            for (k, (stem, &time)) in frame.bracket_stems(spec).iter().zip(&b.exposure_times).enumerate() {
                let ldr = expose(&view.colour, time, b.response, b.noise, frame.noise_seed(orbit.seed, k));
                // The PNG writer sRGB-encodes linear values: hand it the decoded pixel values
                // so that the file stores exactly the camera's 8-bit codes.
                let stored = ldr.map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), p[3]]);
                write_image(root.join(format!("{stem}.png")), &stored)?;
            }
        }
        progress(done + 1, to_do.len());
    }
    let complete = finish_dataset(root, spec)?;
    let mut counts = [0usize; 3];
    for f in &frames {
        counts[f.split] += 1;
    }
    Ok(GeneratedDataset { root: root.to_path_buf(), counts, rendered: to_do.len(), skipped, complete })
}

/// Removes hidden `.*.tmp` files that a killed run left behind (finished files are only ever
/// renamed into place, so these are the unfinished ones).
fn remove_stale_temporaries(folder: &Path) {
    for entry in std::fs::read_dir(folder).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') && name.ends_with(".tmp") {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// If every frame of the dataset exists, writes the transforms files and `points3d.ply` and
/// returns true; otherwise returns false and writes nothing. This is the merge step of a
/// sharded generation.
pub fn finish_dataset(root: &Path, spec: &DatasetSpec) -> Result<bool, GenError> {
    let frames = plan(spec);
    if !frames.iter().all(|f| f.finished(root, spec)) {
        return Ok(false);
    }
    let intrinsics = Intrinsics::from_fov_x(spec.width, spec.height, spec.fov_x);
    for (split_index, split) in Split::ALL.into_iter().enumerate() {
        let mut records: Vec<FrameRecord> = Vec::new();
        for f in frames.iter().filter(|f| f.split == split_index) {
            let [_, exr, depth, normal, albedo] = f.files();
            let base = FrameRecord {
                file_path: format!("./{}", f.stem),
                camera_to_world: f.pose,
                hdr_file_path: Some(exr),
                depth_file_path: Some(depth),
                normal_file_path: Some(normal),
                albedo_file_path: Some(albedo),
                aperture_radius: f.lens.map(|l| l.aperture_radius),
                focus_distance: f.lens.map(|l| l.focus_distance),
                light_direction: match (&f.lighting, spec.rig.olat()) {
                    (Some(Lighting::Light { index }), Some(olat)) => Some(olat.directions[*index]),
                    (Some(Lighting::HeldOutLight { index }), Some(olat)) => Some(olat.held_out[*index]),
                    _ => None,
                },
                held_out_light: matches!(f.lighting, Some(Lighting::HeldOutLight { .. })).then_some(true),
                environment_file_path: match &f.lighting {
                    Some(Lighting::Environment { index }) => Some(environment_file(*index)),
                    _ => None,
                },
                ..Default::default()
            };
            match spec.rig.brackets() {
                None => records.push(base),
                Some(b) => {
                    for (stem, &time) in f.bracket_stems(spec).iter().zip(&b.exposure_times) {
                        records.push(FrameRecord {
                            file_path: format!("./{stem}"),
                            exposure_time: Some(time),
                            ..base.clone()
                        });
                    }
                }
            }
        }
        write_transforms(&root.join(split.file_name()), &intrinsics, Some(spec.aabb), &records, &[])?;
    }
    // One frame per training view (OLAT frames of a view share its geometry).
    let train: Vec<(String, glam::Mat4)> = frames
        .iter()
        .filter(|f| f.split == 0 && matches!(f.lighting, None | Some(Lighting::Light { index: 0 })))
        .map(|f| (f.stem.clone(), f.pose))
        .collect();
    crate::point_cloud::write_point_cloud(root, &intrinsics, &train, POINT_CLOUD_SIZE)?;
    Ok(true)
}

/// Frames of the dataset that are not finished in `root`.
pub fn missing_frames(root: &Path, spec: &DatasetSpec) -> usize {
    plan(spec).iter().filter(|f| !f.finished(root, spec)).count()
}

/// About how many points `points3d.ply` holds: enough to seed 3D Gaussian splatting, as a
/// sparse SfM cloud would, without making the file large.
pub const POINT_CLOUD_SIZE: usize = 20_000;

#[cfg(test)]
mod tests;
