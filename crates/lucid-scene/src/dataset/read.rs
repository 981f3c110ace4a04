//! Reading transforms files, tolerant of the variations real datasets show: `file_path`
//! with or without extension and with or without `./`; intrinsics as `camera_angle_x`, as
//! `fl_x`/`fl_y`/`cx`/`cy`/`w`/`h`, or per frame; sizes written as floats; 3×4 poses.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3, Vec4};
use serde_json::{Map, Value};

use super::{Dataset, DatasetError, Frame, FrameExtras, SceneBounds, Split, SplitFrames};
use crate::{Intrinsics, PinholeCamera};

/// Extensions tried, in order, when a `file_path` has none (the Blender set writes
/// `./train/r_0` for `train/r_0.png`).
const IMAGE_EXTENSIONS: [&str; 7] = ["png", "exr", "jpg", "jpeg", "PNG", "JPG", "JPEG"];

pub(super) fn open(root: &Path) -> Result<Dataset, DatasetError> {
    if !root.is_dir() {
        let source = if root.exists() {
            std::io::Error::other("is not a directory")
        } else {
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such directory")
        };
        return Err(DatasetError::Io { path: root.to_path_buf(), source });
    }
    let mut splits = Vec::new();
    for split in Split::ALL {
        let json = root.join(split.file_name());
        if json.is_file() {
            splits.push(read_split(&json, split)?);
        }
    }
    if splits.is_empty() {
        let single = root.join("transforms.json");
        if !single.is_file() {
            return Err(DatasetError::NotADataset { path: root.to_path_buf() });
        }
        splits.push(read_split(&single, Split::Train)?);
    }
    Ok(Dataset { root: root.to_path_buf(), splits })
}

/// Reads and checks one file; see [`Dataset::open`].
pub(super) fn read_split(json: &Path, split: Split) -> Result<SplitFrames, DatasetError> {
    let text = std::fs::read_to_string(json).map_err(|source| DatasetError::Io { path: json.to_path_buf(), source })?;
    let value: Value =
        serde_json::from_str(&text).map_err(|source| DatasetError::Json { path: json.to_path_buf(), source })?;
    let ctx = Context { json };
    let root = value.as_object().ok_or_else(|| ctx.invalid("(top level)", "expected a JSON object"))?;
    let frames_value = root.get("frames").ok_or_else(|| ctx.invalid("frames", "missing"))?;
    let frames_list = frames_value.as_array().ok_or_else(|| ctx.invalid("frames", "expected an array"))?;
    let base = json.parent().unwrap_or(Path::new("."));

    let mut frames = Vec::with_capacity(frames_list.len());
    for (i, frame_value) in frames_list.iter().enumerate() {
        let key = format!("frames[{i}]");
        let frame = frame_value.as_object().ok_or_else(|| ctx.invalid(&key, "expected an object"))?;
        frames.push(ctx.read_frame(base, root, frame, &key)?);
    }
    Ok(SplitFrames { split, source: json.to_path_buf(), frames, bounds: ctx.bounds(root)? })
}

struct Context<'a> {
    json: &'a Path,
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
        let image_path = resolve_image(base, &file_path)
            .ok_or_else(|| self.invalid(&path_key, format!("image {:?} not found", base.join(&file_path))))?;
        let pose = self.matrix(frame, &format!("{key}.transform_matrix"))?;
        let intrinsics = self.intrinsics(root, frame, key, &image_path)?;
        let extras = FrameExtras {
            hdr_path: self.extra_path(base, frame, "hdr_file_path", key)?,
            depth_path: self.extra_path(base, frame, "depth_file_path", key)?,
            normal_path: self.extra_path(base, frame, "normal_file_path", key)?,
            albedo_path: self.extra_path(base, frame, "albedo_file_path", key)?,
            environment_path: self.extra_path(base, frame, "environment_file_path", key)?,
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
        Ok(Frame { file_path, image_path, camera: PinholeCamera::new(intrinsics, pose), extras })
    }

    fn extra_path(
        &self,
        base: &Path,
        frame: &Map<String, Value>,
        name: &str,
        key: &str,
    ) -> Result<Option<PathBuf>, DatasetError> {
        let Some(v) = frame.get(name) else { return Ok(None) };
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
        Ok(pose)
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
        Ok(Intrinsics { width: w, height: h, fx, fy, cx, cy })
    }
}

/// The image a `file_path` names: as written if it has an extension and exists, else with
/// each of [`IMAGE_EXTENSIONS`] appended.
fn resolve_image(base: &Path, file_path: &str) -> Option<PathBuf> {
    let direct = base.join(file_path);
    if direct.is_file() {
        return Some(direct);
    }
    IMAGE_EXTENSIONS.iter().map(|ext| base.join(format!("{file_path}.{ext}"))).find(|p| p.is_file())
}
