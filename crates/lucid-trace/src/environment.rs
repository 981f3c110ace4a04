//! Image-based environment lighting: a latitude–longitude radiance map, importance-sampled
//! through a 2D piecewise-constant distribution weighted by luminance × sin θ (the pixels
//! near the poles cover less solid angle).
//!
//! Mapping (+Z up, as in the reference notes): pixel column `u ∈ [0,1)` is the azimuth
//! `φ = 2πu` measured from +X towards +Y, row `v ∈ [0,1)` from the top is the polar angle
//! `θ = πv` from +Z; `ω = (sin θ cos φ, sin θ sin φ, cos θ)` in the map's frame, which a
//! rotation places in the world.

use glam::{Mat3, Vec2, Vec3};
use lucid_image::Image;
use lucid_image::color::luminance;
use std::f32::consts::{PI, TAU};

use crate::distribution::Distribution2D;

/// A lat-long environment map with its sampling distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    width: usize,
    height: usize,
    radiance: Vec<Vec3>,
    distribution: Distribution2D,
    /// World-from-map rotation.
    to_world: Mat3,
}

impl EnvironmentMap {
    /// From a linear radiance image, a scale and a world-from-map rotation.
    pub fn new(image: &Image, scale: f32, to_world: Mat3) -> Self {
        let (width, height) = image.dimensions();
        let radiance: Vec<Vec3> =
            image.pixels().iter().map(|p| Vec3::new(p[0], p[1], p[2]).max(Vec3::ZERO) * scale).collect();
        let weights: Vec<f32> = radiance
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let theta = PI * ((i / width) as f32 + 0.5) / height as f32;
                luminance(l.to_array()).max(0.0) * theta.sin()
            })
            .collect();
        Self { width, height, radiance, distribution: Distribution2D::new(&weights, width, height), to_world }
    }

    fn uv_of(&self, world: Vec3) -> Vec2 {
        let d = self.to_world.transpose() * world;
        let theta = d.z.clamp(-1.0, 1.0).acos();
        let phi = d.y.atan2(d.x).rem_euclid(TAU);
        Vec2::new(phi / TAU, theta / PI)
    }

    fn direction_of(&self, uv: Vec2) -> (Vec3, f32) {
        let (theta, phi) = (uv.y * PI, uv.x * TAU);
        let s = theta.sin();
        (self.to_world * Vec3::new(s * phi.cos(), s * phi.sin(), theta.cos()), s)
    }

    fn texel(&self, uv: Vec2) -> Vec3 {
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.radiance[y * self.width + x]
    }

    /// Radiance arriving from world direction `w` (towards the environment).
    pub fn eval(&self, w: Vec3) -> Vec3 {
        self.texel(self.uv_of(w))
    }

    /// Samples a direction: `(direction, radiance, solid-angle density)`.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let (uv, pdf_uv) = self.distribution.sample(u);
        let (w, sin_theta) = self.direction_of(uv);
        if pdf_uv <= 0.0 || sin_theta <= 0.0 {
            return None;
        }
        Some((w, self.texel(uv), pdf_uv / (2.0 * PI * PI * sin_theta)))
    }

    /// Solid-angle density of [`EnvironmentMap::sample`] for direction `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        let uv = self.uv_of(w);
        let sin_theta = (uv.y * PI).sin();
        if sin_theta <= 0.0 { 0.0 } else { self.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta) }
    }

    /// `∫ L(ω) dω` per channel, summing texels times their solid angles.
    pub fn integral(&self) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for y in 0..self.height {
            let (t0, t1) = (PI * y as f32 / self.height as f32, PI * (y + 1) as f32 / self.height as f32);
            let solid_angle = TAU / self.width as f32 * (t0.cos() - t1.cos());
            for x in 0..self.width {
                sum += self.radiance[y * self.width + x] * solid_angle;
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, UNIFORM_SPHERE_PDF, uniform_sphere};

    fn test_map() -> EnvironmentMap {
        // A dim sky with a small, very bright "sun" and a coloured band.
        let img = Image::from_fn(64, 32, |x, y| {
            let sun = if (20..23).contains(&x) && (5..7).contains(&y) { 500.0 } else { 0.0 };
            let band = if (14..18).contains(&y) { 0.5 } else { 0.1 };
            [band + sun, band * 0.8 + sun, 0.2 + sun * 0.9, 1.0]
        });
        EnvironmentMap::new(&img, 1.0, Mat3::from_rotation_z(0.3))
    }

    #[test]
    fn pdf_integrates_to_one_and_matches_sampling() {
        let env = test_map();
        let mut rng = Rng::new(3, 0);
        let n = 1_000_000;
        let mut total = 0.0f64;
        for _ in 0..n {
            total += (env.pdf(uniform_sphere(rng.uniform2())) / UNIFORM_SPHERE_PDF) as f64;
        }
        assert!((total / n as f64 - 1.0).abs() < 0.02, "{}", total / n as f64);
        for _ in 0..2000 {
            let (w, l, pdf) = env.sample(rng.uniform2()).unwrap();
            assert!((env.pdf(w) - pdf).abs() < 2e-3 * pdf, "{} vs {pdf}", env.pdf(w));
            assert!((env.eval(w) - l).length() < 1e-4 * (1.0 + l.length()));
        }
    }

    #[test]
    fn importance_sampling_estimates_the_total_radiance_without_bias() {
        let env = test_map();
        let exact = env.integral();
        let mut rng = Rng::new(4, 0);
        let n = 200_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some((_, l, pdf)) = env.sample(rng.uniform2()) {
                sum += l / pdf;
            }
        }
        let estimate = sum / n as f32;
        assert!(((estimate - exact) / exact).abs().max_element() < 0.01, "{estimate} vs {exact}");
    }

    #[test]
    fn mapping_round_trips_and_puts_the_top_row_at_the_zenith() {
        let env = EnvironmentMap::new(&Image::black(16, 8), 1.0, Mat3::IDENTITY);
        let (up, _) = env.direction_of(Vec2::new(0.3, 0.0));
        assert!(up.z > 0.999);
        let w = Vec3::new(0.3, -0.5, 0.2).normalize();
        let (back, _) = env.direction_of(env.uv_of(w));
        assert!((back - w).length() < 1e-5);
    }
}
