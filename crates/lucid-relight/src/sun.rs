//! Restoring a clipped sun (the reference notes' "measuring sun saturation"): an HDR capture
//! of the sky clips the sun's disc at the sensor's ceiling, so the map holds far less of the
//! sun's light than the sky gave. A diffuse sphere of known albedo photographed under the same
//! sky shades with the true irradiance, `L = ρ/π · E(n)`; the clipped map predicts a smaller
//! `E`. The difference, over the sphere's normals, is the irradiance of the missing sun — the
//! clipped pixels' cosine lobe times one unknown radiance per channel — which a least-squares
//! fit finds and adds back to the clipped pixels.
//!
//! The ball fills the square sphere image, photographed from far out on +Y looking along −Y
//! with +Z up (so image right is −X), as a camera that sees it nearly orthographically.

use glam::Vec3;
use lucid_image::Image;

use crate::RelightError;
use crate::envmap::{pixel_direction, pixel_solid_angle};

/// Pixels whose brightest channel reaches this share of the map's maximum are clipped.
const CLIP_SHARE: f32 = 0.99;
/// A clipped region larger than this share of the sphere is not a sun.
const MAX_CLIPPED_SOLID_ANGLE: f32 = 0.01 * 4.0 * std::f32::consts::PI;
/// Sphere pixels beyond this radius (of the ball's) are left out: the rim's normals are
/// poorly resolved.
const MAX_BALL_RADIUS: f32 = 0.95;
/// The fit uses the normals that see this share of the sun's largest cosine lobe or more.
const MIN_SUN_SHARE: f32 = 0.3;
/// The unclipped sky is integrated at this width (its cosine-weighted integral is smooth).
const SKY_WIDTH: usize = 128;

/// What the fix found.
#[derive(Clone, Debug, PartialEq)]
pub struct SunFix {
    /// The level the map clips at (its brightest channel).
    pub clip_level: f32,
    /// Clipped pixels (the sun's disc in the map).
    pub clipped_pixels: usize,
    /// Their solid angle.
    pub solid_angle: f32,
    /// Radiance added to each clipped pixel, per channel.
    pub added: [f32; 3],
    /// The sun's direction (the clipped pixels' solid-angle-weighted mean).
    pub direction: Vec3,
    /// Sphere pixels the fit used.
    pub fitted_pixels: usize,
    /// RMS of the fit's residual relative to the mean measured radiance of those pixels.
    pub residual: f32,
}

/// The clipped pixels of `map`: `(index, direction, solid angle)`.
fn clipped(map: &Image) -> (f32, Vec<(usize, Vec3, f32)>) {
    let (w, h) = map.dimensions();
    let level = map.pixels().iter().map(|p| p[0].max(p[1]).max(p[2])).fold(0.0f32, f32::max);
    let pixels = (0..w * h)
        .filter(|&i| {
            let p = map.get(i % w, i / w);
            p[0].max(p[1]).max(p[2]) >= CLIP_SHARE * level
        })
        .map(|i| (i, pixel_direction(i % w, i / w, w, h), pixel_solid_angle(i / w, w, h)))
        .collect();
    (level, pixels)
}

/// The map without its clipped pixels, averaged down to `SKY_WIDTH × SKY_WIDTH/2` cells:
/// `(direction, solid angle, radiance)` of each cell.
fn sky_cells(map: &Image, skip: &[bool]) -> Vec<(Vec3, f32, Vec3)> {
    let (w, h) = map.dimensions();
    let (cw, chh) = (SKY_WIDTH.min(w), (SKY_WIDTH / 2).min(h));
    let mut sums = vec![(Vec3::ZERO, 0.0f32, Vec3::ZERO); cw * chh];
    for y in 0..h {
        let omega = pixel_solid_angle(y, w, h);
        for x in 0..w {
            if skip[y * w + x] {
                continue;
            }
            let p = map.get(x, y);
            let cell = &mut sums[(y * chh / h) * cw + x * cw / w];
            cell.0 += pixel_direction(x, y, w, h) * omega;
            cell.1 += omega;
            cell.2 += Vec3::new(p[0], p[1], p[2]) * omega;
        }
    }
    sums.into_iter().filter(|c| c.1 > 0.0).map(|(d, omega, l)| (d.normalize_or_zero(), omega, l / omega)).collect()
}

