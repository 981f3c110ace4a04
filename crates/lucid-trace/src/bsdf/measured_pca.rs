//! Principal components of measured BRDFs (Matusik et al. 2003 built their data-driven
//! reflectance model this way): the tables are vectors of 3 · 90 · 90 · 180 values; their mean
//! and the leading eigenvectors of their covariance span a space in which a new table is
//! fitted by projection, then clamped to non-negative values (a BRDF cannot be negative).
//!
//! With far fewer tables (N) than values, the eigenvectors come from the N × N Gram matrix of
//! the centred tables: if `G v = λ v` then `Xᵀ v / √λ` is a unit eigenvector of `Xᵀ X`. The
//! N × N eigenproblem is solved by cyclic Jacobi rotations, written here: a few dozen lines for
//! a small symmetric matrix, where a linear-algebra crate would be a large dependency for it.

use glam::Vec3;

use super::measured::MerlTable;

/// A PCA basis of measured BRDFs.
pub struct BrdfPca {
    mean: Vec<f32>,
    /// Unit components, largest variance first.
    components: Vec<Vec<f32>>,
    /// Their variances (eigenvalues of the Gram matrix).
    variances: Vec<f64>,
}

fn flatten(table: &MerlTable) -> Vec<f32> {
    table.values().iter().flat_map(|v| v.to_array()).collect()
}

impl BrdfPca {
    /// The basis of `k` components of `tables` (at most one fewer than the tables).
    pub fn fit(tables: &[&MerlTable], k: usize) -> Result<Self, String> {
        let vectors: Vec<Vec<f32>> = tables.iter().map(|t| flatten(t)).collect();
        Self::fit_vectors(&vectors, k)
    }

    /// The basis of `k` components of equally long `vectors`.
    pub fn fit_vectors(vectors: &[Vec<f32>], k: usize) -> Result<Self, String> {
        let n = vectors.len();
        if n < 2 {
            return Err(format!("PCA needs at least two tables, got {n}"));
        }
        if k == 0 || k >= n {
            return Err(format!("{k} components from {n} tables: give 1 to {}", n - 1));
        }
        let d = vectors[0].len();
        let mut mean = vec![0.0f64; d];
        for v in vectors {
            for (m, x) in mean.iter_mut().zip(v) {
                *m += *x as f64 / n as f64;
            }
        }
        let centred: Vec<Vec<f64>> =
            vectors.iter().map(|v| v.iter().zip(&mean).map(|(x, m)| *x as f64 - m).collect()).collect();
        let mut gram = vec![vec![0.0f64; n]; n];
        for i in 0..n {
            for j in i..n {
                let g: f64 = centred[i].iter().zip(&centred[j]).map(|(a, b)| a * b).sum();
                gram[i][j] = g;
                gram[j][i] = g;
            }
        }
        let (values, vectors_of_gram) = jacobi_eigen(gram);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| values[b].total_cmp(&values[a]));
        let mut components = Vec::with_capacity(k);
        let mut variances = Vec::with_capacity(k);
        for &e in order.iter().take(k) {
            let lambda = values[e];
            if lambda <= 1e-12 * values[order[0]].max(1e-300) {
                break;
            }
            let mut c = vec![0.0f64; d];
            for (i, row) in centred.iter().enumerate() {
                let w = vectors_of_gram[i][e] / lambda.sqrt();
                for (ci, x) in c.iter_mut().zip(row) {
                    *ci += w * x;
                }
            }
            components.push(c.into_iter().map(|x| x as f32).collect());
            variances.push(lambda);
        }
        Ok(Self { mean: mean.into_iter().map(|m| m as f32).collect(), components, variances })
    }

    /// Components kept.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// Whether no component was kept.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// Share of the tables' variance the components explain.
    pub fn variances(&self) -> &[f64] {
        &self.variances
    }

    /// `vector` projected on the basis: mean plus its components, clamped at 0.
    pub fn reconstruct_vector(&self, vector: &[f32]) -> Vec<f32> {
        let mut out: Vec<f64> = self.mean.iter().map(|&m| m as f64).collect();
        for c in &self.components {
            let coefficient: f64 =
                c.iter().zip(vector).zip(&self.mean).map(|((e, x), m)| *e as f64 * (*x - *m) as f64).sum();
            for (o, e) in out.iter_mut().zip(c) {
                *o += coefficient * *e as f64;
            }
        }
        out.into_iter().map(|x| x.max(0.0) as f32).collect()
    }

    /// `table` fitted in the basis (non-negative).
    pub fn reconstruct(&self, table: &MerlTable) -> MerlTable {
        let flat = self.reconstruct_vector(&flatten(table));
        MerlTable::from_values(flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
    }
}

