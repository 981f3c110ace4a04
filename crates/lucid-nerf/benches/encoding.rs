//! Hash-encoding lookups per second on samples placed as a render places them (rays from a
//! camera marching through a shell around a surface, consecutive samples along each ray):
//! `cargo bench -p lucid-nerf --bench encoding`. Compares the point-by-point encoder with the
//! level-by-level prefetching one, on all cores (the render's setting) and on one.

use std::time::Instant;

use lucid_nerf::encoding::hash_grid::HashGridConfig;
use rayon::prelude::*;

const CHUNK: usize = 512;

fn samples() -> Vec<f32> {
    // A 200×200 view of a sphere of radius 0.3 at the cube's centre from 1.5 away; each ray
    // takes up to 48 samples 1/600 apart from where it enters the shell r ∈ [0.27, 0.33].
    let (w, h) = (200, 200);
    let eye = [0.5f32, 0.5, -1.0];
    let mut out = Vec::new();
    for py in 0..h {
        for px in 0..w {
            let d = [(px as f32 + 0.5) / w as f32 - 0.5, (py as f32 + 0.5) / h as f32 - 0.5, 1.5];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|c| c / len);
            let mut t = 0.5;
            let mut taken = 0;
            while t < 3.0 && taken < 48 {
                let p = [eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]];
                let r = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
                if (0.27..0.33).contains(&r) {
                    out.extend(p);
                    taken += 1;
                }
                t += 1.0 / 600.0;
            }
        }
    }
    out
}

fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let layout = HashGridConfig::default().layout();
    let width = layout.output_dim();
    let table: Vec<f32> = (0..layout.entries * layout.features).map(|i| (i as f32 * 0.618_034).fract() - 0.5).collect();
    let pos = samples();
    let n = pos.len() / 3;
    let mut out = vec![0.0f32; n * width];
    println!("{n} samples, {} table rows ({:.1} MiB)", layout.entries, table.len() as f64 * 4.0 / (1 << 20) as f64);
    println!("{:<34} {:>12} {:>12}", "encoder", "ns/sample", "M samples/s");
    let mut reference = Vec::new();
    for threads in [rayon::current_num_threads(), 1] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        for chunked in [false, true] {
            let s = pool.install(|| {
                best_of(7, || {
                    out.par_chunks_mut(CHUNK * width).zip(pos.par_chunks(CHUNK * 3)).for_each(|(o, p)| {
                        if chunked {
                            layout.encode_chunk(p, &table, o, width);
                        } else {
                            for (o, p) in o.chunks_exact_mut(width).zip(p.chunks_exact(3)) {
                                layout.encode_point([p[0], p[1], p[2]], &table, o);
                            }
                        }
                    })
                })
            });
            if reference.is_empty() {
                reference = out.clone();
            }
            assert!(out == reference, "the encoders disagree");
            let name =
                format!("{} ({threads} threads)", if chunked { "level by level, prefetch" } else { "point by point" });
            println!("{name:<34} {:>12.1} {:>12.2}", s * 1e9 / n as f64, n as f64 / s / 1e6);
        }
    }
}
