//! Reading transforms files, tolerant of the variations real datasets show: `file_path`
//! with or without extension and with or without `./`; intrinsics as `camera_angle_x`, as
//! `fl_x`/`fl_y`/`cx`/`cy`/`w`/`h`, or per frame; sizes written as floats; 3×4 poses.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3, Vec4, Vec4Swizzles};
use serde_json::{Map, Value};

use super::{
    Dataset, DatasetError, DatasetFormat, Frame, FrameExtras, OpenOptions, SceneBounds, Split, SplitFrames, capture,
};
use crate::{Intrinsics, LensDistortion, PinholeCamera};

/// Extensions tried, in order, when a `file_path` has none (the Blender set writes
/// `./train/r_0` for `train/r_0.png`).
const IMAGE_EXTENSIONS: [&str; 7] = ["png", "exr", "jpg", "jpeg", "PNG", "JPG", "JPEG"];

pub(super) fn open(root: &Path, options: &OpenOptions) -> Result<Dataset, DatasetError> {
    if !root.is_dir() {
        let source = if root.exists() {
            std::io::Error::other("is not a directory")
        } else {
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such directory")
        };
        return Err(DatasetError::Io { path: root.to_path_buf(), source });
    }
    let colmap = || match crate::colmap::find_model(root) {
        Some(model) => capture::open(root, &model, options),
        None => Err(DatasetError::NotADataset { path: root.to_path_buf() }),
    };
    if options.format == Some(DatasetFormat::Colmap) {
        return colmap();
    }
    let mut files = Vec::new();
    for split in Split::ALL {
        let json = root.join(split.file_name());
        if json.is_file() {
            files.push(parse(&json, split)?);
        }
    }
    let mut lone = false;
    if files.is_empty() {
        let single = root.join("transforms.json");
        if !single.is_file() {
            return match options.format {
                Some(DatasetFormat::Transforms) => Err(DatasetError::NotADataset { path: root.to_path_buf() }),
                _ => colmap(),
            };
        }
        files.push(parse(&single, Split::Train)?);
        lone = true;
    }
    let extension = shared_extension(&files);
    let mut splits: Vec<SplitFrames> = files.iter().map(|f| f.read(extension)).collect::<Result<_, _>>()?;
    if lone {
        // No split files: hold out by sorted name, as for a capture.
        let single = splits.remove(0);
        let mut frames = single.frames;
        frames.sort_by(|a, b| a.file_path.cmp(&b.file_path));
        splits = capture::held_out_splits(frames, options.holdout_every, &single.source);
        splits.iter_mut().for_each(|s| s.bounds = single.bounds);
    }
    check_camera_centres(&splits)?;
    super::nerfstudio::downscale(&mut splits, options.downscale.unwrap_or(1))?;
    let file = &files[0];
    let mut points = super::nerfstudio::sparse_points(&file.json, file.value.as_object())?;
    let normalisation = (lone && super::nerfstudio::is_capture(&file.value, &splits))
        .then(|| super::nerfstudio::normalise(&mut splits, &mut points));
    Ok(Dataset { root: root.to_path_buf(), splits, normalisation, points })
}

/// Reads and checks one file; see [`Dataset::open`].
pub(super) fn read_split(json: &Path, split: Split) -> Result<SplitFrames, DatasetError> {
    let file = parse(json, split)?;
    let frames = file.read(shared_extension(std::slice::from_ref(&file)))?;
    check_camera_centres(std::slice::from_ref(&frames))?;
    Ok(frames)
}

/// How far from orthonormal a pose's rotation may be once each axis has unit length: the
/// largest entry of `RᵀR − I` (poses written with 6 or 7 decimals land near 1e-6).
const ROTATION_TOLERANCE: f32 = 1e-3;

