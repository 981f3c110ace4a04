//! Reading and writing image files, with the format chosen by extension.
//!
//! Every writer goes through [`write_atomically`]: the bytes go to a hidden temporary file
//! beside the target, which is renamed over the target only once complete, so a failed
//! or interrupted write never leaves a half-written image behind.

mod animation;
mod exr_file;
pub mod exr_layers;
mod ldr;
mod pfm;
mod rgbe;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::{Image, ImageError};

pub use animation::AnimatedPng;
pub use pfm::{PfmEndianness, read_pfm, write_pfm};

/// The file formats Lucid reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// OpenEXR.
    Exr,
    /// Portable FloatMap.
    Pfm,
    /// Radiance RGBE (`.hdr`).
    Rgbe,
    /// PNG.
    Png,
    /// JPEG.
    Jpeg,
}

impl ImageFormat {
    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, ImageError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        match ext.to_ascii_lowercase().as_str() {
            "exr" => Ok(Self::Exr),
            "pfm" => Ok(Self::Pfm),
            "hdr" | "rgbe" | "pic" => Ok(Self::Rgbe),
            "png" => Ok(Self::Png),
            "jpg" | "jpeg" => Ok(Self::Jpeg),
            _ => Err(ImageError::UnsupportedFormat { path: path.to_path_buf(), ext: ext.to_string() }),
        }
    }

    /// True for the formats that store linear floating-point radiance.
    pub fn is_hdr(self) -> bool {
        matches!(self, Self::Exr | Self::Pfm | Self::Rgbe)
    }

    /// Whether the format stores an alpha channel (EXR and PNG do; PFM, RGBE and JPEG do
    /// not).
    pub fn has_alpha(self) -> bool {
        matches!(self, Self::Exr | Self::Png)
    }

    /// Whether the format stores NaN and infinities as such (EXR and PFM are IEEE floats;
    /// RGBE's shared exponent and 8-bit codes cannot).
    pub fn stores_non_finite(self) -> bool {
        matches!(self, Self::Exr | Self::Pfm)
    }

    /// A short human name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Exr => "OpenEXR",
            Self::Pfm => "PFM",
            Self::Rgbe => "Radiance RGBE",
            Self::Png => "PNG",
            Self::Jpeg => "JPEG",
        }
    }
}

/// Sample precision of EXR output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ExrPrecision {
    /// 16-bit half floats: half the size, ~3 decimal digits, max 65504.
    Half,
    /// 32-bit floats.
    #[default]
    Float,
}

/// Bit depth of PNG output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PngBitDepth {
    /// 8 bits per channel.
    #[default]
    Eight,
    /// 16 bits per channel.
    Sixteen,
}

/// Options for [`write_image_with`]; each applies only to its format.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions {
    /// EXR sample type.
    pub exr_precision: ExrPrecision,
    /// PNG bit depth.
    pub png_bit_depth: PngBitDepth,
    /// Write a single-channel file (EXR `Y`, greyscale PFM `Pf`, grey PNG) from the red
    /// channel, e.g. for depth maps.
    pub single_channel: bool,
}

/// Reads any supported image file into linear RGBA. LDR files are sRGB-decoded.
pub fn read_image(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let format = ImageFormat::from_path(path)?;
    if !path.is_file() {
        let source = if path.exists() {
            std::io::Error::other("is not a regular file")
        } else {
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")
        };
        return Err(ImageError::io(path, source));
    }
    let image = match format {
        ImageFormat::Exr => exr_file::read(path),
        ImageFormat::Pfm => pfm::read_pfm(path),
        ImageFormat::Rgbe => rgbe::read(path),
        ImageFormat::Png | ImageFormat::Jpeg => ldr::read(path, format),
    }?;
    if image.width() == 0 || image.height() == 0 {
        return Err(ImageError::malformed(
            path,
            format.name(),
            format!("the image is {}x{}: it holds no pixels", image.width(), image.height()),
        ));
    }
    Ok(image)
}

/// Reads only the header of an image file and returns `(width, height)`.
pub fn image_dimensions(path: impl AsRef<Path>) -> Result<(usize, usize), ImageError> {
    let path = path.as_ref();
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr => exr_file::dimensions(path),
        ImageFormat::Pfm => pfm::dimensions(path),
        ImageFormat::Rgbe => rgbe::read(path).map(|i| i.dimensions()),
        ImageFormat::Png | ImageFormat::Jpeg => ldr::dimensions(path),
    }
}

/// Reads an image whose every value is finite (an environment map, a light probe): a NaN or
/// an infinity would spread through every coefficient, light or pixel computed from it.
pub fn read_finite_image(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let image = read_image(path)?;
    if let Some(i) = image.pixels().iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        let (x, y) = (i % image.width(), i / image.width());
        let format = ImageFormat::from_path(path)?.name();
        let reason = format!("pixel ({x}, {y}) holds a value that is not finite ({:?})", image.pixels()[i]);
        return Err(ImageError::malformed(path, format, reason));
    }
    Ok(image)
}

/// Reads a depth buffer: of an EXR file its depth layer (`*.Depth`, `Z`; see
/// [`exr_layers`]), of other formats the image, whose first channel is the depth.
pub fn read_depth_image(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr if path.is_file() => exr_file::read_depth(path),
        _ => read_image(path),
    }
}

/// Writes an image with default options (float EXR, 8-bit PNG), format by extension.
pub fn write_image(path: impl AsRef<Path>, image: &Image) -> Result<(), ImageError> {
    write_image_with(path, image, WriteOptions::default())
}

