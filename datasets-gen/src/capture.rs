//! Captures: what a person with a camera and COLMAP would bring home, rendered. Photographs
//! from a hand-held ring around the middle of a scene (`images/`), and the sparse model
//! structure-from-motion would make of them (`sparse/0/`, COLMAP binary, and the same as
//! nerfstudio's `transforms.json` with `sparse_pc.ply`): the camera with its
//! lens, the poses (true, or perturbed as SfM leaves them) and points on surfaces that
//! several photographs see. The renders' depth is kept in `depth/` as ground truth.

use std::collections::BTreeMap;
use std::path::Path;

use glam::{DMat4, DQuat, DVec2, DVec3, Mat4, Vec3};
use lucid_image::tonemap::ToneCurve;
use lucid_image::{Image, WriteOptions, read_image, write_image, write_image_with};
use lucid_scene::colmap::{ColmapCamera, ColmapImage, ColmapPoint, binary};
use lucid_scene::dataset::{FrameRecord, write_transforms};
use lucid_scene::sampling::Rng;
use lucid_scene::{Intrinsics, LensDistortion, PinholeCamera, look_at};
use rayon::prelude::*;
use serde_json::json;

use crate::point_cloud::{ColouredPoint, write_ply};
use crate::writer::{GenError, ViewRenderer};

/// Cameras held by hand while walking around the middle of a scene: a ring at varying
/// heights, each looking roughly at the target, slightly rolled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HandheldRing {
    /// Mean distance from the target, on the ground plane.
    pub radius: f32,
    /// Lowest and highest camera height.
    pub heights: (f32, f32),
    /// What the cameras look at.
    pub target: Vec3,
    /// Seed of the jitter.
    pub seed: u64,
}

impl HandheldRing {
    /// `count` camera-to-world poses (OpenGL convention), in walking order.
    pub fn poses(&self, count: usize) -> Vec<Mat4> {
        let mut rng = Rng::new(self.seed, 0xCA97);
        (0..count)
            .map(|i| {
                let angle = std::f32::consts::TAU * (i as f32 + 0.4 * (rng.uniform() - 0.5)) / count as f32;
                let r = self.radius * (1.0 + 0.08 * (rng.uniform() - 0.5));
                let height = self.heights.0 + (self.heights.1 - self.heights.0) * rng.uniform();
                let eye = Vec3::new(r * angle.cos(), r * angle.sin(), height);
                let aim = self.target
                    + 0.25
                        * self.radius
                        * Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.3 * (rng.uniform() - 0.5));
                let pose = look_at(eye, aim, Vec3::Z);
                let roll = (4.0 * (rng.uniform() - 0.5)).to_radians();
                pose * Mat4::from_rotation_z(roll)
            })
            .collect()
    }
}

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureSpec {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal field of view in radians (of the pinhole before the lens).
    pub fov_x: f32,
    /// The lens the photographs are taken through.
    pub lens: LensDistortion,
    /// Number of photographs.
    pub images: usize,
    /// Where they are taken.
    pub ring: HandheldRing,
    /// Standard deviation of the error SfM leaves in each camera's orientation, degrees.
    pub rotation_noise_degrees: f32,
    /// Standard deviation of the error in each camera's position, as a fraction of the ring's
    /// radius.
    pub position_noise: f32,
    /// Standard deviation of the error in each sparse point's position, world units.
    pub point_noise: f32,
    /// Sparse points to aim for.
    pub points: usize,
    /// Exposure in stops before the tone curve.
    pub exposure: f32,
    /// The camera's tone curve.
    pub tone_curve: ToneCurve,
}

impl CaptureSpec {
    fn intrinsics(&self) -> Intrinsics {
        Intrinsics { distortion: self.lens, ..Intrinsics::from_fov_x(self.width, self.height, self.fov_x) }
    }
}

/// What a capture run did.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedCapture {
    /// Photographs rendered by this run.
    pub rendered: usize,
    /// Photographs found finished.
    pub skipped: usize,
    /// Sparse points written.
    pub points: usize,
}

fn name(i: usize) -> String {
    format!("img_{i:04}")
}

