//! The burn operations of the field and the compositing agree with the slice kernels, and
//! their gradients through burn's autodiff match finite differences of the whole pipeline.

use std::sync::Arc;

use burn::tensor::{Tensor, TensorData};
use lucid_nerf::field::FieldConfig;
use lucid_nerf::ops::{composite, field};
use lucid_nerf::render::composite::PackedSamples;
use lucid_nerf::{HashGridConfig, backend};
use lucid_scene::sampling::Rng;

fn config() -> FieldConfig {
    FieldConfig {
        grid: HashGridConfig {
            levels: 3,
            features_per_level: 2,
            log2_table_size: 7,
            base_resolution: 2.0,
            finest_resolution: 8.0,
            // Footprint weights on (the footprints below weigh the finer levels by 0.3–0.9),
            // so that their gradient is checked too.
            antialias: 1.0,
        },
        hidden: 8,
        geometry_features: 4,
        density_hidden_layers: 1,
        colour_hidden_layers: 2,
        // Above instant-ngp's 4 bands, so the gradients are checked through the recurrence's.
        direction_degree: 5,
    }
}

struct Case {
    pos: Vec<f32>,
    foot: Vec<f32>,
    dir: Vec<f32>,
    table: Vec<f32>,
    mlp: Vec<f32>,
    samples: Arc<PackedSamples>,
    weights: Vec<f32>,
}

fn case() -> Case {
    let layout = config().layout();
    let mut rng = Rng::new(11, 0);
    let mut samples = PackedSamples { offsets: vec![0], ..Default::default() };
    let (mut pos, mut foot, mut dir) = (Vec::new(), Vec::new(), Vec::new());
    for n in [4, 6, 0, 3] {
        let d = [0.6f32, 0.0, 0.8];
        let o = [rng.uniform() * 0.3, rng.uniform() * 0.3, 0.1];
        let mut t = 0.05;
        for _ in 0..n {
            let dt = 0.05 + 0.05 * rng.uniform();
            samples.t.push(t);
            samples.dt.push(dt);
            pos.extend((0..3).map(|a| o[a] + t * d[a]));
            foot.push(0.03 + 0.2 * t);
            dir.extend(d);
            t += dt;
        }
        samples.offsets.push(samples.t.len() as u32);
    }
    Case {
        pos,
        foot,
        dir,
        table: (0..layout.grid.entries * 2).map(|_| rng.uniform() - 0.5).collect(),
        mlp: (0..layout.mlp_params()).map(|_| rng.uniform() - 0.5).collect(),
        weights: (0..samples.rays() * 5).map(|_| rng.uniform() - 0.5).collect(),
        samples: Arc::new(samples),
    }
}

fn tensor<const D: usize>(v: &[f32], shape: [usize; D], device: &burn::tensor::Device) -> Tensor<D> {
    Tensor::from_data(TensorData::new(v.to_vec(), shape), device)
}

/// `Σ w·composite(field(table, mlp))` evaluated through burn.
fn burn_loss(
    c: &Case,
    table: &[f32],
    mlp: &[f32],
    device: &burn::tensor::Device,
    track: bool,
) -> (Tensor<1>, Tensor<2>, Tensor<1>) {
    let s = c.pos.len() / 3;
    let entries = table.len() / 2;
    let (mut table, mut mlp) = (tensor(table, [entries, 2], device), tensor(mlp, [mlp.len()], device));
    if track {
        (table, mlp) = (table.require_grad(), mlp.require_grad());
    }
    let (pos, foot, dir) =
        (tensor(&c.pos, [s, 3], device), tensor(&c.foot, [s], device), tensor(&c.dir, [s, 3], device));
    let raw = field(pos, foot, dir, table.clone(), mlp.clone(), config());
    let out = composite(raw, c.samples.clone(), 0.0, 0.0);
    let w = tensor(&c.weights, [c.samples.rays(), 5], device);
    ((out * w).sum(), table, mlp)
}

fn value(t: Tensor<1>) -> f64 {
    t.into_data().try_to_vec::<f32>().unwrap()[0] as f64
}

#[test]
fn gradients_through_burn_match_finite_differences() {
    let c = case();
    let ad = backend::training_device();
    let (loss, table, mlp) = burn_loss(&c, &c.table, &c.mlp, &ad, true);
    let grads = loss.backward();
    let gt = table.grad(&grads).expect("table gradient").into_data().try_to_vec::<f32>().unwrap();
    let gm = mlp.grad(&grads).expect("mlp gradient").into_data().try_to_vec::<f32>().unwrap();
    let device = backend::default_device();
    let eval = |table: &[f32], mlp: &[f32]| value(burn_loss(&c, table, mlp, &device, false).0);
    let base = eval(&c.table, &c.mlp);
    let eps = 1e-3f32;
    let (mut checked, mut kinks) = (0, 0);
    let mut check = |analytic: f32, plus: f64, minus: f64, what: String| {
        let (right, left) = ((plus - base) / eps as f64, (base - minus) / eps as f64);
        if (right - left).abs() > 1e-2 * (1.0 + right.abs()) {
            kinks += 1; // a ReLU switches inside [−ε, ε]
            return;
        }
        let fd = (plus - minus) / (2.0 * eps as f64);
        assert!((fd - analytic as f64).abs() < 5e-3 * (1.0 + fd.abs()), "{what}: fd {fd} vs {analytic}");
        checked += 1;
    };
    for i in (0..c.mlp.len()).step_by(3) {
        let (mut p, mut m) = (c.mlp.clone(), c.mlp.clone());
        p[i] += eps;
        m[i] -= eps;
        check(gm[i], eval(&c.table, &p), eval(&c.table, &m), format!("mlp[{i}]"));
    }
    for i in (0..c.table.len()).filter(|&i| gt[i] != 0.0) {
        let (mut p, mut m) = (c.table.clone(), c.table.clone());
        p[i] += eps;
        m[i] -= eps;
        check(gt[i], eval(&p, &c.mlp), eval(&m, &c.mlp), format!("table[{i}]"));
    }
    assert!(checked > 60 && kinks <= 3, "checked {checked}, kinks {kinks}");
}
