//! Cameras: intrinsics (with the lens's distortion), the pinhole and thin-lens models, and
//! pose helpers.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

use crate::Ray;
use crate::lens::LensDistortion;
use crate::sampling::concentric_disk;

/// Intrinsics in pixels: image size, focal lengths, principal point, and the lens's
/// distortion (none for the pinhole of synthetic sets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal focal length in pixels.
    pub fx: f32,
    /// Vertical focal length in pixels.
    pub fy: f32,
    /// Principal point, x (pixels from the left edge).
    pub cx: f32,
    /// Principal point, y (pixels from the top edge).
    pub cy: f32,
    /// How the lens bends rays away from the pinhole's.
    pub distortion: LensDistortion,
}

impl Intrinsics {
    /// Square pixels, centred principal point and a horizontal field of view in radians
    /// (the Blender set's `camera_angle_x`): `f = 0.5·W / tan(0.5·fov_x)`.
    pub fn from_fov_x(width: u32, height: u32, fov_x: f32) -> Self {
        let f = 0.5 * width as f32 / (0.5 * fov_x).tan();
        Self::pinhole(width, height, f, f, 0.5 * width as f32, 0.5 * height as f32)
    }

    /// A camera without distortion.
    pub fn pinhole(width: u32, height: u32, fx: f32, fy: f32, cx: f32, cy: f32) -> Self {
        Self { width, height, fx, fy, cx, cy, distortion: LensDistortion::None }
    }

    /// Horizontal field of view in radians.
    pub fn fov_x(&self) -> f32 {
        2.0 * (0.5 * self.width as f32 / self.fx).atan()
    }

    /// Vertical field of view in radians.
    pub fn fov_y(&self) -> f32 {
        2.0 * (0.5 * self.height as f32 / self.fy).atan()
    }

    /// The same camera at another resolution (focal lengths and principal point scale with
    /// the image).
    pub fn resized(&self, width: u32, height: u32) -> Self {
        let sx = width as f32 / self.width as f32;
        let sy = height as f32 / self.height as f32;
        // Distortion acts on normalised coordinates, which do not change with the resolution.
        Self { width, height, fx: self.fx * sx, fy: self.fy * sy, cx: self.cx * sx, cy: self.cy * sy, ..*self }
    }

    /// The same focal lengths and principal point without the lens's distortion: the camera
    /// that undistorted images are taken with.
    pub fn without_distortion(&self) -> Self {
        Self { distortion: LensDistortion::None, ..*self }
    }

    /// The camera-space direction (not normalised, `z = −1`) through the image point
    /// `(px, py)`, where pixel `(i, j)` covers `[i, i+1) × [j, j+1)`: through the inverse of
    /// the lens's distortion, so the ray is the one the real lens saw along.
    #[inline]
    pub fn camera_direction(&self, px: f32, py: f32) -> Vec3 {
        let d = Vec2::new((px - self.cx) / self.fx, (py - self.cy) / self.fy);
        let u = if self.distortion.is_pinhole() { d } else { self.distortion.undistort(d) };
        Vec3::new(u.x, -u.y, -1.0)
    }

    /// The image point where a camera-space point projects, or `None` behind the camera.
    pub fn project(&self, p_camera: Vec3) -> Option<Vec2> {
        if p_camera.z >= 0.0 {
            return None;
        }
        let z = -p_camera.z;
        let d = self.distortion.distort(Vec2::new(p_camera.x / z, -p_camera.y / z));
        Some(Vec2::new(self.cx + self.fx * d.x, self.cy + self.fy * d.y))
    }
}

/// What every camera model can do: turn an image point (and a lens sample) into a ray.
pub trait Camera {
    /// The ray through image point `(px, py)`; `lens` in `[0,1)²` picks a point on the
    /// aperture (ignored by pinholes).
    fn generate_ray(&self, px: f32, py: f32, lens: Vec2) -> Ray;

