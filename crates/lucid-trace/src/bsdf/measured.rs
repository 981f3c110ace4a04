//! Measured isotropic BRDFs tabulated in Rusinkiewicz's half/difference angles, in the MERL
//! binary format (Matusik et al. 2003): three little-endian i32 dimensions (90, 90, 180), then
//! three channels of 90·90·180 little-endian f64, indexed `φd + 180·(θd + 90·θh)`; θh is
//! stored on a square-root scale (index = √(θh/90°)·90), θd and φd ∈ [0°, 180°) linearly;
//! the channels are scaled by 1/1500, 1.15/1500 and 1.66/1500; negative values mark
//! missing measurements (read as 0).
//!
//! Lookups interpolate trilinearly between cell centres (φd wraps: reciprocity folds it into
//! [0, π)). Sampling mixes a cosine lobe (a quarter) with half vectors drawn from a tabulated
//! distribution over θh whose weights are the table's mean value in each θh band.

use std::f32::consts::{FRAC_PI_2, PI};
use std::path::Path;

use glam::{Vec2, Vec3};

use super::half_vector::{HalfVectorDistribution, normal_incidence_albedo};
use super::{Bsdf, BsdfSample, reflect, upper_pair};

/// Table resolution in θh.
pub const THETA_H: usize = 90;
/// Table resolution in θd.
pub const THETA_D: usize = 90;
/// Table resolution in φd.
pub const PHI_D: usize = 180;
const CELLS: usize = THETA_H * THETA_D * PHI_D;
/// MERL's channel scale factors (stored value × factor = BRDF).
const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// Why a table could not be read.
#[derive(Debug, thiserror::Error)]
pub enum MerlError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// The file is not a MERL table.
    #[error("{path}: not a MERL BRDF table: {reason}")]
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// A tabulated isotropic BRDF.
pub struct MerlTable {
    values: Vec<Vec3>,
    /// Where sampled half vectors go.
    half_vectors: HalfVectorDistribution,
    /// Hemispherical reflectance at normal incidence (for the albedo buffer).
    normal_albedo: Vec3,
}

/// Tables are compared by identity: two loads of one file are one table.
impl PartialEq for MerlTable {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl std::fmt::Debug for MerlTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MerlTable({THETA_H}×{THETA_D}×{PHI_D})")
    }
}

/// Rusinkiewicz's coordinates `(θh, θd, φd)` of the pair, φd folded into [0, π).
pub fn half_diff(wo: Vec3, wi: Vec3) -> (f32, f32, f32) {
    let h = (wo + wi).normalize();
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let phi_h = h.y.atan2(h.x);
    // wi in the frame where h is the pole: rotate by −φh about z, then by −θh about y.
    let (sp, cp) = (-phi_h).sin_cos();
    let d = Vec3::new(wi.x * cp - wi.y * sp, wi.x * sp + wi.y * cp, wi.z);
    let (st, ct) = (-theta_h).sin_cos();
    let d = Vec3::new(d.x * ct + d.z * st, d.y, -d.x * st + d.z * ct);
    let theta_d = d.z.clamp(-1.0, 1.0).acos();
    let mut phi_d = d.y.atan2(d.x);
    if phi_d < 0.0 {
        phi_d += PI;
    }
    (theta_h, theta_d, phi_d.min(PI - 1e-6))
}

/// A pair `(wo, wi)` with coordinates `(θh, θd, φd)` and φh = 0.
pub fn from_half_diff(theta_h: f32, theta_d: f32, phi_d: f32) -> (Vec3, Vec3) {
    let d = Vec3::new(theta_d.sin() * phi_d.cos(), theta_d.sin() * phi_d.sin(), theta_d.cos());
    // Rotate by θh about y (back out of the half vector's frame).
    let (st, ct) = theta_h.sin_cos();
    let wi = Vec3::new(d.x * ct + d.z * st, d.y, -d.x * st + d.z * ct);
    let h = Vec3::new(st, 0.0, ct);
    (reflect(wi, h), wi)
}

