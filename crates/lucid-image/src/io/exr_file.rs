//! OpenEXR through the `exr` crate.
//!
//! Reading takes the layer that is the image (see [`super::exr_layers`]), so RGB, RGBA,
//! single-channel (depth `Z`, luminance `Y`, …), multi-layer and multi-part files all load
//! their picture. Half, float and uint samples are converted to `f32`.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use exr::prelude::*;
use std::result::Result;

use super::exr_layers::{Want, choose};
use super::{ExrPrecision, WriteOptions};
use crate::{Image as RgbaImage, ImageError};

const FORMAT: &str = "OpenEXR";

pub(super) fn read(path: &Path) -> Result<RgbaImage, ImageError> {
    read_wanted(path, Want::Colour)
}

/// The file's depth buffer (see [`super::exr_layers`]).
pub(super) fn read_depth(path: &Path) -> Result<RgbaImage, ImageError> {
    read_wanted(path, Want::Depth)
}

fn read_wanted(path: &Path, want: Want) -> Result<RgbaImage, ImageError> {
    let image = read_all_flat_layers_from_file(path).map_err(|e| exr_error(path, e))?;
    let layers = &image.layer_data;
    let parts: Vec<_> = layers
        .iter()
        .map(|l| part_names(l.attributes.layer_name.as_ref(), l.channel_data.list.iter().map(|c| &c.name)))
        .collect();
    let sources = choose(&parts, want).map_err(|reason| ImageError::malformed(path, FORMAT, reason))?;
    let part = sources.iter().flatten().next().map_or(0, |s| s.part);
    let (width, height) = (layers[part].size.width(), layers[part].size.height());
    let mut pixels = vec![[0.0, 0.0, 0.0, 1.0]; width * height];
    for (c, source) in sources.iter().enumerate() {
        let Some(at) = source else { continue };
        let layer = &layers[at.part];
        if (layer.size.width(), layer.size.height()) != (width, height) {
            return Err(ImageError::malformed(path, FORMAT, "the chosen layer's channels lie in parts of other sizes"));
        }
        let samples = &layer.channel_data.list[at.index].sample_data;
        if samples.len() != width * height {
            return Err(ImageError::malformed(path, FORMAT, "subsampled channels are not supported"));
        }
        for (i, p) in pixels.iter_mut().enumerate() {
            p[c] = samples.value_by_flat_index(i).to_f32();
        }
    }
    Ok(RgbaImage::from_pixels(width, height, pixels))
}

/// A part's name and its channels' names, as [`choose`] takes them.
fn part_names<'a>(name: Option<&Text>, channels: impl Iterator<Item = &'a Text>) -> (Option<String>, Vec<String>) {
    (name.map(|n| n.to_string()), channels.map(|c| c.to_string()).collect())
}

pub(super) fn dimensions(path: &Path) -> Result<(usize, usize), ImageError> {
    let meta = MetaData::read_from_file(path, false).map_err(|e| exr_error(path, e))?;
    let parts: Vec<_> = meta
        .headers
        .iter()
        .map(|h| part_names(h.own_attributes.layer_name.as_ref(), h.channels.list.iter().map(|c| &c.name)))
        .collect();
    let sources = choose(&parts, Want::Colour).map_err(|reason| ImageError::malformed(path, FORMAT, reason))?;
    let part = sources.iter().flatten().next().map_or(0, |s| s.part);
    let header = meta.headers.get(part).ok_or_else(|| ImageError::malformed(path, FORMAT, "no layers"))?;
    Ok((header.layer_size.width(), header.layer_size.height()))
}

