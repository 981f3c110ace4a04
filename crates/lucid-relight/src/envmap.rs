//! Lat-long environment maps, in the convention of the path tracer
//! (`lucid_trace::environment`): +Z up, column `u ∈ [0,1)` is the azimuth `φ = 2πu` from +X
//! towards +Y, row `v ∈ [0,1)` from the top is the polar angle `θ = πv` from +Z.

use glam::Vec3;
use lucid_image::Image;
use std::f32::consts::{PI, TAU};

/// The direction through `(u, v)` in `[0,1]²`.
pub fn direction(u: f32, v: f32) -> Vec3 {
    let (theta, phi) = (v * PI, u * TAU);
    Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// `(u, v)` of a unit direction.
pub fn uv(d: Vec3) -> (f32, f32) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.atan2(d.x).rem_euclid(TAU);
    (phi / TAU, theta / PI)
}

/// Direction through the centre of pixel `(x, y)` of a `w × h` map.
pub fn pixel_direction(x: usize, y: usize, w: usize, h: usize) -> Vec3 {
    direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32)
}

/// Solid angle of a pixel in row `y` of a `w × h` map: `(2π/w)(cos θ₀ − cos θ₁)` (the rows near
/// the poles are small); the rows sum to 4π.
pub fn pixel_solid_angle(y: usize, w: usize, h: usize) -> f32 {
    let (t0, t1) = (y as f32 / h as f32 * PI, (y + 1) as f32 / h as f32 * PI);
    TAU / w as f32 * (t0.cos() - t1.cos())
}

/// Radiance from direction `d`, bilinear between pixel centres (wrapping in azimuth).
pub fn lookup(map: &Image, d: Vec3) -> [f32; 3] {
    let (w, h) = map.dimensions();
    let (u, v) = uv(d.normalize_or_zero());
    let (fx, fy) = (u * w as f32 - 0.5, (v * h as f32 - 0.5).clamp(0.0, h as f32 - 1.0));
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let xi = |k: f32| (k as i64).rem_euclid(w as i64) as usize;
    let yi = |k: f32| (k as i64).clamp(0, h as i64 - 1) as usize;
    let mut out = [0.0f32; 3];
    for (dx, wx) in [(0.0, 1.0 - tx), (1.0, tx)] {
        for (dy, wy) in [(0.0, 1.0 - ty), (1.0, ty)] {
            let p = map.get(xi(x0 + dx), yi(y0 + dy));
            for c in 0..3 {
                out[c] += wx * wy * p[c];
            }
        }
    }
    out
}

/// The mirror-ball view: a camera far out on +Y looks at a mirrored sphere along −Y with +Z
/// up, so image right is −X (as a photograph or a render from there has it). The direction a
/// ball pixel at `(s, t) ∈ [−1,1]²` (right, up) reflects, or `None` outside the ball.
pub fn mirror_ball_direction(s: f32, t: f32) -> Option<Vec3> {
    let r2 = s * s + t * t;
    if r2 > 1.0 {
        return None;
    }
    // Normal towards the camera (+Y); the view ray travels along −Y.
    let n = Vec3::new(-s, (1.0 - r2).sqrt(), t);
    let view = Vec3::new(0.0, -1.0, 0.0);
    Some((view - 2.0 * view.dot(n) * n).normalize())
}

/// Inverse of [`mirror_ball_direction`]: the ball pixel `(s, t)` that reflects `d`.
pub fn mirror_ball_coords(d: Vec3) -> (f32, f32) {
    // The normal halves the angle between the reflected direction and the way back to the
    // camera (+Y).
    let n = (d.normalize() + Vec3::Y).try_normalize().unwrap_or(Vec3::X);
    (-n.x, n.z)
}

