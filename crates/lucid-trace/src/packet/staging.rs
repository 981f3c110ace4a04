//! Where the packet's paths get their closest hits: new paths staged eight at a time with
//! their camera rays traced as one packet, later bounces traced by the lanes' live paths.

// Lane loops index several per-lane arrays with one lane number.
#![allow(clippy::needless_range_loop)]

use glam::Vec3;
use lucid_scene::Ray;

use super::LANES;
use super::state::Paths;
use crate::geometry::{PacketHits, RayPacket};
use crate::integrator::PathSample;
use crate::sampling::Rng;
use crate::scene::Scene;

/// A closest hit: `(t, u, v, primitive)`.
type Hit = (f32, f32, f32, u32);

/// The next paths to start, with their camera rays' hits: eight consecutive paths (a pixel's
/// samples, whose camera rays are coherent) traced as one packet, several times faster than
/// one by one; later bounces are traced by whichever paths share the lanes then.
pub(super) struct StagedPaths {
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
    pub(super) fn next(
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
    pub(super) fn stage(&mut self, scene: &Scene, start: &mut impl FnMut(usize) -> (Ray, Rng), count: usize) {
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
pub(super) fn no_hits() -> PacketHits {
    PacketHits { mask: 0, t: [0.0; LANES], u: [0.0; LANES], v: [0.0; LANES], primitive: [0; LANES] }
}

/// Each live path's closest hit: the `first` hit of a new path in a lane of `fresh` (which
/// is then cleared), the others' rays traced together. As lanes of one packet rather than an
/// array of options, which were written field by field and read back whole (a store
/// forwarding stall per lane).
#[inline(always)]
pub(super) fn closest_hits(
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
