//! Point-like lights for the many-light renderers: the scene's point and spot lights, and
//! virtual point lights (VPLs) left by light paths at the non-specular surfaces they reach
//! (Keller's instant radiosity).

use glam::Vec3;

use crate::bdpt::emission::SceneSphere;
use crate::bsdf::Bsdf;
use crate::integrator::{Frame, spawn_origin};
use crate::light::{Light, spot_falloff};
use crate::material::SurfaceBsdf;
use crate::render::RenderSettings;
use crate::sampling::{Rng, mix};
use crate::scene::Scene;
use crate::visible::{LightVertex, VisiblePoint, trace_light_path};

/// How a virtual light's emission varies with direction.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Emitter {
    /// The same in every direction (a point light).
    Omni,
    /// A spot light's cone.
    Spot { axis: Vec3, cos_outer: f32, cos_inner: f32 },
    /// A Lambertian VPL: emission ∝ the cosine to `normal` (on the side it was lit from).
    Diffuse { normal: Vec3 },
    /// A VPL reflecting with its surface's full BSDF, lit from `wo` (local to `frame`).
    Surface { frame: Frame, wo: Vec3, bsdf: SurfaceBsdf },
}

/// A point light, real or virtual.
#[derive(Clone, Copy, Debug)]
pub(crate) struct VirtualLight {
    pub(crate) position: Vec3,
    /// Geometric normal of a VPL's surface (zero for point and spot lights), for rays
    /// leaving it.
    pub(crate) surface_normal: Vec3,
    pub(crate) emitter: Emitter,
    /// Radiant intensity (W/sr) for point and spot lights; for VPLs the power they carry
    /// divided by the paths of the pass, times ρ/π for diffuse ones.
    pub(crate) intensity: Vec3,
    /// Path segments from the light source to here (0 for point and spot lights).
    pub(crate) segments: u32,
}

impl VirtualLight {
    /// The scene's point and spot lights.
    pub(crate) fn from_scene(scene: &Scene) -> Vec<VirtualLight> {
        scene
            .lights
            .iter()
            .filter_map(|light| {
                let (position, emitter, intensity) = match *light {
                    Light::Point { position, intensity } => (position, Emitter::Omni, intensity),
                    Light::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                        (position, Emitter::Spot { axis: direction, cos_outer, cos_inner }, intensity)
                    }
                    _ => return None,
                };
                Some(VirtualLight { position, surface_normal: Vec3::ZERO, emitter, intensity, segments: 0 })
            })
            .collect()
    }

    /// Whether this light is one the many-light renderers take from the scene (the rest are
    /// sampled one at a time).
    pub(crate) fn represents(light: &Light) -> bool {
        matches!(light, Light::Point { .. } | Light::Spot { .. })
    }

    /// The emission towards `to` per unit intensity, with the squared distance floored at
    /// `clamp2` for VPLs: the clamp that keeps a VPL close to a surface from lighting it as a
    /// bright spot (biased, the bias vanishing with the clamp).
    #[inline]
    pub(crate) fn emission(&self, to: Vec3, distance2: f32, clamp2: f32) -> Vec3 {
        let towards = (to - self.position) / distance2.sqrt();
        match self.emitter {
            Emitter::Omni => Vec3::splat(1.0 / distance2),
            Emitter::Spot { axis, cos_outer, cos_inner } => {
                Vec3::splat(spot_falloff(axis.dot(towards), cos_outer, cos_inner) / distance2)
            }
            Emitter::Diffuse { normal } => Vec3::splat(normal.dot(towards).max(0.0) / distance2.max(clamp2)),
            Emitter::Surface { frame, wo, bsdf } => {
                let wi = frame.to_local(towards);
                // Light arrives along `wo` and leaves towards `to`: the camera-side order.
                bsdf.eval(wi, wo) * (wi.z.abs() / distance2.max(clamp2))
            }
        }
    }

    /// What this light sends to visible point `vp` (before the point's path weight), with
    /// the shadow ray counted in `rays`; zero if occluded or facing away.
    #[inline]
    pub(crate) fn contribution(&self, scene: &Scene, vp: &VisiblePoint, clamp2: f32, rays: &mut u32) -> Vec3 {
        self.unit_contribution(scene, vp, clamp2, rays) * self.intensity
    }

    /// [`Self::contribution`] per unit intensity: the factor a cluster this light represents
    /// multiplies by its total intensity.
    #[inline]
    pub(crate) fn unit_contribution(&self, scene: &Scene, vp: &VisiblePoint, clamp2: f32, rays: &mut u32) -> Vec3 {
        let d = self.position - vp.point;
        let distance2 = d.length_squared();
        if distance2 <= 0.0 {
            return Vec3::ZERO;
        }
        let distance = distance2.sqrt();
        let wi_world = d / distance;
        let wi = vp.frame.to_local(wi_world);
        let f = vp.bsdf.eval(vp.wo, wi) * wi.z.abs();
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let e = self.emission(vp.point, distance2, clamp2);
        if e == Vec3::ZERO {
            return Vec3::ZERO;
        }
        *rays += 1;
        let origin = spawn_origin(vp.point, vp.normal, wi_world);
        // Ends short of the light: a VPL lies on a surface the ray must not hit.
        let target = if self.surface_normal == Vec3::ZERO {
            self.position
        } else {
            spawn_origin(self.position, self.surface_normal, -wi_world)
        };
        let to = target - origin;
        let length = to.length();
        if length <= 0.0 {
            return Vec3::ZERO;
        }
        let ray = lucid_scene::Ray { origin, direction: to / length };
        if scene.bvh.occluded(&ray, 0.0, length * (1.0 - 1e-4)) {
            return Vec3::ZERO;
        }
        f * e
    }
}

