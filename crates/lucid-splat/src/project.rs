//! Projection of 3D Gaussians to screen-space ellipses (EWA splatting) and its exact backward.
//!
//! Each Gaussian `(μ, s = exp(log_s), q, logit, SH)` becomes a 2D Gaussian with mean
//! `π(Wμ + t)`, covariance `J W Σ Wᵀ Jᵀ + 0.3·I` (Σ = R S² Rᵀ, J the Jacobian of the pinhole
//! projection, 0.3 px² the low-pass that keeps every splat at least a pixel wide), stored
//! as its inverse (the conic); an opacity `sigmoid(logit)`; and a colour from the SH
//! coefficients along the direction from the camera, `max(Σ Y_k c_k + 0.5, 0)`. The backward
//! recomputes these per Gaussian (cheaper than storing them) and applies the chain rule by
//! hand; `tests` checks it against finite differences.

use glam::{Mat3, Quat, Vec2, Vec3, Vec4};
use serde::{Deserialize, Serialize};

use crate::camera::SplatCamera;
use crate::sh::{SH_COEFFS, basis, basis_gradient};

/// Rest (non-DC) SH coefficients per Gaussian: 15 per channel, coefficient-major.
pub const SH_REST: usize = (SH_COEFFS - 1) * 3;

/// How splats are projected and blended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    /// Gaussians whose centre is nearer than this (view depth, scene units) are culled.
    pub near: f32,
    /// Variance in px² added to every screen-space covariance (anti-aliasing low-pass).
    pub low_pass: f32,
    /// Highest SH degree used (0..=3).
    pub sh_degree: usize,
    /// Colour behind the splats.
    pub background: [f32; 3],
    /// Blends weaker than this are skipped (1/255: invisible in 8 bits).
    pub min_alpha: f32,
    /// Screen footprint half-width in standard deviations along the major axis.
    pub extent_sigmas: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            near: 0.01,
            low_pass: 0.3,
            sh_degree: 3,
            background: [1.0; 3],
            min_alpha: 1.0 / 255.0,
            extent_sigmas: 3.0,
        }
    }
}

/// The parameters of a splat cloud as flat row-major slices (one row per Gaussian).
#[derive(Clone, Copy, Debug)]
pub struct SplatParams<'a> {
    /// `N×3` centres.
    pub means: &'a [f32],
    /// `N×3` log standard deviations along the local axes.
    pub log_scales: &'a [f32],
    /// `N×4` quaternions `(w, x, y, z)`, not necessarily normalised.
    pub rotations: &'a [f32],
    /// `N` opacity logits.
    pub opacities: &'a [f32],
    /// `N×3` DC SH coefficients.
    pub sh_dc: &'a [f32],
    /// `N×45` rest SH coefficients, `[k−1][channel]`.
    pub sh_rest: &'a [f32],
}

