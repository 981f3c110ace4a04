//! Procedural hair: fibres as polylines, later cut into [`Shape::Fibre`](super::Shape::Fibre)
//! segments. Two grooms, both in a unit frame that the scene's transform places: a hairy ball
//! (fibres growing from the unit sphere, bending under gravity and curling) and a tress
//! (fibres hanging from a short parting along x at z = 0, waving as they fall).

use glam::Vec3;

use crate::sampling::{Rng, orthonormal_basis};

/// How the fibres are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Groom {
    /// Fibres over the whole unit sphere.
    Ball,
    /// Fibres hanging from a parting.
    Tress,
}

impl Groom {
    /// Parses `ball` or `tress`.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "ball" => Some(Groom::Ball),
            "tress" => Some(Groom::Tress),
            _ => None,
        }
    }
}

/// What to grow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FibreParams {
    /// Layout.
    pub groom: Groom,
    /// Number of fibres.
    pub count: u32,
    /// Straight segments per fibre.
    pub segments: u32,
    /// Fibre length (unit-frame units).
    pub length: f32,
    /// How much the fibres curl or wave, 0 = straight.
    pub curl: f32,
    /// Seed of the jitter.
    pub seed: u64,
}

/// The fibres' polylines, root first, each `segments + 1` points.
pub fn grow(params: &FibreParams) -> Vec<Vec<Vec3>> {
    (0..params.count)
        .map(|i| {
            let mut rng = Rng::new(params.seed, i as u64);
            match params.groom {
                Groom::Ball => ball_fibre(params, i, &mut rng),
                Groom::Tress => tress_fibre(params, i, &mut rng),
            }
        })
        .collect()
}

fn ball_fibre(params: &FibreParams, i: u32, rng: &mut Rng) -> Vec<Vec3> {
    // A Fibonacci lattice spreads the roots evenly; jitter breaks its spirals.
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let z = (1.0 - 2.0 * (i as f32 + 0.2 + 0.6 * rng.uniform()) / params.count as f32).clamp(-1.0, 1.0);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = golden * i as f32 + 0.3 * (rng.uniform() - 0.5);
    let normal = Vec3::new(r * phi.cos(), r * phi.sin(), z);
    let (e1, e2) = orthonormal_basis(normal);
    let step = params.length / params.segments as f32;
    let (phase, twist) = (std::f32::consts::TAU * rng.uniform(), 0.6 + 0.8 * rng.uniform());
    let mut direction = normal;
    let mut p = normal;
    let mut points = vec![p];
    for k in 0..params.segments {
        let angle = phase + twist * k as f32;
        let side = e1 * angle.cos() + e2 * angle.sin();
        // Gravity bends the fibre more the further it is from its root.
        let droop = 0.08 * (k as f32 + 1.0) / params.segments as f32;
        direction = (direction + params.curl * 0.5 * side - droop * Vec3::Z).normalize();
        if k == 0 && direction.dot(normal) < 0.3 {
            direction = (direction + normal).normalize(); // leave the scalp
        }
        p += step * direction;
        points.push(p);
    }
    points
}

fn tress_fibre(params: &FibreParams, _i: u32, rng: &mut Rng) -> Vec<Vec3> {
    let root = Vec3::new(rng.uniform() - 0.5, 0.06 * (rng.uniform() - 0.5), 0.0);
    let amplitude = params.curl * 0.05 * params.length * (0.7 + 0.6 * rng.uniform());
    let (phase, waves) = (std::f32::consts::TAU * rng.uniform(), 2.0 + rng.uniform());
    let spread = 0.15 * root.x;
    let length = params.length * (0.85 + 0.15 * rng.uniform());
    (0..=params.segments)
        .map(|k| {
            let t = k as f32 / params.segments as f32;
            let wave = amplitude * (std::f32::consts::TAU * waves * t + phase).sin() * t.sqrt();
            root + Vec3::new(spread * t + wave, 0.3 * wave, -length * t)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibres_have_their_length_and_roots() {
        for groom in [Groom::Ball, Groom::Tress] {
            let params = FibreParams { groom, count: 300, segments: 10, length: 0.5, curl: 0.4, seed: 3 };
            let fibres = grow(&params);
            assert_eq!(fibres.len(), 300);
            for f in &fibres {
                assert_eq!(f.len(), 11);
                let length: f32 = f.windows(2).map(|w| (w[1] - w[0]).length()).sum();
                match groom {
                    // Steps of exactly length/segments.
                    Groom::Ball => {
                        assert!((length - 0.5).abs() < 1e-4, "{length}");
                        assert!((f[0].length() - 1.0).abs() < 1e-5);
                        assert!(f[1].length() > 1.0, "the first segment leaves the sphere");
                    }
                    // The path is at least the fall and not much longer.
                    Groom::Tress => {
                        assert!((0.5 * 0.85 - 1e-5..0.6).contains(&length), "{length}");
                        assert!(f[0].z == 0.0 && f[10].z < -0.4);
                    }
                }
            }
            // Deterministic by seed.
            assert_eq!(grow(&params), fibres);
            assert_ne!(grow(&FibreParams { seed: 4, ..params }), fibres);
        }
        // Ball roots cover the sphere evenly: each octant holds about an eighth.
        let fibres =
            grow(&FibreParams { groom: Groom::Ball, count: 4000, segments: 3, length: 0.1, curl: 0.0, seed: 1 });
        let mut octants = [0usize; 8];
        for f in &fibres {
            let r = f[0];
            octants[(r.x > 0.0) as usize | ((r.y > 0.0) as usize) << 1 | ((r.z > 0.0) as usize) << 2] += 1;
        }
        assert!(octants.iter().all(|&n| (440..=560).contains(&n)), "{octants:?}");
    }
}
