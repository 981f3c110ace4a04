//! The hash-grid burn op against its slice kernel, and its table gradient against finite
//! differences taken through the op itself.

use burn::tensor::{Device, Tensor, TensorData};
use lucid_nerf::{HashGridConfig, backend, hash_grid_encode};

/// Deterministic values in [lo, hi).
fn values(n: usize, seed: u64, lo: f32, hi: f32) -> Vec<f32> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (hi - lo) * ((s >> 40) as f32 / (1u64 << 24) as f32)
        })
        .collect()
}

fn tensor(data: &[f32], shape: [usize; 2], device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(data.to_vec(), shape), device)
}

fn to_vec(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_to_vec::<f32>().expect("f32 tensor")
}

/// Levels that are dense, hashed and (with a 2^6 table) full of collisions.
fn config() -> HashGridConfig {
    HashGridConfig {
        levels: 4,
        features_per_level: 2,
        log2_table_size: 6,
        base_resolution: 2.0,
        finest_resolution: 12.0,
    }
}

#[test]
fn op_forward_equals_the_slice_kernel() {
    let config = config();
    let layout = config.layout();
    let n = 257;
    let pos = values(n * 3, 1, 0.0, 1.0);
    let table = values(layout.entries * layout.features, 2, -1.0, 1.0);
    let device = backend::default_device();
    let out =
        to_vec(hash_grid_encode(tensor(&pos, [n, 3], &device), tensor(&table, [layout.entries, 2], &device), config));
    let mut expected = vec![0.0; n * layout.output_dim()];
    layout.forward(&pos, &table, &mut expected);
    assert_eq!(out, expected);
}

#[test]
fn table_gradient_matches_central_differences() {
    let config = config();
    let layout = config.layout();
    let (n, width) = (40, layout.output_dim());
    let pos = values(n * 3, 3, 0.0, 1.0);
    let table = values(layout.entries * 2, 4, -0.5, 0.5);
    let target = values(n * width, 5, -0.3, 0.3);

    // loss = Σ (enc(table) − target)², a quadratic in the table, so central differences are
    // exact up to rounding.
    let loss_at = |table: &[f32], device: &Device| -> Tensor<1> {
        let enc = hash_grid_encode(tensor(&pos, [n, 3], device), tensor(table, [layout.entries, 2], device), config);
        (enc - tensor(&target, [n, width], device)).powf_scalar(2.0).sum()
    };

    let ad = backend::training_device();
    let table_param = tensor(&table, [layout.entries, 2], &ad).require_grad();
    let enc = hash_grid_encode(tensor(&pos, [n, 3], &ad), table_param.clone(), config);
    let loss = (enc - tensor(&target, [n, width], &ad)).powf_scalar(2.0).sum();
    let grads = loss.backward();
    let grad = to_vec(table_param.grad(&grads).expect("the table receives a gradient"));

    let plain = backend::default_device();
    let h = 1e-2f32;
    let mut checked_nonzero = 0;
    for i in (0..table.len()).step_by(3) {
        let mut plus = table.clone();
        plus[i] += h;
        let mut minus = table.clone();
        minus[i] -= h;
        let lp: f32 = loss_at(&plus, &plain).into_scalar();
        let lm: f32 = loss_at(&minus, &plain).into_scalar();
        let fd = (lp - lm) / (2.0 * h);
        assert!((fd - grad[i]).abs() < 2e-3 * (1.0 + fd.abs()), "entry {i}: finite difference {fd}, op {}", grad[i]);
        if fd.abs() > 1e-3 {
            checked_nonzero += 1;
        }
    }
    assert!(checked_nonzero > 20, "the check must exercise entries that matter ({checked_nonzero})");
}