impl<'a> SplatParams<'a> {
    /// From the six arrays in the order of the fields (means, log-scales, rotations,
    /// opacities, DC and rest SH).
    pub fn from_kinds([means, log_scales, rotations, opacities, sh_dc, sh_rest]: [&'a [f32]; 6]) -> Self {
        Self { means, log_scales, rotations, opacities, sh_dc, sh_rest }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.opacities.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.opacities.is_empty()
    }

    /// Panics unless every slice has `len()` rows of the right width.
    pub fn check(&self) {
        let n = self.len();
        assert_eq!(self.means.len(), 3 * n, "means must be N×3");
        assert_eq!(self.log_scales.len(), 3 * n, "log-scales must be N×3");
        assert_eq!(self.rotations.len(), 4 * n, "rotations must be N×4");
        assert_eq!(self.sh_dc.len(), 3 * n, "DC SH must be N×3");
        assert_eq!(self.sh_rest.len(), SH_REST * n, "rest SH must be N×45");
    }

    #[inline(always)]
    fn vec3(s: &[f32], i: usize) -> Vec3 {
        Vec3::from_slice(&s[3 * i..3 * i + 3])
    }

    /// The SH coefficients of Gaussian `i`, `[k][channel]` for `k` in `0..16`.
    #[inline(always)]
    fn coeffs(&self, i: usize) -> [Vec3; SH_COEFFS] {
        let mut c = [Vec3::ZERO; SH_COEFFS];
        c[0] = Self::vec3(self.sh_dc, i);
        for (k, v) in self.sh_rest[SH_REST * i..SH_REST * (i + 1)].chunks_exact(3).enumerate() {
            c[k + 1] = Vec3::new(v[0], v[1], v[2]);
        }
        c
    }
}

/// A Gaussian on screen. `radius == 0` marks a culled one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectedSplat {
    /// Centre in pixels.
    pub mean: Vec2,
    /// Inverse screen covariance `(A, B, C)`: the weight at offset `d` is
    /// `exp(−½(A dx² + C dy²) − B dx dy)`.
    pub conic: [f32; 3],
    /// View depth, for sorting.
    pub depth: f32,
    /// `sigmoid(logit)`.
    pub opacity: f32,
    /// RGB.
    pub colour: [f32; 3],
    /// 3σ extent in pixels along the major axis (the screen size densification limits).
    pub radius: f32,
    /// Half-widths in pixels of the box outside which the splat's weight is below the blend
    /// threshold or beyond `extent_sigmas` (the smaller): the pixels it can touch.
    pub half_extent: Vec2,
}

/// `∂loss/∂` the screen-space quantities of one Gaussian.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectedGrad {
    /// Centre.
    pub mean: Vec2,
    /// Conic `(A, B, C)`.
    pub conic: [f32; 3],
    /// Opacity.
    pub opacity: f32,
    /// RGB.
    pub colour: [f32; 3],
}

impl std::ops::AddAssign for ProjectedGrad {
    fn add_assign(&mut self, o: Self) {
        self.mean += o.mean;
        self.opacity += o.opacity;
        for c in 0..3 {
            self.conic[c] += o.conic[c];
            self.colour[c] += o.colour[c];
        }
    }
}

/// `∂loss/∂` every parameter of one Gaussian.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatGrad {
    /// Centre.
    pub mean: Vec3,
    /// Log-scales.
    pub log_scale: Vec3,
    /// Quaternion `(w, x, y, z)`.
    pub rotation: [f32; 4],
    /// Opacity logit.
    pub opacity: f32,
    /// SH coefficients `[k][channel]`.
    pub sh: [Vec3; SH_COEFFS],
}

