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

use crate::rig::OrbitRig;

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

/// Something that renders a view of a scene.
pub trait ViewRenderer: Sync {
    /// Renders the view that `camera` sees; `view` numbers the views of a dataset so that
    /// stochastic renderers can give each its own random streams.
    fn render(&self, camera: &PinholeCamera, view: u64) -> RenderedView;
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
    /// Where the cameras stand.
    pub rig: OrbitRig,
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
}

/// Where a generated dataset went.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedDataset {
    /// The folder.
    pub root: PathBuf,
    /// Views written per split (train, val, test).
    pub counts: [usize; 3],
}

/// Renders every view and writes the dataset into `root` (created if needed). `progress`
/// is called after each view with `(done, total)`.
pub fn generate_dataset(
    root: &Path,
    spec: &DatasetSpec,
    renderer: &dyn ViewRenderer,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<GeneratedDataset, GenError> {
    if spec.width == 0 || spec.height == 0 {
        return Err(GenError::Spec(format!("image size {}x{} is empty", spec.width, spec.height)));
    }
    if !(spec.fov_x > 0.0 && spec.fov_x < std::f32::consts::PI) {
        return Err(GenError::Spec(format!("field of view {} rad must be in (0, π)", spec.fov_x)));
    }
    let intrinsics = Intrinsics::from_fov_x(spec.width, spec.height, spec.fov_x);
    let total: usize = spec.counts.iter().sum();
    let mut done = 0;
    for (index, split) in Split::ALL.into_iter().enumerate() {
        let folder = root.join(split.name());
        std::fs::create_dir_all(&folder).map_err(|source| GenError::Io { path: folder.clone(), source })?;
        let mut records = Vec::with_capacity(spec.counts[index]);
        for (i, pose) in spec.rig.poses(spec.counts[index], index as u64).into_iter().enumerate() {
            let camera = PinholeCamera::new(intrinsics, pose);
            let view = renderer.render(&camera, (index * 1_000_000 + i) as u64);
            let stem = format!("{}/r_{i}", split.name());
            let ldr = spec.tone_curve.map_image(&view.colour, spec.exposure);
            write_image(root.join(format!("{stem}.png")), &ldr)?;
            write_image(root.join(format!("{stem}.exr")), &view.colour)?;
            let grey = WriteOptions { single_channel: true, ..Default::default() };
            write_image_with(root.join(format!("{stem}_depth.exr")), &view.depth, grey)?;
            write_image(root.join(format!("{stem}_normal.exr")), &view.normal)?;
            write_image(root.join(format!("{stem}_albedo.exr")), &view.albedo)?;
            records.push(FrameRecord {
                file_path: format!("./{stem}"),
                camera_to_world: pose,
                hdr_file_path: Some(format!("{stem}.exr")),
                depth_file_path: Some(format!("{stem}_depth.exr")),
                normal_file_path: Some(format!("{stem}_normal.exr")),
                albedo_file_path: Some(format!("{stem}_albedo.exr")),
                ..Default::default()
            });
            done += 1;
            progress(done, total);
        }
        write_transforms(&root.join(split.file_name()), &intrinsics, Some(spec.aabb), &records)?;
    }
    Ok(GeneratedDataset { root: root.to_path_buf(), counts: spec.counts })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::AnalyticScene;
    use lucid_scene::Dataset;

    #[test]
    fn generated_dataset_reads_back_with_matching_images() {
        let dir = tempfile::tempdir().unwrap();
        let spec = DatasetSpec {
            width: 24,
            height: 16,
            fov_x: 0.8,
            counts: [3, 1, 2],
            rig: OrbitRig { radius: 4.0, target: Vec3::ZERO, upper_hemisphere: true, seed: 5 },
            aabb: (Vec3::splat(-1.0), Vec3::splat(1.0)),
            exposure: 0.0,
            tone_curve: ToneCurve::Clip,
        };
        let scene = AnalyticScene::default();
        let out = generate_dataset(dir.path(), &spec, &scene, &|_, _| {}).unwrap();
        assert_eq!(out.counts, [3, 1, 2]);
        let ds = Dataset::open(dir.path()).unwrap();
        assert_eq!(
            [ds.frames(Split::Train).len(), ds.frames(Split::Val).len(), ds.frames(Split::Test).len()],
            [3, 1, 2]
        );
        let frame = &ds.frames(Split::Test)[1];
        // The HDR image on disk is what the renderer makes for the pose in the JSON.
        let hdr = lucid_image::read_image(frame.extras.hdr_path.as_ref().unwrap()).unwrap();
        let again = scene.render(&frame.camera, 0).colour;
        let diff = hdr.pixels().iter().zip(again.pixels()).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0, f32::max);
        assert!(diff < 1e-5, "max difference {diff}");
        // The scene is in view: some pixels are covered, some are background.
        let covered = hdr.pixels().iter().filter(|p| p[3] > 0.0).count();
        assert!(covered > 10 && covered < 24 * 16, "{covered}");
    }
}
