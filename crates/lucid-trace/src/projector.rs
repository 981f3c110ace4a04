//! A pinhole projector: a point light whose radiant intensity in each direction is the value
//! of the projected image's pixel that the direction passes through (zero outside the
//! frustum), as pbrt's projection light. Dual photography lights it one pixel, or one group of
//! pixels, at a time; a light stage projects patterns with it.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use lucid_image::color::luminance;

use crate::distribution::Distribution1D;

/// A projector: its pose, frustum and image.
#[derive(Clone, Debug, PartialEq)]
pub struct Projector {
    position: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// Half extents of the image on the plane at distance 1 along `forward`.
    half: Vec2,
    width: usize,
    height: usize,
    /// Radiant intensity (W/sr) of each pixel, row-major from the top row.
    pixels: Vec<Vec3>,
    /// Picks pixels by power (luminance × solid angle) for light paths.
    by_power: Distribution1D,
    power: Vec3,
}

/// Solid angle of the rectangle `[0, x] × [0, y]` on the plane at distance 1, seen from the
/// origin (signed with x and y).
fn corner_solid_angle(x: f32, y: f32) -> f32 {
    (x * y / (1.0 + x * x + y * y).sqrt()).atan()
}

/// Solid angle of the rectangle with corners `a` and `b` (a < b) on the plane at distance 1,
/// seen from the origin: a pixel's, for projectors and pinhole cameras alike.
pub fn rectangle_solid_angle(a: Vec2, b: Vec2) -> f32 {
    corner_solid_angle(b.x, b.y) - corner_solid_angle(a.x, b.y) - corner_solid_angle(b.x, a.y)
        + corner_solid_angle(a.x, a.y)
}

impl Projector {
    /// A projector at `position` looking at `target` with `up` roughly up, a horizontal field
    /// of view of `fov_x` radians, and `pixels` (`width × height`, row-major from the top, in
    /// W/sr; square pixels). `None` if the pose is degenerate or the sizes disagree.
    pub fn new(
        position: Vec3,
        target: Vec3,
        up: Vec3,
        fov_x: f32,
        width: usize,
        height: usize,
        pixels: Vec<Vec3>,
    ) -> Option<Self> {
        let forward = (target - position).try_normalize()?;
        let right = forward.cross(up).try_normalize()?;
        let up = right.cross(forward);
        if width == 0 || height == 0 || pixels.len() != width * height || !(fov_x > 0.0 && fov_x < PI) {
            return None;
        }
        let tx = (0.5 * fov_x).tan();
        let half = Vec2::new(tx, tx * height as f32 / width as f32);
        let mut projector = Self {
            position,
            right,
            up,
            forward,
            half,
            width,
            height,
            pixels,
            by_power: Distribution1D::new(vec![0.0]),
            power: Vec3::ZERO,
        };
        let omega: Vec<f32> = (0..width * height).map(|k| projector.pixel_solid_angle(k % width, k / width)).collect();
        let weights: Vec<f32> = projector.pixels.iter().zip(&omega).map(|(p, o)| luminance(p.to_array()) * o).collect();
        projector.power = projector.pixels.iter().zip(&omega).map(|(p, o)| *p * *o).sum();
        projector.by_power = Distribution1D::new(weights);
        Some(projector)
    }

    /// Position.
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Image size `(width, height)`.
    pub fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The same projector showing other pixels.
    pub fn with_pixels(&self, pixels: Vec<Vec3>) -> Option<Self> {
        let fov_x = 2.0 * self.half.x.atan();
        Self::new(self.position, self.position + self.forward, self.up, fov_x, self.width, self.height, pixels)
    }

    /// The pixel's rectangle on the plane at distance 1: its corners `(x0, y0)`, `(x1, y1)`.
    fn pixel_rect(&self, i: usize, j: usize) -> (Vec2, Vec2) {
        let (w, h) = (self.width as f32, self.height as f32);
        let x0 = (2.0 * i as f32 / w - 1.0) * self.half.x;
        let x1 = (2.0 * (i + 1) as f32 / w - 1.0) * self.half.x;
        let y1 = (1.0 - 2.0 * j as f32 / h) * self.half.y;
        let y0 = (1.0 - 2.0 * (j + 1) as f32 / h) * self.half.y;
        (Vec2::new(x0, y0), Vec2::new(x1, y1))
    }