/// Everything the forward computes for one Gaussian, kept for its backward.
struct Forward {
    view: Vec3,
    clamped: [bool; 2],
    ratio: [f32; 2],
    q: Quat,
    q_norm: f32,
    rot: Mat3,
    scale: Vec3,
    sigma: Mat3,
    rows: [Vec3; 2],
    cov: [f32; 3],
    dir: Vec3,
    dir_len: f32,
    basis: [f32; SH_COEFFS],
    raw_colour: Vec3,
    opacity: f32,
    out: ProjectedSplat,
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

fn forward(p: &SplatParams, i: usize, cam: &SplatCamera, s: &RenderSettings) -> Option<Forward> {
    let mean = SplatParams::vec3(p.means, i);
    let view = cam.to_view(mean);
    if view.z < s.near {
        return None;
    }
    let r = &p.rotations[4 * i..4 * i + 4];
    let q_raw = Quat::from_xyzw(r[1], r[2], r[3], r[0]);
    let q_norm = q_raw.length();
    if q_norm.is_nan() || q_norm <= 0.0 {
        return None;
    }
    let q = q_raw / q_norm;
    let rot = Mat3::from_quat(q);
    let scale = SplatParams::vec3(p.log_scales, i).exp();
    let m = rot * Mat3::from_diagonal(scale);
    let sigma = m * m.transpose();

    let (lx, ly) = cam.ratio_limits();
    let (rx, ry) = (view.x / view.z, view.y / view.z);
    let ratio = [rx.clamp(lx[0], lx[1]), ry.clamp(ly[0], ly[1])];
    let clamped = [ratio[0] != rx, ratio[1] != ry];
    let z = view.z;
    // Rows of J (with the clamped ratios), then of T = J·W as vectors in world space.
    let j0 = Vec3::new(cam.fx / z, 0.0, -cam.fx * ratio[0] / z);
    let j1 = Vec3::new(0.0, cam.fy / z, -cam.fy * ratio[1] / z);
    let wt = cam.rotation.transpose();
    let rows = [wt * j0, wt * j1];
    let (st0, st1) = (sigma * rows[0], sigma * rows[1]);
    let cov = [rows[0].dot(st0) + s.low_pass, rows[0].dot(st1), rows[1].dot(st1) + s.low_pass];
    let det = cov[0] * cov[2] - cov[1] * cov[1];
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    let conic = [cov[2] / det, -cov[1] / det, cov[0] / det];
    let mid = 0.5 * (cov[0] + cov[2]);
    let lambda = mid + (mid * mid - det).max(0.1).sqrt();
    let radius = (s.extent_sigmas * lambda.sqrt()).ceil();
    let opacity = sigmoid(p.opacities[i]);
    // Mahalanobis radius² at which the weight falls to the blend threshold, capped at the
    // footprint's extent; the box around that ellipse bounds every pixel the splat touches.
    let reach2 = (2.0 * (opacity / s.min_alpha).ln()).min(s.extent_sigmas * s.extent_sigmas);
    if reach2.is_nan() || reach2 <= 0.0 {
        return None;
    }
    let half_extent = Vec2::new((reach2 * cov[0]).sqrt(), (reach2 * cov[2]).sqrt());
    let centre = Vec2::new(cam.cx + cam.fx * view.x / z, cam.cy + cam.fy * view.y / z);
    // Off-screen: no pixel centre within reach (before the colour, the costly part).
    let size = Vec2::new(cam.width as f32, cam.height as f32);
    if (centre + half_extent).cmplt(Vec2::splat(0.5)).any() || (centre - half_extent).cmpgt(size - 0.5).any() {
        return None;
    }

    let d = mean - cam.position;
    let dir_len = d.length();
    let dir = if dir_len > 0.0 { d / dir_len } else { Vec3::Z };
    let basis = basis(dir, s.sh_degree);
    let coeffs = p.coeffs(i);
    let mut raw_colour = Vec3::splat(0.5);
    for (y, c) in basis.iter().zip(&coeffs).take(crate::sh::coeffs_for_degree(s.sh_degree)) {
        raw_colour += *y * *c;
    }
    let colour = raw_colour.max(Vec3::ZERO);
    let out = ProjectedSplat { mean: centre, conic, depth: z, opacity, colour: colour.to_array(), radius, half_extent };
    Some(Forward {
        view,
        clamped,
        ratio,
        q,
        q_norm,
        rot,
        scale,
        sigma,
        rows,
        cov,
        dir,
        dir_len,
        basis,
        raw_colour,
        opacity,
        out,
    })
}

/// Projects Gaussian `i`; `None` if it is culled (behind the near plane, degenerate).
pub fn project_one(p: &SplatParams, i: usize, cam: &SplatCamera, s: &RenderSettings) -> ProjectedSplat {
    forward(p, i, cam, s).map(|f| f.out).unwrap_or_default()
}

/// `∂loss/∂parameters` of Gaussian `i` from `∂loss/∂` its screen-space quantities.
pub fn project_backward_one(
    p: &SplatParams,
    i: usize,
    cam: &SplatCamera,
    s: &RenderSettings,
    g: &ProjectedGrad,
) -> SplatGrad {
    let mut out = SplatGrad::default();
    let Some(f) = forward(p, i, cam, s) else { return out };
    let z = f.view.z;

    // Colour: SH coefficients and, through the viewing direction, the centre.
    let gc = Vec3::from_array(g.colour);
    let gc = Vec3::select(f.raw_colour.cmpgt(Vec3::ZERO), gc, Vec3::ZERO);
    let used = crate::sh::coeffs_for_degree(s.sh_degree);
    let grad_basis = basis_gradient(f.dir, s.sh_degree);
    let coeffs = p.coeffs(i);
    let mut g_dir = Vec3::ZERO;
    for (k, ((y, dy), c)) in f.basis.iter().zip(&grad_basis).zip(&coeffs).enumerate().take(used) {
        out.sh[k] = *y * gc;
        g_dir += gc.dot(*c) * *dy;
    }
    if f.dir_len > 0.0 {
        out.mean += (g_dir - f.dir * f.dir.dot(g_dir)) / f.dir_len;
    }

    // Opacity.
    out.opacity = g.opacity * f.opacity * (1.0 - f.opacity);

    // Conic → screen covariance.
    let [a, b, c] = f.cov;
    let det = a * c - b * b;
    let det2 = det * det;
    let [ga_, gb_, gc_] = g.conic;
    let g_a = ga_ * (-c * c / det2) + gb_ * (b * c / det2) + gc_ * (1.0 / det - a * c / det2);
    let g_b = ga_ * (2.0 * b * c / det2) + gb_ * (-1.0 / det - 2.0 * b * b / det2) + gc_ * (2.0 * a * b / det2);
    let g_c = ga_ * (1.0 / det - a * c / det2) + gb_ * (a * b / det2) + gc_ * (-a * a / det2);

    // Screen covariance → Σ and the rows of T = J·W.
    let [t0, t1] = f.rows;
    let g_sigma = g_a * outer(t0, t0) + g_b * outer(t0, t1) + g_c * outer(t1, t1);
    let g_t0 = 2.0 * g_a * (f.sigma * t0) + g_b * (f.sigma * t1);
    let g_t1 = 2.0 * g_c * (f.sigma * t1) + g_b * (f.sigma * t0);
    let (g_j0, g_j1) = (cam.rotation * g_t0, cam.rotation * g_t1);

    // J → view position (through z and the possibly clamped ratios).
    let mut g_view = Vec3::ZERO;
    let (fx, fy) = (cam.fx, cam.fy);
    g_view.z += -g_j0.x * fx / (z * z) - g_j1.y * fy / (z * z);
    // J02 = −fx·ratio/z with ratio = x/z unclamped, or a constant when clamped.
    for (axis, (gj, focal)) in [(g_j0.z, fx), (g_j1.z, fy)].into_iter().enumerate() {
        let ratio = f.ratio[axis];
        if f.clamped[axis] {
            g_view.z += gj * focal * ratio / (z * z);
        } else {
            // −focal·x/z²: ∂/∂x = −focal/z², ∂/∂z = 2·focal·x/z³.
            let x = f.view[axis];
            g_view[axis] += -gj * focal / (z * z);
            g_view.z += gj * 2.0 * focal * x / (z * z * z);
        }
    }
    // Screen centre.
    g_view.x += g.mean.x * fx / z;
    g_view.y += g.mean.y * fy / z;
    g_view.z -= (g.mean.x * fx * f.view.x + g.mean.y * fy * f.view.y) / (z * z);
    out.mean += cam.rotation.transpose() * g_view;

    // Σ = M Mᵀ, M = R·diag(s).
    let m = f.rot * Mat3::from_diagonal(f.scale);
    let g_m = (g_sigma + g_sigma.transpose()) * m;
    let mut g_rot = Mat3::ZERO;
    for j in 0..3 {
        let (col_m, col_r) = (g_m.col(j), f.rot.col(j));
        out.log_scale[j] = col_m.dot(col_r) * f.scale[j];
        *g_rot.col_mut(j) = col_m * f.scale[j];
    }
    let gq = quat_backward(f.q, &g_rot);
    // Through the normalisation q̂ = q/|q|.
    let q = Vec4::from(f.q);
    let gq = (gq - q * q.dot(gq)) / f.q_norm;
    out.rotation = [gq.w, gq.x, gq.y, gq.z];
    out
}

fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// `∂loss/∂q̂` of the unit quaternion, as `(x, y, z, w)`, from `∂loss/∂R` (`g.col(j)[i]`
/// is `∂/∂R_ij`).
fn quat_backward(q: Quat, g: &Mat3) -> Vec4 {
    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
    let r = |i: usize, j: usize| g.col(j)[i];
    let gw = 2.0 * (-z * r(0, 1) + y * r(0, 2) + z * r(1, 0) - x * r(1, 2) - y * r(2, 0) + x * r(2, 1));
    let gx = 2.0
        * (y * r(0, 1) + z * r(0, 2) + y * r(1, 0) - 2.0 * x * r(1, 1) - w * r(1, 2) + z * r(2, 0) + w * r(2, 1)
            - 2.0 * x * r(2, 2));
    let gy = 2.0
        * (-2.0 * y * r(0, 0) + x * r(0, 1) + w * r(0, 2) + x * r(1, 0) + z * r(1, 2) - w * r(2, 0) + z * r(2, 1)
            - 2.0 * y * r(2, 2));
    let gz = 2.0
        * (-2.0 * z * r(0, 0) - w * r(0, 1) + x * r(0, 2) + w * r(1, 0) - 2.0 * z * r(1, 1)
            + y * r(1, 2)
            + x * r(2, 0)
            + y * r(2, 1));
    Vec4::new(gx, gy, gz, gw)
}

#[cfg(test)]
mod tests {
    use lucid_scene::Intrinsics;
    use lucid_scene::camera::{PinholeCamera, look_at};

