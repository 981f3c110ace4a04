//! COLMAP's text model files: `#` comments, whitespace-separated fields, and in `images.txt`
//! two lines per image (the pose, then its 2D observations, possibly empty).

use std::collections::BTreeMap;
use std::path::Path;
use std::str::FromStr;

use super::{CameraModel, ColmapCamera, ColmapError, ColmapImage, ColmapPoint, invalid, quaternion, translation};

fn read(path: &Path) -> Result<String, ColmapError> {
    crate::text_file::read_text(path).map_err(|source| ColmapError::Io { path: path.to_path_buf(), source })
}

/// The lines that are not comments, numbered from 1 as an editor shows them.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.starts_with('#'))
}

fn field<T: FromStr>(path: &Path, line: usize, fields: &[&str], i: usize, what: &str) -> Result<T, ColmapError> {
    let text = fields.get(i).ok_or_else(|| invalid(path, format!("line {line}: {what} is missing")))?;
    text.parse().map_err(|_| invalid(path, format!("line {line}: {what} '{text}' is not a number")))
}

pub(super) fn cameras(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>, ColmapError> {
    let text = read(path)?;
    let mut cameras = BTreeMap::new();
    for (line, l) in data_lines(&text).filter(|(_, l)| !l.is_empty()) {
        let f: Vec<&str> = l.split_whitespace().collect();
        let id: u32 = field(path, line, &f, 0, "the camera id")?;
        let name = f.get(1).ok_or_else(|| invalid(path, format!("line {line}: the camera model is missing")))?;
        let model = CameraModel::by_name(name)
            .ok_or_else(|| invalid(path, format!("line {line}: unknown camera model {name}")))?;
        let width = field(path, line, &f, 2, "the width")?;
        let height = field(path, line, &f, 3, "the height")?;
        if f.len() != 4 + model.params {
            return Err(invalid(
                path,
                format!(
                    "line {line}: {name} takes {} parameters, the line has {}",
                    model.params,
                    f.len().saturating_sub(4)
                ),
            ));
        }
        let params =
            (0..model.params).map(|k| field(path, line, &f, 4 + k, "a parameter")).collect::<Result<_, _>>()?;
        if cameras.insert(id, ColmapCamera { id, model, width, height, params }).is_some() {
            return Err(invalid(path, format!("line {line}: camera {id} appears twice")));
        }
    }
    Ok(cameras)
}

pub(super) fn images(path: &Path) -> Result<Vec<ColmapImage>, ColmapError> {
    let text = read(path)?;
    let mut images = Vec::new();
    let mut lines = data_lines(&text).peekable();
    while let Some((line, l)) = lines.next() {
        if l.is_empty() {
            continue;
        }
        // The name is the rest of the line: it may hold spaces.
        let f: Vec<&str> = l.splitn(10, char::is_whitespace).filter(|s| !s.is_empty()).collect();
        let id: u32 = field(path, line, &f, 0, "the image id")?;
        let mut q = [0.0f64; 4];
        for (k, v) in q.iter_mut().enumerate() {
            *v = field(path, line, &f, 1 + k, "a quaternion component")?;
        }
        let mut t = [0.0f64; 3];
        for (k, v) in t.iter_mut().enumerate() {
            *v = field(path, line, &f, 5 + k, "a translation component")?;
        }
        let camera_id = field(path, line, &f, 8, "the camera id")?;
        let name = f.get(9).map(|s| s.trim().to_string()).filter(|s| !s.is_empty());
        let name = name.ok_or_else(|| invalid(path, format!("line {line}: the image name is missing")))?;
        let rotation = quaternion(q).map_err(|e| invalid(path, format!("line {line}: {e}")))?;
        let t = translation(t).map_err(|e| invalid(path, format!("line {line}: {e}")))?;
        images.push(ColmapImage { id, rotation, translation: t, camera_id, name });
        // The observations line (skipped): empty or all numbers. Some writers leave it out,
        // so a line with a name in it is the next image's.
        if lines.peek().is_some_and(|(_, next)| next.split_whitespace().all(|v| v.parse::<f64>().is_ok())) {
            lines.next();
        }
    }
    Ok(images)
}

pub(super) fn points(path: &Path) -> Result<Vec<ColmapPoint>, ColmapError> {
    let text = read(path)?;
    let mut points = Vec::new();
    for (line, l) in data_lines(&text).filter(|(_, l)| !l.is_empty()) {
        let f: Vec<&str> = l.split_whitespace().collect();
        let xyz: [f64; 3] =
            [field(path, line, &f, 1, "x")?, field(path, line, &f, 2, "y")?, field(path, line, &f, 3, "z")?];
        let colour =
            [field(path, line, &f, 4, "red")?, field(path, line, &f, 5, "green")?, field(path, line, &f, 6, "blue")?];
        let error = field(path, line, &f, 7, "the error")?;
        let position = translation(xyz).map_err(|e| invalid(path, format!("line {line}: position {e}")))?;
        let track = f.len().saturating_sub(8);
        if !track.is_multiple_of(2) {
            return Err(invalid(path, format!("line {line}: the track has an odd number of fields")));
        }
        points.push(ColmapPoint { position, colour, error, track_length: track / 2 });
    }
    Ok(points)
}
