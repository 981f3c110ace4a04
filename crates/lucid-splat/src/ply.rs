//! The standard 3DGS `.ply`: one `vertex` element with `x y z nx ny nz f_dc_0..2
//! f_rest_0..44 opacity scale_0..2 rot_0..3`, values stored before activation (log-scales,
//! opacity logits, unnormalised quaternions `(w, x, y, z)`), `f_rest` channel-major (all red
//! coefficients, then green, then blue) as the reference implementation writes them.
//!
//! Reading goes through `ply-rs-bw`, so ASCII and both binary encodings, any property order,
//! `double` properties, fewer `f_rest` (lower SH degrees) and extra properties all load.
//! Writing is binary little-endian `float`, written directly: the layout is fixed and it
//! keeps multi-million-splat exports fast.

use std::io::Write;
use std::path::{Path, PathBuf};

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};

use crate::cloud::SplatCloud;
use crate::project::SH_REST;

/// A `.ply` that could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct PlyError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
}

fn err(path: &Path, message: impl Into<String>) -> PlyError {
    PlyError { path: path.to_path_buf(), message: message.into() }
}

/// Values per splat in the file order below (normals excluded).
const VALUES: usize = 3 + 3 + SH_REST + 1 + 3 + 4;
const DC: usize = 3;
const REST: usize = 6;
const OPACITY: usize = REST + SH_REST;
const SCALE: usize = OPACITY + 1;
const ROT: usize = SCALE + 3;

/// The slot of a property name, if it is one of ours.
fn slot(name: &str) -> Option<usize> {
    let indexed = |prefix: &str, count: usize| {
        name.strip_prefix(prefix).and_then(|k| k.parse::<usize>().ok()).filter(|&k| k < count)
    };
    match name {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        "opacity" => Some(OPACITY),
        _ => indexed("f_dc_", 3)
            .map(|k| DC + k)
            .or_else(|| indexed("f_rest_", SH_REST).map(|k| REST + k))
            .or_else(|| indexed("scale_", 3).map(|k| SCALE + k))
            .or_else(|| indexed("rot_", 4).map(|k| ROT + k)),
    }
}

struct Row([f32; VALUES]);