/// Renders the photographs not yet in `root` (each file atomic, so a killed run resumes), then
/// writes the sparse model. `progress` gets the photographs done and to do.
pub fn generate_capture(
    root: &Path,
    spec: &CaptureSpec,
    renderer: &dyn ViewRenderer,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<GeneratedCapture, GenError> {
    if spec.images < 2 {
        return Err(GenError::Spec("a capture needs at least two photographs".into()));
    }
    let k = spec.intrinsics();
    ColmapCamera::from_intrinsics(1, &k).map_err(GenError::Spec)?;
    let poses = spec.ring.poses(spec.images);
    for folder in ["images", "depth", "sparse/0"] {
        let path = root.join(folder);
        std::fs::create_dir_all(&path).map_err(|source| GenError::Io { path, source })?;
    }
    let finished = |i: usize| {
        root.join(format!("images/{}.png", name(i))).is_file() && root.join(format!("depth/{}.exr", name(i))).is_file()
    };
    let to_do: Vec<usize> = (0..spec.images).filter(|&i| !finished(i)).collect();
    for (done, &i) in to_do.iter().enumerate() {
        let view = renderer.render(&PinholeCamera::new(k, poses[i]), None, i as u64).map_err(GenError::Spec)?;
        let grey = WriteOptions { single_channel: true, ..Default::default() };
        write_image_with(root.join(format!("depth/{}.exr", name(i))), &view.depth, grey)?;
        // A photograph has no alpha: the sky is part of it.
        let photo = spec.tone_curve.map_image(&view.colour, spec.exposure).map(|p| [p[0], p[1], p[2], 1.0]);
        write_image(root.join(format!("images/{}.png", name(i))), &photo)?;
        progress(done + 1, to_do.len());
    }
    let points = write_sparse_model(root, spec, &k, &poses)?;
    Ok(GeneratedCapture { rendered: to_do.len(), skipped: spec.images - to_do.len(), points })
}

/// A surface point, its colour, and the photographs (index, pixel) that see it.
type TrackedPoint = (Vec3, [u8; 3], Vec<(usize, DVec2)>);

/// Points on surfaces that at least this many photographs see: what SfM can triangulate.
const MIN_TRACK: usize = 3;

/// Writes `sparse/0/{cameras,images,points3D}.bin` from the renders' depth.
fn write_sparse_model(root: &Path, spec: &CaptureSpec, k: &Intrinsics, poses: &[Mat4]) -> Result<usize, GenError> {
    let depths: Vec<Image> = (0..spec.images)
        .into_par_iter()
        .map(|i| read_image(root.join(format!("depth/{}.exr", name(i)))))
        .collect::<Result<_, _>>()?;
    let photos: Vec<Image> = (0..spec.images)
        .into_par_iter()
        .map(|i| read_image(root.join(format!("images/{}.png", name(i)))))
        .collect::<Result<_, _>>()?;
    let cameras: Vec<PinholeCamera> = poses.iter().map(|p| PinholeCamera::new(*k, *p)).collect();
    let world_to_camera: Vec<Mat4> = poses.iter().map(|p| p.inverse()).collect();
    let (w, h) = (k.width as usize, k.height as usize);
    let stride = (w * h * spec.images / spec.points.max(1) / 4).max(1);

    // Candidates back-projected from every photograph's depth, kept where enough other
    // photographs see the same surface (their depth agrees at the point's projection).
    let found: Vec<Vec<TrackedPoint>> = (0..spec.images)
        .into_par_iter()
        .map(|i| {
            let mut out = Vec::new();
            for pixel in (i % stride..w * h).step_by(stride) {
                let (x, y) = (pixel % w, pixel / w);
                let d = depths[i].get(x, y)[0];
                if d <= 0.0 {
                    continue;
                }
                let p = poses[i].transform_point3(k.camera_direction(x as f32 + 0.5, y as f32 + 0.5) * d);
                let mut track = Vec::new();
                for (j, camera) in cameras.iter().enumerate() {
                    let Some(uv) = camera.project(p) else { continue };
                    if uv.x < 0.0 || uv.y < 0.0 || uv.x >= w as f32 || uv.y >= h as f32 {
                        continue;
                    }
                    let z = -world_to_camera[j].transform_point3(p).z;
                    let seen = depths[j].get(uv.x as usize, uv.y as usize)[0];
                    if (seen - z).abs() < 0.01 * z {
                        track.push((j, uv.as_dvec2()));
                    }
                }
                if track.len() >= MIN_TRACK {
                    let c = photos[i].get(x, y);
                    let encode = |v: f32| (lucid_image::color::srgb_encode(v) * 255.0).round() as u8;
                    out.push((p, [encode(c[0]), encode(c[1]), encode(c[2])], track));
                }
            }
            out
        })
        .collect();
    let mut candidates: Vec<_> = found.into_iter().flatten().collect();
    // Thin evenly to the target (in a fixed order: deterministic).
    let keep_every = candidates.len().div_ceil(spec.points.max(1)).max(1);
    candidates = candidates.into_iter().step_by(keep_every).collect();

    let mut noise = Rng::new(spec.ring.seed, 0x5F3);
    let mut points = Vec::with_capacity(candidates.len());
    let mut tracks = Vec::with_capacity(candidates.len());
    let mut observations: Vec<Vec<(DVec2, i64)>> = vec![Vec::new(); spec.images];
    for (id, (p, colour, track)) in candidates.iter().enumerate() {
        let jitter = Vec3::new(noise.normal(), noise.normal(), noise.normal()) * spec.point_noise;
        points.push(ColmapPoint {
            position: (*p + jitter).as_dvec3(),
            colour: *colour,
            error: 0.5,
            track_length: track.len(),
        });
        let mut elements = Vec::with_capacity(track.len());
        for &(j, uv) in track {
            elements.push((j as u32 + 1, observations[j].len() as u32));
            observations[j].push((uv, id as i64 + 1));
        }
        tracks.push(elements);
    }
    let solved: Vec<DMat4> = poses.iter().map(|pose| perturbed(pose.as_dmat4(), spec, &mut noise)).collect();
    let images: Vec<ColmapImage> = solved
        .iter()
        .enumerate()
        .map(|(i, pose)| ColmapImage::from_pose(i as u32 + 1, 1, format!("{}.png", name(i)), *pose))
        .collect();
    let camera = ColmapCamera::from_intrinsics(1, k).map_err(GenError::Spec)?;
    let sparse = root.join("sparse/0");
    write_bytes(&sparse.join("cameras.bin"), &binary::write::cameras(&BTreeMap::from([(1, camera)])))?;
    write_bytes(&sparse.join("images.bin"), &binary::write::images(&images, &observations))?;
    write_bytes(&sparse.join("points3D.bin"), &binary::write::points(&points, &tracks))?;
    write_nerfstudio(root, k, &solved, &points)?;
    Ok(points.len())
}

/// The same reconstruction as nerfstudio's `ns-process-data` leaves it: `transforms.json`
/// (OpenGL camera-to-world poses, the lens as `camera_model` and coefficients) and the sparse
/// points as `sparse_pc.ply`.
fn write_nerfstudio(root: &Path, k: &Intrinsics, poses: &[DMat4], points: &[ColmapPoint]) -> Result<(), GenError> {
    let cloud: Vec<ColouredPoint> = points
        .iter()
        .map(|p| ColouredPoint { position: p.position.as_vec3(), normal: Vec3::ZERO, colour: p.colour })
        .collect();
    write_ply(&root.join("sparse_pc.ply"), &cloud)?;
    let frames: Vec<FrameRecord> = poses
        .iter()
        .enumerate()
        .map(|(i, pose)| FrameRecord {
            file_path: format!("images/{}.png", name(i)),
            camera_to_world: pose.as_mat4(),
            ..Default::default()
        })
        .collect();
    let extra = [("camera_model", json!("OPENCV")), ("ply_file_path", json!("sparse_pc.ply"))];
    write_transforms(&root.join("transforms.json"), k, None, &frames, &extra)?;
    Ok(())
}

/// A pose as SfM would leave it: turned about a random axis and moved by normal errors.
fn perturbed(pose: DMat4, spec: &CaptureSpec, noise: &mut Rng) -> DMat4 {
    let axis = DVec3::new(noise.normal().into(), noise.normal().into(), noise.normal().into()).normalize_or(DVec3::Z);
    let angle = f64::from(spec.rotation_noise_degrees.to_radians() * noise.normal());
    let shift = DVec3::new(noise.normal().into(), noise.normal().into(), noise.normal().into())
        * f64::from(spec.position_noise * spec.ring.radius);
    let turn = DMat4::from_quat(DQuat::from_axis_angle(axis, angle));
    let moved = DMat4::from_translation(pose.w_axis.truncate() + shift);
    moved * turn * DMat4::from_mat3(glam::DMat3::from_mat4(pose))
}

fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), GenError> {
    use std::io::Write;
    lucid_image::write_atomically(path, |out| {
        out.write_all(bytes).map_err(|source| lucid_image::ImageError::Io { path: path.to_path_buf(), source })
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4Swizzles;

    #[test]
    fn the_ring_circles_the_target_at_its_heights() {
        let ring = HandheldRing { radius: 4.5, heights: (0.8, 2.0), target: Vec3::new(0.0, 0.0, 0.5), seed: 3 };
        let poses = ring.poses(40);
        for pose in &poses {
            let eye = pose.w_axis.xyz();
            let r = eye.truncate().length();
            assert!((4.2..4.8).contains(&r) && (0.8..=2.0).contains(&eye.z), "{eye}");
            // Roughly at the target: within 20 degrees.
            let forward = -pose.z_axis.xyz();
            assert!(forward.dot((ring.target - eye).normalize()) > 20f32.to_radians().cos());
        }
        assert_eq!(poses, ring.poses(40), "deterministic");
    }
}