impl MerlTable {
    fn with_values(values: Vec<Vec3>) -> Self {
        // Mean luminance of each θh band.
        let weights: Vec<f32> = (0..THETA_H)
            .map(|k| {
                let band = &values[k * THETA_D * PHI_D..(k + 1) * THETA_D * PHI_D];
                band.iter().map(|v| v.dot(Vec3::new(0.2126, 0.7152, 0.0722)) as f64).sum::<f64>() as f32
                    / band.len() as f32
            })
            .collect();
        let half_vectors = HalfVectorDistribution::from_band_weights(&weights);
        let mut table = Self { values, half_vectors, normal_albedo: Vec3::ZERO };
        table.normal_albedo = normal_incidence_albedo(|wo, wi| {
            let (h, d, p) = half_diff(wo, wi);
            table.lookup(h, d, p)
        });
        table
    }

    /// A table from its cells' values (BRDF units, `φd + 180·(θd + 90·θh)` order).
    ///
    /// # Panics
    /// If there are not 90 · 90 · 180 values.
    pub fn from_values(values: Vec<Vec3>) -> Self {
        assert_eq!(values.len(), CELLS, "a MERL table has 90 · 90 · 180 cells");
        Self::with_values(values)
    }

    /// Hemispherical reflectance at normal incidence.
    pub fn normal_albedo(&self) -> Vec3 {
        self.normal_albedo
    }

    /// The cells' values.
    pub fn values(&self) -> &[Vec3] {
        &self.values
    }

    /// Tabulates `f(wo, wi)` at the cells' centres.
    pub fn from_fn(f: impl Fn(Vec3, Vec3) -> Vec3 + Sync) -> Self {
        use rayon::prelude::*;
        let values = (0..CELLS)
            .into_par_iter()
            .map(|i| {
                let (p, d, h) = (i % PHI_D, (i / PHI_D) % THETA_D, i / (PHI_D * THETA_D));
                let x = (h as f32 + 0.5) / THETA_H as f32;
                let theta_h = x * x * FRAC_PI_2;
                let theta_d = (d as f32 + 0.5) / THETA_D as f32 * FRAC_PI_2;
                let phi_d = (p as f32 + 0.5) / PHI_D as f32 * PI;
                let (wo, wi) = from_half_diff(theta_h, theta_d, phi_d);
                // A centre below the horizon still serves lookups above it, between it and its
                // neighbours: lift it to just above the horizon rather than store a black cell.
                let lift = |w: Vec3| if w.z > 1e-3 { w } else { Vec3::new(w.x, w.y, 1e-3).normalize() };
                f(lift(wo), lift(wi)).max(Vec3::ZERO)
            })
            .collect();
        Self::with_values(values)
    }

    /// Reads a MERL `.binary` file.
    pub fn read(path: &Path) -> Result<Self, MerlError> {
        let bytes = std::fs::read(path).map_err(|source| MerlError::Io { path: path.to_path_buf(), source })?;
        let bad = |reason: String| MerlError::Format { path: path.to_path_buf(), reason };
        if bytes.len() < 12 {
            return Err(bad(format!("{} bytes, shorter than its header", bytes.len())));
        }
        let dims: Vec<i32> =
            bytes[..12].chunks(4).map(|c| i32::from_le_bytes(c.try_into().expect("4 bytes"))).collect();
        if dims != [THETA_H as i32, THETA_D as i32, PHI_D as i32] {
            return Err(bad(format!("dimensions {dims:?}, expected [90, 90, 180]")));
        }
        let expected = 12 + 3 * CELLS * 8;
        if bytes.len() != expected {
            return Err(bad(format!("{} bytes, expected {expected}", bytes.len())));
        }
        let mut values = vec![Vec3::ZERO; CELLS];
        for (c, scale) in SCALE.iter().enumerate() {
            let channel = &bytes[12 + c * CELLS * 8..12 + (c + 1) * CELLS * 8];
            for (i, chunk) in channel.chunks_exact(8).enumerate() {
                let v = f64::from_le_bytes(chunk.try_into().expect("8 bytes"));
                if !v.is_finite() {
                    return Err(bad(format!("value {v} at cell {i} of channel {c}")));
                }
                values[i][c] = (v.max(0.0) * scale) as f32;
            }
        }
        Ok(Self::with_values(values))
    }

