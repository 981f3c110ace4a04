//! Time per stage of one splat render and its backward, for a random 100k-Gaussian cloud at
//! 200×200 and 800×800: `cargo bench -p lucid-splat --bench raster`. With
//! `LUCID_BENCH_PLY=cloud.ply LUCID_BENCH_DATASET=folder` it times a trained cloud from the
//! dataset's first training cameras instead (`LUCID_BENCH_SCALE=2`: at twice their
//! resolution, as a viewer shows them); `view` is a whole `render_view` (what `lucid render`
//! and the viewer call) and `png` the viewer's encoding of it. Prints a table; the headline numbers
//! (blends/s/core, images/s) are in `lucid bench splat`.

use std::time::Instant;

// As in the `lucid` binary: glibc malloc hands large freed buffers back to the OS, and the
// next call's page faults would be timed as rasterizing.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use glam::Vec3;
use lucid_scene::evaluation::ViewModel;
use lucid_scene::{Intrinsics, PinholeCamera, look_at};
use lucid_splat::project::{RenderSettings, project_backward_one, project_one};
use lucid_splat::raster::{bin, rasterize, rasterize_backward};
use lucid_splat::view::SplatRenderer;
use lucid_splat::{SplatCamera, SplatCloud};

fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    if std::env::var("LUCID_BENCH_COLD").is_ok() {
        let t = Instant::now();
        f();
        return t.elapsed().as_secs_f64();
    }
    f();
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    if let (Ok(ply), Ok(dataset)) = (std::env::var("LUCID_BENCH_PLY"), std::env::var("LUCID_BENCH_DATASET")) {
        let cloud = lucid_splat::ply::read_splat_ply(std::path::Path::new(&ply)).expect("readable splat .ply");
        let data = lucid_scene::Dataset::open(&dataset).expect("readable dataset");
        let cameras: Vec<PinholeCamera> = data
            .frames(lucid_scene::Split::Train)
            .iter()
            .take(10)
            .map(|f| {
                let scale: f32 = std::env::var("LUCID_BENCH_SCALE").ok().and_then(|s| s.parse().ok()).unwrap_or(1.0);
                let k = f.camera.intrinsics;
                let scaled = Intrinsics {
                    width: (k.width as f32 * scale).round() as u32,
                    height: (k.height as f32 * scale).round() as u32,
                    fx: k.fx * scale,
                    fy: k.fy * scale,
                    cx: k.cx * scale,
                    cy: k.cy * scale,
                    ..k
                };
                PinholeCamera::new(scaled, f.camera.camera_to_world)
            })
            .collect();
        println!("{} Gaussians, {} training views", cloud.len(), cameras.len());
        header();
        stages(&cloud, &cameras);
        return;
    }
    let mut rng = lucid_scene::sampling::Rng::new(11, 3);
    let mut cloud = SplatCloud::default();
    while cloud.len() < 100_000 {
        let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
        if p.length() <= 1.0 {
            let colour = [rng.uniform(), rng.uniform(), rng.uniform()];
            cloud.push(p, 0.005 + 0.02 * rng.uniform(), 0.2 + 0.6 * rng.uniform(), colour);
        }
    }
    header();
    let cameras: Vec<PinholeCamera> = [200u32, 800]
        .iter()
        .map(|&size| {
            let k = Intrinsics::from_fov_x(size, size, 0.69);
            PinholeCamera::new(k, look_at(Vec3::new(0.0, -4.0, 1.0), Vec3::ZERO, Vec3::Z))
        })
        .collect();
    stages(&cloud, &cameras);
}

fn header() {
    println!(
        "{:>6} {:>10} {:>10} {:>10} {:>10} {:>10} {:>12}",
        "size", "project", "bin", "raster", "raster_bw", "project_bw", "blends"
    );
    println!("{:>6} {:>10} {:>10}", "", "view", "png");
}

fn stages(cloud: &SplatCloud, cameras: &[PinholeCamera]) {
    let params = cloud.params();
    let settings = RenderSettings::default();
    for pinhole in cameras {
        let camera = SplatCamera::from_pinhole(pinhole);
        let (w, h) = (camera.width as usize, camera.height as usize);
        let size = camera.width;
        let projected: Vec<_> = (0..params.len()).map(|i| project_one(&params, i, &camera, &settings)).collect();
        let t_project = best_of(7, || {
            use rayon::prelude::*;
            let p: Vec<_> =
                (0..params.len()).into_par_iter().map(|i| project_one(&params, i, &camera, &settings)).collect();
            std::hint::black_box(p);
        });
        let bins = bin(&projected, w, h);
        let t_bin = best_of(7, || {
            std::hint::black_box(bin(&projected, w, h));
        });
        let (_, state) = rasterize(&projected, &bins, w, h, settings.background, settings.min_alpha);
        let t_raster = best_of(7, || {
            std::hint::black_box(rasterize(&projected, &bins, w, h, settings.background, settings.min_alpha));
        });
        let grad = vec![1e-3f32; w * h * 4];
        let screen =
            rasterize_backward(&projected, &bins, &state, w, h, settings.background, settings.min_alpha, &grad);
        let t_raster_bw = best_of(7, || {
            std::hint::black_box(rasterize_backward(
                &projected,
                &bins,
                &state,
                w,
                h,
                settings.background,
                settings.min_alpha,
                &grad,
            ));
        });
        let t_project_bw = best_of(7, || {
            use rayon::prelude::*;
            let g: Vec<_> = (0..params.len())
                .into_par_iter()
                .filter(|&i| projected[i].radius > 0.0)
                .map(|i| project_backward_one(&params, i, &camera, &settings, &screen[i]))
                .collect();
            std::hint::black_box(g);
        });
        let ms = |t: f64| format!("{:.2} ms", 1e3 * t);
        println!(
            "{size:>6} {:>10} {:>10} {:>10} {:>10} {:>10} {:>18}",
            ms(t_project),
            ms(t_bin),
            ms(t_raster),
            ms(t_raster_bw),
            ms(t_project_bw),
            format!("{} ({:.1})", state.blends, state.blends as f64 / bins.pairs() as f64)
        );
        let renderer = SplatRenderer { cloud, settings };
        let view = renderer.render_view(pinhole, None, 1, 0);
        let t_view = best_of(7, || {
            std::hint::black_box(renderer.render_view(pinhole, None, 1, 0));
        });
        let t_png = best_of(7, || {
            std::hint::black_box(lucid_image::encoded_png(&view.colour, true).expect("encodes"));
        });
        println!("{:>6} {:>10} {:>10}", "", ms(t_view), ms(t_png));
    }
}