    /// The intrinsics of the image this camera makes.
    fn intrinsics(&self) -> &Intrinsics;

    /// The ray through the centre of pixel `(i, j)` (and the centre of the lens).
    fn pixel_centre_ray(&self, i: u32, j: u32) -> Ray {
        self.generate_ray(i as f32 + 0.5, j as f32 + 0.5, Vec2::splat(0.5))
    }

    /// A ray through pixel `(i, j)` at the sub-pixel offset `jitter ∈ [0,1)²`.
    fn jittered_ray(&self, i: u32, j: u32, jitter: Vec2, lens: Vec2) -> Ray {
        self.generate_ray(i as f32 + jitter.x, j as f32 + jitter.y, lens)
    }
}

/// An ideal pinhole camera with a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    /// Image-forming parameters.
    pub intrinsics: Intrinsics,
    /// Camera-to-world transform (OpenGL convention: looks down local −Z, +Y up).
    pub camera_to_world: Mat4,
}

impl PinholeCamera {
    /// A camera from intrinsics and a camera-to-world pose.
    pub fn new(intrinsics: Intrinsics, camera_to_world: Mat4) -> Self {
        Self { intrinsics, camera_to_world }
    }

    /// The centre of projection in world space.
    #[inline]
    pub fn position(&self) -> Vec3 {
        self.camera_to_world.w_axis.xyz()
    }

    /// The world-space viewing direction (the pose's −Z axis).
    pub fn forward(&self) -> Vec3 {
        -self.camera_to_world.z_axis.xyz().normalize()
    }

    /// Projects a world point into the image; `None` if it is behind the camera.
    pub fn project(&self, world: Vec3) -> Option<Vec2> {
        let p = self.camera_to_world.inverse().transform_point3(world);
        self.intrinsics.project(p)
    }
}

impl Camera for PinholeCamera {
    #[inline]
    fn generate_ray(&self, px: f32, py: f32, _lens: Vec2) -> Ray {
        let d = self.intrinsics.camera_direction(px, py);
        Ray::new(self.position(), self.camera_to_world.transform_vector3(d))
    }

    fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }
}

/// A thin-lens camera: a pinhole camera whose rays start on a disk-shaped aperture and
/// converge on the plane of focus, giving depth of field. Points at `focus_distance` in front
/// of the camera (measured along its axis) are sharp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLensCamera {
    /// The pinhole camera at the lens centre.
    pub pinhole: PinholeCamera,
    /// Aperture radius in world units (0 gives a pinhole).
    pub aperture_radius: f32,
    /// Distance from the lens to the plane of focus, along the optical axis.
    pub focus_distance: f32,
}

impl ThinLensCamera {
    /// A thin-lens camera.
    pub fn new(pinhole: PinholeCamera, aperture_radius: f32, focus_distance: f32) -> Self {
        Self { pinhole, aperture_radius, focus_distance }
    }
}

impl Camera for ThinLensCamera {
    fn generate_ray(&self, px: f32, py: f32, lens: Vec2) -> Ray {
        let d = self.pinhole.intrinsics.camera_direction(px, py);
        // d has z = −1, so the pinhole ray meets the focus plane at d·focus_distance.
        let focus_point = d * self.focus_distance;
        let lens_point = (self.aperture_radius * concentric_disk(lens)).extend(0.0);
        let m = &self.pinhole.camera_to_world;
        Ray::new(m.transform_point3(lens_point), m.transform_vector3(focus_point - lens_point))
    }

    fn intrinsics(&self) -> &Intrinsics {
        &self.pinhole.intrinsics
    }
}

