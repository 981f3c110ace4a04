//! COLMAP's binary model files: little-endian counts and records, names NUL-terminated.

use std::collections::BTreeMap;
use std::path::Path;

use super::{CameraModel, ColmapCamera, ColmapError, ColmapImage, ColmapPoint, invalid, quaternion, translation};

/// A cursor over a file's bytes that names the file and the record when it runs out.
struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], ColmapError> {
        if self.bytes.len() - self.at < n {
            return Err(invalid(self.path, format!("truncated: {what} is cut off at byte {}", self.at)));
        }
        let out = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(out)
    }

    fn u8(&mut self, what: &str) -> Result<u8, ColmapError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, ColmapError> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    fn i32(&mut self, what: &str) -> Result<i32, ColmapError> {
        Ok(i32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    fn u64(&mut self, what: &str) -> Result<u64, ColmapError> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }

    fn f64(&mut self, what: &str) -> Result<f64, ColmapError> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }

    fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N], ColmapError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }

    /// A record count, refused when the file could not hold that many records of at least
    /// `min_record` bytes (a damaged count would otherwise allocate without bound).
    fn count(&mut self, what: &str, min_record: usize) -> Result<usize, ColmapError> {
        let n = self.u64(what)?;
        let left = (self.bytes.len() - self.at) as u64;
        if n.saturating_mul(min_record as u64) > left {
            return Err(invalid(
                self.path,
                format!("{what} says {n}, but only {left} bytes follow (truncated or damaged)"),
            ));
        }
        Ok(n as usize)
    }

    fn name(&mut self, what: &str) -> Result<String, ColmapError> {
        let rest = &self.bytes[self.at..];
        let end = rest
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(|| invalid(self.path, format!("truncated: {what} has no terminating NUL")))?;
        let name = std::str::from_utf8(&rest[..end])
            .map_err(|_| invalid(self.path, format!("{what} is not UTF-8")))?
            .to_string();
        self.at += end + 1;
        Ok(name)
    }

    fn finish(&self) -> Result<(), ColmapError> {
        match self.bytes.len() - self.at {
            0 => Ok(()),
            n => Err(invalid(self.path, format!("{n} bytes follow the last record"))),
        }
    }
}

fn read(path: &Path) -> Result<Vec<u8>, ColmapError> {
    std::fs::read(path).map_err(|source| ColmapError::Io { path: path.to_path_buf(), source })
}

