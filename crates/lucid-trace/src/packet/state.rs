//! The packet's per-lane state — its paths, one bounce's surface vertices, light samples,
//! next-event estimates and BSDF samples, each a struct of lane rows — and the stages written
//! in lane arithmetic over it (shading frames, triangle-light samples, the continuation).

// Lane loops index several per-lane arrays with one lane number.
#![allow(clippy::needless_range_loop)]

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};
use lucid_scene::Ray;

use super::LANES;
use super::lanes::{F8, M8, V8};
use crate::integrator::Frame;
use crate::light::LightSample;
use crate::material::SurfaceBsdf;
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};

pub(super) type Lanes = [f32; LANES];

/// Vectors, one coordinate per row of lanes.
#[derive(Clone, Copy, Default)]
pub(super) struct Vec3Lanes {
    pub(super) x: Lanes,
    pub(super) y: Lanes,
    pub(super) z: Lanes,
}

impl Vec3Lanes {
    #[inline(always)]
    pub(super) fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.x[l], self.y[l], self.z[l])
    }

    #[inline(always)]
    pub(super) fn set(&mut self, l: usize, v: Vec3) {
        self.x[l] = v.x;
        self.y[l] = v.y;
        self.z[l] = v.z;
    }

    /// The x, y and z rows.
    #[inline(always)]
    pub(super) fn rows(&self) -> [Lanes; 3] {
        [self.x, self.y, self.z]
    }

    /// The lanes as a value for lane arithmetic.
    #[inline(always)]
    pub(super) fn v8(&self) -> V8 {
        V8 { x: F8(self.x), y: F8(self.y), z: F8(self.z) }
    }

    /// Stores `v`'s lanes.
    #[inline(always)]
    pub(super) fn store(&mut self, v: V8) {
        (self.x, self.y, self.z) = (v.x.0, v.y.0, v.z.0);
    }
}

/// What kind of surface vertex a lane has this bounce.
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum VertexKind {
    /// The path ended.
    #[default]
    None,
    /// A Lambertian surface: evaluated and sampled in the lane loops.
    Diffuse,
    /// Any other material: its BSDF is built and called per lane.
    General,
}

/// How a lane's light sample was drawn.
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum LightDraw {
    /// No light sample this bounce.
    #[default]
    None,
    /// A triangle of an area light: the point on it is in the lane arrays, the rest is computed
    /// in a lane loop.
    Triangle,
    /// Already complete (any other light), or rejected.
    Done,
}

/// The packet's paths.
pub(super) struct Paths {
    pub(super) origin: Vec3Lanes,
    pub(super) direction: Vec3Lanes,
    pub(super) beta: Vec3Lanes,
    pub(super) radiance: Vec3Lanes,
    /// The previous vertex's BSDF pdf, meaningful where `prev_specular` is false.
    pub(super) prev_pdf: Lanes,
    /// The previous bounce was specular, or this is the camera ray: emission found counts fully.
    pub(super) prev_specular: [bool; LANES],
    pub(super) prev_point: Vec3Lanes,
    pub(super) segments: [u32; LANES],
    pub(super) alive: [bool; LANES],
}

impl Default for Paths {
    /// No live paths.
    fn default() -> Self {
        Self {
            origin: Vec3Lanes::default(),
            direction: Vec3Lanes::default(),
            beta: Vec3Lanes::default(),
            radiance: Vec3Lanes::default(),
            prev_pdf: [0.0; LANES],
            prev_specular: [true; LANES],
            prev_point: Vec3Lanes::default(),
            segments: [1; LANES],
            alive: [false; LANES],
        }
    }
}

impl Paths {
    /// The live lanes, bit `l` for lane `l`.
    #[inline(always)]
    pub(super) fn alive_mask(&self) -> u32 {
        (0..LANES).fold(0, |mask, l| mask | (self.alive[l] as u32) << l)
    }

    /// Starts a camera path along `ray` in lane `l`.
    pub(super) fn begin(&mut self, l: usize, ray: &Ray) {
        self.origin.set(l, ray.origin);
        self.direction.set(l, ray.direction);
        self.beta.set(l, Vec3::ONE);
        self.radiance.set(l, Vec3::ZERO);
        self.prev_pdf[l] = 0.0;
        self.prev_specular[l] = true;
        self.prev_point.set(l, ray.origin);
        self.segments[l] = 1;
        self.alive[l] = true;
    }
}

