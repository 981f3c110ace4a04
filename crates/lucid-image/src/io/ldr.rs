//! 8/16-bit PNG and JPEG through the `image` crate. Colour channels are sRGB-encoded in the
//! file and linear in memory; alpha is straight and linear in both.

use std::fs::File;
use std::io::{BufReader, Write};
use std::path::Path;

use image::{DynamicImage, ImageBuffer, ImageEncoder, ImageReader, Rgb, Rgba};

use super::{ImageFormat, PngBitDepth, WriteOptions};
use crate::color::{srgb_decode, srgb_encode};
use crate::{Image, ImageError};

fn image_format(format: ImageFormat) -> image::ImageFormat {
    match format {
        ImageFormat::Png => image::ImageFormat::Png,
        ImageFormat::Jpeg => image::ImageFormat::Jpeg,
        ImageFormat::Rgbe => image::ImageFormat::Hdr,
        ImageFormat::Exr | ImageFormat::Pfm => unreachable!("not an image-crate format"),
    }
}

pub(super) fn read(path: &Path, format: ImageFormat) -> Result<Image, ImageError> {
    let file = File::open(path).map_err(|e| ImageError::io(path, e))?;
    let reader = ImageReader::with_format(BufReader::new(file), image_format(format));
    let decoded: DynamicImage = reader.decode().map_err(|e| malformed(path, format, e))?;
    let (w, h) = (decoded.width() as usize, decoded.height() as usize);
    // to_rgba32f normalises 8- and 16-bit samples to [0,1] and expands grey/RGB to RGBA.
    let rgba = decoded.to_rgba32f();
    let pixels = rgba.pixels().map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), p[3]]).collect();
    Ok(Image::from_pixels(w, h, pixels))
}

pub(super) fn dimensions(path: &Path) -> Result<(usize, usize), ImageError> {
    let format = super::ImageFormat::from_path(path)?;
    let file = File::open(path).map_err(|e| ImageError::io(path, e))?;
    let reader = ImageReader::with_format(BufReader::new(file), image_format(format));
    let (w, h) = reader.into_dimensions().map_err(|e| malformed(path, format, e))?;
    Ok((w as usize, h as usize))
}

pub(super) fn write(
    out: impl Write,
    path: &Path,
    image: &Image,
    format: ImageFormat,
    options: WriteOptions,
) -> Result<(), ImageError> {
    let (w, h) = (image.width() as u32, image.height() as u32);
    let quantise8 = super::quantise;
    let quantise16 = |v: f32| (v.clamp(0.0, 1.0) * 65535.0).round() as u16;
    let colour = |p: &[f32; 4], c: usize| srgb_encode(if options.single_channel { p[0] } else { p[c] });
    let alpha = format == ImageFormat::Png && image.has_alpha();
    let encoded = match (options.png_bit_depth, alpha) {
        (PngBitDepth::Sixteen, _) if format == ImageFormat::Png => {
            DynamicImage::ImageRgba16(ImageBuffer::from_fn(w, h, |x, y| {
                let p = image.get(x as usize, y as usize);
                Rgba([
                    quantise16(colour(&p, 0)),
                    quantise16(colour(&p, 1)),
                    quantise16(colour(&p, 2)),
                    quantise16(p[3]),
                ])
            }))
        }
        (_, true) => DynamicImage::ImageRgba8(ImageBuffer::from_fn(w, h, |x, y| {
            let p = image.get(x as usize, y as usize);
            Rgba([quantise8(colour(&p, 0)), quantise8(colour(&p, 1)), quantise8(colour(&p, 2)), quantise8(p[3])])
        })),
        (_, false) => DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| {
            let p = image.get(x as usize, y as usize);
            Rgb([quantise8(colour(&p, 0)), quantise8(colour(&p, 1)), quantise8(colour(&p, 2))])
        })),
    };
    let result = match format {
        ImageFormat::Png => {
            let encoder = image::codecs::png::PngEncoder::new(out);
            encoder.write_image(encoded.as_bytes(), w, h, encoded.color().into())
        }
        _ => {
            let encoder = image::codecs::jpeg::JpegEncoder::new_with_quality(out, 95);
            encoder.write_image(encoded.as_bytes(), w, h, encoded.color().into())
        }
    };
    result.map_err(|e| match e {
        image::ImageError::IoError(io) => ImageError::io(path, io),
        other => ImageError::encode(path, format.name(), other),
    })
}

fn malformed(path: &Path, format: ImageFormat, e: image::ImageError) -> ImageError {
    match e {
        image::ImageError::IoError(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => ImageError::io(path, io),
        image::ImageError::IoError(_) => ImageError::malformed(path, format.name(), "file is truncated"),
        other => ImageError::malformed(path, format.name(), other.to_string()),
    }
}
