//! The camera as the rasterizer sees it: a rigid world-to-view transform in the computer-vision
//! convention (x right, y down, z forward, so depth is positive) and pinhole intrinsics.

use glam::{Mat3, Vec3, Vec4Swizzles};
use lucid_scene::camera::PinholeCamera;

/// A pinhole camera for splatting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplatCamera {
    /// World-to-view rotation (view: x right, y down, z forward).
    pub rotation: Mat3,
    /// World-to-view translation.
    pub translation: Vec3,
    /// Centre of projection in world space.
    pub position: Vec3,
    /// Focal lengths in pixels.
    pub fx: f32,
    /// Focal lengths in pixels.
    pub fy: f32,
    /// Principal point in pixels (pixel `(i, j)` has its centre at `(i + 0.5, j + 0.5)`).
    pub cx: f32,
    /// Principal point in pixels.
    pub cy: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl SplatCamera {
    /// From a dataset camera (OpenGL convention: looks down −Z, +Y up) without lens
    /// distortion: distorted views go through [`lucid_scene::undistort`] first (training images
    /// by `ImageSet::undistorted`, renders by the view renderer's warp).
    ///
    /// # Panics
    /// On a camera with distortion, which a pinhole projection would silently ignore.
    pub fn from_pinhole(camera: &PinholeCamera) -> Self {
        assert!(
            camera.intrinsics.distortion.is_pinhole(),
            "a splat camera projects through a pinhole: undistort the view first"
        );
        let w2c = camera.camera_to_world.inverse();
        // OpenGL view → computer-vision view: flip y and z.
        let flip = Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0));
        let k = camera.intrinsics;
        Self {
            rotation: flip * Mat3::from_mat4(w2c),
            translation: flip * w2c.w_axis.xyz(),
            position: camera.position(),
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
            width: k.width,
            height: k.height,
        }
    }

    /// The same camera at another resolution.
    pub fn resized(&self, width: u32, height: u32) -> Self {
        let (sx, sy) = (width as f32 / self.width as f32, height as f32 / self.height as f32);
        Self { fx: self.fx * sx, fy: self.fy * sy, cx: self.cx * sx, cy: self.cy * sy, width, height, ..*self }
    }

    /// A world point in view coordinates.
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// The limits of `x/z` and `y/z` beyond which the projection's Jacobian is evaluated at
    /// the limit (15 % of the image beyond each edge, as the reference implementation's 1.3×
    /// half field of view): far off-screen Gaussians would otherwise get huge footprints.
    pub fn ratio_limits(&self) -> ([f32; 2], [f32; 2]) {
        let (w, h) = (self.width as f32, self.height as f32);
        (
            [-(self.cx + 0.15 * w) / self.fx, (w - self.cx + 0.15 * w) / self.fx],
            [-(self.cy + 0.15 * h) / self.fy, (h - self.cy + 0.15 * h) / self.fy],
        )
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;
    use lucid_scene::Intrinsics;
    use lucid_scene::camera::look_at;

    use super::*;

    /// Projecting through the splat camera lands where the dataset camera projects.
    #[test]
    fn agrees_with_the_dataset_camera() {
        let k = Intrinsics::from_fov_x(64, 48, 0.8);
        let pinhole = PinholeCamera::new(k, look_at(Vec3::new(3.0, -2.0, 1.5), Vec3::ZERO, Vec3::Z));
        let cam = SplatCamera::from_pinhole(&pinhole);
        let p = Vec3::new(0.2, 0.3, -0.1);
        let v = cam.to_view(p);
        assert!(v.z > 0.0);
        let uv = Vec2::new(cam.cx + cam.fx * v.x / v.z, cam.cy + cam.fy * v.y / v.z);
        let want = pinhole.project(p).unwrap();
        assert!((uv - want).length() < 1e-4, "{uv} vs {want}");
        assert!((cam.to_view(cam.position)).length() < 1e-5);
    }
}