pub(super) fn cameras(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>, ColmapError> {
    let bytes = read(path)?;
    let mut r = Reader { path, bytes: &bytes, at: 0 };
    let n = r.count("the camera count", 24)?;
    let mut cameras = BTreeMap::new();
    for i in 0..n {
        let what = format!("camera record {i}");
        let id = r.u32(&what)?;
        let model_id = r.i32(&what)?;
        let model = CameraModel::by_id(model_id)
            .ok_or_else(|| invalid(path, format!("camera {id}: unknown camera model id {model_id}")))?;
        let (width, height) = (r.u64(&what)?, r.u64(&what)?);
        let params = (0..model.params).map(|_| r.f64(&what)).collect::<Result<Vec<_>, _>>()?;
        if cameras.insert(id, ColmapCamera { id, model, width, height, params }).is_some() {
            return Err(invalid(path, format!("camera {id} appears twice")));
        }
    }
    r.finish()?;
    Ok(cameras)
}

pub(super) fn images(path: &Path) -> Result<Vec<ColmapImage>, ColmapError> {
    let bytes = read(path)?;
    let mut r = Reader { path, bytes: &bytes, at: 0 };
    let n = r.count("the image count", 73)?;
    let mut images = Vec::with_capacity(n);
    for i in 0..n {
        let what = format!("image record {i}");
        let id = r.u32(&what)?;
        let q = r.f64s::<4>(&what)?;
        let t = r.f64s::<3>(&what)?;
        let camera_id = r.u32(&what)?;
        let name = r.name(&what)?;
        let rotation = quaternion(q).map_err(|e| invalid(path, format!("image {id} ({name}): {e}")))?;
        let t = translation(t).map_err(|e| invalid(path, format!("image {id} ({name}): {e}")))?;
        // x, y (f64) and the point's id (i64) per observation: skipped.
        let observations = r.count(&format!("image {id}'s observation count"), 24)?;
        r.take(observations * 24, &what)?;
        images.push(ColmapImage { id, rotation, translation: t, camera_id, name });
    }
    r.finish()?;
    Ok(images)
}

pub(super) fn points(path: &Path) -> Result<Vec<ColmapPoint>, ColmapError> {
    let bytes = read(path)?;
    let mut r = Reader { path, bytes: &bytes, at: 0 };
    let n = r.count("the point count", 51)?;
    let mut points = Vec::with_capacity(n);
    for i in 0..n {
        let what = format!("point record {i}");
        let _id = r.u64(&what)?;
        let xyz = r.f64s::<3>(&what)?;
        let colour = [r.u8(&what)?, r.u8(&what)?, r.u8(&what)?];
        let error = r.f64(&what)?;
        // image id (u32) and 2D point index (u32) per track element: skipped.
        let track_length = r.count(&format!("point {i}'s track length"), 8)?;
        r.take(track_length * 8, &what)?;
        let position = translation(xyz).map_err(|e| invalid(path, format!("point record {i}: position {e}")))?;
        points.push(ColmapPoint { position, colour, error, track_length });
    }
    r.finish()?;
    Ok(points)
}

/// Writers for the generator's captures (and tests): the records COLMAP writes.
pub mod write {
    use super::*;
    use glam::DVec2;

    /// `cameras.bin` bytes.
    pub fn cameras(cameras: &BTreeMap<u32, ColmapCamera>) -> Vec<u8> {
        let mut out = (cameras.len() as u64).to_le_bytes().to_vec();
        for c in cameras.values() {
            out.extend(c.id.to_le_bytes());
            out.extend(c.model.id.to_le_bytes());
            out.extend(c.width.to_le_bytes());
            out.extend(c.height.to_le_bytes());
            c.params.iter().for_each(|p| out.extend(p.to_le_bytes()));
        }
        out
    }

    /// `images.bin` bytes, with each image's observations `(pixel, point id)` (−1: none).
    pub fn images(images: &[ColmapImage], observations: &[Vec<(DVec2, i64)>]) -> Vec<u8> {
        let mut out = (images.len() as u64).to_le_bytes().to_vec();
        for (i, im) in images.iter().enumerate() {
            out.extend(im.id.to_le_bytes());
            let q = im.rotation;
            [q.w, q.x, q.y, q.z].iter().chain(&im.translation.to_array()).for_each(|v| out.extend(v.to_le_bytes()));
            out.extend(im.camera_id.to_le_bytes());
            out.extend(im.name.as_bytes());
            out.push(0);
            let seen = observations.get(i).map(Vec::as_slice).unwrap_or(&[]);
            out.extend((seen.len() as u64).to_le_bytes());
            for (p, id) in seen {
                out.extend(p.x.to_le_bytes());
                out.extend(p.y.to_le_bytes());
                out.extend(id.to_le_bytes());
            }
        }
        out
    }

    /// `points3D.bin` bytes; point `i` gets id `i + 1` and the track `(image id, observation
    /// index)` of `tracks[i]`.
    pub fn points(points: &[ColmapPoint], tracks: &[Vec<(u32, u32)>]) -> Vec<u8> {
        let mut out = (points.len() as u64).to_le_bytes().to_vec();
        for (i, p) in points.iter().enumerate() {
            out.extend((i as u64 + 1).to_le_bytes());
            p.position.to_array().iter().for_each(|v| out.extend(v.to_le_bytes()));
            out.extend(p.colour);
            out.extend(p.error.to_le_bytes());
            let track = tracks.get(i).map(Vec::as_slice).unwrap_or(&[]);
            out.extend((track.len() as u64).to_le_bytes());
            for (image, index) in track {
                out.extend(image.to_le_bytes());
                out.extend(index.to_le_bytes());
            }
        }
        out
    }
}
