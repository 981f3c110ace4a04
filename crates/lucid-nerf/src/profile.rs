//! Kernel timings on synthetic inputs, for `lucid bench nerf`: how the field's time splits
//! between the hash-grid encoding, the MLPs and the backward pass, and the compositing.

use std::time::Instant;

use lucid_scene::sampling::Rng;

use crate::field::FieldConfig;
use crate::render::composite::{PackedSamples, RAY_OUTPUTS, composite_backward, composite_forward};

/// Seconds per call of each kernel on `samples` random samples (best of `repeats`).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct KernelTimes {
    /// Samples per call.
    pub samples: usize,
    /// Hash-grid encoding alone.
    pub encoding: f64,
    /// Field forward (encoding + MLPs) without saving activations.
    pub field_forward: f64,
    /// Field forward saving activations (training).
    pub field_forward_saving: f64,
    /// Field backward (MLPs + grid scatter).
    pub field_backward: f64,
    /// The grid scatter alone.
    pub encoding_backward: f64,
    /// Compositing forward + backward (64 samples per ray).
    pub composite: f64,
}

/// Times the kernels on random inputs.
pub fn time_kernels(config: &FieldConfig, samples: usize, repeats: usize) -> KernelTimes {
    let layout = config.layout();
    let mut rng = Rng::new(1, 2);
    let pos: Vec<f32> = (0..3 * samples).map(|_| rng.uniform()).collect();
    let dir: Vec<f32> = (0..samples)
        .flat_map(|_| {
            let z = 2.0 * rng.uniform() - 1.0;
            let phi = std::f32::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).sqrt();
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect();
    let table: Vec<f32> =
        (0..layout.grid.entries * layout.grid.features).map(|_| 1e-2 * (rng.uniform() - 0.5)).collect();
    let mlp: Vec<f32> = (0..layout.mlp_params()).map(|_| 0.3 * (rng.uniform() - 0.5)).collect();
    // A 200-pixel view's footprint at the centre of a box it sees from about its own size
    // away (it only matters with `field.grid.antialias` on).
    let foot = vec![0.002f32; samples];
    let best = |f: &mut dyn FnMut()| {
        (0..repeats.max(1))
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut enc = vec![0.0; samples * layout.grid.output_dim()];
    let encoding = best(&mut || layout.grid.forward(&pos, &table, &mut enc));
    let mut out = vec![0.0; 4 * samples];
    let field_forward = best(&mut || layout.forward(&pos, &foot, &dir, &table, &mlp, &mut out, None));
    let mut saved = vec![0.0; samples * layout.saved_per_sample()];
    let field_forward_saving =
        best(&mut || layout.forward(&pos, &foot, &dir, &table, &mlp, &mut out, Some(&mut saved)));
    let grad_out: Vec<f32> = (0..4 * samples).map(|_| rng.uniform() - 0.5).collect();
    let field_backward = best(&mut || {
        let mut gt = vec![0.0; table.len()];
        let mut gm = vec![0.0; mlp.len()];
        layout.backward(&pos, &foot, &mlp, &saved, &grad_out, &mut gt, &mut gm);
    });
    let encoding_backward = best(&mut || {
        let mut gt = vec![0.0; table.len()];
        layout.grid.backward(&pos, &enc, &mut gt);
    });
    let per_ray = 64;
    let rays = samples / per_ray;
    let packed = PackedSamples {
        offsets: (0..=rays).map(|r| (r * per_ray) as u32).collect(),
        t: (0..rays * per_ray).map(|i| (i % per_ray) as f32 * 0.01).collect(),
        dt: vec![0.01; rays * per_ray],
    };
    let raw: Vec<f32> = out[..4 * rays * per_ray].to_vec();
    let composite = best(&mut || {
        let mut o = vec![0.0; rays * RAY_OUTPUTS];
        composite_forward(&packed, &raw, 1e-4, &mut o);
        let g = vec![0.1; o.len()];
        let mut gr = vec![0.0; raw.len()];
        composite_backward(&packed, &raw, &o, &g, 1e-4, &mut gr);
    });
    KernelTimes { samples, encoding, field_forward, field_forward_saving, field_backward, encoding_backward, composite }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Not a timing assertion: prints the split when run with `--ignored --nocapture`.
    #[test]
    #[ignore]
    fn print_kernel_times() {
        for log2 in [15, 17, 19] {
            let mut c = FieldConfig::default();
            c.grid.log2_table_size = log2;
            let t = time_kernels(&c, 1 << 16, 5);
            println!("T=2^{log2}: {t:?}");
        }
    }
}
