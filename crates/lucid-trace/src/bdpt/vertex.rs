//! Path vertices of bidirectional methods and the densities between them: each vertex keeps
//! the density with which its subpath sampled it (`pdf_fwd`) and the density with which the
//! other direction would have (`pdf_rev`), both per unit area (per solid angle towards a
//! distant light), which is what the MIS weight compares (Veach's thesis, ch. 10; pbrt's
//! `Vertex`).

use glam::Vec3;

use super::camera::CameraImportance;
use super::emission::{SceneSphere, emission_pdf, is_delta, is_distant};
use crate::bsdf::Bsdf;
use crate::integrator::Frame;
use crate::light::Light;
use crate::material::SurfaceBsdf;
use crate::scene::Scene;

/// What a vertex is.
#[derive(Clone, Copy, Debug)]
pub(crate) enum VertexKind {
    /// On the lens.
    Camera,
    /// On a light (the start of a light subpath or a sampled point on a light), or where a
    /// camera path escaped to the environment (`light` is then the environment's index).
    Light {
        /// Index into the scene's lights.
        light: u32,
    },
    /// On a surface that scatters.
    Surface {
        bsdf: SurfaceBsdf,
        frame: Frame,
        /// Unit direction towards the previous vertex of its subpath.
        wo: Vec3,
        /// The area light the surface belongs to, if it emits.
        emitter: Option<u32>,
    },
}

/// A vertex of a camera or light subpath.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Vertex {
    pub(crate) kind: VertexKind,
    pub(crate) point: Vec3,
    /// Geometric normal; zero off surfaces (lens, point lights, distant lights).
    pub(crate) normal: Vec3,
    /// Throughput of the subpath up to and including this vertex.
    pub(crate) beta: Vec3,
    pub(crate) pdf_fwd: f32,
    pub(crate) pdf_rev: f32,
    /// The subpath left this vertex by a specular (Dirac) sample.
    pub(crate) delta: bool,
}

/// Whether a BSDF or an importance travels: light subpaths carry importance, whose adjoint
/// BSDF differs from the radiance one for refraction and shading normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Transport {
    Radiance,
    Importance,
}

/// What the densities need to know about the scene.
pub(crate) struct Context<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) camera: CameraImportance,
    pub(crate) sphere: SceneSphere,
    /// The probability of picking any one light.
    pub(crate) light_pick: f32,
}

impl Vertex {
    pub(crate) fn camera(point: Vec3, beta: Vec3) -> Self {
        Self { kind: VertexKind::Camera, point, normal: Vec3::ZERO, beta, pdf_fwd: 0.0, pdf_rev: 0.0, delta: false }
    }

    pub(crate) fn light(light: u32, point: Vec3, normal: Vec3, beta: Vec3, pdf_fwd: f32) -> Self {
        Self { kind: VertexKind::Light { light }, point, normal, beta, pdf_fwd, pdf_rev: 0.0, delta: false }
    }

    pub(crate) fn is_on_surface(&self) -> bool {
        self.normal != Vec3::ZERO
    }

    /// The normal that cosines of light leaving or arriving use (shading on surfaces).
    pub(crate) fn shading_normal(&self) -> Vec3 {
        match self.kind {
            VertexKind::Surface { frame, .. } => frame.n,
            _ => self.normal,
        }
    }

    /// The light this vertex emits as, if any.
    fn emitter(&self) -> Option<u32> {
        match self.kind {
            VertexKind::Light { light } => Some(light),
            VertexKind::Surface { emitter, .. } => emitter,
            VertexKind::Camera => None,
        }
    }

    /// Whether the vertex is on a distant light (directional or environment).
    pub(crate) fn is_distant_light(&self, ctx: &Context) -> bool {
        matches!(self.kind, VertexKind::Light { light } if is_distant(&ctx.scene.lights[light as usize]))
    }

    /// Whether the vertex is on a light whose position or direction is a delta.
    pub(crate) fn is_delta_light(&self, ctx: &Context) -> bool {
        matches!(self.kind, VertexKind::Light { light } if is_delta(&ctx.scene.lights[light as usize]))
    }

    /// Whether a deterministic connection to this vertex can carry light: not through a
    /// purely specular surface nor to a directional light.
    pub(crate) fn is_connectible(&self, ctx: &Context) -> bool {
        match self.kind {
            VertexKind::Camera => true,
            VertexKind::Light { light } => !matches!(ctx.scene.lights[light as usize], Light::Directional { .. }),
            VertexKind::Surface { bsdf, .. } => !bsdf.is_specular(),
        }
    }

    /// The BSDF towards `next` (for the subpath's transport), with the shading-normal
    /// correction of adjoint transport.
    pub(crate) fn f(&self, next: &Vertex, mode: Transport) -> Vec3 {
        let VertexKind::Surface { bsdf, frame, wo, .. } = self.kind else { return Vec3::ZERO };
        let Some(wi) = (next.point - self.point).try_normalize() else { return Vec3::ZERO };
        let (wo_local, wi_local) = (frame.to_local(wo), frame.to_local(wi));
        let f = match mode {
            Transport::Radiance => bsdf.eval(wo_local, wi_local),
            Transport::Importance => bsdf.eval_adjoint(wo_local, wi_local),
        };
        f * shading_correction(frame.n, self.normal, wo, wi, mode)
    }

