//! Single-channel planes and their Gaussian blur.
//!
//! Written by hand: the image crates blur 8-bit or RGBA buffers with direct convolution, while
//! the local tone mappers blur `f32` luminance at many scales, up to tens of pixels, where an
//! O(1)-per-pixel blur matters: large σ use three box filters by running sums (the
//! box-filter approximation of a Gaussian, Wells 1986; widths after Kovesi 2010), small σ an
//! exact sampled kernel.

use rayon::prelude::*;

/// A single-channel `f32` image, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// `width × height` values.
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane of one value.
    pub fn filled(width: usize, height: usize, v: f32) -> Self {
        Self { width, height, data: vec![v; width * height] }
    }

    /// A plane from a function of the pixel index.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize) -> f32 + Sync + Send) -> Self {
        Self { width, height, data: (0..width * height).into_par_iter().map(f).collect() }
    }

    /// Value at `(x, y)`.
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    fn transposed(&self) -> Plane {
        let (w, h) = (self.width, self.height);
        let mut data = vec![0.0f32; w * h];
        data.par_chunks_mut(h.max(1)).enumerate().for_each(|(x, col)| {
            for (y, v) in col.iter_mut().enumerate() {
                *v = self.data[y * w + x];
            }
        });
        Plane { width: h, height: w, data }
    }

    /// Applies `f` to every row, in parallel.
    fn rows(&self, f: impl Fn(&[f32], &mut [f32]) + Sync) -> Plane {
        let mut out = vec![0.0f32; self.data.len()];
        let w = self.width.max(1);
        out.par_chunks_mut(w).zip(self.data.par_chunks(w)).for_each(|(dst, src)| f(src, dst));
        Plane { width: self.width, height: self.height, data: out }
    }
}

/// The plane blurred by a Gaussian of standard deviation `sigma` pixels (edges replicated).
pub fn gaussian_blur(plane: &Plane, sigma: f32) -> Plane {
    if sigma <= 0.0 || plane.data.is_empty() {
        return plane.clone();
    }
    let pass = |p: &Plane| -> Plane {
        if sigma < 2.0 {
            let kernel = sampled_gaussian(sigma);
            p.rows(|src, dst| convolve_row(src, dst, &kernel))
        } else {
            let widths = box_widths(sigma);
            p.rows(|src, dst| {
                let mut a = src.to_vec();
                let mut b = vec![0.0f32; src.len()];
                for &r in &widths {
                    box_row(&a, &mut b, r);
                    std::mem::swap(&mut a, &mut b);
                }
                dst.copy_from_slice(&a);
            })
        }
    };
    let horizontal = pass(plane);
    pass(&horizontal.transposed()).transposed()
}

/// Normalised Gaussian taps out to 3σ.
fn sampled_gaussian(sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as i32;
    let taps: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f32 = taps.iter().sum();
    taps.into_iter().map(|t| t / sum).collect()
}

fn convolve_row(src: &[f32], dst: &mut [f32], kernel: &[f32]) {
    let r = (kernel.len() / 2) as isize;
    let n = src.len() as isize;
    for (x, out) in dst.iter_mut().enumerate() {
        let mut s = 0.0;
        for (k, &t) in kernel.iter().enumerate() {
            let i = (x as isize + k as isize - r).clamp(0, n - 1);
            s += t * src[i as usize];
        }
        *out = s;
    }
}

/// Radii of three box filters whose succession has variance σ² (Kovesi's widths).
fn box_widths(sigma: f32) -> [usize; 3] {
    let n = 3.0f32;
    let ideal = (12.0 * sigma * sigma / n + 1.0).sqrt();
    let mut wl = ideal.floor() as i32;
    if wl % 2 == 0 {
        wl -= 1;
    }
    let wu = wl + 2;
    let m = ((12.0 * sigma * sigma - n * (wl * wl) as f32 - 4.0 * n * wl as f32 - 3.0 * n) / (-4.0 * wl as f32 - 4.0))
        .round() as i32;
    let mut out = [0usize; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let w = if (i as i32) < m { wl } else { wu };
        *o = ((w - 1) / 2).max(0) as usize;
    }
    out
}

/// Mean over `[x−r, x+r]` with replicated edges, by a running sum.
fn box_row(src: &[f32], dst: &mut [f32], r: usize) {
    let n = src.len();
    let at = |i: isize| src[i.clamp(0, n as isize - 1) as usize] as f64;
    let r = r as isize;
    let mut sum: f64 = (-r..=r).map(at).sum();
    let norm = 1.0 / (2 * r + 1) as f64;
    for (x, out) in dst.iter_mut().enumerate() {
        *out = (sum * norm) as f32;
        let x = x as isize;
        sum += at(x + r + 1) - at(x - r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blurring an impulse gives a kernel of unit mass and variance σ² per axis.
    #[test]
    fn blur_of_an_impulse_has_the_right_mass_and_variance() {
        for sigma in [0.8f32, 1.5, 3.0, 7.5] {
            let n = 121;
            let mut p = Plane::filled(n, n, 0.0);
            p.data[60 * n + 60] = 1.0;
            let b = gaussian_blur(&p, sigma);
            let mass: f32 = b.data.iter().sum();
            let var: f32 = (0..n * n).map(|i| b.data[i] * ((i % n) as f32 - 60.0).powi(2)).sum::<f32>() / mass;
            assert!((mass - 1.0).abs() < 1e-3, "σ {sigma}: mass {mass}");
            assert!((var.sqrt() - sigma).abs() < 0.06 * sigma + 0.05, "σ {sigma}: measured {}", var.sqrt());
        }
    }

    #[test]
    fn constants_stay_constant() {
        let p = Plane::filled(37, 23, 0.7);
        for sigma in [0.5, 4.0, 30.0] {
            assert!(gaussian_blur(&p, sigma).data.iter().all(|v| (v - 0.7).abs() < 1e-5));
        }
    }
}
