//! Low-level warps from the unit square, shared by the cameras and the renderer.

use glam::Vec2;

/// Shirley–Chiu concentric map from `[0,1)²` to the unit disk: area-preserving and with
/// low distortion, so stratified samples stay stratified on the lens.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let p = 2.0 * u - Vec2::ONE;
    if p == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if p.x.abs() > p.y.abs() {
        (p.x, std::f32::consts::FRAC_PI_4 * (p.y / p.x))
    } else {
        (p.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (p.x / p.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concentric_disk_stays_inside_and_preserves_area() {
        // A regular grid on the square maps inside the disk, and the fraction inside the
        // half-radius disk equals its area fraction 1/4 (the map preserves area).
        let n = 200;
        let mut inner = 0;
        for i in 0..n {
            for j in 0..n {
                let p = concentric_disk(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                assert!(p.length() <= 1.0 + 1e-6);
                if p.length() < 0.5 {
                    inner += 1;
                }
            }
        }
        let fraction = inner as f64 / (n * n) as f64;
        assert!((fraction - 0.25).abs() < 0.01, "{fraction}");
    }
}
