//! Camera paths traced eight at a time in lock-step (a small wavefront). Each stage of a
//! bounce — closest hits, surface events, light samples, shadow rays, BSDF samples — runs for
//! every live path before the next starts, over per-lane arrays, and a lane whose path ends
//! takes the next path of the batch. One path alone is a long chain of dependent square roots,
//! divisions and mispredicted branches that leaves the core waiting; eight side by side give
//! it independent work (the whole Cornell frame renders about 20 % faster than one path at a
//! time). Diffuse surfaces and triangle lights are computed in lane loops of their own (the
//! Lambertian sample and the shading frames vectorise), other materials and lights by the
//! scalar code per lane. The estimator is [`PathTracer::trace`]'s, step for step, with the same
//! random numbers in the same order per path, for scenes without participating media or
//! index-matched boundaries (the renderer traces those one path at a time).

// Lane loops index several per-lane arrays with one lane number.
#![allow(clippy::needless_range_loop)]

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};
use lucid_scene::Ray;
use lucid_scene::simd::wide;

use crate::LightStrategy;
use crate::bsdf::Bsdf;
use crate::geometry::{Intersection, PacketHits, RayPacket, Shape};
use crate::integrator::{Frame, PathSample, PathTracer, light_selection_probability, pick_light_index};
use crate::light::{Light, LightSample, area_share};
use crate::material::{Material, SurfaceBsdf};
use crate::sampling::{Rng, cosine_hemisphere, cosine_hemisphere_pdf};
use crate::scene::Scene;

mod lanes;

use lanes::{F8, M8, V8};

/// Paths per packet.
pub const LANES: usize = 8;

type Lanes = [f32; LANES];

/// Vectors, one coordinate per row of lanes.
#[derive(Clone, Copy, Default)]
struct Vec3Lanes {
    x: Lanes,
    y: Lanes,
    z: Lanes,
}

impl Vec3Lanes {
    #[inline(always)]
    fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.x[l], self.y[l], self.z[l])
    }

    #[inline(always)]
    fn set(&mut self, l: usize, v: Vec3) {
        self.x[l] = v.x;
        self.y[l] = v.y;
        self.z[l] = v.z;
    }

    /// The x, y and z rows.
    #[inline(always)]
    fn rows(&self) -> [Lanes; 3] {
        [self.x, self.y, self.z]
    }

    /// The lanes as a value for lane arithmetic.
    #[inline(always)]
    fn v8(&self) -> V8 {
        V8 { x: F8(self.x), y: F8(self.y), z: F8(self.z) }
    }

    /// Stores `v`'s lanes.
    #[inline(always)]
    fn store(&mut self, v: V8) {
        (self.x, self.y, self.z) = (v.x.0, v.y.0, v.z.0);
    }
}

/// What kind of surface vertex a lane has this bounce.
#[derive(Clone, Copy, Default, PartialEq, Eq)]
enum VertexKind {
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
enum LightDraw {
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
struct Paths {
    origin: Vec3Lanes,
    direction: Vec3Lanes,
    beta: Vec3Lanes,
    radiance: Vec3Lanes,
    /// The previous vertex's BSDF pdf, meaningful where `prev_specular` is false.
    prev_pdf: Lanes,
    /// The previous bounce was specular, or this is the camera ray: emission found counts fully.
    prev_specular: [bool; LANES],
    prev_point: Vec3Lanes,
    segments: [u32; LANES],
    alive: [bool; LANES],
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
    fn alive_mask(&self) -> u32 {
        (0..LANES).fold(0, |mask, l| mask | (self.alive[l] as u32) << l)
    }