/// One bounce's surface vertices.
#[derive(Default)]
pub(super) struct Vertices {
    pub(super) kind: [VertexKind; LANES],
    pub(super) point: Vec3Lanes,
    pub(super) geometric_normal: Vec3Lanes,
    /// Shading frame: tangent, bitangent, normal.
    pub(super) t: Vec3Lanes,
    pub(super) b: Vec3Lanes,
    pub(super) n: Vec3Lanes,
    /// Towards the viewer, in the shading frame.
    pub(super) wo: Vec3Lanes,
    /// Albedo of diffuse vertices.
    pub(super) albedo: Vec3Lanes,
    /// The BSDF of each general vertex, built once per bounce.
    pub(super) general: [Option<SurfaceBsdf>; LANES],
}

/// One bounce's light samples.
#[derive(Default)]
pub(super) struct LightSamples {
    pub(super) draw: [LightDraw; LANES],
    /// A triangle light's draw: the point `u · area` among the cumulative areas, the bounds
    /// of the picked triangle's share (`light::area_share`) and the second uniform.
    pub(super) target: Lanes,
    pub(super) share_lo: Lanes,
    pub(super) share_hi: Lanes,
    pub(super) v: Lanes,
    /// The picked triangle's vertices and normal, the light's area and radiance.
    pub(super) p0: Vec3Lanes,
    pub(super) p1: Vec3Lanes,
    pub(super) p2: Vec3Lanes,
    pub(super) light_normal: Vec3Lanes,
    pub(super) area: Lanes,
    pub(super) two_sided: [bool; LANES],
    pub(super) li: Vec3Lanes,
    pub(super) wi: Vec3Lanes,
    pub(super) pdf: Lanes,
    pub(super) distance: Lanes,
    pub(super) delta: [bool; LANES],
    pub(super) valid: [bool; LANES],
}

/// One bounce's next-event estimates: each lane's contribution if its shadow ray is unblocked.
#[derive(Default)]
pub(super) struct NextEvents {
    pub(super) contribution: Vec3Lanes,
    pub(super) shadow: [bool; LANES],
}

/// One bounce's BSDF samples.
#[derive(Default)]
pub(super) struct BsdfSamples {
    pub(super) u: [Vec2; LANES],
    pub(super) uc: Lanes,
    pub(super) wi: Vec3Lanes,
    pub(super) f: Vec3Lanes,
    pub(super) pdf: Lanes,
    pub(super) specular: [bool; LANES],
    pub(super) valid: [bool; LANES],
}

impl BsdfSamples {
    /// The Lambertian sample ([`crate::bsdf::Lambertian`]'s `sample`) in every lane, in a lane
    /// loop that the compiler vectorises; other lanes overwrite it afterwards.
    #[inline(always)]
    pub(super) fn sample_diffuse(&mut self, vertices: &Vertices) {
        for l in 0..LANES {
            let mut wi = cosine_hemisphere(self.u[l]);
            if vertices.wo.z[l] < 0.0 {
                wi.z = -wi.z;
            }
            let pdf = cosine_hemisphere_pdf(wi.z.abs());
            let f = vertices.albedo.get(l) * FRAC_1_PI;
            self.wi.set(l, wi);
            self.f.set(l, f);
            self.pdf[l] = pdf;
            self.specular[l] = false;
            self.valid[l] = (pdf > 0.0) & (f != Vec3::ZERO);
        }
    }
}

impl Paths {
    /// Moves each path with a valid sample on to its next ray, ending the others: every lane
    /// computed in lane arithmetic and the results kept where valid (`Frame::to_world`,
    /// `spawn_origin`; as one lane loop it did not vectorise and cost a twentieth of the frame).
    #[inline(always)]
    pub(super) fn continue_from(&mut self, vertices: &Vertices, s: &BsdfSamples) {
        let valid = M8(s.valid);
        let wi = s.wi.v8();
        let point = vertices.point.v8();
        let direction = (wi.x * vertices.t.v8() + wi.y * vertices.b.v8() + wi.z * vertices.n.v8()).normalize();
        let beta = self.beta.v8() * (s.f.v8() * wi.z.abs() / F8(s.pdf));
        let origin = spawn_origin8(point, vertices.geometric_normal.v8(), direction);
        self.beta.store(valid.select3(beta, self.beta.v8()));
        self.origin.store(valid.select3(origin, self.origin.v8()));
        self.direction.store(valid.select3(direction, self.direction.v8()));
        self.prev_point.store(valid.select3(point, self.prev_point.v8()));
        self.prev_pdf = valid.select(F8(s.pdf), F8(self.prev_pdf)).0;
        for l in 0..LANES {
            self.prev_specular[l] = if valid.0[l] { s.specular[l] } else { self.prev_specular[l] };
            self.segments[l] += valid.0[l] as u32;
            self.alive[l] &= valid.0[l];
        }
    }
}