    /// Writes the table as a MERL `.binary` file (through a temporary name, then renamed).
    pub fn write(&self, path: &Path) -> Result<(), MerlError> {
        let mut bytes = Vec::with_capacity(12 + 3 * CELLS * 8);
        for d in [THETA_H, THETA_D, PHI_D] {
            bytes.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for (c, scale) in SCALE.iter().enumerate() {
            for v in &self.values {
                bytes.extend_from_slice(&(v[c] as f64 / scale).to_le_bytes());
            }
        }
        let io = |source| MerlError::Io { path: path.to_path_buf(), source };
        let tmp = path.with_extension("binary.partial");
        std::fs::write(&tmp, &bytes).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// The table kept for the rest of the process (BSDFs are plain values that borrow it).
    pub fn leak(self) -> &'static MerlTable {
        Box::leak(Box::new(self))
    }

    /// The table in `path`, read once per process and kept (17 MB per file): scenes loaded
    /// again, by benchmarks or the viewer, share it.
    pub fn load_shared(path: &Path) -> Result<&'static MerlTable, MerlError> {
        let io = |source| MerlError::Io { path: path.to_path_buf(), source };
        super::shared_file::load_shared(path, io, Self::read)
    }

    /// The value at `(θh, θd, φd)`, trilinear between cell centres.
    pub fn lookup(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> Vec3 {
        let axis = |u: f32, n: usize, wrap: bool| -> [(usize, f32); 2] {
            let c = u - 0.5;
            let i = c.floor();
            let t = c - i;
            let (i0, i1) = (i as i64, i as i64 + 1);
            let fix = |j: i64| if wrap { j.rem_euclid(n as i64) as usize } else { j.clamp(0, n as i64 - 1) as usize };
            [(fix(i0), 1.0 - t), (fix(i1), t)]
        };
        let uh = (theta_h.max(0.0) / FRAC_PI_2).sqrt() * THETA_H as f32;
        let ud = theta_d.max(0.0) / FRAC_PI_2 * THETA_D as f32;
        let up = phi_d / PI * PHI_D as f32;
        let mut sum = Vec3::ZERO;
        for (h, wh) in axis(uh, THETA_H, false) {
            for (d, wd) in axis(ud, THETA_D, false) {
                for (p, wp) in axis(up, PHI_D, true) {
                    sum += self.values[p + PHI_D * (d + THETA_D * h)] * (wh * wd * wp);
                }
            }
        }
        sum
    }
}

/// A measured BRDF at a surface point.
#[derive(Clone, Copy, Debug)]
pub struct MeasuredBrdf {
    /// The table.
    pub table: &'static MerlTable,
}

impl MeasuredBrdf {
    fn upper_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.table.half_vectors.direction_pdf(wo, wi)
    }
}

impl Bsdf for MeasuredBrdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return Vec3::ZERO };
        let (h, d, p) = half_diff(wo, wi);
        self.table.lookup(h, d, p)
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let up = if flip { -wo } else { wo };
        let wi = self.table.half_vectors.sample_direction(up, u, uc)?;
        let pdf = self.upper_pdf(up, wi);
        let (h, d, p) = half_diff(up, wi);
        let f = self.table.lookup(h, d, p);
        let wi = if flip { -wi } else { wi };
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return 0.0 };
        self.upper_pdf(wo, wi)
    }
}

