//! OpenEXR through the `exr` crate.
//!
//! Reading takes the first layer with all its channels, so RGB, RGBA and single-channel
//! files (depth `Z`, luminance `Y`, …) all load; channel names may carry a layer prefix
//! (`ViewLayer.Combined.R`). Half, float and uint samples are converted to `f32`.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use exr::prelude::*;
use std::result::Result;

use super::{ExrPrecision, WriteOptions};
use crate::{Image as RgbaImage, ImageError};

const FORMAT: &str = "OpenEXR";

pub(super) fn read(path: &Path) -> Result<RgbaImage, ImageError> {
    let image = read_first_flat_layer_from_file(path).map_err(|e| exr_error(path, e))?;
    let layer = &image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;

    // The last dot-separated component is the channel proper; the rest is a layer path.
    let find = |want: &str| {
        channels.iter().position(|c| {
            let name = c.name.to_string();
            name.rsplit('.').next().is_some_and(|short| short.eq_ignore_ascii_case(want))
        })
    };
    let sources: [Option<usize>; 4] = match (find("R"), find("G"), find("B")) {
        (Some(r), Some(g), Some(b)) => [Some(r), Some(g), Some(b), find("A")],
        _ => {
            // A single-channel image: prefer a well-known grey name, else the only channel.
            let grey = ["Y", "Z", "L", "V", "depth"].iter().find_map(|n| find(n));
            let grey = grey.or(if channels.len() == 1 { Some(0) } else { None });
            match grey {
                Some(g) => [Some(g), Some(g), Some(g), find("A")],
                None => {
                    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
                    return Err(ImageError::malformed(
                        path,
                        FORMAT,
                        format!("no R/G/B or single grey channel in the first layer (channels: {})", names.join(", ")),
                    ));
                }
            }
        }
    };

    let mut pixels = vec![[0.0, 0.0, 0.0, 1.0]; width * height];
    for (c, source) in sources.iter().enumerate() {
        let Some(index) = source else { continue };
        let samples = &channels[*index].sample_data;
        if samples.len() != width * height {
            return Err(ImageError::malformed(path, FORMAT, "subsampled channels are not supported"));
        }
        for (i, p) in pixels.iter_mut().enumerate() {
            p[c] = samples.value_by_flat_index(i).to_f32();
        }
    }
    Ok(RgbaImage::from_pixels(width, height, pixels))
}

pub(super) fn dimensions(path: &Path) -> Result<(usize, usize), ImageError> {
    let meta = MetaData::read_from_file(path, false).map_err(|e| exr_error(path, e))?;
    let header = meta.headers.first().ok_or_else(|| ImageError::malformed(path, FORMAT, "no layers"))?;
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
