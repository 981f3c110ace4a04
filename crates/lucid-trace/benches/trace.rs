//! Where a path-traced frame's time goes, query by query, on the Cornell box of `lucid bench
//! trace`: `cargo bench -p lucid-trace --bench trace`. Times closest-hit and shadow queries
//! over fixed ray sets gathered from the scene (camera rays, then diffuse bounces and light
//! samples from their hits), and whole paths, on one thread, in nanoseconds per query; the
//! headline wall time of the frame is `lucid bench trace`'s.

use std::time::Instant;

use glam::Vec2;
use lucid_scene::Ray;
use lucid_scene::camera::Camera;
use lucid_trace::geometry::{RAYS, RayPacket};
use lucid_trace::integrator::spawn;
use lucid_trace::render::RenderCamera;
use lucid_trace::sampling::{Rng, cosine_hemisphere, orthonormal_basis};
use lucid_trace::scene_file::load_scene;

fn best_of(reps: usize, mut f: impl FnMut() -> usize) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut out = 0;
    for _ in 0..reps {
        let t = Instant::now();
        out = f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, out)
}

fn main() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes/cornell.toml");
    let loaded = load_scene(&path).expect("configs/scenes/cornell.toml");
    let scene = &loaded.scene;
    let RenderCamera::Pinhole(camera) = loaded.camera else { panic!("the Cornell camera is a pinhole") };
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);

    // Camera rays, one per pixel; then from each hit a cosine-distributed bounce and a shadow
    // ray towards a sampled light point.
    let mut rng = Rng::new(1, 1);
    let camera_rays: Vec<Ray> = (0..w * h)
        .map(|k| camera.generate_ray((k % w) as f32 + rng.uniform(), (k / w) as f32 + rng.uniform(), Vec2::ZERO))
        .collect();
    let mut bounce_rays = Vec::new();
    let mut shadow_rays = Vec::new();
    for ray in &camera_rays {
        let Some(hit) = scene.bvh.intersect(ray, 0.0, f32::INFINITY) else { continue };
        let (t, b) = orthonormal_basis(hit.shading_normal);
        let d = cosine_hemisphere(rng.uniform2());
        bounce_rays.push(spawn(&hit, d.x * t + d.y * b + d.z * hit.shading_normal));
        if let Some(ls) = scene.lights.first().and_then(|l| l.sample(hit.point, rng.uniform2())) {
            shadow_rays.push((spawn(&hit, ls.wi), ls.distance * (1.0 - 1e-3)));
        }
    }

    println!("Cornell box, {} primitives, one thread", scene.bvh.primitives().len());
    println!("{:<28} {:>10} {:>12} {:>10}", "query", "count", "ns/query", "hit rate");
    let closest = |name: &str, rays: &[Ray]| {
        let (s, hits) =
            best_of(5, || rays.iter().filter(|r| scene.bvh.intersect(r, 0.0, f32::INFINITY).is_some()).count());
        let n = rays.len();
        println!("{name:<28} {n:>10} {:>12.1} {:>10.3}", s * 1e9 / n as f64, hits as f64 / n as f64);
    };
    // The same rays eight at a time, as the renderer traces them.
    let packets = |rays: &[Ray]| -> Vec<(RayPacket, u32)> {
        rays.chunks(RAYS).map(|chunk| (RayPacket::from_rays(chunk), (1u32 << chunk.len()) - 1)).collect()
    };
    let closest_packets = |name: &str, rays: &[Ray]| {
        let packets = packets(rays);
        let (s, hits) = best_of(5, || {
            packets
                .iter()
                .map(|(p, live)| scene.bvh.closest_packet(p, *live, 0.0, f32::INFINITY).mask.count_ones() as usize)
                .sum()
        });
        let n = rays.len();
        println!("{name:<28} {n:>10} {:>12.1} {:>10.3}", s * 1e9 / n as f64, hits as f64 / n as f64);
    };
    closest("closest hit, camera rays", &camera_rays);
    closest_packets("  packets of 8", &camera_rays);
    closest("closest hit, bounce rays", &bounce_rays);
    closest_packets("  packets of 8", &bounce_rays);
    let (s, hits) = best_of(5, || shadow_rays.iter().filter(|(r, d)| scene.bvh.occluded(r, 0.0, *d)).count());
    let n = shadow_rays.len();
    println!("{:<28} {n:>10} {:>12.1} {:>10.3}", "shadow rays", s * 1e9 / n as f64, hits as f64 / n as f64);
    let rays: Vec<Ray> = shadow_rays.iter().map(|(r, _)| *r).collect();
    let shadow_packets: Vec<_> = packets(&rays)
        .into_iter()
        .zip(shadow_rays.chunks(RAYS))
        .map(|((p, live), chunk)| (p, live, std::array::from_fn(|l| chunk.get(l).map_or(0.0, |c| c.1))))
        .collect();
    let (s, hits) = best_of(5, || {
        shadow_packets
            .iter()
            .map(|(p, live, reach)| scene.bvh.occluded_packet(p, *live, 0.0, reach).count_ones() as usize)
            .sum()
    });
    println!("{:<28} {n:>10} {:>12.1} {:>10.3}", "  packets of 8", s * 1e9 / n as f64, hits as f64 / n as f64);

    let tracer = loaded.settings.path;
    let (s, rays) = best_of(3, || {
        let mut rng = Rng::new(2, 2);
        camera_rays.iter().map(|r| tracer.trace(scene, *r, &mut rng).rays as usize).sum()
    });
    let n = camera_rays.len();
    println!("{:<28} {n:>10} {:>12.1} {:>10}", "whole paths", s * 1e9 / n as f64, "");
    println!("{:<28} {:>10} {:>12.1} {:>10}", "  per ray of a path", rays, s * 1e9 / rays as f64, "");
    // The renderer's way: eight paths in lock-step, each with its own stream.
    let (s, rays) = best_of(3, || {
        let mut out = vec![Default::default(); camera_rays.len()];
        tracer.trace_paths(scene, |k| (camera_rays[k], Rng::new(2, k as u64)), &mut out);
        out.iter().map(|o| o.rays as usize).sum::<usize>()
    });
    println!("{:<28} {n:>10} {:>12.1} {:>10}", "whole paths, packets of 8", s * 1e9 / n as f64, "");
    println!("{:<28} {:>10} {:>12.1} {:>10}", "  per ray of a path", rays, s * 1e9 / rays as f64, "");
}
