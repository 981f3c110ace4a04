//! Free-form light stage calibration (the reference notes' relighting section): each OLAT
//! light's direction found from its highlight on chrome reference spheres, not taken on
//! trust from the generator.
//!
//! On a mirror sphere the light shows where the sphere's normal halves the angle between the
//! view ray and the light, so the light direction is the view direction reflected about the
//! normal there. The spheres of a capture are slightly rough (a mirror would show a delta
//! light as a point no pixel resolves), so each highlight is a lobe over a few pixels, and the
//! direction is the lobe's mean over reflected directions: each pixel's reflected direction
//! weighted by its radiance above the sphere's background and by the solid angle of reflected
//! directions it covers, which for a sphere seen from distance `t` is `4 Ω_pixel t² / R²`
//! (the obliquity cancels). Estimates from every sphere and view that sees the light are
//! combined, dropping outliers.

use glam::Vec3;
use lucid_image::Image;
use lucid_image::color::luminance;
use lucid_scene::{Camera, PinholeCamera};

/// A chrome reference sphere in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChromeSphere {
    /// Centre.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
}

/// One sphere's evidence for a light direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Highlight {
    /// Towards the light (unit, world space).
    pub direction: Vec3,
    /// The highlight's image position (sub-pixel, the lobe's radiance-weighted centroid).
    pub pixel: glam::Vec2,
    /// Cosine between the normal at the highlight and the direction to the camera: near the
    /// silhouette (small) the lobe is foreshortened and the estimate is poor.
    pub facing: f32,
    /// The highlight's brightest pixel (linear luminance).
    pub peak: f32,
}

/// Reflected directions farther than this from the peak's are not the highlight's lobe.
const LOBE_RADIUS: f32 = 0.35;
/// Highlights whose normal faces the camera less than this are refused.
const MIN_FACING: f32 = 0.3;
/// A highlight must be this many times brighter than the sphere's median pixel.
const MIN_CONTRAST: f32 = 4.0;
/// At least this many pixels of the sphere must be seen.
const MIN_PIXELS: usize = 12;

/// Distance along the unit ray `(origin, dir)` to its first hit of the sphere.
fn hit(origin: Vec3, dir: Vec3, sphere: &ChromeSphere) -> Option<f32> {
    let oc = origin - sphere.centre;
    let b = oc.dot(dir);
    let c = oc.length_squared() - sphere.radius * sphere.radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t > 0.0).then_some(t)
}

/// A pixel of the sphere: where its centre ray meets the sphere, and what it reflects.
struct SpherePixel {
    x: u32,
    y: u32,
    value: f32,
    /// Distance from the camera.
    t: f32,
    /// The view ray reflected about the normal.
    reflected: Vec3,
    facing: f32,
}

/// The highlight of `sphere` in `image` (linear radiance) seen by `camera`, if one stands out;
/// with `depth` (the frame's depth along the camera axis), pixels where something is in front
/// of the sphere are left out.
pub fn find_highlight(
    image: &Image,
    depth: Option<&Image>,
    camera: &PinholeCamera,
    sphere: &ChromeSphere,
) -> Option<Highlight> {
    let (w, h) = image.dimensions();
    let origin = camera.position();
    let forward = camera.forward();
    // The window that holds the sphere's image: its centre's projection ± its angular
    // radius's extent (generous: the projection of a sphere off-axis is an ellipse).
    let centre_px = camera.project(sphere.centre)?;
    let distance = (sphere.centre - origin).length();
    if distance <= sphere.radius * 1.01 {
        return None;
    }
    let angular = (sphere.radius / distance).asin();
    let radius_px = camera.intrinsics.fx.max(camera.intrinsics.fy) * angular.tan();
    // A sphere cut by the frame may have lost part of its highlight's lobe.
    let inside = centre_px.x - 1.2 * radius_px >= 0.0
        && centre_px.y - 1.2 * radius_px >= 0.0
        && centre_px.x + 1.2 * radius_px <= w as f32
        && centre_px.y + 1.2 * radius_px <= h as f32;
    if !inside {
        return None;
    }
    let extent = 1.5 * radius_px + 2.0;
    let (x0, x1) = ((centre_px.x - extent).floor().max(0.0) as u32, (centre_px.x + extent).ceil().min(w as f32) as u32);
    let (y0, y1) = ((centre_px.y - extent).floor().max(0.0) as u32, (centre_px.y + extent).ceil().min(h as f32) as u32);
    let mut pixels = Vec::new();
    // Reflected directions of pixels where something hides the sphere.
    let mut hidden = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let ray = camera.pixel_centre_ray(x, y);
            let d = ray.direction.normalize();
            let Some(t) = hit(origin, d, sphere) else { continue };
            let n = (origin + t * d - sphere.centre) / sphere.radius;
            if let Some(depth) = depth {
                let seen = depth.get(x as usize, y as usize)[0];
                let expected = t * d.dot(forward);
                if seen > 0.0 && seen < expected - 0.1 * sphere.radius {
                    hidden.push(d - 2.0 * d.dot(n) * n);
                    continue;
                }
            }
            let facing = -d.dot(n);
            pixels.push(SpherePixel {
                x,
                y,
                value: {
                    let p = image.get(x as usize, y as usize);
                    luminance([p[0], p[1], p[2]])
                },
                t,
                reflected: d - 2.0 * d.dot(n) * n,
                facing,
            });
        }
    }
    if pixels.len() < MIN_PIXELS {
        return None;
    }
    let mut values: Vec<f32> = pixels.iter().map(|p| p.value).collect();
    values.sort_by(f32::total_cmp);
    let median = values[values.len() / 2];
    let peak = pixels.iter().max_by(|a, b| a.value.total_cmp(&b.value))?;
    if peak.value <= MIN_CONTRAST * median.max(1e-6) || peak.facing < MIN_FACING {
        return None;
    }
    // An occluder over part of the lobe would pull its mean away from the light.
    if hidden.iter().any(|r| r.dot(peak.reflected) >= LOBE_RADIUS.cos()) {
        return None;
    }
    let floor = median.max(0.02 * peak.value);
    let (mut sum, mut centroid, mut total) = (Vec3::ZERO, glam::Vec2::ZERO, 0.0);
    for p in &pixels {
        if p.reflected.dot(peak.reflected) < LOBE_RADIUS.cos() || p.value <= floor {
            continue;
        }
        // A microfacet highlight's radiance is D(h)·F·G / (4 n·v) times the irradiance: the
        // facing factor undoes the 1/(n·v) that would tilt the lobe's mean towards the
        // silhouette, leaving D, which is symmetric about the light.
        let weight = (p.value - floor) * p.t * p.t * p.facing;
        sum += weight * p.reflected;
        centroid += (p.value - floor) * glam::Vec2::new(p.x as f32 + 0.5, p.y as f32 + 0.5);
        total += p.value - floor;
    }
    let direction = sum.try_normalize()?;
    Some(Highlight { direction, pixel: centroid / total, facing: peak.facing, peak: peak.value })
}