/// A camera-to-world pose at `eye` looking at `target`, with `up` as the approximate up
/// direction (OpenGL convention: the camera's −Z points at the target).
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let back = (eye - target).normalize();
    let right = up.cross(back).normalize();
    let true_up = back.cross(right);
    Mat4::from_cols(right.extend(0.0), true_up.extend(0.0), back.extend(0.0), eye.extend(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn posed_camera() -> PinholeCamera {
        let pose = look_at(Vec3::new(2.0, -3.0, 1.5), Vec3::new(0.1, 0.2, 0.3), Vec3::Z);
        PinholeCamera::new(Intrinsics::from_fov_x(64, 48, 0.7), pose)
    }

    #[test]
    fn central_ray_points_along_minus_z_of_the_pose() {
        let cam = posed_camera();
        // Pixel centre (W/2, H/2) is the principal point for even sizes.
        let ray = cam.generate_ray(32.0, 24.0, Vec2::splat(0.5));
        let minus_z = -cam.camera_to_world.z_axis.xyz();
        assert!(ray.direction.dot(minus_z) > 1.0 - 1e-6, "{:?} vs {minus_z:?}", ray.direction);
        assert!((ray.origin - Vec3::new(2.0, -3.0, 1.5)).length() < 1e-6);
        // ... and that is the direction to the look-at target.
        let to_target = (Vec3::new(0.1, 0.2, 0.3) - ray.origin).normalize();
        assert!(ray.direction.dot(to_target) > 1.0 - 1e-6);
    }

    #[test]
    fn image_axes_follow_the_opengl_convention() {
        let cam = PinholeCamera::new(Intrinsics::from_fov_x(100, 100, 1.0), Mat4::IDENTITY);
        let right = cam.pixel_centre_ray(99, 50).direction;
        let top = cam.pixel_centre_ray(50, 0).direction;
        assert!(right.x > 0.0 && top.y > 0.0, "+X right, +Y up, rows from the top");
    }

    #[test]
    fn field_of_view_and_projection_round_trip() {
        let k = Intrinsics::from_fov_x(800, 600, 0.691_111_1);
        assert!((k.fov_x() - 0.691_111_1).abs() < 1e-6);
        // The edge of the image is at half the field of view.
        let edge = k.camera_direction(800.0, 300.0).normalize();
        assert!((edge.x.atan2(-edge.z) - 0.5 * 0.691_111_1).abs() < 1e-6);
        let cam = posed_camera();
        let ray = cam.generate_ray(10.25, 40.75, Vec2::ZERO);
        let back = cam.project(ray.at(3.0)).unwrap();
        assert!((back - Vec2::new(10.25, 40.75)).length() < 1e-3, "{back:?}");
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let pinhole = posed_camera();
        let lens = ThinLensCamera::new(pinhole, 0.2, 2.5);
        let (px, py) = (17.3, 30.1);
        let centre = pinhole.generate_ray(px, py, Vec2::ZERO);
        // The pinhole ray reaches the focus plane (axial distance 2.5) at t = 2.5 / cos.
        let cos = centre.direction.dot(pinhole.forward());
        let focus_point = centre.at(2.5 / cos);
        for u in [Vec2::new(0.1, 0.9), Vec2::new(0.8, 0.3), Vec2::new(0.5, 0.5)] {
            let ray = lens.generate_ray(px, py, u);
            // The ray starts on the aperture disk ...
            let offset = ray.origin - pinhole.position();
            assert!(offset.length() <= 0.2 + 1e-5 && offset.dot(pinhole.forward()).abs() < 1e-5);
            // ... and passes through the in-focus point.
            let t = (focus_point - ray.origin).dot(ray.direction);
            assert!((ray.at(t) - focus_point).length() < 1e-4);
        }
        // Zero aperture is a pinhole.
        let pin = ThinLensCamera::new(pinhole, 0.0, 2.5).generate_ray(px, py, Vec2::new(0.9, 0.1));
        assert!((pin.direction - centre.direction).length() < 1e-6);
    }

    #[test]
    fn resizing_keeps_the_field_of_view() {
        let k = Intrinsics::from_fov_x(800, 800, 0.69);
        let half = k.resized(400, 400);
        assert!((half.fov_x() - k.fov_x()).abs() < 1e-6);
        assert_eq!(half.cx, 200.0);
    }
}