/// Writes an image, format by extension, atomically.
pub fn write_image_with(path: impl AsRef<Path>, image: &Image, options: WriteOptions) -> Result<(), ImageError> {
    let path = path.as_ref();
    let format = ImageFormat::from_path(path)?;
    if image.width() == 0 || image.height() == 0 {
        return Err(ImageError::encode(path, format.name(), "image is empty"));
    }
    write_atomically(path, |out| match format {
        ImageFormat::Exr => exr_file::write(out, path, image, options),
        ImageFormat::Pfm => pfm::write_pfm_to(out, image, options.single_channel, PfmEndianness::Little)
            .map_err(|e| ImageError::io(path, e)),
        ImageFormat::Rgbe => rgbe::write(out, path, image),
        ImageFormat::Png | ImageFormat::Jpeg => ldr::write(out, path, image, format, options),
    })
}

/// The image as an 8-bit PNG in memory (RGBA where it has alpha), encoded exactly as
/// [`write_image`] writes a `.png`, for servers that send images rather than store them.
pub fn encode_png(image: &Image) -> Result<Vec<u8>, ImageError> {
    let path = Path::new("(PNG in memory)");
    if image.width() == 0 || image.height() == 0 {
        return Err(ImageError::encode(path, "PNG", "image is empty"));
    }
    let mut bytes = Vec::new();
    ldr::write(&mut bytes, path, image, ImageFormat::Png, WriteOptions::default())?;
    Ok(bytes)
}

/// An image whose colours are already sRGB-encoded in `[0,1]` (as NeRF and splat renders
/// are) as an opaque 8-bit RGB PNG in memory, its pixels those of [`encoded_rgb8`]: quantised
/// directly, with no decode and re-encode that could move a value across a rounding step, so
/// every writer of such renders (`lucid render`'s frames, the viewer's replies) gives the same
/// pixels. `fast` trades size for encoding time (for a viewer's frames).
pub fn encoded_png(image: &Image, fast: bool) -> Result<Vec<u8>, ImageError> {
    let path = Path::new("(PNG in memory)");
    let fail = |reason: String| ImageError::encode(path, "PNG", reason);
    if image.width() == 0 || image.height() == 0 {
        return Err(fail("image is empty".into()));
    }
    let data = encoded_rgb8(image);
    let mut bytes = Vec::with_capacity(data.len() / 2);
    let mut encoder = png::Encoder::new(&mut bytes, image.width() as u32, image.height() as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    if fast {
        encoder.set_compression(png::Compression::Fast);
    }
    let mut writer = encoder.write_header().map_err(|e| fail(e.to_string()))?;
    writer.write_image_data(&data).map_err(|e| fail(e.to_string()))?;
    writer.finish().map_err(|e| fail(e.to_string()))?;
    Ok(bytes)
}

/// The 8-bit RGB bytes (rows top to bottom, no padding) of an image whose colours are already
/// sRGB-encoded in `[0,1]`: each channel clamped and rounded to the nearest of 255 steps.
pub fn encoded_rgb8(image: &Image) -> Vec<u8> {
    image.pixels().iter().flat_map(|p| [quantise(p[0]), quantise(p[1]), quantise(p[2])]).collect()
}

/// `round(255·clamp(v, 0, 1))`, for every 8-bit writer here. `f32::round` is a libm call on baseline x86-64 (a few
/// per cent of a viewer's frame). `⌊x + ½⌋` equals it for every `x ∈ [½, 255]`: the sum's
/// rounding could carry it up to an integer only from just below one, where the sum has `x`'s
/// spacing and is exact; below ½ both are 0 (where `x + ½` would round up to 1).
#[inline]
pub(super) fn quantise(v: f32) -> u8 {
    let x = v.clamp(0.0, 1.0) * 255.0;
    if x < 0.5 { 0 } else { (x + 0.5) as u8 }
}

/// Writes a file through `write` into a temporary sibling, then renames it over `path`.
/// On any error the temporary file is removed and `path` is left untouched.
pub fn write_atomically<E>(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<(), E>) -> Result<(), E>
where
    E: From<ImageError>,
{
    let tmp = temporary_sibling(path);
    let file = File::create(&tmp).map_err(|e| ImageError::io(path, e))?;
    let mut out = BufWriter::new(file);
    let result = write(&mut out).and_then(|()| {
        out.flush().map_err(|e| ImageError::io(path, e))?;
        let file = out.into_inner().map_err(|e| ImageError::io(path, e.into_error()))?;
        file.sync_all().map_err(|e| ImageError::io(path, e))?;
        drop(file);
        std::fs::rename(&tmp, path).map_err(|e| ImageError::io(path, e).into())
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// `dir/.name.<pid>.tmp`: hidden, in the same directory so the rename is atomic, and unique
/// per process so two writers never share one.
fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantise_rounds_as_f32_round_does() {
        let round = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        // Every 7th float in [0, 1], and every float within 64 steps of each rounding boundary
        // (where the two could part), and values outside the range.
        let strided = (0..=1.0f32.to_bits()).step_by(7).map(f32::from_bits);
        let boundaries = (0..255).flat_map(|k| {
            let edge = ((k as f32 + 0.5) / 255.0).to_bits();
            (edge - 64..=edge + 64).map(f32::from_bits)
        });
        let outside = [-1.0, -0.0, 1.0 + f32::EPSILON, 2.0, f32::INFINITY, f32::NEG_INFINITY];
        for v in strided.chain(boundaries).chain(outside) {
            assert_eq!(quantise(v), round(v), "{v:e}");
        }
    }
}
