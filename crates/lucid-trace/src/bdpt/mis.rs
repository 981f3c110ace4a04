//! The multiple-importance weight of one connection strategy: the power heuristic over every
//! strategy that could have sampled the same path, computed from ratios of the per-vertex
//! densities as pbrt-v3 does (its balance heuristic squared), so that the cost is linear in
//! the path's length.

use super::vertex::{Context, Vertex};

/// The weight of strategy (s, t) for the path made of the first `s` light vertices and the
/// first `t` camera vertices; `sampled` is the vertex that replaced the last light vertex
/// (s = 1) or camera vertex (t = 1) when the connection sampled a new one.
pub(crate) fn weight(
    ctx: &Context,
    cam: &[Vertex],
    lig: &[Vertex],
    sampled: Option<&Vertex>,
    s: usize,
    t: usize,
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    let pt = if t == 1 { sampled.expect("t = 1 samples the lens") } else { &cam[t - 1] };
    let qs = match s {
        0 => None,
        1 => Some(sampled.expect("s = 1 samples a light")),
        _ => Some(&lig[s - 1]),
    };
    let pt_minus = (t > 1).then(|| &cam[t - 2]);
    let qs_minus = (s > 1).then(|| &lig[s - 2]);

    // The densities in the reverse direction at the connection's four nearest vertices,
    // which this connection determines.
    let pt_rev = match qs {
        Some(q) => q.pdf(ctx, qs_minus, pt),
        None => pt.pdf_light_origin(ctx, pt_minus.expect("s = 0 has t ≥ 2")),
    };
    let pt_minus_rev = pt_minus.map(|pm| match qs {
        Some(q) => pt.pdf(ctx, Some(q), pm),
        None => pt.pdf_light(ctx, pm),
    });
    let qs_rev = qs.map(|q| pt.pdf(ctx, pt_minus, q));
    let qs_minus_rev = qs_minus.map(|qm| qs.expect("s ≥ 2").pdf(ctx, Some(pt), qm));

    let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
    let mut sum = 0.0f32;
    // Strategies with fewer camera vertices: vertex i of the camera path sampled from the
    // light side instead.
    let mut ratio = 1.0f32;
    for i in (1..t).rev() {
        let v = &cam[i];
        let rev = if i == t - 1 {
            pt_rev
        } else if i + 2 == t {
            pt_minus_rev.expect("t ≥ 2")
        } else {
            v.pdf_rev
        };
        ratio *= remap(rev) / remap(v.pdf_fwd);
        // The connection vertex is never a delta: the strategy connected there.
        let delta = i != t - 1 && v.delta;
        if !delta && !cam[i - 1].delta {
            sum += ratio * ratio;
        }
    }
    // Strategies with fewer light vertices.
    let first_light = if s == 1 { qs } else { lig.first() };
    ratio = 1.0;
    for i in (0..s).rev() {
        let v = if s == 1 { qs.expect("s = 1") } else { &lig[i] };
        let rev = if i == s - 1 {
            qs_rev.expect("s ≥ 1")
        } else if i + 2 == s {
            qs_minus_rev.expect("s ≥ 2")
        } else {
            v.pdf_rev
        };
        ratio *= remap(rev) / remap(v.pdf_fwd);
        let delta = i != s - 1 && v.delta;
        let delta_before = if i > 0 { lig[i - 1].delta } else { first_light.is_some_and(|l| l.is_delta_light(ctx)) };
        if !delta && !delta_before {
            sum += ratio * ratio;
        }
    }
    1.0 / (1.0 + sum)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::vertex::{Transport, Vertex, VertexKind};
    use super::super::{Bidirectional, CameraImportance, Strategies};
    use super::*;
    use crate::integrator::PathSample;
    use crate::render::RenderCamera;
    use crate::sampling::Rng;
    use crate::scene_file::load_scene;

    /// Camera paths of a scene's camera that end on an emitter (the first one they hit), with
    /// at least two segments.
    fn paths_to_emitters(sampler: &Bidirectional, camera: &RenderCamera, wanted: usize) -> Vec<Vec<Vertex>> {
        let mut rng = Rng::new(21, 0);
        let mut found = Vec::new();
        let mut out = PathSample::default();
        for _ in 0..1_000_000 {
            if found.len() == wanted {
                break;
            }
            let k = match camera {
                RenderCamera::Pinhole(c) => c.intrinsics,
                RenderCamera::ThinLens(c) => c.pinhole.intrinsics,
            };
            let ray = camera.ray(rng.uniform() * k.width as f32, rng.uniform() * k.height as f32, rng.uniform2());
            let mut path = vec![Vertex::camera(ray.origin, Vec3::ONE)];
            let pdf_dir = sampler.ctx.camera.pdf(ray.origin, ray.direction).1;
            sampler.random_walk(ray, Vec3::ONE, pdf_dir, 7, Transport::Radiance, &mut rng, &mut path, &mut out);
            let end = path.iter().skip(1).position(emits).map(|i| i + 1);
            // Only paths that carry light: not those that meet a one-sided light from behind.
            if let Some(end) = end.filter(|&e| e >= 2 && path[e].le(&sampler.ctx, &path[e - 1]) != Vec3::ZERO) {
                path.truncate(end + 1);
                found.push(path);
            }
        }
        assert_eq!(found.len(), wanted, "too few paths reach an emitter");
        found
    }

    fn emits(v: &Vertex) -> bool {
        matches!(v.kind, VertexKind::Light { .. } | VertexKind::Surface { emitter: Some(_), .. })
    }

    /// The light vertex a light subpath would start with at the path's emitter `x[k]`.
    fn light_start(ctx: &Context, x: &[Vertex]) -> Vertex {
        let k = x.len() - 1;
        let light = match x[k].kind {
            VertexKind::Light { light } => light,
            VertexKind::Surface { emitter: Some(l), .. } => l,
            _ => unreachable!(),
        };
        let mut v = Vertex::light(light, x[k].point, x[k].normal, Vec3::ONE, 0.0);
        v.pdf_fwd = v.pdf_light_origin(ctx, &x[k - 1]);
        v
    }

    /// Whether strategy s (the rest camera vertices) can make path `x`: its connection
    /// vertices must not scatter by a specular lobe, which no connection can evaluate.
    fn valid(ctx: &Context, x: &[Vertex], s: usize) -> bool {
        let t = x.len() - s;
        if t == 0 || (s == 1 && t == 1) {
            return false;
        }
        let connectible = |v: &Vertex| v.is_connectible(ctx) && !v.delta;
        s == 0 || (connectible(&x[t - 1]) && (s == 1 || connectible(&x[t])))
    }

    /// The camera and light subpaths strategy s would have sampled for path `x`, with the
    /// densities their walks record.
    fn subpaths(ctx: &Context, x: &[Vertex], s: usize) -> (Vec<Vertex>, Vec<Vertex>) {
        let k = x.len() - 1;
        let t = x.len() - s;
        let mut cam: Vec<Vertex> = x[..t].to_vec();
        cam[0] = Vertex::camera(x[0].point, Vec3::ONE);
        for i in 1..t {
            cam[i].pdf_fwd = x[i - 1].pdf(ctx, i.checked_sub(2).map(|j| &x[j]), &x[i]);
            cam[i].pdf_rev = if i + 2 <= k { x[i + 1].pdf(ctx, Some(&x[i + 2]), &x[i]) } else { 0.0 };
        }
        let start = light_start(ctx, x);
        let mut lig = Vec::new();
        for j in 0..s {
            let mut v = if j == 0 { start } else { x[k - j] };
            if j == 1 {
                v.pdf_fwd = start.pdf_light(ctx, &x[k - 1]);
            } else if j >= 2 {
                v.pdf_fwd = x[k - j + 1].pdf(ctx, Some(&x[k - j + 2]), &x[k - j]);
            }
            v.pdf_rev = x[k - j - 1].pdf(ctx, (k - j).checked_sub(2).map(|i| &x[i]), &x[k - j]);
            v.delta = x[k - j].delta;
            lig.push(v);
        }
        (cam, lig)
    }

    /// The density of strategy s sampling path `x`: the product of its vertices' densities
    /// along each subpath, computed directly.
    fn density(ctx: &Context, x: &[Vertex], s: usize) -> f64 {
        let k = x.len() - 1;
        let t = x.len() - s;
        let start = light_start(ctx, x);
        let mut p = 1.0f64;
        for j in 0..s {
            p *= match j {
                0 => start.pdf_fwd,
                1 => start.pdf_light(ctx, &x[k - 1]),
                _ => x[k - j + 1].pdf(ctx, Some(&x[k - j + 2]), &x[k - j]),
            } as f64;
        }
        for i in 1..t {
            p *= x[i - 1].pdf(ctx, i.checked_sub(2).map(|j| &x[j]), &x[i]) as f64;
        }
        p
    }

    fn efficient_weight(ctx: &Context, x: &[Vertex], s: usize) -> f32 {
        let t = x.len() - s;
        let (cam, lig) = subpaths(ctx, x, s);
        let sampled = if s == 1 {
            Some(&lig[0])
        } else if t == 1 {
            Some(&cam[0])
        } else {
            None
        };
        weight(ctx, &cam, &lig, sampled, s, t)
    }

    fn check_scene(name: &str, paths: usize) {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenes").join(name);
        let loaded = load_scene(&file).unwrap();
        let settings = crate::integrator::PathTracer { max_depth: 8, ..loaded.settings.path };
        let sampler =
            Bidirectional::new(&loaded.scene, CameraImportance::new(&loaded.camera), &settings, Strategies::All);
        let ctx = &sampler.ctx;
        let mut lengths = [0usize; 8];
        let mut brute_forced = 0;
        for x in paths_to_emitters(&sampler, &loaded.camera, paths) {
            lengths[x.len() - 1] += 1;
            let strategies: Vec<usize> = (0..x.len()).filter(|&s| valid(ctx, &x, s)).collect();
            let weights: Vec<f32> = strategies.iter().map(|&s| efficient_weight(ctx, &x, s)).collect();
            let sum: f32 = weights.iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-3,
                "{name}: weights {weights:?} of a {}-segment path sum to {sum}",
                x.len() - 1
            );
            // Through a specular vertex the densities are deltas, which only the ratios cancel.
            if !x.iter().any(|v| v.delta) {
                let densities: Vec<f64> = strategies.iter().map(|&s| density(ctx, &x, s)).collect();
                let total: f64 = densities.iter().map(|p| p * p).sum();
                brute_forced += 1;
                for ((&s, w), p) in strategies.iter().zip(&weights).zip(&densities) {
                    let expected = (p * p / total) as f32;
                    assert!((w - expected).abs() < 1e-3, "{name}: strategy s = {s}: {w} against {expected}");
                }
            }
        }
        // The paths cover several lengths, so every loop of the weight ran.
        assert!(lengths.iter().filter(|&&n| n > 0).count() >= 3, "{name}: path lengths {lengths:?}");
        assert!(brute_forced >= paths / 3, "{name}: only {brute_forced} paths without specular vertices");
    }

    #[test]
    fn mis_weights_of_all_strategies_sum_to_one_and_match_the_power_heuristic() {
        // Diffuse walls and an area light; glossy BRDFs under an environment (whose escaped
        // camera paths are the s = 0 strategy); glass, whose specular vertices no strategy may
        // connect at (the weights of the others must still sum to one).
        check_scene("cornell.toml", 300);
        check_scene("toys.toml", 300);
        check_scene("caustic.toml", 150);
    }
}