impl PropertyAccess for Row {
    fn new() -> Self {
        Row([0.0; VALUES])
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(s) = slot(name) else { return PropertyAccessResult::Ignored };
        match property.to_f32_lossy() {
            Some(v) => {
                self.0[s] = v;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// Reads a 3DGS `.ply`. The SH degree follows from the number of `f_rest` properties
/// (0, 9, 24 or 45); missing higher coefficients are zero.
pub fn read_splat_ply(path: &Path) -> Result<SplatCloud, PlyError> {
    let file = std::fs::File::open(path).map_err(|e| err(path, e.to_string()))?;
    let mut reader = Reader::new(std::io::BufReader::new(file));
    let parser = Parser::<Row>::new();
    let header = parser.read_header(&mut reader).map_err(|e| err(path, format!("malformed PLY header: {e}")))?;
    let vertex = header.elements.get("vertex").ok_or_else(|| err(path, "no vertex element"))?.clone();
    let names: Vec<&str> = vertex.properties.keys().map(String::as_str).collect();
    let mut required: Vec<String> = ["x", "y", "z", "opacity"].map(String::from).to_vec();
    required.extend((0..3).map(|k| format!("f_dc_{k}")));
    required.extend((0..3).map(|k| format!("scale_{k}")));
    required.extend((0..4).map(|k| format!("rot_{k}")));
    let missing: Vec<&String> = required.iter().filter(|r| !names.contains(&r.as_str())).collect();
    if !missing.is_empty() {
        let list: Vec<&str> = missing.iter().map(|s| s.as_str()).collect();
        return Err(err(path, format!("not a 3DGS splat file: missing properties {}", list.join(", "))));
    }
    let rest = names.iter().filter(|n| n.starts_with("f_rest_")).count();
    let per_channel = match rest {
        0 | 9 | 24 | 45 => rest / 3,
        _ => return Err(err(path, format!("{rest} f_rest properties; expected 0, 9, 24 or 45"))),
    };
    if let Some(n) = (0..rest).map(|k| format!("f_rest_{k}")).find(|n| !names.contains(&n.as_str())) {
        return Err(err(path, format!("missing property {n}")));
    }
    // Elements come in header order; skip (read and drop) any before the vertices.
    let mut rows = Vec::new();
    for (name, def) in header.elements.iter() {
        let read = parser
            .read_payload_for_element(&mut reader, def, &header)
            .map_err(|e| err(path, format!("malformed PLY data in element {name}: {e}")))?;
        if name == "vertex" {
            rows = read;
            break;
        }
    }
    let mut cloud = SplatCloud::default();
    for row in rows {
        let v = &row.0;
        cloud.means.extend_from_slice(&v[0..3]);
        cloud.sh_dc.extend_from_slice(&v[DC..DC + 3]);
        // File: channel-major over `per_channel` coefficients; memory: [k][channel] over 15.
        let mut sh = [0.0f32; SH_REST];
        for c in 0..3 {
            for k in 0..per_channel {
                sh[3 * k + c] = v[REST + c * per_channel + k];
            }
        }
        cloud.sh_rest.extend_from_slice(&sh);
        cloud.opacities.push(v[OPACITY]);
        cloud.log_scales.extend_from_slice(&v[SCALE..SCALE + 3]);
        cloud.rotations.extend_from_slice(&v[ROT..ROT + 4]);
    }
    cloud.validate().map_err(|m| err(path, m))?;
    Ok(cloud)
}

/// Writes `cloud` as a binary 3DGS `.ply` (all 45 `f_rest`), atomically (a temporary file in
/// the same folder, renamed into place).
pub fn write_splat_ply(path: &Path, cloud: &SplatCloud) -> Result<(), PlyError> {
    // Through the one atomic writer of every Lucid output, so that the file gets the same
    // permissions as the others (a named temporary file is private, 0600).
    let written = lucid_image::write_atomically(path, |w| -> Result<(), lucid_image::ImageError> {
        let mut header = format!("ply\nformat binary_little_endian 1.0\nelement vertex {}\n", cloud.len());
        let mut props: Vec<String> = ["x", "y", "z", "nx", "ny", "nz"].map(String::from).to_vec();
        props.extend((0..3).map(|k| format!("f_dc_{k}")));
        props.extend((0..SH_REST).map(|k| format!("f_rest_{k}")));
        props.push("opacity".into());
        props.extend((0..3).map(|k| format!("scale_{k}")));
        props.extend((0..4).map(|k| format!("rot_{k}")));
        for p in props {
            header.push_str(&format!("property float {p}\n"));
        }
        header.push_str("end_header\n");
        let io = |e: std::io::Error| lucid_image::ImageError::io(path, e);
        w.write_all(header.as_bytes()).map_err(io)?;
        let mut row = Vec::with_capacity(4 * (VALUES + 3));
        for i in 0..cloud.len() {
            row.clear();
            let mut put = |v: f32| row.extend_from_slice(&v.to_le_bytes());
            cloud.means[3 * i..3 * i + 3].iter().for_each(|&v| put(v));
            [0.0; 3].iter().for_each(|&v| put(v));
            cloud.sh_dc[3 * i..3 * i + 3].iter().for_each(|&v| put(v));
            let sh = &cloud.sh_rest[SH_REST * i..SH_REST * (i + 1)];
            for c in 0..3 {
                for k in 0..SH_REST / 3 {
                    put(sh[3 * k + c]);
                }
            }
            put(cloud.opacities[i]);
            cloud.log_scales[3 * i..3 * i + 3].iter().for_each(|&v| put(v));
            cloud.rotations[4 * i..4 * i + 4].iter().for_each(|&v| put(v));
            w.write_all(&row).map_err(io)?;
        }
        Ok(())
    });
    written.map_err(|e| err(path, format!("cannot write: {e}")))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn sample() -> SplatCloud {
        let mut c = SplatCloud::default();
        for i in 0..5 {
            c.push(Vec3::new(i as f32, -0.5 * i as f32, 0.25), 0.01 * (i + 1) as f32, 0.3, [0.1, 0.5, 0.9]);
        }
        for (k, v) in c.sh_rest.iter_mut().enumerate() {
            *v = k as f32 * 1e-3 - 0.1;
        }
        c.rotations[5] = 0.3;
        c
    }

    #[test]
    fn binary_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.ply");
        let c = sample();
        write_splat_ply(&path, &c).unwrap();
        assert_eq!(read_splat_ply(&path).unwrap(), c);
    }

    /// Another tool's ASCII file with degree-1 SH, shuffled properties and an extra one.
    #[test]
    fn reads_ascii_lower_degree_any_order() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.ply");
        let mut text = String::from("ply\nformat ascii 1.0\ncomment other tool\nelement vertex 1\n");
        let mut names = vec!["rot_0", "rot_1", "rot_2", "rot_3", "opacity", "x", "y", "z", "extra"];
        let rest: Vec<String> = (0..9).map(|k| format!("f_rest_{k}")).collect();
        names.extend(rest.iter().map(String::as_str));
        names.extend(["f_dc_0", "f_dc_1", "f_dc_2", "scale_0", "scale_1", "scale_2"]);
        for n in &names {
            text.push_str(&format!("property double {n}\n"));
        }
        text.push_str("end_header\n");
        let values: Vec<String> = (0..names.len()).map(|k| format!("{}", k as f32 * 0.5)).collect();
        text.push_str(&values.join(" "));
        text.push('\n');
        std::fs::write(&path, text).unwrap();
        let c = read_splat_ply(&path).unwrap();
        let at = |n: &str| names.iter().position(|m| *m == n).unwrap() as f32 * 0.5;
        assert_eq!(c.rotations, vec![at("rot_0"), at("rot_1"), at("rot_2"), at("rot_3")]);
        assert_eq!(c.means, vec![at("x"), at("y"), at("z")]);
        // Green coefficient 2 (file f_rest_{3 + 1}) lands at [k = 1][channel 1].
        assert_eq!(c.sh_rest[3 + 1], at("f_rest_4"));
        assert_eq!(c.sh_rest[3 * 3..].iter().filter(|v| **v != 0.0).count(), 0);
    }

    #[test]
    fn clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("points.ply");
        std::fs::write(&path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n").unwrap();
        let e = read_splat_ply(&path).unwrap_err().to_string();
        assert!(e.contains("points.ply") && e.contains("missing properties") && e.contains("opacity"), "{e}");
        std::fs::write(&path, "not a ply").unwrap();
        assert!(read_splat_ply(&path).unwrap_err().to_string().contains("malformed"));
        let missing = dir.path().join("nope.ply");
        assert!(read_splat_ply(&missing).unwrap_err().to_string().contains("nope.ply"));
    }
}
