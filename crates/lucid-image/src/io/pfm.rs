//! Portable FloatMap, written by hand: no maintained crate reads both the colour (`PF`) and
//! grey (`Pf`) variants in both byte orders, and the format is a three-line header plus
//! raw `f32`s.
//!
//! Header: `PF` or `Pf`, then width and height, then a scale whose sign gives the byte
//! order (negative = little-endian); the magnitude is a scale factor that readers ignore.
//! Exactly one whitespace byte separates the header from the data. Rows are stored from
//! the bottom of the image to the top.

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

use crate::{Image, ImageError};

const FORMAT: &str = "PFM";

/// Byte order of PFM samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PfmEndianness {
    /// Little-endian (scale written as `-1.0`).
    Little,
    /// Big-endian (scale written as `1.0`).
    Big,
}

struct Header {
    channels: usize,
    width: usize,
    height: usize,
    endianness: PfmEndianness,
    data_offset: usize,
}

fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header, ImageError> {
    let bad = |reason: &str| ImageError::malformed(path, FORMAT, reason);
    let mut pos = 0;
    let mut tokens: Vec<String> = Vec::with_capacity(4);
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        // Comments are not in the format, but some writers add `#` lines; skip them.
        if pos < bytes.len() && bytes[pos] == b'#' {
            while pos < bytes.len() && bytes[pos] != b'\n' {
                pos += 1;
            }
            continue;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(bad("header ends early"));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
        if tokens.len() == 1 && tokens[0] != "PF" && tokens[0] != "Pf" {
            return Err(bad("does not start with PF or Pf"));
        }
    }
    if pos >= bytes.len() {
        return Err(bad("no pixel data after the header"));
    }
    let channels = if tokens[0] == "PF" { 3 } else { 1 };
    let dim = |s: &str, what: &str| {
        s.parse::<usize>().ok().filter(|&v| v > 0).ok_or_else(|| bad(&format!("invalid {what} {s:?}")))
    };
    let width = dim(&tokens[1], "width")?;
    let height = dim(&tokens[2], "height")?;
    let scale: f32 = tokens[3].parse().map_err(|_| bad(&format!("invalid scale {:?}", tokens[3])))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(bad(&format!("scale must be a non-zero number, got {scale}")));
    }
    let endianness = if scale < 0.0 { PfmEndianness::Little } else { PfmEndianness::Big };
    Ok(Header { channels, width, height, endianness, data_offset: pos + 1 })
}

/// Reads a PFM file (colour or grey, either byte order). Grey images are replicated to RGB.
pub fn read_pfm(path: &Path) -> Result<Image, ImageError> {
    let mut bytes = Vec::new();
    File::open(path).and_then(|mut f| f.read_to_end(&mut bytes)).map_err(|e| ImageError::io(path, e))?;
    let h = parse_header(path, &bytes)?;
    let count = h.width.checked_mul(h.height).and_then(|n| n.checked_mul(h.channels));
    let needed =
        count.and_then(|n| n.checked_mul(4)).ok_or_else(|| ImageError::malformed(path, FORMAT, "image too large"))?;
    let data = &bytes[h.data_offset..];
    if data.len() < needed {
        return Err(ImageError::malformed(
            path,
            FORMAT,
            format!(
                "truncated: {}x{}x{} floats need {needed} bytes, found {}",
                h.width,
                h.height,
                h.channels,
                data.len()
            ),
        ));
    }
    let value = |i: usize| {
        let b: [u8; 4] = data[4 * i..4 * i + 4].try_into().expect("4 bytes");
        match h.endianness {
            PfmEndianness::Little => f32::from_le_bytes(b),
            PfmEndianness::Big => f32::from_be_bytes(b),
        }
    };
    let image = Image::from_fn(h.width, h.height, |x, y| {
        let file_row = h.height - 1 - y;
        let base = (file_row * h.width + x) * h.channels;
        if h.channels == 3 {
            [value(base), value(base + 1), value(base + 2), 1.0]
        } else {
            let v = value(base);
            [v, v, v, 1.0]
        }
    });
    Ok(image)
}

pub(super) fn dimensions(path: &Path) -> Result<(usize, usize), ImageError> {
    let mut head = vec![0u8; 256];
    let n = File::open(path).and_then(|mut f| f.read(&mut head)).map_err(|e| ImageError::io(path, e))?;
    head.truncate(n);
    let h = parse_header(path, &head)?;
    Ok((h.width, h.height))
}

/// Writes a PFM file atomically; `grey` writes the red channel as a `Pf` image. Alpha is
/// dropped, since the format has none.
pub fn write_pfm(path: &Path, image: &Image, grey: bool, endianness: PfmEndianness) -> Result<(), ImageError> {
    super::write_atomically(path, |out| write_pfm_to(out, image, grey, endianness).map_err(|e| ImageError::io(path, e)))
}

pub(super) fn write_pfm_to(
    out: &mut BufWriter<File>,
    image: &Image,
    grey: bool,
    endianness: PfmEndianness,
) -> std::io::Result<()> {
    let (tag, scale) = match (grey, endianness) {
        (false, PfmEndianness::Little) => ("PF", "-1.0"),
        (false, PfmEndianness::Big) => ("PF", "1.0"),
        (true, PfmEndianness::Little) => ("Pf", "-1.0"),
        (true, PfmEndianness::Big) => ("Pf", "1.0"),
    };
    write!(out, "{tag}\n{} {}\n{scale}\n", image.width(), image.height())?;
    let channels = if grey { 1 } else { 3 };
    let mut row = Vec::with_capacity(image.width() * channels * 4);
    for y in (0..image.height()).rev() {
        row.clear();
        for p in image.row(y) {
            for &v in &p[..channels] {
                row.extend_from_slice(&match endianness {
                    PfmEndianness::Little => v.to_le_bytes(),
                    PfmEndianness::Big => v.to_be_bytes(),
                });
            }
        }
        out.write_all(&row)?;
    }
    Ok(())
}
