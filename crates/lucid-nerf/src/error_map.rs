//! Error-driven pixel sampling (instant-ngp's error map): a running estimate of the colour
//! loss of every block of pixels of every training image, from which part of each batch is
//! drawn in proportion to it. The rest of the batch stays uniform, so every pixel keeps
//! being seen and the estimate of a block that became easy gets refreshed.

use lucid_scene::sampling::Rng;

/// Blocks across the larger side of an image, about: the estimate of one pixel would be
/// refreshed too rarely (a batch holds a few thousand of millions of pixels), while ~64
/// blocks across (4×4 pixels at 200×200, visited every few dozen steps with 100 views) still
/// follow edges and thin structures. Block sides are powers of two, at least 4 pixels.
const BLOCKS_ACROSS: usize = 64;

/// Per-block loss estimates of a set of images, with the distribution to sample them by.
#[derive(Clone, Debug)]
pub struct ErrorMap {
    /// Pixels per side of a block.
    block: usize,
    /// Per image: width, height, blocks across, index of its first block.
    images: Vec<ImageBlocks>,
    /// Loss estimate per block.
    error: Vec<f32>,
    /// Running sums of `error` (f64, so that small blocks do not round away), rebuilt by
    /// [`ErrorMap::rebuild`]: every step, so that they follow from `error` alone and a
    /// checkpoint need only hold that.
    cdf: Vec<f64>,
}

#[derive(Clone, Copy, Debug)]
struct ImageBlocks {
    width: usize,
    height: usize,
    across: usize,
    first: usize,
}

impl ErrorMap {
    /// A map over images of the given sizes; every block starts at `initial` (high, so that
    /// blocks not yet seen are favoured over ones known to be easy).
    pub fn new(sizes: &[(usize, usize)], initial: f32) -> Self {
        let largest = sizes.iter().map(|&(w, h)| w.max(h)).max().unwrap_or(1);
        let block = (largest / BLOCKS_ACROSS).next_power_of_two().max(4);
        let mut images = Vec::with_capacity(sizes.len());
        let mut first = 0;
        for &(width, height) in sizes {
            let (across, down) = (width.div_ceil(block), height.div_ceil(block));
            images.push(ImageBlocks { width, height, across, first });
            first += across * down;
        }
        let mut map = Self { block, images, error: vec![initial; first], cdf: Vec::new() };
        map.rebuild();
        map
    }

    /// Whether the map was made for images of these sizes.
    pub fn fits(&self, sizes: &[(usize, usize)]) -> bool {
        self.images.len() == sizes.len() && self.images.iter().zip(sizes).all(|(im, &s)| (im.width, im.height) == s)
    }

    /// The map of images of `sizes` with the block estimates `errors` (as
    /// [`ErrorMap::errors`] gave them), or `None` if their number does not fit the sizes.
    pub fn from_errors(sizes: &[(usize, usize)], errors: Vec<f32>) -> Option<Self> {
        let mut map = Self::new(sizes, 0.0);
        if errors.len() != map.error.len() {
            return None;
        }
        map.error = errors;
        map.rebuild();
        Some(map)
    }

    /// The block holding pixel `k` (row-major) of image `image`.
    pub fn block_of(&self, image: usize, k: usize) -> usize {
        let im = &self.images[image];
        let (x, y) = (k % im.width, k / im.width);
        im.first + (y / self.block) * im.across + x / self.block
    }

    /// A pixel drawn with probability proportional to its block's loss estimate (uniform
    /// within the block): `(image, row-major pixel index)`.
    pub fn sample(&self, rng: &mut Rng) -> (usize, usize) {
        let total = *self.cdf.last().expect("at least one block");
        let target = rng.uniform() as f64 * total;
        let block = self.cdf.partition_point(|&c| c <= target).min(self.error.len() - 1);
        let image = self.images.partition_point(|im| im.first <= block) - 1;
        let im = &self.images[image];
        let local = block - im.first;
        let b = self.block;
        let (x0, y0) = ((local % im.across) * b, (local / im.across) * b);
        let x = x0 + rng.below(b.min(im.width - x0));
        let y = y0 + rng.below(b.min(im.height - y0));
        (image, y * im.width + x)
    }

    /// Folds one measured loss into its block's estimate (an average that halves the weight
    /// of older measurements at every visit).
    pub fn record(&mut self, block: usize, loss: f32) {
        if loss.is_finite() {
            self.error[block] = 0.5 * (self.error[block] + loss);
        }
    }