/// The pose as a rigid, right-handed camera-to-world: a rotation whose axes are orthogonal but
/// scaled (a Blender camera with an object scale) loses the scale, with a warning; a sheared
/// or mirrored one is refused.
fn rigid(pose: Mat4) -> Result<Mat4, String> {
    let axes = [pose.x_axis.truncate(), pose.y_axis.truncate(), pose.z_axis.truncate()];
    let lengths = axes.map(|a| a.length());
    let unit = axes.map(|a| a.normalize_or_zero());
    let r = glam::Mat3::from_cols(unit[0], unit[1], unit[2]);
    let off = (r.transpose() * r - glam::Mat3::IDENTITY).to_cols_array().iter().fold(0f32, |m, v| m.max(v.abs()));
    if off > ROTATION_TOLERANCE {
        return Err(format!(
            "the rotation is not orthogonal (its axes are {off:.2e} from perpendicular, more than {ROTATION_TOLERANCE:e}): \
             a camera pose must be a rotation and a translation"
        ));
    }
    if r.determinant() < 0.0 {
        return Err(
            "the rotation is mirrored (determinant −1, a left-handed frame): a camera pose must be a rotation \
                    and a translation"
                .into(),
        );
    }
    // A rigid pose is kept as written, to the bit.
    if lengths.iter().all(|l| (l - 1.0).abs() <= ROTATION_TOLERANCE) {
        return Ok(pose);
    }
    tracing::warn!("a camera pose's axes have lengths {lengths:?}: the scale is removed (a rigid pose has none)");
    Ok(Mat4::from_cols(unit[0].extend(0.0), unit[1].extend(0.0), unit[2].extend(0.0), pose.w_axis))
}

/// Largest magnitude of a pose entry: beyond it a `f32` resolves no better than a few
/// hundredths of a unit, and no capture's coordinates reach it (re-centred ones certainly not).
pub const MAX_POSE_ENTRY: f64 = 1e7;

/// How many times farther from the median centre than the typical camera a camera may stand.
const MAX_CENTRE_SPREAD: f32 = 1000.0;

