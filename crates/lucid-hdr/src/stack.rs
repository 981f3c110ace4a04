//! An exposure stack: LDR frames of one static scene at known exposure times.

use lucid_image::Image;
use lucid_image::color::srgb_encode;

use crate::HdrError;

/// Number of pixel codes of an 8-bit channel.
pub const CODES: usize = 256;

/// Frames as 8-bit codes per channel, with their exposure times.
///
/// Images arrive linearised by the file reader (`lucid_image::read_image` decodes sRGB); the
/// codes are recovered by encoding again, which is exact for 8-bit files. A 16-bit file is
/// quantised to 8 bits here: response recovery works on 256 codes.
#[derive(Clone, Debug)]
pub struct ExposureStack {
    width: usize,
    height: usize,
    /// Per frame, per pixel, RGB codes.
    codes: Vec<Vec<[u8; 3]>>,
    /// Exposure times in seconds, one per frame.
    times: Vec<f32>,
}

/// The 8-bit code of a linear value as the file stored it: `round(255·srgb(v))`, found by
/// binary search among the linear values where the code changes (a `powf` per value made
/// decoding a megapixel stack the slowest step of a merge).
pub fn code_of(linear: f32) -> u8 {
    static EDGES: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    let edges = EDGES.get_or_init(|| {
        // Code k+1 starts where the encoded value reaches (k + 0.5)/255; refine the decoded
        // edge so that the search agrees with rounding the encoded value exactly.
        std::array::from_fn(|k| {
            let mut edge = lucid_image::color::srgb_decode((k as f32 + 0.5) / 255.0);
            while (srgb_encode(edge) * 255.0).round() as usize <= k {
                edge = f32::from_bits(edge.to_bits() + 1);
            }
            while edge > 0.0 && (srgb_encode(f32::from_bits(edge.to_bits() - 1)) * 255.0).round() as usize > k {
                edge = f32::from_bits(edge.to_bits() - 1);
            }
            edge
        })
    });
    edges.partition_point(|&e| e <= linear) as u8
}

impl ExposureStack {
    /// A stack from linear images (as read from LDR files) and their exposure times.
    pub fn new(frames: &[Image], times: &[f32]) -> Result<Self, HdrError> {
        if frames.is_empty() {
            return Err(HdrError::Stack("no frames".into()));
        }
        if frames.len() != times.len() {
            return Err(HdrError::Stack(format!("{} frames but {} exposure times", frames.len(), times.len())));
        }
        let (w, h) = frames[0].dimensions();
        for (k, f) in frames.iter().enumerate() {
            if f.dimensions() != (w, h) {
                let (fw, fh) = f.dimensions();
                return Err(HdrError::Stack(format!("frame {k} is {fw}x{fh}, frame 0 is {w}x{h}")));
            }
        }
        for (k, &t) in times.iter().enumerate() {
            if !(t.is_finite() && t > 0.0) {
                return Err(HdrError::Stack(format!("exposure time {k} is {t}: it must be positive and finite")));
            }
        }
        let codes = frames
            .iter()
            .map(|f| {
                use rayon::prelude::*;
                f.pixels().par_iter().map(|p| [code_of(p[0]), code_of(p[1]), code_of(p[2])]).collect()
            })
            .collect();
        Ok(Self { width: w, height: h, codes, times: times.to_vec() })
    }

    /// A stack from codes directly (`codes[frame][pixel]`).
    pub fn from_codes(
        width: usize,
        height: usize,
        codes: Vec<Vec<[u8; 3]>>,
        times: Vec<f32>,
    ) -> Result<Self, HdrError> {
        if codes.is_empty() || codes.len() != times.len() || codes.iter().any(|c| c.len() != width * height) {
            return Err(HdrError::Stack("codes do not match the frame count or the image size".into()));
        }
        Ok(Self { width, height, codes, times })
    }

    /// Image width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Whether there are no frames (never true for a constructed stack).
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// Exposure times.
    pub fn times(&self) -> &[f32] {
        &self.times
    }

    /// Codes of frame `k`.
    pub fn frame(&self, k: usize) -> &[[u8; 3]] {
        &self.codes[k]
    }

    /// Code of channel `c` of pixel `i` in frame `k`.
    pub fn code(&self, k: usize, i: usize, c: usize) -> u8 {
        self.codes[k][i][c]
    }

    /// Frame indices from the shortest exposure to the longest.
    pub fn by_time(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by(|&a, &b| self.times[a].total_cmp(&self.times[b]));
        order
    }

    /// `n` pixel indices for response recovery, chosen so that channel `c` of the middle
    /// exposure covers its range of codes evenly (the system needs every code observed):
    /// pixels sorted by that code, taken at evenly spaced ranks. Deterministic.
    pub fn sample_pixels(&self, c: usize, n: usize) -> Vec<usize> {
        let mid = self.by_time()[self.len() / 2];
        // Pixels ordered by (code, index): a counting sort over the 256 codes.
        let mut start = [0usize; CODES + 1];
        for p in &self.codes[mid] {
            start[p[c] as usize + 1] += 1;
        }
        for z in 0..CODES {
            start[z + 1] += start[z];
        }
        let mut order = vec![0usize; self.width * self.height];
        for (i, p) in self.codes[mid].iter().enumerate() {
            let slot = &mut start[p[c] as usize];
            order[*slot] = i;
            *slot += 1;
        }
        let n = n.min(order.len()).max(1);
        let mut picks: Vec<usize> =
            (0..n).map(|k| order[((k as f64 + 0.5) / n as f64 * order.len() as f64) as usize]).collect();
        picks.dedup();
        picks
    }
}

/// Debevec and Malik's hat weighting: trust in a code, 0 at both ends of the range.
pub fn hat_weight(z: u8) -> f32 {
    let z = z as f32;
    if z <= 127.5 { z } else { 255.0 - z }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_match_rounding_the_encoded_value() {
        let mut v = 0.0f32;
        while v <= 1.2 {
            let want = (srgb_encode(v) * 255.0).round() as u8;
            assert_eq!(code_of(v), want, "at {v}");
            v += 1.3e-5;
        }
        for k in 0..=255u8 {
            let stored = lucid_image::color::srgb_decode(k as f32 / 255.0);
            assert_eq!(code_of(stored), k, "an 8-bit file's value {k} round-trips");
        }
        assert_eq!(code_of(-1.0), 0);
    }
}
