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

use glam::Vec3;
use lucid_scene::Ray;
use lucid_scene::simd::wide;

use crate::LightStrategy;
use crate::bsdf::Bsdf;
use crate::geometry::{Intersection, PacketHits, RayPacket, Shape};
use crate::integrator::{PathSample, PathTracer, light_selection_probability, pick_light_index};
use crate::light::{Light, area_share};
use crate::material::Material;
use crate::sampling::Rng;
use crate::scene::Scene;

mod lanes;
mod staging;
mod state;

use lanes::{F8, M8, V8};
use staging::{StagedPaths, closest_hits, no_hits};
use state::{BsdfSamples, LightDraw, LightSamples, NextEvents, Paths, VertexKind, Vertices};

/// Paths per packet.
pub const LANES: usize = 8;

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