/// Refuses a camera standing absurdly far from the rest (a pose with a translation of 1e6
/// among cameras a few units apart), which would otherwise stretch the scene's bounds and
/// learning rates until training yields NaN. "Far" is measured against the median distance of
/// the cameras from their per-axis median, so a few broken poses cannot hide themselves.
pub(super) fn check_camera_centres(splits: &[SplitFrames]) -> Result<(), DatasetError> {
    let centres: Vec<Vec3> =
        splits.iter().flat_map(|s| s.frames.iter().map(|f| f.camera.camera_to_world.w_axis.xyz())).collect();
    if centres.len() < 3 {
        return Ok(());
    }
    let median = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    let centre = Vec3::new(
        median(centres.iter().map(|c| c.x).collect()),
        median(centres.iter().map(|c| c.y).collect()),
        median(centres.iter().map(|c| c.z).collect()),
    );
    // Cameras sharing one place (a fixed camera under changing lights) do not set the scale.
    let spread: Vec<f32> = centres.iter().map(|c| c.distance(centre)).filter(|d| *d > 0.0).collect();
    if spread.is_empty() {
        return Ok(());
    }
    let typical = median(spread);
    for s in splits {
        for (i, f) in s.frames.iter().enumerate() {
            let d = f.camera.camera_to_world.w_axis.xyz().distance(centre);
            if d > MAX_CENTRE_SPREAD * typical {
                return Err(DatasetError::Invalid {
                    path: s.source.clone(),
                    key: if s.source.extension().is_some_and(|e| e == "json") {
                        format!("frames[{i}].transform_matrix")
                    } else {
                        format!("image {}", f.file_path)
                    },
                    reason: format!(
                        "the camera stands at {}, {d:.3e} from the cameras' median centre, while the typical camera is {typical:.3e} from it: a broken pose?",
                        f.camera.camera_to_world.w_axis.xyz()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// A transforms file, parsed but not yet checked.
struct TransformsFile {
    json: PathBuf,
    split: Split,
    value: Value,
}

fn parse(json: &Path, split: Split) -> Result<TransformsFile, DatasetError> {
    let text =
        crate::text_file::read_text(json).map_err(|source| DatasetError::Io { path: json.to_path_buf(), source })?;
    let value: Value =
        serde_json::from_str(&text).map_err(|source| DatasetError::Json { path: json.to_path_buf(), source })?;
    Ok(TransformsFile { json: json.to_path_buf(), split, value })
}

impl TransformsFile {
    fn base(&self) -> &Path {
        self.json.parent().unwrap_or(Path::new("."))
    }

    /// The `file_path`s that name no file as written, resolved against the file's folder.
    fn extensionless_paths(&self) -> impl Iterator<Item = PathBuf> + '_ {
        let frames = self.value.get("frames").and_then(Value::as_array).map(Vec::as_slice).unwrap_or(&[]);
        frames.iter().filter_map(|f| f.get("file_path")?.as_str()).map(|p| self.base().join(p)).filter(|p| !p.is_file())
    }

    fn read(&self, extension: Option<&'static str>) -> Result<SplitFrames, DatasetError> {
        let json = self.json.as_path();
        let ctx = Context { json, extension };
        let root = self.value.as_object().ok_or_else(|| ctx.invalid("(top level)", "expected a JSON object"))?;
        let frames_value = root.get("frames").ok_or_else(|| ctx.invalid("frames", "missing"))?;
        let frames_list = frames_value.as_array().ok_or_else(|| ctx.invalid("frames", "expected an array"))?;
        let mut frames = Vec::with_capacity(frames_list.len());
        for (i, frame_value) in frames_list.iter().enumerate() {
            let key = format!("frames[{i}]");
            let frame = frame_value.as_object().ok_or_else(|| ctx.invalid(&key, "expected an object"))?;
            frames.push(ctx.read_frame(self.base(), root, frame, &key)?);
        }
        Ok(SplitFrames { split: self.split, source: json.to_path_buf(), frames, bounds: ctx.bounds(root)? })
    }
}

/// `path` with `.ext` appended (not replacing what follows a dot in the stem).
fn with_extension(path: &Path, ext: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// The one extension that the dataset's extension-less `file_path`s take: the first of
/// [`IMAGE_EXTENSIONS`] that at least half of them have, else the one most of them have.
/// Chosen once, so that a frame whose image is missing is reported as missing instead of
/// quietly reading another file of the same stem (an `.exr` beside a missing `.png`).
fn shared_extension(files: &[TransformsFile]) -> Option<&'static str> {
    let stems: Vec<PathBuf> = files.iter().flat_map(TransformsFile::extensionless_paths).collect();
    if stems.is_empty() {
        return None;
    }
    let mut best: Option<(&'static str, usize)> = None;
    for ext in IMAGE_EXTENSIONS {
        let found = stems.iter().filter(|s| with_extension(s, ext).is_file()).count();
        if 2 * found >= stems.len() {
            return Some(ext);
        }
        if found > best.map_or(0, |b| b.1) {
            best = Some((ext, found));
        }
    }
    best.map(|b| b.0)
}

struct Context<'a> {
    json: &'a Path,
    /// What extension-less `file_path`s take ([`shared_extension`]).
    extension: Option<&'static str>,
}

impl Context<'_> {
    fn invalid(&self, key: &str, reason: impl Into<String>) -> DatasetError {
        DatasetError::Invalid { path: self.json.to_path_buf(), key: key.to_string(), reason: reason.into() }
    }

    /// A finite number, if the key is present.
    fn number(&self, obj: &Map<String, Value>, name: &str, key: &str) -> Result<Option<f32>, DatasetError> {
        match obj.get(name) {
            None | Some(Value::Null) => Ok(None),
            Some(v) => {
                let x = v.as_f64().ok_or_else(|| self.invalid(key, format!("expected a number, got {v}")))?;
                if !x.is_finite() {
                    return Err(self.invalid(key, "must be finite"));
                }
                Ok(Some(x as f32))
            }
        }
    }

    fn positive(&self, obj: &Map<String, Value>, name: &str, key: &str) -> Result<Option<f32>, DatasetError> {
        match self.number(obj, name, key)? {
            Some(x) if x <= 0.0 => Err(self.invalid(key, format!("must be positive, got {x}"))),
            other => Ok(other),
        }
    }

    /// An image size; nerfstudio and COLMAP converters sometimes write `800.0`.
    fn size(&self, obj: &Map<String, Value>, name: &str, key: &str) -> Result<Option<u32>, DatasetError> {
        match self.positive(obj, name, key)? {
            Some(x) if x.fract() != 0.0 || x > 1e6 => {
                Err(self.invalid(key, format!("expected a pixel count, got {x}")))
            }
            other => Ok(other.map(|x| x as u32)),
        }
    }

    fn vec3(&self, obj: &Map<String, Value>, name: &str, key: &str) -> Result<Option<Vec3>, DatasetError> {
        let Some(v) = obj.get(name) else { return Ok(None) };
        let arr = v.as_array().filter(|a| a.len() == 3).ok_or_else(|| self.invalid(key, "expected [x, y, z]"))?;
        let mut out = [0.0f32; 3];
        for (o, x) in out.iter_mut().zip(arr) {
            *o = x.as_f64().filter(|x| x.is_finite()).ok_or_else(|| self.invalid(key, "expected finite numbers"))?
                as f32;
        }
        Ok(Some(Vec3::from(out)))
    }

    fn bounds(&self, root: &Map<String, Value>) -> Result<Option<SceneBounds>, DatasetError> {
        if let Some(v) = root.get("aabb") {
            let corners =
                v.as_array().filter(|a| a.len() == 2).ok_or_else(|| self.invalid("aabb", "expected [[min], [max]]"))?;
            let corner = |i: usize| -> Result<Vec3, DatasetError> {
                let mut tmp = Map::new();
                tmp.insert("c".into(), corners[i].clone());
                self.vec3(&tmp, "c", "aabb")?.ok_or_else(|| self.invalid("aabb", "expected [[min], [max]]"))
            };
            let (min, max) = (corner(0)?, corner(1)?);
            if !min.cmplt(max).all() {
                return Err(self.invalid("aabb", format!("min {min} must be below max {max} on every axis")));
            }
            return Ok(Some(SceneBounds::Box { min, max }));
        }
        Ok(self.positive(root, "aabb_scale", "aabb_scale")?.map(SceneBounds::AabbScale))
    }

    fn read_frame(
        &self,
        base: &Path,
        root: &Map<String, Value>,
        frame: &Map<String, Value>,
        key: &str,
    ) -> Result<Frame, DatasetError> {
        let path_key = format!("{key}.file_path");
        let file_path = frame
            .get("file_path")
            .ok_or_else(|| self.invalid(&path_key, "missing"))?
            .as_str()
            .ok_or_else(|| self.invalid(&path_key, "expected a string"))?
            .to_string();
        let image_path = self.resolve_image(base, &file_path).map_err(|reason| self.invalid(&path_key, reason))?;
        let pose = self.matrix(frame, &format!("{key}.transform_matrix"))?;
        let intrinsics = self.intrinsics(root, frame, key, &image_path)?;
        let extras = FrameExtras {
            hdr_path: self.extra_path(base, frame, "hdr_file_path", key)?,
            depth_path: self.extra_path(base, frame, "depth_file_path", key)?,
            normal_path: self.extra_path(base, frame, "normal_file_path", key)?,
            albedo_path: self.extra_path(base, frame, "albedo_file_path", key)?,
            environment_path: self.extra_path(base, frame, "environment_file_path", key)?,
            mask_path: self.extra_path(base, frame, "mask_path", key)?,
            exposure_time: self.positive(frame, "exposure_time", &format!("{key}.exposure_time"))?,
            light_direction: self.vec3(frame, "light_direction", &format!("{key}.light_direction"))?,
            held_out_light: match frame.get("held_out_light") {
                None => false,
                Some(v) => v
                    .as_bool()
                    .ok_or_else(|| self.invalid(&format!("{key}.held_out_light"), "expected true or false"))?,
            },
            aperture_radius: self.number(frame, "aperture_radius", &format!("{key}.aperture_radius"))?,
            focus_distance: self.positive(frame, "focus_distance", &format!("{key}.focus_distance"))?,
        };
        if extras.aperture_radius.is_some_and(|r| r < 0.0) {
            return Err(self.invalid(&format!("{key}.aperture_radius"), "must not be negative"));
        }
        Ok(Frame { file_path, image_path, camera: PinholeCamera::new(intrinsics, pose), extras, resize_to: None })
    }

    /// The image a `file_path` names: as written if that is a file, else with the dataset's
    /// extension appended.
    fn resolve_image(&self, base: &Path, file_path: &str) -> Result<PathBuf, String> {
        let direct = base.join(file_path);
        if direct.is_file() {
            return Ok(direct);
        }
        match self.extension {
            Some(ext) => {
                let path = with_extension(&direct, ext);
                if path.is_file() {
                    Ok(path)
                } else {
                    Err(format!("image {} not found (the other frames' images are .{ext} files)", path.display()))
                }
            }
            None => Err(format!("image {} not found, with or without an image extension", direct.display())),
        }
    }

    fn extra_path(
        &self,
        base: &Path,
        frame: &Map<String, Value>,
        name: &str,
        key: &str,
    ) -> Result<Option<PathBuf>, DatasetError> {
        let Some(v) = frame.get(name).filter(|v| !v.is_null()) else { return Ok(None) };
        let full_key = format!("{key}.{name}");
        let rel = v.as_str().ok_or_else(|| self.invalid(&full_key, "expected a string"))?;
        let path = base.join(rel);
        if !path.is_file() {
            return Err(self.invalid(&full_key, format!("file {:?} not found", path)));
        }
        Ok(Some(path))
    }

    /// A 4×4 pose (a 3×4 one gets the implicit `[0, 0, 0, 1]` row), finite, with an
    /// invertible rotation part.
    fn matrix(&self, frame: &Map<String, Value>, key: &str) -> Result<Mat4, DatasetError> {
        let v = frame.get("transform_matrix").ok_or_else(|| self.invalid(key, "missing"))?;
        let rows = v.as_array().ok_or_else(|| self.invalid(key, "expected a 4x4 array of numbers"))?;
        if rows.len() != 4 && rows.len() != 3 {
            return Err(self.invalid(key, format!("expected a 4x4 matrix, got {} rows", rows.len())));
        }
        let mut m = [[0.0f32; 4]; 4];
        m[3] = [0.0, 0.0, 0.0, 1.0];
        for (r, row) in rows.iter().enumerate() {
            let row = row.as_array().ok_or_else(|| self.invalid(key, format!("row {r} is not an array")))?;
            if row.len() != 4 {
                return Err(self.invalid(key, format!("expected a 4x4 matrix, row {r} has {} entries", row.len())));
            }
            for (c, x) in row.iter().enumerate() {
                let x = x.as_f64().ok_or_else(|| self.invalid(key, format!("entry [{r}][{c}] is not a number")))?;
                if !x.is_finite() {
                    return Err(self.invalid(key, format!("entry [{r}][{c}] is not finite")));
                }
                if x.abs() > MAX_POSE_ENTRY {
                    return Err(self.invalid(
                        key,
                        format!(
                            "entry [{r}][{c}] = {x:e} is beyond ±{MAX_POSE_ENTRY:e}; re-centre and scale the poses"
                        ),
                    ));
                }
                m[r][c] = x as f32;
            }
        }
        if (Vec4::from(m[3]) - Vec4::W).abs().max_element() > 1e-4 {
            return Err(self.invalid(key, format!("last row must be [0, 0, 0, 1], got {:?}", m[3])));
        }
        // JSON stores rows; glam is column-major.
        let pose = Mat4::from_cols_array_2d(&m).transpose();
        if pose.determinant().abs() < 1e-8 {
            return Err(self.invalid(key, "the rotation part is singular"));
        }
        rigid(pose).map_err(|reason| self.invalid(key, reason))
    }

    /// A focal length and a field of view given side by side (at one level: the file's or a
    /// frame's) must describe the same camera, within 1% (converters round the angle).
    fn focal_agrees(&self, obj: &Map<String, Value>, focal: &str, angle: &str, size: u32) -> Result<(), DatasetError> {
        let (Some(f), Some(a)) = (self.positive(obj, focal, focal)?, self.positive(obj, angle, angle)?) else {
            return Ok(());
        };
        if a >= std::f32::consts::PI {
            return Ok(());
        }
        let implied = 0.5 * size as f32 / (0.5 * a).tan();
        if (f - implied).abs() > 0.01 * implied {
            return Err(self.invalid(
                focal,
                format!("{f} contradicts {angle} = {a} rad, which gives {implied:.2} for {size} pixels"),
            ));
        }
        Ok(())
    }

    /// An error about a frame's key, named inside that frame.
    fn prefixed(&self, e: DatasetError, frame_key: &str) -> DatasetError {
        match e {
            DatasetError::Invalid { path, key, reason } => {
                DatasetError::Invalid { path, key: format!("{frame_key}.{key}"), reason }
            }
            other => other,
        }
    }

    /// Intrinsics from the frame's own keys, else the file's, else the image size.
    fn intrinsics(
        &self,
        root: &Map<String, Value>,
        frame: &Map<String, Value>,
        key: &str,
        image_path: &Path,
    ) -> Result<Intrinsics, DatasetError> {
        // Per-frame keys win; error messages name where the value came from.
        let pick_size = |name: &str| -> Result<Option<u32>, DatasetError> {
            match self.size(frame, name, &format!("{key}.{name}"))? {
                Some(v) => Ok(Some(v)),
                None => self.size(root, name, name),
            }
        };
        let pick = |name: &str| -> Result<Option<f32>, DatasetError> {
            match self.positive(frame, name, &format!("{key}.{name}"))? {
                Some(v) => Ok(Some(v)),
                None => self.positive(root, name, name),
            }
        };
        let image_size = lucid_image::image_dimensions(image_path).map_err(|source| DatasetError::Image {
            path: self.json.to_path_buf(),
            key: format!("{key}.file_path"),
            source,
        })?;
        let (iw, ih) = (image_size.0 as u32, image_size.1 as u32);
        let (w, h) = (pick_size("w")?.unwrap_or(iw), pick_size("h")?.unwrap_or(ih));
        if (w, h) != (iw, ih) {
            return Err(self.invalid(
                &format!("{key}.file_path"),
                format!("image {} is {iw}x{ih} but the transforms say {w}x{h}", image_path.display()),
            ));
        }
        self.focal_agrees(root, "fl_x", "camera_angle_x", w)?;
        self.focal_agrees(root, "fl_y", "camera_angle_y", h)?;
        self.focal_agrees(frame, "fl_x", "camera_angle_x", w).map_err(|e| self.prefixed(e, key))?;
        self.focal_agrees(frame, "fl_y", "camera_angle_y", h).map_err(|e| self.prefixed(e, key))?;
        let fx = match (pick("fl_x")?, pick("camera_angle_x")?) {
            (Some(f), _) => f,
            (None, Some(angle)) if angle < std::f32::consts::PI => 0.5 * w as f32 / (0.5 * angle).tan(),
            (None, Some(angle)) => return Err(self.invalid("camera_angle_x", format!("{angle} rad is not below π"))),
            (None, None) => return Err(self.invalid(key, "no focal length: need camera_angle_x or fl_x")),
        };
        let fy = match (pick("fl_y")?, pick("camera_angle_y")?) {
            (Some(f), _) => f,
            (None, Some(angle)) if angle < std::f32::consts::PI => 0.5 * h as f32 / (0.5 * angle).tan(),
            (None, Some(angle)) => return Err(self.invalid("camera_angle_y", format!("{angle} rad is not below π"))),
            (None, None) => fx,
        };
        let cx = pick("cx")?.unwrap_or(0.5 * w as f32);
        let cy = pick("cy")?.unwrap_or(0.5 * h as f32);
        let distortion = self.distortion(root, frame, key)?;
        Ok(Intrinsics { distortion, ..Intrinsics::pinhole(w, h, fx, fy, cx, cy) })
    }

    /// The lens from nerfstudio's `camera_model` and `k1…k4`, `p1`, `p2` (instant-ngp writes
    /// the coefficients without a model, and `is_fisheye`), per frame or for the file. A model
    /// that cannot be honoured, or coefficients a pinhole model does not have, are errors:
    /// training through the wrong lens would quietly blur everything away from the centre.
    fn distortion(
        &self,
        root: &Map<String, Value>,
        frame: &Map<String, Value>,
        key: &str,
    ) -> Result<LensDistortion, DatasetError> {
        let (model_key, model) = match (frame.get("camera_model"), root.get("camera_model")) {
            (Some(v), _) => (format!("{key}.camera_model"), Some(v)),
            (None, Some(v)) => ("camera_model".to_string(), Some(v)),
            (None, None) => ("camera_model".to_string(), None),
        };
        let model = match model {
            None | Some(Value::Null) => None,
            Some(v) => Some(v.as_str().ok_or_else(|| self.invalid(&model_key, format!("expected a string, got {v}")))?),
        };
        let coefficient = |name: &str| -> Result<f32, DatasetError> {
            match self.number(frame, name, &format!("{key}.{name}"))? {
                Some(v) => Ok(v),
                None => Ok(self.number(root, name, name)?.unwrap_or(0.0)),
            }
        };
        let [k1, k2, k3, k4, p1, p2] = ["k1", "k2", "k3", "k4", "p1", "p2"].map(coefficient);
        let (k1, k2, k3, k4, p1, p2) = (k1?, k2?, k3?, k4?, p1?, p2?);
        let fisheye_flag = match frame.get("is_fisheye").or_else(|| root.get("is_fisheye")) {
            None | Some(Value::Null) => false,
            Some(v) => v.as_bool().ok_or_else(|| self.invalid("is_fisheye", "expected true or false"))?,
        };
        let opencv = LensDistortion::OpenCv { radial: [k1, k2, k3, k4], rational: [0.0; 3], tangential: [p1, p2] };
        let fisheye = || -> Result<LensDistortion, DatasetError> {
            if p1 != 0.0 || p2 != 0.0 {
                return Err(self.invalid(&model_key, "a fisheye lens has no tangential p1, p2 in nerfstudio's model"));
            }
            Ok(LensDistortion::Fisheye { k: [k1, k2, k3, k4] })
        };
        match model {
            None if fisheye_flag => fisheye(),
            None => Ok(opencv.simplified()),
            Some("PINHOLE" | "SIMPLE_PINHOLE") => {
                if !opencv.simplified().is_pinhole() {
                    return Err(self.invalid(
                        &model_key,
                        format!("{} has no distortion, yet k1..k4, p1, p2 = {k1}, {k2}, {k3}, {k4}, {p1}, {p2}", model.unwrap_or_default()),
                    ));
                }
                Ok(LensDistortion::None)
            }
            Some("OPENCV" | "SIMPLE_RADIAL" | "RADIAL") => Ok(opencv.simplified()),
            Some("OPENCV_FISHEYE") => fisheye(),
            Some(other) => Err(self.invalid(
                &model_key,
                format!("camera model {other} is not supported (Lucid honours PINHOLE, SIMPLE_PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV and OPENCV_FISHEYE)"),
            )),
        }
    }
}
