//! The scene file's `projector` lights (documented in the parent module).

use std::path::Path;

use glam::Vec3;

use super::{Builder, SceneFileError};
use crate::light::Light;
use crate::projector::Projector;

/// A `[[lights]]` section of type `projector`, as read.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ProjectorSection {
    position: [f32; 3],
    look_at: [f32; 3],
    #[serde(default = "super::default_up")]
    up: [f32; 3],
    fov: f32,
    intensity: [f32; 3],
    resolution: Option<[u32; 2]>,
    image: Option<String>,
    pixel: Option<[u32; 2]>,
}

/// Projector images above this many pixels are refused: each pixel's intensity is kept in
/// linear RGB beside a sampling table.
const MAX_PIXELS: u64 = 4096 * 4096;

impl Builder<'_> {
    pub(super) fn projector(&self, key: &str, p: &ProjectorSection) -> Result<Light, SceneFileError> {
        self.finite(key, &[p.position, p.look_at, p.up].concat())?;
        let intensity = self.colour(&format!("{key}.intensity"), p.intensity)?;
        if !(p.fov > 0.0 && p.fov < 180.0) {
            return Err(self.invalid(format!("{key}.fov"), format!("must be in (0, 180) degrees, got {}", p.fov)));
        }
        let (width, height, mut pixels) = match (&p.image, p.resolution) {
            (Some(file), resolution) => {
                let path = self.path.parent().unwrap_or(Path::new(".")).join(file);
                let image =
                    lucid_image::read_image(&path).map_err(|e| self.invalid(format!("{key}.image"), e.to_string()))?;
                if !image.is_finite() || image.pixels().iter().any(|p| p[..3].iter().any(|&c| c < 0.0)) {
                    return Err(self.invalid(
                        format!("{key}.image"),
                        format!("{} has negative, NaN or infinite pixels", path.display()),
                    ));
                }
                let (w, h) = image.dimensions();
                if let Some([rw, rh]) = resolution
                    && (rw as usize, rh as usize) != (w, h)
                {
                    return Err(self.invalid(
                        format!("{key}.resolution"),
                        format!("{rw}×{rh} disagrees with {} ({w}×{h}); give one of them", path.display()),
                    ));
                }
                let pixels = (0..w * h).map(|k| Vec3::from_slice(&image.get(k % w, k / w)[..3]) * intensity).collect();
                (w, h, pixels)
            }
            (None, Some([w, h])) => {
                let (w, h) = (w as usize, h as usize);
                (w, h, vec![intensity; w * h])
            }
            (None, None) => return Err(self.invalid(key, "a projector needs an image or a resolution")),
        };
        if width == 0 || height == 0 || (width as u64) * (height as u64) > MAX_PIXELS {
            return Err(self.invalid(
                format!("{key}.resolution"),
                format!("{width}×{height}: each side must be at least 1, and at most {MAX_PIXELS} pixels"),
            ));
        }
        if let Some([i, j]) = p.pixel {
            let (i, j) = (i as usize, j as usize);
            if i >= width || j >= height {
                return Err(
                    self.invalid(format!("{key}.pixel"), format!("[{i}, {j}] is outside the {width}×{height} image"))
                );
            }
            let lit = pixels[j * width + i];
            pixels = vec![Vec3::ZERO; width * height];
            pixels[j * width + i] = lit;
        }
        let (position, target, up) = (Vec3::from(p.position), Vec3::from(p.look_at), Vec3::from(p.up));
        Projector::new(position, target, up, p.fov.to_radians(), width, height, pixels)
            .map(|projector| Light::Projector(Box::new(projector)))
            .ok_or_else(|| self.invalid(format!("{key}.look_at"), "must differ from position, and not along up"))
    }
}
