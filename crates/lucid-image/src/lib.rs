//! Image buffers and image files for Lucid.
//!
//! Everything in Lucid that touches pixels goes through [`Image`]: a linear, scene-referred,
//! straight-alpha RGBA `f32` buffer. Files are read and written by extension with
//! [`read_image`] and [`write_image`]:
//!
//! | extension        | format                      | read | write | notes |
//! |------------------|-----------------------------|------|-------|-------|
//! | `.exr`           | OpenEXR (half/float/uint)   | yes  | yes   | RGB(A) or a single channel (`Y`, `Z`, …) |
//! | `.pfm`           | Portable FloatMap           | yes  | yes   | colour `PF` and grey `Pf`, both endiannesses, rows bottom-to-top |
//! | `.hdr`, `.rgbe`  | Radiance RGBE               | yes  | yes   | shared 8-bit exponent: ~1% relative precision |
//! | `.png`           | PNG, 8 or 16 bit            | yes  | yes   | sRGB-encoded colour, straight linear alpha |
//! | `.jpg`, `.jpeg`  | JPEG                        | yes  | yes   | sRGB, no alpha (read for real-world datasets) |
//!
//! The colour helpers ([`color`]), global tone curves ([`tonemap`]) and the quality
//! metrics ([`metrics`]: PSNR, SSIM) live here too, because every other crate needs them.

pub mod buffer;
pub mod color;
pub mod error;
pub mod io;
pub mod metrics;
pub mod output;
pub mod owned_folder;
pub mod tonemap;

pub use buffer::Image;
pub use error::ImageError;
pub use io::{
    ExrPrecision, ImageFormat, PngBitDepth, WriteOptions, encode_png, encoded_png, encoded_rgb8, image_dimensions,
    read_depth_image, read_finite_image, read_image, write_atomically, write_image, write_image_with,
};