/// Restores the clipped sun of `map` (lat-long, linear) from `sphere`, a diffuse ball of
/// `albedo` photographed under the unclipped sky; returns the fixed map and what was found.
pub fn fix_sun(map: &Image, sphere: &Image, albedo: Vec3) -> Result<(Image, SunFix), RelightError> {
    let invalid = |s: String| RelightError::Invalid(s);
    let (w, h) = map.dimensions();
    if w != 2 * h {
        return Err(invalid(format!("the map is {w}×{h}; a lat-long map is twice as wide as high")));
    }
    let (bw, bh) = sphere.dimensions();
    if bw != bh || bw < 8 {
        return Err(invalid(format!("the sphere image is {bw}×{bh}; it must be square (the ball filling it)")));
    }
    if !(albedo.min_element() > 0.0 && albedo.max_element() <= 1.0) {
        return Err(invalid(format!("albedo {albedo} must be in (0, 1]")));
    }
    let (level, sun) = clipped(map);
    let solid_angle: f32 = sun.iter().map(|s| s.2).sum();
    if level <= 0.0 || sun.is_empty() {
        return Err(invalid("the map is black".into()));
    }
    if solid_angle > MAX_CLIPPED_SOLID_ANGLE {
        return Err(invalid(format!(
            "{} pixels ({solid_angle:.3} sr) reach the map's maximum {level}: not a clipped sun (does the map clip at all?)",
            sun.len()
        )));
    }
    let mut skip = vec![false; w * h];
    for s in &sun {
        skip[s.0] = true;
    }
    let sky = sky_cells(map, &skip);
    let clip: Vec<(Vec3, f32, Vec3)> = sun
        .iter()
        .map(|&(i, d, omega)| {
            let p = map.get(i % w, i / w);
            (d, omega, Vec3::new(p[0], p[1], p[2]))
        })
        .collect();
    let lobe = |n: Vec3| -> f32 { clip.iter().map(|(d, omega, _)| omega * n.dot(*d).max(0.0)).sum() };
    // Each usable sphere pixel: its normal, measured radiance and the clipped map's prediction.
    let mut samples = Vec::new();
    for y in 0..bh {
        for x in 0..bw {
            let s = 2.0 * (x as f32 + 0.5) / bw as f32 - 1.0;
            let t = 1.0 - 2.0 * (y as f32 + 0.5) / bh as f32;
            let r2 = s * s + t * t;
            if r2 > MAX_BALL_RADIUS * MAX_BALL_RADIUS {
                continue;
            }
            let n = Vec3::new(-s, (1.0 - r2).sqrt(), t);
            let irradiance: Vec3 =
                sky.iter().chain(&clip).map(|(d, omega, l)| *l * (*omega * n.dot(*d).max(0.0))).sum();
            let p = sphere.get(x, y);
            samples.push((lobe(n), Vec3::new(p[0], p[1], p[2]), albedo / std::f32::consts::PI * irradiance));
        }
    }
    let strongest = samples.iter().map(|s| s.0).fold(0.0f32, f32::max);
    if strongest <= 0.0 {
        return Err(invalid("no pixel of the ball faces the sun".into()));
    }
    let used: Vec<&(f32, Vec3, Vec3)> = samples.iter().filter(|s| s.0 >= MIN_SUN_SHARE * strongest).collect();
    // ΔL = k ρ/π K(n), per channel: k = Σ ΔL·a / Σ a², a = ρ/π K.
    let (mut num, mut den) = (Vec3::ZERO, Vec3::ZERO);
    for (k, measured, predicted) in &used {
        let a = albedo / std::f32::consts::PI * *k;
        num += (*measured - *predicted) * a;
        den += a * a;
    }
    let added = (num / den).max(Vec3::ZERO);
    let (mut residual, mut mean) = (0.0f32, 0.0f32);
    for (k, measured, predicted) in &used {
        let model = *predicted + albedo / std::f32::consts::PI * *k * added;
        residual += (*measured - model).length_squared() / 3.0;
        mean += measured.element_sum() / 3.0;
    }
    let residual = (residual / used.len() as f32).sqrt() / (mean / used.len() as f32).max(1e-12);
    let mut fixed = map.clone();
    for &(i, _, _) in &sun {
        let p = &mut fixed.pixels_mut()[i];
        for c in 0..3 {
            p[c] += added[c];
        }
    }
    let direction = clip.iter().map(|(d, omega, _)| *d * *omega).sum::<Vec3>().normalize_or_zero();
    Ok((
        fixed,
        SunFix {
            clip_level: level,
            clipped_pixels: sun.len(),
            solid_angle,
            added: added.to_array(),
            direction,
            fitted_pixels: used.len(),
            residual,
        },
    ))
}

#[cfg(test)]
mod tests;
