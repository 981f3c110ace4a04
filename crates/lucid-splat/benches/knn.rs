//! Time of the initial splat sizes' neighbour search (`knn::mean_neighbour_distance`, k = 3)
//! on 100k points: uniform in a unit cube, the same with one point a million units away (an
//! SfM outlier), and a quarter of them on a sphere of radius 100 around the rest (a capture's
//! background shell): `cargo bench -p lucid-splat --bench knn`. Prints the best of three.

use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use glam::Vec3;
use lucid_scene::sampling::Rng;
use lucid_splat::knn::mean_neighbour_distance;

fn main() {
    let n = 100_000;
    let mut rng = Rng::new(1, 2);
    let cube: Vec<Vec3> = (0..n).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())).collect();
    let mut outlier = cube.clone();
    outlier[0] = Vec3::new(1e6, 0.0, 0.0);
    let mut shell = cube.clone();
    for p in shell.iter_mut().take(n / 4) {
        let d = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5).normalize_or(Vec3::X);
        *p = d * 100.0;
    }
    println!("{:<40} {:>10}", "100k points, k = 3", "seconds");
    for (name, points) in
        [("uniform in a cube", &cube), ("one point 1e6 away", &outlier), ("a quarter on a far shell", &shell)]
    {
        let best = (0..3)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(mean_neighbour_distance(points, 3));
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        println!("{name:<40} {best:>10.3}");
    }
}
