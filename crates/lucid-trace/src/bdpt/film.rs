//! The film that light paths reaching the camera (t = 1) add to: any pixel, from any thread.
//!
//! Sums are fixed-point integers in atomics rather than floats behind locks: integer
//! addition is associative, so the image is bit-identical whatever the number of threads and
//! the order in which they splat, which the renderer promises.

use std::sync::atomic::{AtomicI64, Ordering};

use glam::{Vec2, Vec3};

/// Fixed-point scale: 2⁻²⁸ ≈ 3.7·10⁻⁹ resolution, sums up to ±3.4·10¹⁰ per pixel.
const SCALE: f64 = (1u64 << 28) as f64;
/// Largest splat kept (a NaN or an absurd firefly is dropped rather than wrap a sum).
const LIMIT: f32 = 1e7;

/// An RGB sum that threads add to in any order with the same result.
#[derive(Default)]
pub(crate) struct FixedRgb([AtomicI64; 3]);

impl FixedRgb {
    /// Adds `value` (dropped if not finite or absurdly large).
    #[inline]
    pub(crate) fn add(&self, value: Vec3) {
        if !(value.is_finite() && value.max_element() < LIMIT && value.min_element() > -LIMIT) || value == Vec3::ZERO {
            return;
        }
        for (sum, v) in self.0.iter().zip(value.to_array()) {
            sum.fetch_add((v as f64 * SCALE).round() as i64, Ordering::Relaxed);
        }
    }

    /// The sum so far.
    pub(crate) fn get(&self) -> Vec3 {
        let c = |k: usize| (self.0[k].load(Ordering::Relaxed) as f64 / SCALE) as f32;
        Vec3::new(c(0), c(1), c(2))
    }
}

/// Per-pixel RGB sums of splatted radiance.
pub(crate) struct SplatFilm {
    width: usize,
    height: usize,
    sums: Vec<FixedRgb>,
}

impl SplatFilm {
    pub(crate) fn new(width: usize, height: usize) -> Self {
        Self { width, height, sums: (0..width * height).map(|_| FixedRgb::default()).collect() }
    }

    /// Adds `value` to the pixel containing image point `raster`.
    pub(crate) fn add(&self, raster: Vec2, value: Vec3) {
        let (x, y) = (raster.x.floor(), raster.y.floor());
        if x < 0.0 || y < 0.0 || x >= self.width as f32 || y >= self.height as f32 {
            return;
        }
        self.sums[y as usize * self.width + x as usize].add(value);
    }

    /// The sum at pixel `(x, y)`.
    pub(crate) fn get(&self, x: usize, y: usize) -> Vec3 {
        self.sums[y * self.width + x].get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splats_sum_exactly_in_any_order() {
        let film = SplatFilm::new(4, 2);
        let values = [0.1f32, 3.7e-3, 12.5, 1e-6, 0.33];
        for v in values {
            film.add(Vec2::new(2.5, 1.2), Vec3::new(v, 2.0 * v, 0.0));
        }
        let reversed = SplatFilm::new(4, 2);
        for v in values.iter().rev() {
            reversed.add(Vec2::new(2.9, 1.9), Vec3::new(*v, 2.0 * v, 0.0));
        }
        assert_eq!(film.get(2, 1), reversed.get(2, 1));
        let expected: f32 = values.iter().sum();
        assert!((film.get(2, 1).x - expected).abs() < 1e-6);
        assert_eq!(film.get(0, 0), Vec3::ZERO);
        film.add(Vec2::new(4.0, 0.0), Vec3::ONE); // off the image: dropped
        film.add(Vec2::new(0.0, 0.0), Vec3::splat(f32::NAN));
        assert_eq!(film.get(0, 0), Vec3::ZERO);
    }
}