/// How the VPLs of a pass reflect.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum VplKind {
    /// With the full BSDF of their surface (instant radiosity).
    Surface,
    /// As Lambertian reflectors of their surface's diffuse part (lightcuts, whose cluster
    /// bounds need a cosine emitter).
    Diffuse,
}

/// The VPLs of `paths` light paths traced from stream `seed`, in path order; each carries its
/// path's power divided by `paths`. Returns them and the rays traced.
pub(crate) fn trace_vpls(
    scene: &Scene,
    settings: &RenderSettings,
    paths: u32,
    seed: u64,
    kind: VplKind,
) -> (Vec<VirtualLight>, u64) {
    use rayon::prelude::*;
    let sphere = SceneSphere::around(scene);
    let per_path: Vec<(Vec<VirtualLight>, u32)> = (0..paths)
        .into_par_iter()
        .map(|n| {
            let mut rng = Rng::new(mix(seed ^ 0x0056_504C), n as u64);
            let mut out = Vec::new();
            let rays = trace_light_path(scene, settings, sphere, &mut rng, |v| {
                if let Some(light) = vpl_at(v, kind, paths) {
                    out.push(light);
                }
            });
            (out, rays)
        })
        .collect();
    let rays = per_path.iter().map(|p| p.1 as u64).sum();
    (per_path.into_iter().flat_map(|p| p.0).collect(), rays)
}

fn vpl_at(v: &LightVertex, kind: VplKind, paths: u32) -> Option<VirtualLight> {
    let power = v.beta / paths as f32;
    let wo = v.frame.to_local(v.towards_light);
    let (emitter, intensity) = match kind {
        VplKind::Surface => (Emitter::Surface { frame: v.frame, wo, bsdf: *v.bsdf }, power),
        VplKind::Diffuse => {
            let rho = diffuse_reflectance(v.bsdf, wo);
            if rho == Vec3::ZERO {
                return None;
            }
            let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
            (Emitter::Diffuse { normal: v.frame.to_world(Vec3::Z * side) }, power * rho * std::f32::consts::FRAC_1_PI)
        }
    };
    if intensity == Vec3::ZERO {
        return None;
    }
    Some(VirtualLight {
        position: v.hit.point,
        surface_normal: v.hit.geometric_normal,
        emitter,
        intensity,
        segments: v.bounce + 1,
    })
}

/// The Lambertian part of a BSDF lit from `wo` (local): the albedo of diffuse materials,
/// the diffuse term of diffuse-plus-lobe ones, the base seen through a plastic's coating
/// towards the normal; zero for metals and glass.
fn diffuse_reflectance(bsdf: &SurfaceBsdf, wo: Vec3) -> Vec3 {
    match bsdf {
        SurfaceBsdf::Lambertian(b) => b.albedo,
        SurfaceBsdf::Plastic(b) => b.eval(wo, Vec3::new(0.0, 0.0, wo.z.signum())) * std::f32::consts::PI,
        SurfaceBsdf::Phong(b) => b.diffuse,
        SurfaceBsdf::BlinnPhong(b) => b.diffuse,
        SurfaceBsdf::Lafortune(b) => b.diffuse,
        SurfaceBsdf::Ward(b) => b.diffuse,
        SurfaceBsdf::CookTorrance(b) => b.diffuse,
        SurfaceBsdf::AshikhminShirley(b) => b.rd * (Vec3::ONE - b.rs),
        SurfaceBsdf::MetallicRoughness(b) => b.base_color * (1.0 - b.metallic),
        // Its reflectance towards the normal, as a Lambertian surface would have.
        SurfaceBsdf::Measured(b) => b.eval(wo, Vec3::new(0.0, 0.0, wo.z.signum())) * std::f32::consts::PI,
        SurfaceBsdf::Neural(b) => b.eval(wo, Vec3::new(0.0, 0.0, wo.z.signum())) * std::f32::consts::PI,
        SurfaceBsdf::PoulinFournier(b) => b.diffuse(),
        // Fibres scatter around their axis, not as a Lambertian surface.
        SurfaceBsdf::Conductor(_) | SurfaceBsdf::Dielectric(_) | SurfaceBsdf::Hair(_) | SurfaceBsdf::KajiyaKay(_) => {
            Vec3::ZERO
        }
    }
}
