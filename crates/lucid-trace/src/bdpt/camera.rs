//! The camera as a sensor for bidirectional methods: its importance `We`, the densities with
//! which it emits rays, and sampling a point on its lens seen from a scene point (for light
//! paths connected to the camera, t = 1), as in pbrt's `PerspectiveCamera`.
//!
//! `We` is normalised over the whole image: a camera ray carries weight We·cos/(p_pos·p_dir)
//! = 1, and a light path that reaches the lens lands in one pixel of a film whose splats are
//! divided by the samples per pixel.

use glam::{Mat4, Vec2, Vec3};
use lucid_scene::Intrinsics;
use lucid_scene::sampling::concentric_disk;

use crate::render::RenderCamera;

/// The importance function of a pinhole or thin-lens camera.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraImportance {
    to_world: Mat4,
    to_camera: Mat4,
    intrinsics: Intrinsics,
    lens_radius: f32,
    /// Distance from the lens to the plane that projects sharp (1 for a pinhole: any plane).
    focus_distance: f32,
    pub(crate) forward: Vec3,
    /// Area of the image rectangle on the plane one unit in front of the lens.
    image_area: f32,
    /// Area of the aperture (1 for a pinhole, whose position density is a delta).
    lens_area: f32,
}

/// A point on the lens seen from a scene point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LensSample {
    /// The point on the lens.
    pub(crate) point: Vec3,
    /// Unit direction from the scene point to `point`.
    pub(crate) wi: Vec3,
    /// Distance from the scene point to `point`.
    pub(crate) distance: f32,
    /// Density of `point` in solid angle at the scene point.
    pub(crate) pdf: f32,
    /// Importance arriving along the ray from `point` through the scene point.
    pub(crate) importance: f32,
    /// Where that ray lands on the image, in pixels.
    pub(crate) raster: Vec2,
}

impl CameraImportance {
    /// The camera's importance.
    pub(crate) fn new(camera: &RenderCamera) -> Self {
        let (pinhole, lens_radius, focus) = match camera {
            RenderCamera::Pinhole(c) => (c, 0.0, 1.0),
            RenderCamera::ThinLens(c) if c.aperture_radius > 0.0 => (&c.pinhole, c.aperture_radius, c.focus_distance),
            RenderCamera::ThinLens(c) => (&c.pinhole, 0.0, 1.0),
        };
        let k = pinhole.intrinsics;
        Self {
            to_world: pinhole.camera_to_world,
            to_camera: pinhole.camera_to_world.inverse(),
            intrinsics: k,
            lens_radius,
            focus_distance: focus,
            forward: pinhole.forward(),
            image_area: k.width as f32 * k.height as f32 / (k.fx * k.fy),
            lens_area: if lens_radius > 0.0 { std::f32::consts::PI * lens_radius * lens_radius } else { 1.0 },
        }
    }

    /// The image point a ray leaving the lens at `origin` along `direction` lands on and the
    /// density per solid angle of the camera emitting that direction; `None` off the image or
    /// behind the camera.
    fn raster(&self, origin: Vec3, direction: Vec3) -> Option<(Vec2, f32)> {
        let cos = direction.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        // A thin lens focuses the ray where it meets the plane of focus; that point projects
        // through the lens centre.
        let focus = origin + direction * (self.focus_distance / cos);
        let local = self.to_camera.transform_point3(focus);
        let p = self.intrinsics.project(local)?;
        let (w, h) = (self.intrinsics.width as f32, self.intrinsics.height as f32);
        if !(p.x >= 0.0 && p.x < w && p.y >= 0.0 && p.y < h) {
            return None;
        }
        // Pixels are uniform on the (distorted) image: per unit of the undistorted image plane
        // one unit in front of the lens that is |det J| as dense, and per solid angle 1/cos³.
        let stretch = self.distortion_stretch(Vec2::new(local.x, -local.y) / -local.z);
        Some((p, stretch / (self.image_area * cos * cos * cos)))
    }

    /// |det| of the lens distortion's Jacobian at undistorted image-plane point `u` (1 for
    /// a pinhole), by central differences: the distortion models are polynomials, smooth at
    /// the step used.
    fn distortion_stretch(&self, u: Vec2) -> f32 {
        let distortion = self.intrinsics.distortion;
        if distortion.is_pinhole() {
            return 1.0;
        }
        let h = 1e-3 * (1.0 + u.length());
        let dx = (distortion.distort(u + Vec2::X * h) - distortion.distort(u - Vec2::X * h)) / (2.0 * h);
        let dy = (distortion.distort(u + Vec2::Y * h) - distortion.distort(u - Vec2::Y * h)) / (2.0 * h);
        (dx.x * dy.y - dx.y * dy.x).abs()
    }

