//! Piecewise-constant distributions in one and two dimensions, sampled by inverting their
//! cumulative distribution (pbrt's `Distribution1D`/`Distribution2D`).

use glam::Vec2;

/// A piecewise-constant density on `[0, 1)` with `n` equal cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    values: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
}

impl Distribution1D {
    /// From non-negative cell values (all zero gives the uniform distribution).
    pub fn new(values: Vec<f32>) -> Self {
        let n = values.len().max(1);
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f32);
        let mut acc = 0.0f64;
        for v in &values {
            acc += v.max(0.0) as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let integral = acc as f32;
        if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        Self { values, cdf, integral }
    }

    /// `∫ f` over `[0, 1)`.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True without cells.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Samples `x ∈ [0,1)`: returns `(x, density at x, cell index)`.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.values.len();
        let i = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let offset = if width > 0.0 { (u - self.cdf[i]) / width } else { 0.5 };
        let x = ((i as f32 + offset.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON);
        (x, self.pdf_cell(i), i)
    }

    /// Density of cell `i`.
    pub fn pdf_cell(&self, i: usize) -> f32 {
        if self.integral > 0.0 { self.values[i].max(0.0) / self.integral } else { 1.0 }
    }
}

/// A piecewise-constant density on `[0,1)²` over a `width × height` grid of cells (row-major,
/// row 0 at v = 0): a marginal over rows and a conditional within each row.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// From `width × height` non-negative values.
    pub fn new(values: &[f32], width: usize, height: usize) -> Self {
        let rows: Vec<Distribution1D> =
            (0..height).map(|y| Distribution1D::new(values[y * width..(y + 1) * width].to_vec())).collect();
        let marginal = Distribution1D::new(rows.iter().map(|r| r.integral()).collect());
        Self { rows, marginal }
    }

    /// Samples `(u, v)` and returns it with its density.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample(u.y);
        let (x, pdf_u, _) = self.rows[row].sample(u.x);
        (Vec2::new(x, v), pdf_v * pdf_u)
    }

    /// Density at `(u, v)`.
    pub fn pdf(&self, uv: Vec2) -> f32 {
        let h = self.rows.len();
        let w = self.rows[0].len();
        let iy = ((uv.y * h as f32) as usize).min(h - 1);
        let ix = ((uv.x * w as f32) as usize).min(w - 1);
        if self.marginal.integral() <= 0.0 {
            return 1.0;
        }
        self.rows[iy].values[ix].max(0.0) / self.marginal.integral()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn one_dimensional_sampling_follows_the_values() {
        let d = Distribution1D::new(vec![1.0, 3.0, 0.0, 4.0]);
        assert!((d.integral() - 2.0).abs() < 1e-6);
        let mut counts = [0usize; 4];
        let mut rng = Rng::new(1, 0);
        let n = 200_000;
        for _ in 0..n {
            let (x, pdf, i) = d.sample(rng.uniform());
            assert_eq!(i, (x * 4.0) as usize);
            assert!((pdf - d.pdf_cell(i)).abs() < 1e-6);
            counts[i] += 1;
        }
        for (c, expected) in counts.iter().zip([0.125, 0.375, 0.0, 0.5]) {
            assert!((*c as f64 / n as f64 - expected).abs() < 0.005, "{counts:?}");
        }
    }

    #[test]
    fn two_dimensional_density_integrates_to_one_and_matches_samples() {
        let (w, h) = (8, 5);
        let values: Vec<f32> = (0..w * h).map(|i| ((i * 7) % 11) as f32).collect();
        let d = Distribution2D::new(&values, w, h);
        let mut total = 0.0;
        for y in 0..h {
            for x in 0..w {
                total += d.pdf(Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32)) / (w * h) as f32;
            }
        }
        assert!((total - 1.0).abs() < 1e-5);
        let mut rng = Rng::new(2, 0);
        for _ in 0..1000 {
            let (uv, pdf) = d.sample(rng.uniform2());
            assert!((pdf - d.pdf(uv)).abs() < 1e-4 * pdf.max(1.0), "{uv} {pdf} {}", d.pdf(uv));
            assert!(pdf > 0.0);
        }
    }
}
