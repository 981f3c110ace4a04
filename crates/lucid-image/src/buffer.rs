//! [`Image`]: the RGBA `f32` buffer every crate passes around.

/// A linear, scene-referred RGBA image with straight (non-premultiplied) alpha.
///
/// Pixels are stored row by row from the top-left corner; pixel `(x, y)` has its centre at
/// `(x + 0.5, y + 0.5)` in image coordinates. Alpha is 1 for opaque pixels; files without
/// an alpha channel read as opaque.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 4]>,
}

impl Image {
    /// An image of one colour.
    pub fn filled(width: usize, height: usize, rgba: [f32; 4]) -> Self {
        Self { width, height, pixels: vec![rgba; width * height] }
    }

    /// An opaque black image.
    pub fn black(width: usize, height: usize) -> Self {
        Self::filled(width, height, [0.0, 0.0, 0.0, 1.0])
    }

    /// Builds an image from a function of the pixel coordinates.
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> [f32; 4]) -> Self {
        let mut pixels = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self { width, height, pixels }
    }

    /// Wraps row-major pixels. Panics if the length is not `width * height`, which is a
    /// programming error rather than bad input.
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<[f32; 4]>) -> Self {
        assert_eq!(pixels.len(), width * height, "pixel count does not match {width}x{height}");
        Self { width, height, pixels }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// `(width, height)`.
    pub fn dimensions(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// All pixels, row-major.
    pub fn pixels(&self) -> &[[f32; 4]] {
        &self.pixels
    }

    /// All pixels, row-major, mutable.
    pub fn pixels_mut(&mut self) -> &mut [[f32; 4]] {
        &mut self.pixels
    }

    /// Consumes the image, returning its pixels.
    pub fn into_pixels(self) -> Vec<[f32; 4]> {
        self.pixels
    }

    /// The pixel at `(x, y)`.
    pub fn get(&self, x: usize, y: usize) -> [f32; 4] {
        self.pixels[y * self.width + x]
    }

    /// Sets the pixel at `(x, y)`.
    pub fn set(&mut self, x: usize, y: usize, rgba: [f32; 4]) {
        self.pixels[y * self.width + x] = rgba;
    }

    /// One row of pixels.
    pub fn row(&self, y: usize) -> &[[f32; 4]] {
        &self.pixels[y * self.width..(y + 1) * self.width]
    }

    /// True when some pixel is not fully opaque, i.e. the alpha channel carries information.
    pub fn has_alpha(&self) -> bool {
        self.pixels.iter().any(|p| p[3] != 1.0)
    }

    /// True when every value is finite (no NaN or infinity).
    pub fn is_finite(&self) -> bool {
        self.pixels.iter().all(|p| p.iter().all(|v| v.is_finite()))
    }

    /// How many values (channels of pixels) are NaN or infinite.
    pub fn non_finite_count(&self) -> usize {
        self.pixels.iter().flatten().filter(|v| !v.is_finite()).count()
    }

    /// Applies `f` to every pixel.
    pub fn map(&self, mut f: impl FnMut([f32; 4]) -> [f32; 4]) -> Self {
        Self { width: self.width, height: self.height, pixels: self.pixels.iter().map(|&p| f(p)).collect() }
    }

    /// The image resampled to `width × height` with a triangle filter whose support widens
    /// with the reduction (so downscaling averages every source pixel, without aliasing), on
    /// the linear values.
    pub fn resized(&self, width: usize, height: usize) -> Self {
        if (width, height) == (self.width, self.height) {
            return self.clone();
        }
        let flat: Vec<f32> = self.pixels.iter().flatten().copied().collect();
        let source = image::Rgba32FImage::from_raw(self.width as u32, self.height as u32, flat)
            .expect("the buffer holds width × height pixels");
        let out = image::imageops::resize(&source, width as u32, height as u32, image::imageops::FilterType::Triangle);
        let pixels = out.into_raw().chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
        Self { width, height, pixels }
    }

    /// Mean of each channel over all pixels (in `f64` to stay exact on large images).
    pub fn mean(&self) -> [f64; 4] {
        let mut sum = [0.0f64; 4];
        for p in &self.pixels {
            for c in 0..4 {
                sum[c] += p[c] as f64;
            }
        }
        let n = self.pixels.len().max(1) as f64;
        sum.map(|s| s / n)
    }
}