    /// Solid angle of pixel `(i, j)` seen from the projector (closed form).
    pub fn pixel_solid_angle(&self, i: usize, j: usize) -> f32 {
        let (a, b) = self.pixel_rect(i, j);
        rectangle_solid_angle(a, b)
    }

    /// The pinhole camera that sees, pixel for pixel, what this projector lights.
    pub fn camera(&self) -> lucid_scene::PinholeCamera {
        let intrinsics =
            lucid_scene::Intrinsics::from_fov_x(self.width as u32, self.height as u32, 2.0 * self.half.x.atan());
        let pose = lucid_scene::look_at(self.position, self.position + self.forward, self.up);
        lucid_scene::PinholeCamera::new(intrinsics, pose)
    }

    /// A projector at `camera` with its frustum and resolution, every pixel `intensity`: the
    /// camera turned into a light (dual photography's other half); the camera's principal point
    /// is taken as centred and its pixels as square, as scene files make them.
    pub fn from_camera(camera: &lucid_scene::PinholeCamera, intensity: Vec3) -> Option<Self> {
        let k = &camera.intrinsics;
        let position = camera.position();
        let up = camera.camera_to_world.y_axis.truncate();
        let (w, h) = (k.width as usize, k.height as usize);
        Self::new(position, position + camera.forward(), up, k.fov_x(), w, h, vec![intensity; w * h])
    }

    /// The pixel that the direction `w` (unit, from the projector) passes through, and its
    /// point on the plane at distance 1.
    pub fn pixel_towards(&self, w: Vec3) -> Option<((usize, usize), Vec2)> {
        let z = w.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let p = Vec2::new(w.dot(self.right), w.dot(self.up)) / z;
        let u = (p.x / self.half.x + 1.0) * 0.5 * self.width as f32;
        let v = (1.0 - p.y / self.half.y) * 0.5 * self.height as f32;
        let inside = (0.0..self.width as f32).contains(&u) && (0.0..self.height as f32).contains(&v);
        inside.then_some(((u as usize, v as usize), p))
    }

    /// Radiant intensity towards `w` (unit, from the projector).
    pub fn intensity(&self, w: Vec3) -> Vec3 {
        self.pixel_towards(w).map_or(Vec3::ZERO, |((i, j), _)| self.pixels[j * self.width + i])
    }

    /// Total emitted power.
    pub fn power(&self) -> Vec3 {
        self.power
    }

    /// A direction of emission, chosen by pixel power then uniformly over the pixel's
    /// rectangle on the image plane: `(direction, intensity, density per solid angle)`.
    pub fn sample_emission(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        if self.power == Vec3::ZERO {
            return None;
        }
        let (x, _, k) = self.by_power.sample(u.x);
        let n = self.width * self.height;
        let ux = (x * n as f32 - k as f32).clamp(0.0, 0.999_999);
        let (a, b) = self.pixel_rect(k % self.width, k / self.width);
        let p = a + (b - a) * Vec2::new(ux, u.y);
        let w = (p.x * self.right + p.y * self.up + self.forward).normalize();
        // The pixel the direction passes through (not `k`): where rounding puts a direction on
        // an edge into a neighbour, value and density stay those of one pixel.
        let pdf = self.emission_pdf(w);
        (pdf > 0.0).then(|| (w, self.intensity(w), pdf))
    }

    /// Density per solid angle with which [`Projector::sample_emission`] picks `w`: the
    /// pixel's probability over its area on the plane, times dA/dω = 1/cos³θ.
    pub fn emission_pdf(&self, w: Vec3) -> f32 {
        let Some(((i, j), _)) = self.pixel_towards(w) else { return 0.0 };
        let k = j * self.width + i;
        let probability = self.by_power.pdf_cell(k) / (self.width * self.height) as f32;
        let (a, b) = self.pixel_rect(i, j);
        let area = (b.x - a.x) * (b.y - a.y);
        let cos = w.dot(self.forward);
        probability / (area * cos * cos * cos)
    }
}

#[cfg(test)]
mod tests;