pub(super) fn write(
    out: &mut BufWriter<File>,
    path: &Path,
    image: &RgbaImage,
    options: WriteOptions,
) -> Result<(), ImageError> {
    let size = (image.width(), image.height());
    let channel = |c: usize| -> FlatSamples {
        let values = image.pixels().iter().map(|p| p[c]);
        match options.exr_precision {
            ExrPrecision::Float => FlatSamples::F32(values.collect()),
            ExrPrecision::Half => FlatSamples::F16(values.map(f16::from_f32).collect()),
        }
    };
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    if options.single_channel {
        list.push(AnyChannel::new("Y", channel(0)));
    } else {
        list.push(AnyChannel::new("R", channel(0)));
        list.push(AnyChannel::new("G", channel(1)));
        list.push(AnyChannel::new("B", channel(2)));
        if image.has_alpha() {
            list.push(AnyChannel::new("A", channel(3)));
        }
    }
    // Blocks in increasing order: parallel compression otherwise writes them in completion
    // order, and the same image would not give the same bytes (datasets must be reproducible).
    let encoding =
        Encoding { compression: Compression::ZIP16, line_order: LineOrder::Increasing, ..Encoding::default() };
    let exr_image = Image::from_encoded_channels(size, encoding, AnyChannels::sort(list));
    exr_image.write().to_buffered(out).map_err(|e| match e {
        exr::error::Error::Io(io) => ImageError::io(path, io),
        other => ImageError::encode(path, FORMAT, other),
    })
}

fn exr_error(path: &Path, error: exr::error::Error) -> ImageError {
    match error {
        exr::error::Error::Io(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => ImageError::io(path, io),
        exr::error::Error::Io(_) => ImageError::malformed(path, FORMAT, "file is truncated"),
        other => ImageError::malformed(path, FORMAT, other.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layer of constant channels: `(name, value)`.
    fn layer(name: Option<&str>, channels: &[(&str, f32)]) -> Layer<AnyChannels<FlatSamples>> {
        let list: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            channels.iter().map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(vec![*v; 6]))).collect();
        let attributes = match name {
            Some(n) => LayerAttributes::named(n),
            None => LayerAttributes::default(),
        };
        Layer::new((3, 2), attributes, Encoding::FAST_LOSSLESS, AnyChannels::sort(list))
    }

    fn write_layers(path: &Path, layers: Vec<Layer<AnyChannels<FlatSamples>>>) {
        Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((3, 2))), layers)
            .write()
            .to_file(path)
            .unwrap();
    }

    #[test]
    fn multi_layer_and_multi_part_files_read_as_their_beauty_pass() {
        let dir = tempfile::tempdir().unwrap();
        let blender = dir.path().join("blender.exr");
        let passes = [
            ("ViewLayer.AO.R", 0.9),
            ("ViewLayer.AO.G", 0.9),
            ("ViewLayer.AO.B", 0.9),
            ("ViewLayer.Combined.R", 0.1),
            ("ViewLayer.Combined.G", 0.2),
            ("ViewLayer.Combined.B", 0.3),
            ("ViewLayer.Combined.A", 0.5),
            ("ViewLayer.Depth.Z", 4.0),
        ];
        write_layers(&blender, vec![layer(None, &passes)]);
        assert_eq!(read(&blender).unwrap().pixels()[0], [0.1, 0.2, 0.3, 0.5]);
        assert_eq!(read_depth(&blender).unwrap().pixels()[0][0], 4.0);

        let aov = dir.path().join("aov.exr");
        let channels = [("R", 0.25), ("G", 0.5), ("B", 0.75), ("AOV.R", 9.0), ("AOV.G", 9.0), ("AOV.B", 9.0)];
        write_layers(&aov, vec![layer(None, &channels)]);
        assert_eq!(read(&aov).unwrap().pixels()[0], [0.25, 0.5, 0.75, 1.0]);

        let parts = dir.path().join("parts.exr");
        write_layers(
            &parts,
            vec![layer(Some("depth"), &[("Z", 7.0)]), layer(Some("rgba"), &[("R", 0.4), ("G", 0.6), ("B", 0.8)])],
        );
        assert_eq!(read(&parts).unwrap().pixels()[0], [0.4, 0.6, 0.8, 1.0]);
        assert_eq!(read_depth(&parts).unwrap().pixels()[0][0], 7.0);
        assert_eq!(dimensions(&parts).unwrap(), (3, 2));

        let two = dir.path().join("two.exr");
        write_layers(
            &two,
            vec![layer(Some("left"), &[("R", 1.0), ("G", 1.0), ("B", 1.0)]), {
                layer(Some("right"), &[("R", 0.0), ("G", 0.0), ("B", 0.0)])
            }],
        );
        let err = read(&two).unwrap_err().to_string();
        assert!(err.contains("two.exr") && err.contains("left") && err.contains("right"), "{err}");
    }
}