    use super::*;

    fn params(v: &[Vec<f32>]) -> SplatParams<'_> {
        SplatParams::from_kinds(std::array::from_fn(|k| v[k].as_slice()))
    }

    /// The projection's backward against central differences of a fixed linear function of
    /// its outputs.
    #[test]
    fn projection_backward_matches_finite_differences() {
        let k = Intrinsics::from_fov_x(40, 28, 0.7);
        let cam =
            SplatCamera::from_pinhole(&PinholeCamera::new(k, look_at(Vec3::new(0.0, 2.5, 0.8), Vec3::ZERO, Vec3::Z)));
        let s = RenderSettings::default();
        let mut v: Vec<Vec<f32>> = vec![
            vec![0.1, -0.2, 0.15],
            vec![-1.7, -2.0, -1.8],
            vec![0.9, 0.2, -0.3, 0.4],
            vec![0.3],
            vec![0.5, 0.7, 0.9],
            (0..SH_REST).map(|k| 0.05 * ((k * 7 % 11) as f32 - 5.0) / 5.0).collect(),
        ];
        let g = ProjectedGrad {
            mean: Vec2::new(0.7, -0.4),
            conic: [2.0, -3.0, 1.5],
            opacity: 0.8,
            colour: [0.3, -0.6, 0.9],
        };
        let objective = |v: &Vec<Vec<f32>>| -> f64 {
            let p = params(v);
            let o = project_one(&p, 0, &cam, &s);
            assert!(o.radius > 0.0);
            let mut f = (g.mean.x * o.mean.x + g.mean.y * o.mean.y + g.opacity * o.opacity) as f64;
            for c in 0..3 {
                f += (g.conic[c] * o.conic[c] + g.colour[c] * o.colour[c]) as f64;
            }
            f
        };
        let p = params(&v);
        let a = project_backward_one(&p, 0, &cam, &s, &g);
        let analytic: Vec<Vec<f32>> = vec![
            a.mean.to_array().to_vec(),
            a.log_scale.to_array().to_vec(),
            a.rotation.to_vec(),
            vec![a.opacity],
            a.sh[0].to_array().to_vec(),
            a.sh[1..].iter().flat_map(|c| c.to_array()).collect(),
        ];
        let h = 1e-3;
        for kind in 0..v.len() {
            for k in 0..v[kind].len() {
                let orig = v[kind][k];
                v[kind][k] = orig + h;
                let plus = objective(&v);
                v[kind][k] = orig - h;
                let minus = objective(&v);
                v[kind][k] = orig;
                let fd = ((plus - minus) / (2.0 * h as f64)) as f32;
                let an = analytic[kind][k];
                assert!((fd - an).abs() <= 1e-2 * (1.0 + fd.abs()), "kind {kind} [{k}]: fd {fd} vs analytic {an}");
            }
        }
    }
}