    /// Recomputes the sampling distribution from the current estimates.
    pub fn rebuild(&mut self) {
        self.cdf.clear();
        let mut sum = 0.0f64;
        // A floor keeps every block reachable through this part of the batch too.
        let floor = 1e-4;
        self.cdf.extend(self.error.iter().map(|&e| {
            sum += e.max(floor) as f64;
            sum
        }));
    }

    /// The map as bytes for a checkpoint: image count, each image's width and height (`u32`),
    /// then the block estimates (`f32`), little-endian.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(4 + 8 * self.images.len() + 4 * self.error.len());
        out.extend((self.images.len() as u32).to_le_bytes());
        for im in &self.images {
            out.extend((im.width as u32).to_le_bytes());
            out.extend((im.height as u32).to_le_bytes());
        }
        out.extend(self.error.iter().flat_map(|e| e.to_le_bytes()));
        out
    }

    /// The map [`ErrorMap::to_bytes`] wrote, or `None` if the bytes are not one.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        let word = |i: usize| bytes.get(4 * i..4 * i + 4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")));
        let n = word(0)? as usize;
        let sizes: Vec<(usize, usize)> =
            (0..n).map(|i| Some((word(1 + 2 * i)? as usize, word(2 + 2 * i)? as usize))).collect::<Option<_>>()?;
        let rest = bytes.get(4 * (1 + 2 * n)..)?;
        if rest.len() % 4 != 0 || sizes.iter().any(|&(w, h)| w == 0 || h == 0) {
            return None;
        }
        let errors = rest.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect();
        Self::from_errors(&sizes, errors)
    }

    /// The loss estimate of every block.
    pub fn errors(&self) -> &[f32] {
        &self.error
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_are_drawn_in_proportion_to_their_error() {
        // Two images, one 6×5 (blocks 2×2, partial at the edges) and one 4×4 (one block).
        let mut map = ErrorMap::new(&[(6, 5), (4, 4)], 1.0);
        assert_eq!(map.errors().len(), 5);
        for b in 0..5 {
            map.error[b] = 0.0;
        }
        map.error[3] = 3.0; // image 0, bottom-right partial block (pixels x 4..6, y 4..5)
        map.error[4] = 1.0; // image 1
        map.rebuild();
        let mut rng = Rng::new(3, 4);
        let mut counts = [0usize; 5];
        let n = 40_000;
        for _ in 0..n {
            let (image, k) = map.sample(&mut rng);
            let b = map.block_of(image, k);
            if image == 0 {
                let (x, y) = (k % 6, k / 6);
                assert!(b == 3 && (4..6).contains(&x) && y == 4 || map.error[b] <= 1e-4, "{x},{y}");
            }
            counts[b] += 1;
        }
        let share = counts[3] as f64 / n as f64;
        assert!((share - 0.75).abs() < 0.01, "{counts:?}");
        // Floored blocks are rare but reachable.
        assert!(counts[0] < n / 1000);
    }

    #[test]
    fn estimates_follow_the_recorded_losses() {
        let mut map = ErrorMap::new(&[(8, 8)], 1.0);
        let b = map.block_of(0, 8 * 5 + 6);
        assert_eq!(b, 3);
        // Blocks grow with the images: ~64 across the larger side.
        assert_eq!(ErrorMap::new(&[(800, 600)], 1.0).block, 16);
        assert_eq!(ErrorMap::new(&[(200, 200)], 1.0).block, 4);
        for _ in 0..20 {
            map.record(b, 0.25);
        }
        assert!((map.errors()[b] - 0.25).abs() < 1e-5);
        map.record(b, f32::NAN);
        assert!((map.errors()[b] - 0.25).abs() < 1e-5, "non-finite losses are ignored");
        // A map rebuilt from its estimates samples exactly as the original (which the trainer
        // rebuilds after every step's records).
        map.rebuild();
        let copy = ErrorMap::from_errors(&[(8, 8)], map.errors().to_vec()).unwrap();
        let (mut r1, mut r2) = (Rng::new(1, 1), Rng::new(1, 1));
        for _ in 0..100 {
            assert_eq!(map.sample(&mut r1), copy.sample(&mut r2));
        }
        assert!(ErrorMap::from_errors(&[(8, 9)], map.errors().to_vec()).is_none());
        let restored = ErrorMap::from_bytes(&map.to_bytes()).unwrap();
        assert_eq!(restored.errors(), map.errors());
        assert!(ErrorMap::from_bytes(&map.to_bytes()[..10]).is_none());
        assert!(copy.fits(&[(8, 8)]) && !copy.fits(&[(8, 8), (8, 8)]));
    }
}