    /// `pdf` (per solid angle at this vertex) as a density per area at `next`.
    pub(crate) fn convert_density(&self, pdf: f32, next: &Vertex, ctx: &Context) -> f32 {
        if next.is_distant_light(ctx) {
            return pdf;
        }
        let w = next.point - self.point;
        let d2 = w.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let cos = if next.is_on_surface() { next.normal.dot(w).abs() / d2.sqrt() } else { 1.0 };
        pdf * cos / d2
    }

    /// Density per area at `next` of this vertex sampling `next`, having come from `prev`.
    pub(crate) fn pdf(&self, ctx: &Context, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        if let VertexKind::Light { .. } = self.kind {
            return self.pdf_light(ctx, next);
        }
        let Some(wn) = (next.point - self.point).try_normalize() else { return 0.0 };
        let pdf = match self.kind {
            VertexKind::Camera => ctx.camera.pdf(self.point, wn).1,
            VertexKind::Surface { bsdf, frame, .. } => {
                let Some(wp) = prev.and_then(|p| (p.point - self.point).try_normalize()) else { return 0.0 };
                bsdf.pdf(frame.to_local(wp), frame.to_local(wn))
            }
            VertexKind::Light { .. } => unreachable!(),
        };
        self.convert_density(pdf, next, ctx)
    }

    /// Density per area at `v` of this light vertex emitting towards it.
    pub(crate) fn pdf_light(&self, ctx: &Context, v: &Vertex) -> f32 {
        let w = v.point - self.point;
        let d2 = w.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let w = w / d2.sqrt();
        let pdf = if self.is_distant_light(ctx) {
            ctx.sphere.disk_pdf()
        } else {
            let Some(light) = self.emitter() else { return 0.0 };
            emission_pdf(&ctx.scene.lights[light as usize], ctx.sphere, self.normal, w).1 / d2
        };
        if v.is_on_surface() { pdf * v.normal.dot(w).abs() } else { pdf }
    }

    /// Density of this light vertex as the start of a light subpath (light choice included):
    /// per area, or per solid angle for distant lights.
    pub(crate) fn pdf_light_origin(&self, ctx: &Context, v: &Vertex) -> f32 {
        let Some(w) = (v.point - self.point).try_normalize() else { return 0.0 };
        if self.is_distant_light(ctx) {
            return distant_light_density(ctx, -w);
        }
        let Some(light) = self.emitter() else { return 0.0 };
        emission_pdf(&ctx.scene.lights[light as usize], ctx.sphere, self.normal, w).0 * ctx.light_pick
    }

    /// Radiance this vertex emits towards `v` (area lights and the environment).
    pub(crate) fn le(&self, ctx: &Context, v: &Vertex) -> Vec3 {
        let Some(w) = (v.point - self.point).try_normalize() else { return Vec3::ZERO };
        let Some(light) = self.emitter() else { return Vec3::ZERO };
        let light = &ctx.scene.lights[light as usize];
        if self.is_distant_light(ctx) {
            return light.environment(-w).map_or(Vec3::ZERO, |(l, _)| l);
        }
        light.emitted(self.normal, w)
    }
}

/// Density with which a light subpath starts at the environment towards direction
/// `towards` (pointing at the environment), light choice included.
pub(crate) fn distant_light_density(ctx: &Context, towards: Vec3) -> f32 {
    match ctx.scene.environment {
        Some(env) => ctx.scene.lights[env].environment(towards).map_or(0.0, |(_, pdf)| pdf) * ctx.light_pick,
        None => 0.0,
    }
}

/// The factor that turns a BSDF sample's radiance weight into its importance weight on a
/// light path at a surface with shading frame `frame` and geometric normal `ng`, from `wo`
/// (towards the light's side) to `wi`: refraction's η² and the shading-normal correction.
pub(crate) fn importance_factor(
    bsdf: &SurfaceBsdf,
    frame: Frame,
    ng: Vec3,
    wo: Vec3,
    wi: Vec3,
    sample: &crate::bsdf::BsdfSample,
) -> f32 {
    bsdf.adjoint_scale(frame.to_local(wo), sample) * shading_correction(frame.n, ng, wo, wi, Transport::Importance)
}

/// Veach's correction for shading normals under adjoint transport (1 for radiance):
/// |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
pub(crate) fn shading_correction(ns: Vec3, ng: Vec3, wo: Vec3, wi: Vec3, mode: Transport) -> f32 {
    if mode == Transport::Radiance || ns == ng {
        return 1.0;
    }
    let denominator = wo.dot(ng).abs() * wi.dot(ns).abs();
    if denominator == 0.0 { 0.0 } else { wo.dot(ns).abs() * wi.dot(ng).abs() / denominator }
}
