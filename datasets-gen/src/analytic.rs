//! An analytic scene: spheres over a checkered ground disk, lit by a sun with hard shadows
//! and a uniform sky, shaded in closed form (Lambertian direct light, no interreflection).
//!
//! Its images are exact and noise-free, so it renders in milliseconds and gives the tests
//! and the quick demo a dataset whose depth, normals and albedo are known exactly.

use glam::{Vec2, Vec3};
use lucid_image::Image;
use lucid_scene::{Camera, PinholeCamera, Ray, ThinLensCamera};
use rayon::prelude::*;

use crate::writer::{Lens, RenderedView, ViewRenderer};

/// A sphere with a constant albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
    /// Diffuse reflectance (linear RGB).
    pub albedo: Vec3,
}

/// A horizontal disk (normal +Z) with a checkerboard albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckerDisk {
    /// Centre of the disk.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
    /// Side of one checker square.
    pub square: f32,
    /// Albedo of the even squares.
    pub albedo_a: Vec3,
    /// Albedo of the odd squares.
    pub albedo_b: Vec3,
}

/// What a ray hits first.
#[derive(Clone, Copy, Debug)]
struct Hit {
    t: f32,
    point: Vec3,
    normal: Vec3,
    albedo: Vec3,
}

/// A scene shaded analytically; see the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalyticScene {
    /// The spheres.
    pub spheres: Vec<Sphere>,
    /// The ground.
    pub ground: Option<CheckerDisk>,
    /// Unit direction towards the sun.
    pub sun_direction: Vec3,
    /// Irradiance from the sun on a surface facing it (linear RGB, W/m²-like units).
    pub sun_irradiance: Vec3,
    /// Radiance of the uniform sky; lights every surface as unoccluded ambient light.
    pub sky_radiance: Vec3,
    /// Supersampling: `n × n` stratified samples per pixel.
    pub samples_per_axis: u32,
}

impl Default for AnalyticScene {
    /// Three coloured spheres on a checkered disk, fitting in [-1, 1]³, with a sun bright
    /// enough that lit white surfaces exceed 1 (so HDR matters).
    fn default() -> Self {
        Self {
            spheres: vec![
                Sphere { centre: Vec3::new(0.0, 0.0, 0.0), radius: 0.5, albedo: Vec3::new(0.8, 0.3, 0.2) },
                Sphere { centre: Vec3::new(0.6, -0.45, -0.3), radius: 0.2, albedo: Vec3::new(0.2, 0.7, 0.3) },
                Sphere { centre: Vec3::new(-0.55, 0.5, -0.25), radius: 0.25, albedo: Vec3::new(0.25, 0.35, 0.85) },
            ],
            ground: Some(CheckerDisk {
                centre: Vec3::new(0.0, 0.0, -0.5),
                radius: 1.0,
                square: 0.25,
                albedo_a: Vec3::splat(0.85),
                albedo_b: Vec3::splat(0.15),
            }),
            sun_direction: Vec3::new(0.4, -0.3, 0.87).normalize(),
            sun_irradiance: Vec3::new(4.0, 3.8, 3.4),
            sky_radiance: Vec3::new(0.25, 0.3, 0.4),
            samples_per_axis: 3,
        }
    }
}

impl AnalyticScene {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for s in &self.spheres {
            // |o + t d − c|² = r² with |d| = 1.
            let oc = ray.origin - s.centre;
            let b = oc.dot(ray.direction);
            let c = oc.length_squared() - s.radius * s.radius;
            let disc = b * b - c;
            if disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            let t = if -b - sq > 1e-4 { -b - sq } else { -b + sq };
            if t > 1e-4 && best.is_none_or(|h| t < h.t) {
                let point = ray.at(t);
                best = Some(Hit { t, point, normal: (point - s.centre) / s.radius, albedo: s.albedo });
            }
        }
        if let Some(g) = &self.ground
            && ray.direction.z.abs() > 1e-8
        {
            let t = (g.centre.z - ray.origin.z) / ray.direction.z;
            let point = ray.at(t);
            let local = Vec2::new(point.x - g.centre.x, point.y - g.centre.y);
            if t > 1e-4 && local.length() <= g.radius && best.is_none_or(|h| t < h.t) {
                let cell = (local / g.square).floor();
                let even = (cell.x as i64 + cell.y as i64).rem_euclid(2) == 0;
                let albedo = if even { g.albedo_a } else { g.albedo_b };
                // Two-sided: the normal faces the viewer.
                let normal = if ray.direction.z < 0.0 { Vec3::Z } else { -Vec3::Z };
                best = Some(Hit { t, point, normal, albedo });
            }
        }
        best
    }

    /// Outgoing radiance at a hit: Lambertian sun term with a shadow ray, plus sky ambient.
    fn shade(&self, hit: &Hit) -> Vec3 {
        let cos = hit.normal.dot(self.sun_direction).max(0.0);
        let lit = cos > 0.0 && self.intersect(&Ray::new(hit.point + 1e-3 * hit.normal, self.sun_direction)).is_none();
        let direct = if lit { self.sun_irradiance * cos / std::f32::consts::PI } else { Vec3::ZERO };
        hit.albedo * (direct + self.sky_radiance)
    }
}