/// A lat-long map (`width × width/2`) from a mirror-ball image (the ball filling the square
/// image). The direction straight behind the ball is a singularity; it takes the rim's colour.
pub fn mirror_ball_to_latlong(ball: &Image, width: usize) -> Image {
    let (bw, bh) = ball.dimensions();
    let h = (width / 2).max(1);
    Image::from_fn(width, h, |x, y| {
        let (s, t) = mirror_ball_coords(pixel_direction(x, y, width, h));
        // Bilinear in the ball image; (s, t) = (−1, 1) is the top-left corner.
        let fx = ((s + 1.0) * 0.5 * bw as f32 - 0.5).clamp(0.0, bw as f32 - 1.0);
        let fy = ((1.0 - t) * 0.5 * bh as f32 - 0.5).clamp(0.0, bh as f32 - 1.0);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(bw - 1), (y0 + 1).min(bh - 1));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let mut out = [0.0, 0.0, 0.0, 1.0];
        for (xx, wx) in [(x0, 1.0 - tx), (x1, tx)] {
            for (yy, wy) in [(y0, 1.0 - ty), (y1, ty)] {
                let p = ball.get(xx, yy);
                for c in 0..3 {
                    out[c] += wx * wy * p[c];
                }
            }
        }
        out
    })
}

/// A `size × size` mirror-ball image of a lat-long map (transparent outside the ball).
pub fn latlong_to_mirror_ball(map: &Image, size: usize) -> Image {
    Image::from_fn(size, size, |x, y| {
        let s = (x as f32 + 0.5) / size as f32 * 2.0 - 1.0;
        let t = 1.0 - (y as f32 + 0.5) / size as f32 * 2.0;
        match mirror_ball_direction(s, t) {
            Some(d) => {
                let c = lookup(map, d);
                [c[0], c[1], c[2], 1.0]
            }
            None => [0.0; 4],
        }
    })
}

/// `∫ L dω` per channel: the map's total (the irradiance-like integral of radiance).
pub fn integral(map: &Image) -> [f64; 3] {
    let (w, h) = map.dimensions();
    let mut sum = [0.0f64; 3];
    for y in 0..h {
        let omega = pixel_solid_angle(y, w, h) as f64;
        for x in 0..w {
            let p = map.get(x, y);
            for c in 0..3 {
                sum[c] += p[c] as f64 * omega;
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_solid_angles_sum_to_the_sphere() {
        let (w, h) = (64, 32);
        let total: f32 = (0..h).map(|y| pixel_solid_angle(y, w, h) * w as f32).sum();
        assert!((total - 4.0 * PI).abs() < 1e-4, "{total}");
    }

    #[test]
    fn directions_and_uv_invert_and_the_ball_reflects_consistently() {
        for &(u, v) in &[(0.1f32, 0.3f32), (0.7, 0.8), (0.45, 0.05)] {
            let (u2, v2) = uv(direction(u, v));
            assert!((u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5);
        }
        // The ball's centre reflects straight back at the camera; its rim looks behind.
        assert!((mirror_ball_direction(0.0, 0.0).unwrap() - Vec3::Y).length() < 1e-6);
        for d in [Vec3::new(0.3, 0.5, 0.8).normalize(), Vec3::new(-0.7, -0.1, 0.2).normalize(), Vec3::Z] {
            let (s, t) = mirror_ball_coords(d);
            assert!((mirror_ball_direction(s, t).unwrap() - d).length() < 1e-4, "{d}");
        }
    }

    /// Lat-long → mirror ball → lat-long keeps a smooth map, except near the direction behind
    /// the ball where the ball's rim compresses everything.
    #[test]
    fn mirror_ball_round_trip() {
        let map = Image::from_fn(64, 32, |x, y| {
            let d = pixel_direction(x, y, 64, 32);
            [0.5 + 0.5 * d.x, 0.5 + 0.5 * d.z, 1.0, 1.0]
        });
        let back = mirror_ball_to_latlong(&latlong_to_mirror_ball(&map, 256), 64);
        let mut worst = 0.0f32;
        for y in 0..32 {
            for x in 0..64 {
                let d = pixel_direction(x, y, 64, 32);
                if d.y < -0.5 {
                    continue;
                }
                let (a, b) = (map.get(x, y), back.get(x, y));
                worst = worst.max((a[0] - b[0]).abs().max((a[1] - b[1]).abs()));
            }
        }
        assert!(worst < 0.05, "{worst}");
    }
}
