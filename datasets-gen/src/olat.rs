//! One-light-at-a-time capture: every view lit by each of `L` directional lights spread over
//! the sphere in turn (linear HDR), plus ground truth of held-out views under environment
//! maps, for relighting.

use std::sync::Arc;

use glam::Vec3;
use lucid_image::Image;
use lucid_trace::environment::EnvironmentMap;
use lucid_trace::light::Light;

/// What an OLAT dataset lights its frames with.
#[derive(Clone, Debug, PartialEq)]
pub struct OlatSpec {
    /// Unit directions towards each light.
    pub directions: Vec<Vec3>,
    /// Directions of further lights that light only the validation and test views, one at a time: light
    /// directions a relighting model never saw in training (frames marked
    /// `"held_out_light": true`).
    pub held_out: Vec<Vec3>,
    /// Irradiance of each light on a surface facing it (π makes a white Lambertian surface
    /// facing the light render with radiance 1).
    pub irradiance: f32,
    /// Held-out environment maps (lat-long, linear) for the ground-truth frames, with names.
    pub environments: Vec<(String, Arc<Image>)>,
}

/// How one frame is lit.
#[derive(Clone, Debug, PartialEq)]
pub enum Lighting {
    /// OLAT light number `index`.
    Light {
        /// Which light.
        index: usize,
    },
    /// Held-out light number `index` (validation and test views only).
    HeldOutLight {
        /// Which light.
        index: usize,
    },
    /// Environment map number `index`.
    Environment {
        /// Which map.
        index: usize,
    },
}

impl OlatSpec {
    /// The lights of a frame, for [`lucid_trace::Scene::relit`].
    pub fn lights(&self, lighting: &Lighting) -> Vec<Light> {
        match *lighting {
            Lighting::Light { index } => {
                vec![Light::Directional { direction: self.directions[index], irradiance: Vec3::splat(self.irradiance) }]
            }
            Lighting::HeldOutLight { index } => {
                vec![Light::Directional { direction: self.held_out[index], irradiance: Vec3::splat(self.irradiance) }]
            }
            Lighting::Environment { index } => {
                let map = EnvironmentMap::new(&self.environments[index].1, 1.0, glam::Mat3::IDENTITY);
                vec![Light::EnvironmentMap(Box::new(map))]
            }
        }
    }
}

/// `n` directions spread almost uniformly over the sphere (a Fibonacci lattice).
pub fn sphere_directions(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// `n` held-out light directions: a Fibonacci lattice of `n` points turned about two axes, so
/// that they fall between the lattice of the training lights rather than on it.
pub fn held_out_directions(n: usize) -> Vec<Vec3> {
    let turn = glam::Mat3::from_rotation_z(0.7) * glam::Mat3::from_rotation_x(0.45);
    sphere_directions(n).into_iter().map(|d| (turn * d).normalize()).collect()
}

/// Two held-out lighting environments (lat-long, +Z up, 128×64): a clear sky with a sun, and
/// a dark studio with a warm key and a cool rim light. Procedural, so the dataset needs no
/// external files.
pub fn builtin_environments() -> Vec<(String, Arc<Image>)> {
    let direction = |u: f32, v: f32| {
        let (theta, phi) = (v * std::f32::consts::PI, u * std::f32::consts::TAU);
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    };
    let towards = |azimuth: f32, elevation: f32| {
        let (a, e) = (azimuth.to_radians(), elevation.to_radians());
        Vec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin())
    };
    let (w, h) = (128, 64);
    let sun = towards(60.0, 35.0);
    let sky = Image::from_fn(w, h, |x, y| {
        let d = direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        let base = if d.z > 0.0 {
            Vec3::new(0.9, 0.9, 1.0).lerp(Vec3::new(0.25, 0.45, 0.9), d.z.powf(0.6))
        } else {
            Vec3::new(0.15, 0.12, 0.1)
        };
        let disk = if d.dot(sun) > 4f32.to_radians().cos() { Vec3::splat(150.0) } else { Vec3::ZERO };
        (base + disk).extend(1.0).to_array()
    });
    let (key, rim) = (towards(30.0, 40.0), towards(200.0, 20.0));
    let blob = |d: Vec3, centre: Vec3, sigma_deg: f32| {
        let angle = d.dot(centre).clamp(-1.0, 1.0).acos();
        (-(angle / sigma_deg.to_radians()).powi(2) / 2.0).exp()
    };
    let studio = Image::from_fn(w, h, |x, y| {
        let d = direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        let l = Vec3::splat(0.02)
            + Vec3::new(8.0, 6.0, 4.0) * blob(d, key, 12.0)
            + Vec3::new(2.0, 4.0, 8.0) * blob(d, rim, 15.0);
        l.extend(1.0).to_array()
    });
    vec![("sky".into(), Arc::new(sky)), ("studio".into(), Arc::new(studio))]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_cover_the_sphere_evenly() {
        let d = sphere_directions(200);
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
        // The mean direction of an even spread is near zero, and every octant gets ~1/8.
        let mean = d.iter().sum::<Vec3>() / d.len() as f32;
        assert!(mean.length() < 0.02, "{mean}");
        for octant in 0..8 {
            let count = d
                .iter()
                .filter(|v| {
                    ((v.x > 0.0) as usize) | (((v.y > 0.0) as usize) << 1) | (((v.z > 0.0) as usize) << 2) == octant
                })
                .count();
            assert!((count as f32 - 25.0).abs() <= 5.0, "octant {octant}: {count}");
        }
    }
}