/// Estimates whose peak is below this share of the brightest one of their light are not the
/// light's highlight: where the light is hidden from a sphere (shadowed by the object, or
/// behind the sphere as seen from the camera) the brightest spot is a reflection of something
/// it lights, tens of times dimmer than the light's own highlight.
const MIN_PEAK_SHARE: f32 = 0.1;

/// One direction from several spheres' and views' estimates: those bright enough to be the
/// light's highlight, then the one with the most others within `outlier_degrees` of it, then
/// the mean (weighted by facing) of those near it; the rest are outliers (a lobe cut by the
/// silhouette or an occluder). `None` without estimates.
pub fn combine(estimates: &[Highlight], outlier_degrees: f32) -> Option<Vec3> {
    combine_with_agreement(estimates, outlier_degrees).map(|(d, _)| d)
}

/// How well a light's estimates support its direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agreement {
    /// Estimates within the outlier angle of the direction (the ones averaged).
    pub agreeing: usize,
    /// Estimates bright enough to be the light's highlight.
    pub candidates: usize,
    /// The largest facing (normal towards the camera) among the agreeing estimates: near
    /// the sphere's rim (small) a highlight's lobe is foreshortened and cut by the silhouette.
    pub facing: f32,
}

/// Agreeing estimates needed before a direction is trusted: one highlight has nothing to
/// check it against (a reflection of a lit surface looks like a dim highlight).
pub const MIN_AGREEING: usize = 2;
/// A lone highlight is trusted only this far from the rim (its normal within ~60° of the view).
pub const MIN_LONE_FACING: f32 = 0.5;

impl Agreement {
    /// Whether the direction can be trusted: two or more spheres or views agree on it, or a
    /// lone highlight lies well inside its sphere's disc.
    pub fn trusted(&self) -> bool {
        self.agreeing >= MIN_AGREEING || (self.agreeing == 1 && self.candidates == 1 && self.facing >= MIN_LONE_FACING)
    }
}

/// [`combine`], with how well the estimates agree.
pub fn combine_with_agreement(estimates: &[Highlight], outlier_degrees: f32) -> Option<(Vec3, Agreement)> {
    let brightest = estimates.iter().map(|h| h.peak).fold(0.0, f32::max);
    let bright: Vec<&Highlight> = estimates.iter().filter(|h| h.peak >= MIN_PEAK_SHARE * brightest).collect();
    let cos = outlier_degrees.to_radians().cos();
    let near = |a: Vec3| bright.iter().filter(move |b| a.dot(b.direction) >= cos);
    let anchor = bright.iter().max_by_key(|a| near(a.direction).count())?;
    let agreeing: Vec<&&Highlight> = near(anchor.direction).collect();
    let direction = agreeing.iter().map(|h| h.direction * h.facing).sum::<Vec3>().try_normalize()?;
    let agreement = Agreement {
        agreeing: agreeing.len(),
        candidates: bright.len(),
        facing: agreeing.iter().map(|h| h.facing).fold(0.0, f32::max),
    };
    Some((direction, agreement))
}

/// Angle between two directions, in degrees.
pub fn angle_degrees(a: Vec3, b: Vec3) -> f32 {
    a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
}

pub mod capture;

#[cfg(test)]
mod tests;