/// [`crate::integrator::spawn_origin`] in every lane.
#[inline(always)]
fn spawn_origin8(point: V8, normal: V8, direction: V8) -> V8 {
    let offset = 1e-4 * (1.0 + point.abs().max_element());
    let side = direction.dot(normal).ge(0.0).select(1.0.into(), (-1.0).into());
    point + side * offset * normal
}

impl Vertices {
    /// The shading frames ([`Frame::new`]) and `wo` in them, in a lane loop.
    #[inline(always)]
    pub(super) fn shading_frames(&mut self, paths: &Paths) {
        for l in 0..LANES {
            let n = self.n.get(l);
            let frame = Frame::new(n, self.t.get(l));
            self.t.set(l, frame.t);
            self.b.set(l, frame.b);
            self.wo.set(l, frame.to_local(-paths.direction.get(l)));
        }
    }

    /// Lane `l`'s shading frame (after [`Vertices::shading_frames`]).
    #[inline(always)]
    pub(super) fn frame(&self, l: usize) -> Frame {
        Frame { t: self.t.get(l), b: self.b.get(l), n: self.n.get(l) }
    }

    /// The BSDF of a general vertex.
    pub(super) fn bsdf(&self, l: usize) -> &SurfaceBsdf {
        self.general[l].as_ref().expect("a general vertex has its BSDF")
    }
}

impl LightSamples {
    /// A complete sample, its density times the light's selection probability `light_pick`.
    pub(super) fn store(&mut self, l: usize, ls: &LightSample, light_pick: f32) {
        self.wi.set(l, ls.wi);
        self.li.set(l, ls.li);
        self.pdf[l] = light_pick * ls.pdf;
        self.distance[l] = ls.distance;
        self.delta[l] = ls.delta;
        self.valid[l] = true;
    }

    /// The shadow rays' origins (`spawn_origin`) and reaches, in every lane.
    #[inline(always)]
    pub(super) fn shadow_rays(&self, vertices: &Vertices) -> (Vec3Lanes, Lanes) {
        let origin = spawn_origin8(vertices.point.v8(), vertices.geometric_normal.v8(), self.wi.v8());
        let distance = F8(self.distance);
        let reach = distance.is_finite().select(distance * (1.0 - 1e-3), f32::INFINITY.into());
        let mut rows = Vec3Lanes::default();
        rows.store(origin);
        (rows, reach.0)
    }

    /// Completes the samples of triangle lights in lane arithmetic: the point on the picked
    /// triangle (`light::rescale_in_share`, `light::point_on_triangle`) and the sample towards
    /// it (`light::towards_area_point`), kept where a lane drew a triangle.
    #[inline(always)]
    pub(super) fn finish_triangles(&mut self, vertices: &Vertices, light_pick: f32) {
        let on = M8(self.draw.map(|d| d == LightDraw::Triangle));
        let ux = ((F8(self.target) - F8(self.share_lo))
            / (F8(self.share_hi) - F8(self.share_lo)).max(f32::MIN_POSITIVE))
        .clamp(0.0, 0.999_999);
        // `uniform_triangle` and `point_on_triangle`.
        let s = ux.sqrt();
        let (b0, b1) = (1.0 - s, F8(self.v) * s);
        let light_point = b0 * self.p0.v8() + b1 * self.p1.v8() + (1.0 - b0 - b1) * self.p2.v8();
        // `towards_area_point`.
        let d = light_point - vertices.point.v8();
        let dist2 = d.length_squared();
        let distance = dist2.sqrt();
        let wi = d / distance;
        let cos_light = -wi.dot(self.light_normal.v8());
        let pdf = dist2 / (cos_light.abs() * F8(self.area));
        let valid = distance.ne(0.0) & (cos_light.gt(0.0) | M8(self.two_sided)) & pdf.is_finite();
        self.wi.store(on.select3(wi, self.wi.v8()));
        self.pdf = on.select(light_pick * pdf, F8(self.pdf)).0;
        self.distance = on.select(distance, F8(self.distance)).0;
        for l in 0..LANES {
            if on.0[l] {
                self.delta[l] = false;
                self.valid[l] = valid.0[l] & (pdf.0[l] > 0.0);
            }
        }
    }
}