    /// Importance of the ray and its image point.
    pub(crate) fn importance(&self, origin: Vec3, direction: Vec3) -> Option<(f32, Vec2)> {
        let (raster, pdf_dir) = self.raster(origin, direction)?;
        // We = p_dir / (lens area · cos), so that a camera ray's weight We·cos/(p_pos·p_dir) is 1.
        Some((pdf_dir / (self.lens_area * direction.dot(self.forward)), raster))
    }

    /// Densities of emitting this ray: position on the lens (per area) and direction (per
    /// solid angle); zeros for rays off the image.
    pub(crate) fn pdf(&self, origin: Vec3, direction: Vec3) -> (f32, f32) {
        match self.raster(origin, direction) {
            Some((_, pdf_dir)) => (1.0 / self.lens_area, pdf_dir),
            None => (0.0, 0.0),
        }
    }

    /// Samples a point on the lens as seen from `point`.
    pub(crate) fn sample_lens(&self, point: Vec3, u: Vec2) -> Option<LensSample> {
        let on_lens = (self.lens_radius * concentric_disk(u)).extend(0.0);
        let lens_point = self.to_world.transform_point3(on_lens);
        let d = lens_point - point;
        let distance = d.length();
        if distance == 0.0 {
            return None;
        }
        let wi = d / distance;
        let (importance, raster) = self.importance(lens_point, -wi)?;
        let cos = wi.dot(self.forward).abs();
        let pdf = distance * distance / (cos * self.lens_area);
        Some(LensSample { point: lens_point, wi, distance, pdf, importance, raster })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use lucid_scene::{Camera, PinholeCamera, ThinLensCamera, look_at};

    fn cameras() -> Vec<RenderCamera> {
        let pose = look_at(Vec3::new(0.3, 0.2, 4.0), Vec3::ZERO, Vec3::Y);
        let pinhole = PinholeCamera::new(Intrinsics::from_fov_x(40, 30, 0.7), pose);
        let mut distorted = pinhole;
        distorted.intrinsics.distortion = lucid_scene::LensDistortion::opencv(-0.2, 0.05, 0.001, -0.002);
        vec![
            RenderCamera::Pinhole(pinhole),
            RenderCamera::ThinLens(ThinLensCamera::new(pinhole, 0.1, 3.0)),
            RenderCamera::Pinhole(distorted),
        ]
    }

    #[test]
    fn camera_rays_carry_unit_weight_and_land_on_their_pixel() {
        let mut rng = Rng::new(1, 2);
        for camera in cameras() {
            let we = CameraImportance::new(&camera);
            for _ in 0..200 {
                let (px, py) = (rng.uniform() * 40.0, rng.uniform() * 30.0);
                let ray = match &camera {
                    RenderCamera::Pinhole(c) => c.generate_ray(px, py, rng.uniform2()),
                    RenderCamera::ThinLens(c) => c.generate_ray(px, py, rng.uniform2()),
                };
                let (importance, raster) = we.importance(ray.origin, ray.direction).unwrap();
                let (pdf_pos, pdf_dir) = we.pdf(ray.origin, ray.direction);
                let cos = ray.direction.dot(we.forward);
                let weight = importance * cos / (pdf_pos * pdf_dir);
                assert!((weight - 1.0).abs() < 1e-4, "{weight}");
                assert!((raster - Vec2::new(px, py)).length() < 2e-3, "{raster} vs {px},{py}");
            }
        }
    }

    #[test]
    fn the_importance_over_the_image_integrates_to_one() {
        // ∫ We cos dω over the image from a lens point is 1 / lens area: estimate it by sampling
        // directions uniformly on the sphere from the lens centre.
        for camera in cameras() {
            let we = CameraImportance::new(&camera);
            let mut rng = Rng::new(3, 4);
            let origin = we.to_world.transform_point3(Vec3::ZERO);
            let n = 400_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let d = crate::sampling::uniform_sphere(rng.uniform2());
                if let Some((importance, _)) = we.importance(origin, d) {
                    sum += (importance * d.dot(we.forward) / crate::sampling::UNIFORM_SPHERE_PDF) as f64;
                }
            }
            let integral = sum / n as f64 * we.lens_area as f64;
            assert!((integral - 1.0).abs() < 0.02, "{integral}");
        }
    }
}
