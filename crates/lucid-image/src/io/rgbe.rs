//! Radiance RGBE (`.hdr`) through the `image` crate. The header is read in non-strict mode
//! so that files signed `#?RGBE` (common in the wild) load as well as `#?RADIANCE`.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;

use image::codecs::hdr::{HdrDecoder, HdrEncoder};
use image::{ImageDecoder, Rgb};

use crate::{Image, ImageError};

const FORMAT: &str = "Radiance RGBE";

pub(super) fn read(path: &Path) -> Result<Image, ImageError> {
    let file = File::open(path).map_err(|e| ImageError::io(path, e))?;
    let decoder = HdrDecoder::new_nonstrict(BufReader::new(file)).map_err(|e| malformed(path, e))?;
    let (w, h) = decoder.dimensions();
    let mut bytes = vec![0u8; decoder.total_bytes() as usize];
    decoder.read_image(&mut bytes).map_err(|e| malformed(path, e))?;
    let pixels = bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_ne_bytes(c[4 * i..4 * i + 4].try_into().expect("4 bytes"));
            [f(0), f(1), f(2), 1.0]
        })
        .collect();
    Ok(Image::from_pixels(w as usize, h as usize, pixels))
}

pub(super) fn write(out: &mut BufWriter<File>, path: &Path, image: &Image) -> Result<(), ImageError> {
    // RGBE cannot store negative or non-finite values: clamp them to zero rather than
    // letting the encoder produce garbage exponents.
    let rgb: Vec<Rgb<f32>> = image
        .pixels()
        .iter()
        .map(|p| Rgb([0, 1, 2].map(|c| if p[c].is_finite() { p[c].max(0.0) } else { 0.0 })))
        .collect();
    HdrEncoder::new(out).encode(&rgb, image.width(), image.height()).map_err(|e| match e {
        image::ImageError::IoError(io) => ImageError::io(path, io),
        other => ImageError::encode(path, FORMAT, other),
    })
}

fn malformed(path: &Path, e: image::ImageError) -> ImageError {
    match e {
        image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            ImageError::malformed(path, FORMAT, "file is truncated")
        }
        image::ImageError::IoError(io) => ImageError::io(path, io),
        other => ImageError::malformed(path, FORMAT, other.to_string()),
    }
}