impl ViewRenderer for AnalyticScene {
    fn render(&self, camera: &PinholeCamera, lens: Option<Lens>, _view: u64) -> Result<RenderedView, String> {
        let k = camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        let n = self.samples_per_axis.max(1);
        // A thin lens needs the aperture integrated too: a stratified 8x8 grid of lens points
        // per pixel sample.
        let lens_n: u32 = if lens.is_some() { 8 } else { 1 };
        let thin_lens = lens.map(|l| ThinLensCamera::new(*camera, l.aperture_radius, l.focus_distance));
        let inv = 1.0 / (n * n * lens_n * lens_n) as f32;
        let view_axis = camera.forward();
        let rows: Vec<Vec<[[f32; 4]; 4]>> = (0..h)
            .into_par_iter()
            .map(|j| {
                (0..w)
                    .map(|i| {
                        let (mut colour, mut normal, mut albedo) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
                        let (mut depth, mut coverage) = (0.0f32, 0.0f32);
                        for s in 0..n * n * lens_n * lens_n {
                            let (pixel, lens_index) = (s / (lens_n * lens_n), s % (lens_n * lens_n));
                            let (sx, sy) = (pixel % n, pixel / n);
                            let jitter = Vec2::new((sx as f32 + 0.5) / n as f32, (sy as f32 + 0.5) / n as f32);
                            let lens_uv = Vec2::new(
                                ((lens_index % lens_n) as f32 + 0.5) / lens_n as f32,
                                ((lens_index / lens_n) as f32 + 0.5) / lens_n as f32,
                            );
                            let ray = match &thin_lens {
                                Some(t) => t.jittered_ray(i as u32, j as u32, jitter, lens_uv),
                                None => camera.jittered_ray(i as u32, j as u32, jitter, Vec2::ZERO),
                            };
                            {
                                if let Some(hit) = self.intersect(&ray) {
                                    colour += self.shade(&hit);
                                    normal += hit.normal;
                                    albedo += hit.albedo;
                                    depth += hit.t * ray.direction.dot(view_axis);
                                    coverage += 1.0;
                                }
                            }
                        }
                        let alpha = coverage * inv;
                        // Straight alpha: colour is the mean over the covered samples.
                        let c = if coverage > 0.0 { colour / coverage } else { Vec3::ZERO };
                        let a = if coverage > 0.0 { albedo / coverage } else { Vec3::ZERO };
                        let nrm = normal.normalize_or_zero();
                        let d = if coverage > 0.0 { depth / coverage } else { 0.0 };
                        [
                            c.extend(alpha).to_array(),
                            [d, d, d, alpha],
                            nrm.extend(alpha).to_array(),
                            a.extend(alpha).to_array(),
                        ]
                    })
                    .collect()
            })
            .collect();
        let plane = |k: usize| Image::from_pixels(w, h, rows.iter().flat_map(|r| r.iter().map(|p| p[k])).collect());
        Ok(RenderedView { colour: plane(0), depth: plane(1), normal: plane(2), albedo: plane(3) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;
    use lucid_scene::{Intrinsics, look_at};

    #[test]
    fn depth_and_normals_match_the_geometry() {
        // Looking straight down at the top of the big sphere from z = 3: the centre pixel
        // hits (0, 0, 0.5) at z-depth 2.5 with normal +Z.
        let scene = AnalyticScene::default();
        let pose = look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y);
        let cam = PinholeCamera::new(Intrinsics::from_fov_x(33, 33, 0.5), pose);
        let view = scene.render(&cam, None, 0).unwrap();
        let d = view.depth.get(16, 16);
        assert!((d[0] - 2.5).abs() < 1e-3, "{d:?}");
        let n = view.normal.get(16, 16);
        assert!(n[2] > 0.999);
        let a = view.albedo.get(16, 16);
        assert!((Vec3::new(a[0], a[1], a[2]) - Vec3::new(0.8, 0.3, 0.2)).length() < 1e-5, "{a:?}");
        // The lit top of the sphere: albedo · (E cos / π + sky).
        let cos = scene.sun_direction.z;
        let expected =
            scene.spheres[0].albedo * (scene.sun_irradiance * cos / std::f32::consts::PI + scene.sky_radiance);
        let c = view.colour.get(16, 16);
        assert!((Vec3::new(c[0], c[1], c[2]) - expected).length() < 0.02, "{c:?} vs {expected}");
    }

    #[test]
    fn background_is_transparent() {
        let scene = AnalyticScene::default();
        let pose = Mat4::from_translation(Vec3::new(0.0, 10.0, 0.0)); // looks down −Z, misses everything
        let view = scene.render(&PinholeCamera::new(Intrinsics::from_fov_x(8, 8, 0.2), pose), None, 0).unwrap();
        assert!(view.colour.pixels().iter().all(|p| p[3] == 0.0));
    }
}