/// Lambert's constant, for tests of tabulation.
#[cfg(test)]
const LAMBERT: f32 = std::f32::consts::FRAC_1_PI;

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;
    use crate::bsdf::{GgxDistribution, MicrofacetConductor};
    use crate::sampling::{Rng, uniform_sphere};

    #[test]
    fn half_difference_coordinates_round_trip() {
        let mut rng = Rng::new(1, 0);
        for _ in 0..10_000 {
            let (th, td, pd) = (rng.uniform() * 1.5, rng.uniform() * 1.5, rng.uniform() * 3.1);
            let (wo, wi) = from_half_diff(th, td, pd);
            let (h, d, p) = half_diff(wo, wi);
            assert!((h - th).abs() < 2e-3 && (d - td).abs() < 2e-3, "{th} {td} → {h} {d}");
            assert!((p - pd).abs() < 2e-3 || td < 1e-2, "{pd} → {p}");
        }
        // Rotating the pair about the normal changes nothing; swapping the directions only φd's
        // fold.
        for _ in 0..1000 {
            let mut wo = uniform_sphere(rng.uniform2());
            let mut wi = uniform_sphere(rng.uniform2());
            (wo.z, wi.z) = (wo.z.abs(), wi.z.abs());
            let rotate = |v: Vec3, a: f32| Vec3::new(v.x * a.cos() - v.y * a.sin(), v.x * a.sin() + v.y * a.cos(), v.z);
            let (a, b) = (half_diff(wo, wi), half_diff(rotate(wo, 0.7), rotate(wi, 0.7)));
            assert!((a.0 - b.0).abs() < 1e-3 && (a.1 - b.1).abs() < 1e-3, "{a:?} {b:?}");
        }
    }

    #[test]
    fn a_lambertian_table_is_exact_and_survives_the_file_format() {
        let table = MerlTable::from_fn(|_, _| Vec3::new(0.8, 0.5, 0.2) * LAMBERT);
        let dir = std::env::temp_dir().join(format!("lucid-merl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("lambert.binary");
        table.write(&path).unwrap();
        let back = MerlTable::read(&path).unwrap();
        let brdf = MeasuredBrdf { table: back.leak() };
        let mut rng = Rng::new(2, 0);
        for _ in 0..1000 {
            let mut wo = uniform_sphere(rng.uniform2());
            let mut wi = uniform_sphere(rng.uniform2());
            (wo.z, wi.z) = (wo.z.abs(), wi.z.abs());
            let f = brdf.eval(wo, wi);
            assert!((f - Vec3::new(0.8, 0.5, 0.2) * LAMBERT).abs().max_element() < 1e-5, "{f}");
        }
        // Broken files are refused with the file's name.
        let short = dir.join("short.binary");
        std::fs::write(&short, [90u8, 0, 0, 0]).unwrap();
        let err = MerlTable::read(&short).unwrap_err().to_string();
        assert!(err.contains("short.binary") && err.contains("header"), "{err}");
        let mut wrong = std::fs::read(&path).unwrap();
        wrong[0] = 45;
        std::fs::write(&short, &wrong).unwrap();
        assert!(MerlTable::read(&short).unwrap_err().to_string().contains("dimensions"));
        wrong[0] = 90;
        wrong.truncate(wrong.len() - 8);
        std::fs::write(&short, &wrong).unwrap();
        assert!(MerlTable::read(&short).unwrap_err().to_string().contains("bytes"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A table of a rough GGX metal reflects what the metal does, and its sampler matches its
    /// density.
    #[test]
    fn a_tabulated_ggx_metal_matches_the_analytic_one() {
        let metal = MicrofacetConductor {
            distribution: GgxDistribution { alpha_x: 0.3, alpha_y: 0.3 },
            eta: Vec3::new(0.2, 0.9, 1.1),
            k: Vec3::new(3.9, 2.4, 2.2),
        };
        let brdf = MeasuredBrdf { table: MerlTable::from_fn(|wo, wi| metal.eval(wo, wi)).leak() };
        for wo in outgoing_directions() {
            sample_matches_eval(&brdf, wo, 3000);
            let (a, b) = (albedo_by_sampling(&brdf, wo, 400_000), albedo_by_sampling(&metal, wo, 400_000));
            assert!((a - b).abs().max_element() < 0.02 + 0.02 * b.max_element(), "cos {}: {a} vs {b}", wo.z);
            let uniform = albedo_by_uniform(&brdf, wo, 1_000_000);
            assert!((a - uniform).abs().max_element() < 0.02 + 0.03 * uniform.max_element(), "{a} vs {uniform}");
            assert!(pdf_integral(&brdf, wo, 1_000_000) <= 1.02);
        }
        reciprocal(&brdf, 3000);
    }
}