/// Relative RMS difference `‖a − b‖ / ‖b‖` of two tables.
pub fn relative_rms(a: &MerlTable, b: &MerlTable) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (x, y) in a.values().iter().zip(b.values()) {
        num += (*x - *y).length_squared() as f64;
        den += y.length_squared() as f64;
    }
    (num / den.max(1e-300)).sqrt()
}

/// Eigenvalues and eigenvectors (columns) of a symmetric matrix by cyclic Jacobi rotations.
fn jacobi_eigen(mut a: Vec<Vec<f64>>) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut v = vec![vec![0.0; n]; n];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let scale: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum::<f64>().max(1e-300);
        if off <= 1e-24 * scale {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let sign = if theta >= 0.0 { 1.0 } else { -1.0 };
                let t = sign / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (row_p, row_q) = (a[p].clone(), a[q].clone());
                for (k, (apk, aqk)) in row_p.into_iter().zip(row_q).enumerate() {
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut() {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i][i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn jacobi_finds_the_eigenpairs_of_a_symmetric_matrix() {
        let m = vec![vec![4.0, 1.0, 2.0], vec![1.0, 3.0, 0.5], vec![2.0, 0.5, 5.0]];
        let (values, vectors) = jacobi_eigen(m.clone());
        for e in 0..3 {
            for i in 0..3 {
                let mv: f64 = (0..3).map(|j| m[i][j] * vectors[j][e]).sum();
                assert!((mv - values[e] * vectors[i][e]).abs() < 1e-9, "eigenpair {e}");
            }
        }
        assert!((values.iter().sum::<f64>() - 12.0).abs() < 1e-9, "trace");
    }

    /// Vectors mixed from three patterns: three components reconstruct them exactly (the
    /// centred data has rank 3), fewer leave an error that falls with each component.
    #[test]
    fn pca_reconstructs_what_its_components_span() {
        let d = 500;
        let mut rng = Rng::new(3, 0);
        let patterns: Vec<Vec<f32>> = (0..3).map(|_| (0..d).map(|_| rng.uniform()).collect()).collect();
        let vectors: Vec<Vec<f32>> = (0..6)
            .map(|_| {
                let w = [rng.uniform(), rng.uniform(), rng.uniform()];
                (0..d).map(|i| w[0] * patterns[0][i] + w[1] * patterns[1][i] + w[2] * patterns[2][i]).collect()
            })
            .collect();
        let error = |k: usize| {
            let pca = BrdfPca::fit_vectors(&vectors, k).unwrap();
            vectors
                .iter()
                .map(|v| {
                    let r = pca.reconstruct_vector(v);
                    let num: f32 = r.iter().zip(v).map(|(a, b)| (a - b).powi(2)).sum();
                    let den: f32 = v.iter().map(|b| b * b).sum();
                    (num / den).sqrt()
                })
                .fold(0.0f32, f32::max)
        };
        let (one, two, three) = (error(1), error(2), error(3));
        assert!(one > two && two > 1e-3 && three < 1e-4, "{one} {two} {three}");
        assert!(BrdfPca::fit_vectors(&vectors, 6).is_err() && BrdfPca::fit_vectors(&vectors[..1], 1).is_err());
    }
}