    /// Starts a camera path along `ray` in lane `l`.
    fn begin(&mut self, l: usize, ray: &Ray) {
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
struct Vertices {
    kind: [VertexKind; LANES],
    point: Vec3Lanes,
    geometric_normal: Vec3Lanes,
    /// Shading frame: tangent, bitangent, normal.
    t: Vec3Lanes,
    b: Vec3Lanes,
    n: Vec3Lanes,
    /// Towards the viewer, in the shading frame.
    wo: Vec3Lanes,
    /// Albedo of diffuse vertices.
    albedo: Vec3Lanes,
    /// The BSDF of each general vertex, built once per bounce.
    general: [Option<SurfaceBsdf>; LANES],
}

/// One bounce's light samples.
#[derive(Default)]
struct LightSamples {
    draw: [LightDraw; LANES],
    /// A triangle light's draw: the point `u · area` among the cumulative areas, the bounds
    /// of the picked triangle's share (`light::area_share`) and the second uniform.
    target: Lanes,
    share_lo: Lanes,
    share_hi: Lanes,
    v: Lanes,
    /// The picked triangle's vertices and normal, the light's area and radiance.
    p0: Vec3Lanes,
    p1: Vec3Lanes,
    p2: Vec3Lanes,
    light_normal: Vec3Lanes,
    area: Lanes,
    two_sided: [bool; LANES],
    li: Vec3Lanes,
    wi: Vec3Lanes,
    pdf: Lanes,
    distance: Lanes,
    delta: [bool; LANES],
    valid: [bool; LANES],
}

impl PathTracer {
    /// Whether [`PathTracer::trace_paths`] can render `scene`.
    pub fn packet_supports(scene: &Scene) -> bool {
        !scene.has_media() && !scene.has_subsurface()
    }

    /// Traces `out.len()` camera paths, `start(k)` giving path `k`'s camera ray and random
    /// stream, into `out[k]`: eight at a time, a lane whose path ends taking the next one, so
    /// that the lanes stay busy (paths end after different numbers of bounces). Each path
    /// draws only from its own stream, so the results do not depend on which lane traced it
    /// when. The same estimator as [`PathTracer::trace`] for scenes that
    /// [`PathTracer::packet_supports`].
    pub fn trace_paths(&self, scene: &Scene, start: impl FnMut(usize) -> (Ray, Rng), out: &mut [PathSample]) {
        // The whole bounce loop compiled for AVX2 where the CPU has it, not only its lane
        // arithmetic: the per-lane scalar code (surface events, light draws, BSDF samples) in
        // three-operand instructions ran the Cornell box 4 % faster, and the lane arithmetic
        // inlined into the loop rather than called as AVX2 functions of its own 2 % more.
        // Same numbers either way (no fused multiply-adds).
        wide(
            #[inline(always)]
            || self.trace_paths_in(scene, start, out),
        )
    }

    /// [`PathTracer::trace_paths`]' loop, inlined into its AVX2 build.
    #[inline(always)]
    fn trace_paths_in(&self, scene: &Scene, mut start: impl FnMut(usize) -> (Ray, Rng), out: &mut [PathSample]) {
        debug_assert!(Self::packet_supports(scene));
        let light_pick = light_selection_probability(scene);
        let mut paths = Paths::default();
        let mut rngs: [Rng; LANES] = std::array::from_fn(|_| Rng::new(0, 0));
        let mut camera_rays = [Ray { origin: Vec3::ZERO, direction: Vec3::Z }; LANES];
        let mut results = [PathSample::default(); LANES];
        let mut traced: [Option<usize>; LANES] = [None; LANES];
        // New paths' first hits, in the lanes of `fresh`, until their lane's next closest-hit
        // stage takes them.
        let mut first = no_hits();
        let mut fresh = 0u32;
        let mut staged = StagedPaths::default();
        let mut vertices = Vertices::default();
        let mut lights = LightSamples::default();
        loop {
            // The lanes whose path ended, as a mask: a branch per lane on whether it is alive
            // went either way at random.
            let mut ended = !paths.alive_mask() & ((1 << LANES) - 1);
            while ended != 0 {
                let l = ended.trailing_zeros() as usize;
                ended &= ended - 1;
                if let Some(k) = traced[l].take() {
                    out[k] = PathSample { radiance: paths.radiance.get(l), ..results[l] };
                }
                if let Some((k, ray, rng, hit)) = staged.next(scene, &mut start, out.len()) {
                    first.mask = first.mask & !(1 << l) | (hit.is_some() as u32) << l;
                    (first.t[l], first.u[l], first.v[l], first.primitive[l]) = hit.unwrap_or((0.0, 0.0, 0.0, 0));
                    fresh |= 1 << l;
                    paths.begin(l, &ray);
                    (rngs[l], camera_rays[l], results[l], traced[l]) = (rng, ray, PathSample::default(), Some(k));
                }
            }
            if paths.alive_mask() == 0 {
                break;
            }
            let hits = closest_hits(scene, &paths, &first, &mut fresh, &mut results);
            self.surface_events(scene, &mut paths, &hits, &mut vertices, &camera_rays, light_pick, &mut results);
            if vertices.kind.iter().all(|&k| k == VertexKind::None) {
                continue;
            }
            vertices.shading_frames(&paths);
            if !scene.lights.is_empty() && self.strategy != LightStrategy::BsdfOnly {
                self.draw_lights(scene, &vertices, &mut lights, light_pick, &mut rngs);
                lights.finish_triangles(&vertices, light_pick);
                self.next_events(scene, &mut paths, &vertices, &lights, &mut results);
            }
            self.scatter(&mut paths, &vertices, &mut rngs);
        }
    }

    /// Emission found by the rays, the environment where they miss, the material where they hit.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn surface_events(
        &self,
        scene: &Scene,
        paths: &mut Paths,
        hits: &PacketHits,
        vertices: &mut Vertices,
        camera_rays: &[Ray; LANES],
        light_pick: f32,
        out: &mut [PathSample; LANES],
    ) {
        for l in 0..LANES {
            vertices.kind[l] = VertexKind::None;
            if !paths.alive[l] {
                continue;
            }
            let direction = paths.direction.get(l);
            let beta = paths.beta.get(l);
            let prev_pdf = (!paths.prev_specular[l]).then_some(paths.prev_pdf[l]);
            let first = paths.segments[l] == 1;
            let Some((t, u, v, i)) = hits.lane(l) else {
                if let Some(env) = scene.environment
                    && !(first && self.hide_emitters)
                    && let Some((radiance, env_pdf)) = scene.lights[env].environment(direction)
                {
                    let weight = self.emission_weight(prev_pdf, light_pick * env_pdf);
                    paths.radiance.set(l, paths.radiance.get(l) + beta * radiance * weight);
                }
                paths.alive[l] = false;
                continue;
            };
            let hit: Intersection = scene
                .bvh
                .triangle_interaction(t, u, v, i)
                .unwrap_or_else(|| scene.bvh.interaction(&Ray { origin: paths.origin.get(l), direction }, t, u, v, i));
            let primitive = &scene.bvh.primitives()[i as usize];
            let material = &scene.materials[primitive.material as usize];
            if first {
                out[l].alpha = 1.0;
                out[l].distance = (hit.point - camera_rays[l].origin).dot(camera_rays[l].direction);
                out[l].normal = hit.shading_normal;
                out[l].albedo = material.albedo(hit.uv);
            }
            if let Some(light) = primitive.light
                && !(first && self.hide_emitters)
            {
                let light = &scene.lights[light as usize];
                let le = light.emitted(hit.geometric_normal, -direction);
                if le != Vec3::ZERO {
                    let weight = self.emission_weight(
                        prev_pdf,
                        light_pick * light.pdf_area(paths.prev_point.get(l), hit.point, hit.geometric_normal),
                    );
                    paths.radiance.set(l, paths.radiance.get(l) + beta * le * weight);
                }
            }
            if paths.segments[l] >= self.max_depth {
                paths.alive[l] = false;
                continue;
            }
            vertices.kind[l] = match material {
                Material::Lambertian { albedo } => {
                    vertices.albedo.set(l, albedo.eval(hit.uv));
                    VertexKind::Diffuse
                }
                _ => {
                    vertices.general[l] = Some(material.bsdf(hit.uv));
                    VertexKind::General
                }
            };
            vertices.point.set(l, hit.point);
            vertices.geometric_normal.set(l, hit.geometric_normal);
            vertices.n.set(l, hit.shading_normal);
            vertices.t.set(l, hit.tangent);
        }
    }

    /// Picks a light per lane and draws its sample: points on triangle lights are left for
    /// [`LightSamples::finish_triangles`], other lights are sampled here.
    #[inline(always)]
    fn draw_lights(
        &self,
        scene: &Scene,
        vertices: &Vertices,
        lights: &mut LightSamples,
        light_pick: f32,
        rngs: &mut [Rng; LANES],
    ) {
        for l in 0..LANES {
            lights.draw[l] = LightDraw::None;
            lights.valid[l] = false;
            let kind = vertices.kind[l];
            if kind == VertexKind::None || (kind == VertexKind::General && vertices.bsdf(l).is_specular()) {
                continue;
            }
            // The same draws as `PathTracer::pick_light` and `Light::sample`.
            let rng = &mut rngs[l];
            let pick = pick_light_index(scene, rng);
            let u = rng.uniform2();
            let light = &scene.lights[pick];
            if let Light::Area { cdf, shapes, area, radiance, two_sided } = light {
                let (k, target, lo, hi) = area_share(cdf, *area, u.x);
                if let (Shape::Triangle { p, .. }, normal) = &shapes[k] {
                    lights.draw[l] = LightDraw::Triangle;
                    (lights.target[l], lights.share_lo[l], lights.share_hi[l], lights.v[l]) = (target, lo, hi, u.y);
                    lights.p0.set(l, p[0]);
                    lights.p1.set(l, p[1]);
                    lights.p2.set(l, p[2]);
                    lights.light_normal.set(l, *normal);
                    lights.area[l] = *area;
                    lights.two_sided[l] = *two_sided;
                    lights.li.set(l, *radiance);
                    continue;
                }
            }
            lights.draw[l] = LightDraw::Done;
            if let Some(ls) = light.sample(vertices.point.get(l), u)
                && ls.pdf > 0.0
            {
                lights.store(l, &ls, light_pick);
            }
        }
    }

    /// Light samples weighed by the BSDF and tested with shadow rays.
    #[inline(always)]
    fn next_events(
        &self,
        scene: &Scene,
        paths: &mut Paths,
        vertices: &Vertices,
        lights: &LightSamples,
        out: &mut [PathSample; LANES],
    ) {
        let mut nee = self.diffuse_next_events(paths, vertices, lights);
        if vertices.kind.contains(&VertexKind::General) {
            for l in 0..LANES {
                if vertices.kind[l] != VertexKind::General || !lights.valid[l] {
                    continue;
                }
                let wo = vertices.wo.get(l);
                let wi = vertices.frame(l).to_local(lights.wi.get(l));
                let bsdf = vertices.bsdf(l);
                let f = bsdf.eval(wo, wi);
                if f == Vec3::ZERO {
                    continue;
                }
                let light_pdf = lights.pdf[l];
                let weight = self.light_sample_weight(lights.delta[l], light_pdf, bsdf.pdf(wo, wi));
                nee.contribution.set(l, paths.beta.get(l) * f * wi.z.abs() * lights.li.get(l) * weight / light_pdf);
                nee.shadow[l] = true;
            }
        }
        // The shadow rays, traced together.
        let mut live = 0u32;
        for l in 0..LANES {
            live |= (nee.shadow[l] as u32) << l;
            out[l].rays += nee.shadow[l] as u32;
        }
        if live == 0 {
            return;
        }
        let (origin, reach) = lights.shadow_rays(vertices);
        let packet = RayPacket { origin: origin.rows(), direction: lights.wi.rows() };
        let blocked = scene.bvh.occluded_packet(&packet, live, 0.0, &reach);
        let lit = M8(std::array::from_fn(|l| (live & !blocked) >> l & 1 != 0));
        let radiance = paths.radiance.v8();
        paths.radiance.store(lit.select3(radiance + nee.contribution.v8(), radiance));
    }

    /// The next-event estimates of the diffuse vertices in lane arithmetic: the Lambertian
    /// BSDF's value and density (`Lambertian::eval`, `pdf`), the MIS weight
    /// ([`PathTracer::light_sample_weight`]) and the contribution, with which lanes need a
    /// shadow ray. Other lanes need none here.
    #[inline(always)]
    fn diffuse_next_events(&self, paths: &Paths, vertices: &Vertices, lights: &LightSamples) -> NextEvents {
        let world = lights.wi.v8();
        let wi = V8 { x: world.dot(vertices.t.v8()), y: world.dot(vertices.b.v8()), z: world.dot(vertices.n.v8()) };
        let same_side = (vertices.wo.v8().z * wi.z).gt(0.0);
        let f = same_side.select3(vertices.albedo.v8() * F8::from(FRAC_1_PI), V8::default());
        let bsdf_pdf = same_side.select(wi.z.abs().max(0.0) * FRAC_1_PI, 0.0.into());
        let light_pdf = F8(lights.pdf);
        let weight = match self.strategy {
            LightStrategy::Mis => {
                // `power_heuristic`.
                let (a, b) = (light_pdf * light_pdf, bsdf_pdf * bsdf_pdf);
                let sum = a + b;
                sum.eq(0.0).select(0.0.into(), a / sum)
            }
            LightStrategy::NextEventOnly => 1.0.into(),
            LightStrategy::BsdfOnly => 0.0.into(),
        };
        let weight = M8(lights.delta).select(1.0.into(), weight);
        let contribution = paths.beta.v8() * f * wi.z.abs() * lights.li.v8() * weight / light_pdf;
        let nonzero = f.x.ne(0.0) | f.y.ne(0.0) | f.z.ne(0.0);
        let diffuse = M8(vertices.kind.map(|k| k == VertexKind::Diffuse));
        let mut nee = NextEvents::default();
        nee.contribution.store(contribution);
        nee.shadow = (diffuse & M8(lights.valid) & nonzero).0;
        nee
    }

    /// Samples each live vertex's BSDF for the next ray, and plays Russian roulette.
    #[inline(always)]
    fn scatter(&self, paths: &mut Paths, vertices: &Vertices, rngs: &mut [Rng; LANES]) {
        let mut s = BsdfSamples::default();
        for l in 0..LANES {
            if vertices.kind[l] != VertexKind::None {
                let rng = &mut rngs[l];
                (s.u[l], s.uc[l]) = (rng.uniform2(), rng.uniform());
            }
        }
        s.sample_diffuse(vertices);
        for l in 0..LANES {
            match vertices.kind[l] {
                VertexKind::None => s.valid[l] = false,
                VertexKind::Diffuse => {}
                VertexKind::General => {
                    let sample = vertices.bsdf(l).sample(vertices.wo.get(l), s.u[l], s.uc[l]);
                    s.valid[l] = sample.is_some_and(|b| b.pdf > 0.0 && b.f != Vec3::ZERO);
                    if let Some(b) = sample.filter(|_| s.valid[l]) {
                        s.wi.set(l, b.wi);
                        s.f.set(l, b.f);
                        s.pdf[l] = b.pdf;
                        s.specular[l] = b.specular;
                    }
                }
            }
        }
        paths.continue_from(vertices, &s);
        for l in 0..LANES {
            if paths.alive[l] && paths.segments[l] > self.rr_depth {
                let mut beta = paths.beta.get(l);
                paths.alive[l] = self.russian_roulette(paths.segments[l], &mut beta, &mut rngs[l]);
                paths.beta.set(l, beta);
            }
        }
    }
}

/// One bounce's next-event estimates: each lane's contribution if its shadow ray is unblocked.
#[derive(Default)]
struct NextEvents {
    contribution: Vec3Lanes,
    shadow: [bool; LANES],
}

/// One bounce's BSDF samples.
#[derive(Default)]
struct BsdfSamples {
    u: [Vec2; LANES],
    uc: Lanes,
    wi: Vec3Lanes,
    f: Vec3Lanes,
    pdf: Lanes,
    specular: [bool; LANES],
    valid: [bool; LANES],
}

impl BsdfSamples {
    /// The Lambertian sample ([`crate::bsdf::Lambertian`]'s `sample`) in every lane, in a lane
    /// loop that the compiler vectorises; other lanes overwrite it afterwards.
    #[inline(always)]
    fn sample_diffuse(&mut self, vertices: &Vertices) {
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
    fn continue_from(&mut self, vertices: &Vertices, s: &BsdfSamples) {
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

/// A closest hit: `(t, u, v, primitive)`.
type Hit = (f32, f32, f32, u32);

/// The next paths to start, with their camera rays' hits: eight consecutive paths (a pixel's
/// samples, whose camera rays are coherent) traced as one packet, several times faster than
/// one by one; later bounces are traced by whichever paths share the lanes then.
struct StagedPaths {
    rays: [Ray; LANES],
    rngs: [Option<Rng>; LANES],
    hits: [Option<Hit>; LANES],
    /// The first path staged, and how many are staged and taken.
    first: usize,
    len: usize,
    taken: usize,
}

impl Default for StagedPaths {
    fn default() -> Self {
        Self {
            rays: [Ray { origin: Vec3::ZERO, direction: Vec3::Z }; LANES],
            rngs: [const { None }; LANES],
            hits: [None; LANES],
            first: 0,
            len: 0,
            taken: 0,
        }
    }
}

impl StagedPaths {
    /// Path `k`'s camera ray, random stream and first hit, for the paths `0..count` in order
    /// (`start(k)` is called once per path, in that order). Inlined into the caller, where
    /// the tuple stays in registers: returned through memory, written field by field and read
    /// back whole, it stalled every path's start.
    #[inline(always)]
    fn next(
        &mut self,
        scene: &Scene,
        start: &mut impl FnMut(usize) -> (Ray, Rng),
        count: usize,
    ) -> Option<(usize, Ray, Rng, Option<Hit>)> {
        if self.taken == self.len {
            self.stage(scene, start, count);
            if self.len == 0 {
                return None;
            }
        }
        let l = self.taken;
        self.taken += 1;
        let rng = self.rngs[l].take().expect("a staged path has its stream");
        Some((self.first + l, self.rays[l], rng, self.hits[l]))
    }

    /// Stages the next eight paths (fewer at the end) and traces their camera rays.
    #[inline(never)]
    fn stage(&mut self, scene: &Scene, start: &mut impl FnMut(usize) -> (Ray, Rng), count: usize) {
        self.first += self.len;
        self.len = LANES.min(count.saturating_sub(self.first));
        self.taken = 0;
        for l in 0..self.len {
            let (ray, rng) = start(self.first + l);
            (self.rays[l], self.rngs[l]) = (ray, Some(rng));
        }
        if self.len > 0 {
            let packet = RayPacket::from_rays(&self.rays[..self.len]);
            let hits = scene.bvh.closest_packet(&packet, (1 << self.len) - 1, 0.0, f32::INFINITY);
            self.hits = std::array::from_fn(|l| hits.lane(l));
        }
    }
}

/// No hits in any lane.
fn no_hits() -> PacketHits {
    PacketHits { mask: 0, t: [0.0; LANES], u: [0.0; LANES], v: [0.0; LANES], primitive: [0; LANES] }
}

/// Each live path's closest hit: the `first` hit of a new path in a lane of `fresh` (which
/// is then cleared), the others' rays traced together. As lanes of one packet rather than an
/// array of options, which were written field by field and read back whole (a store
/// forwarding stall per lane).
#[inline(always)]
fn closest_hits(
    scene: &Scene,
    paths: &Paths,
    first: &PacketHits,
    fresh: &mut u32,
    out: &mut [PathSample; LANES],
) -> PacketHits {
    let mut live = 0u32;
    for l in 0..LANES {
        live |= (paths.alive[l] as u32) << l;
        out[l].rays += paths.alive[l] as u32;
    }
    let rays = RayPacket { origin: paths.origin.rows(), direction: paths.direction.rows() };
    let mut hits = scene.bvh.closest_packet(&rays, live & !*fresh, 0.0, f32::INFINITY);
    let new = *fresh;
    for l in 0..LANES {
        let on = new >> l & 1 != 0;
        hits.t[l] = if on { first.t[l] } else { hits.t[l] };
        hits.u[l] = if on { first.u[l] } else { hits.u[l] };
        hits.v[l] = if on { first.v[l] } else { hits.v[l] };
        hits.primitive[l] = if on { first.primitive[l] } else { hits.primitive[l] };
    }
    hits.mask = hits.mask & !new | first.mask & new;
    *fresh = 0;
    hits
}

impl Vertices {
    /// The shading frames ([`Frame::new`]) and `wo` in them, in a lane loop.
    #[inline(always)]
    fn shading_frames(&mut self, paths: &Paths) {
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
    fn frame(&self, l: usize) -> Frame {
        Frame { t: self.t.get(l), b: self.b.get(l), n: self.n.get(l) }
    }

    /// The BSDF of a general vertex.
    fn bsdf(&self, l: usize) -> &SurfaceBsdf {
        self.general[l].as_ref().expect("a general vertex has its BSDF")
    }
}

impl LightSamples {
    /// A complete sample, its density times the light's selection probability `light_pick`.
    fn store(&mut self, l: usize, ls: &LightSample, light_pick: f32) {
        self.wi.set(l, ls.wi);
        self.li.set(l, ls.li);
        self.pdf[l] = light_pick * ls.pdf;
        self.distance[l] = ls.distance;
        self.delta[l] = ls.delta;
        self.valid[l] = true;
    }

    /// The shadow rays' origins (`spawn_origin`) and reaches, in every lane.
    #[inline(always)]
    fn shadow_rays(&self, vertices: &Vertices) -> (Vec3Lanes, Lanes) {
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
    fn finish_triangles(&mut self, vertices: &Vertices, light_pick: f32) {
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
