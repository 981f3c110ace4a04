use super::*;
use lucid_scene::sampling::Rng;

pub(crate) fn tiny_config() -> FieldConfig {
    FieldConfig {
        grid: HashGridConfig {
            levels: 2,
            features_per_level: 2,
            log2_table_size: 6,
            base_resolution: 2.0,
            finest_resolution: 6.0,
            antialias: 0.0,
        },
        hidden: 8,
        geometry_features: 4,
        density_hidden_layers: 1,
        colour_hidden_layers: 2,
        direction_degree: 4,
    }
}

struct Case {
    layout: FieldLayout,
    pos: Vec<f32>,
    foot: Vec<f32>,
    dir: Vec<f32>,
    table: Vec<f32>,
    mlp: Vec<f32>,
    weights: Vec<f32>,
}

fn case(seed: u64) -> Case {
    case_of(seed, 9)
}

fn case_of(seed: u64, s: usize) -> Case {
    // Footprint weights on, with footprints from none to wider than the coarse cells, so
    // that every test here also covers them.
    let mut config = tiny_config();
    config.grid.antialias = 1.0;
    let layout = config.layout();
    let mut rng = Rng::new(seed, 0);
    let pos: Vec<f32> = (0..3 * s).map(|_| rng.uniform()).collect();
    let foot: Vec<f32> = (0..s).map(|i| if i % 4 == 0 { 0.0 } else { 0.3 * rng.uniform() }).collect();
    let dir: Vec<f32> = (0..s)
        .flat_map(|_| {
            let v = [rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|x| x / n)
        })
        .collect();
    let table = (0..layout.grid.entries * layout.grid.features).map(|_| 2.0 * rng.uniform() - 1.0).collect();
    let mlp = (0..layout.mlp_params()).map(|_| rng.uniform() - 0.5).collect();
    let weights = (0..4 * s).map(|_| rng.uniform() - 0.5).collect();
    Case { layout, pos, foot, dir, table, mlp, weights }
}

fn loss(c: &Case, table: &[f32], mlp: &[f32]) -> f64 {
    let mut out = vec![0.0; c.weights.len()];
    c.layout.forward(&c.pos, &c.foot, &c.dir, table, mlp, &mut out, None);
    out.iter().zip(&c.weights).map(|(a, b)| *a as f64 * *b as f64).sum()
}

#[test]
fn saved_and_unsaved_forwards_agree_and_density_matches() {
    let c = case(1);
    let s = c.pos.len() / 3;
    let (mut a, mut b) = (vec![0.0; 4 * s], vec![0.0; 4 * s]);
    let mut saved = vec![0.0; s * c.layout.saved_per_sample()];
    c.layout.forward(&c.pos, &c.foot, &c.dir, &c.table, &c.mlp, &mut a, None);
    c.layout.forward(&c.pos, &c.foot, &c.dir, &c.table, &c.mlp, &mut b, Some(&mut saved));
    assert_eq!(a, b);
    let mut sigma = vec![0.0; s];
    c.layout.density(&c.pos, &c.foot, &c.table, &c.mlp, &mut sigma);
    for i in 0..s {
        assert_eq!(sigma[i], a[4 * i]);
        assert!(a[4 * i] > 0.0 && (0.0..=1.0).contains(&a[4 * i + 1]));
    }
}

/// The forward from the density's saved activations repeats the whole forward exactly:
/// the same outputs and the same saved rows for the backward.
#[test]
fn forward_from_the_density_activations_is_the_forward() {
    // Over two chunks and a part.
    let c = case_of(5, 2 * CHUNK + 37);
    let s = c.pos.len() / 3;
    let stride = c.layout.saved_per_sample();
    let (mut a, mut b) = (vec![0.0; 4 * s], vec![0.0; 4 * s]);
    let (mut saved_a, mut saved_b) = (vec![0.0; s * stride], vec![0.0; s * stride]);
    c.layout.forward(&c.pos, &c.foot, &c.dir, &c.table, &c.mlp, &mut a, Some(&mut saved_a));
    let mut sigma = vec![0.0; s];
    let mut density = vec![0.0; s * c.layout.density_width()];
    c.layout.density_saving(&c.pos, &c.foot, &c.table, &c.mlp, &mut sigma, &mut density);
    c.layout.forward_from_density(&density, &c.dir, &c.mlp, &mut b, Some(&mut saved_b));
    assert_eq!(a, b);
    assert_eq!(saved_a, saved_b);
    assert!((0..s).all(|i| sigma[i] == a[4 * i]));
    let mut unsaved = vec![0.0; 4 * s];
    c.layout.forward_from_density(&density, &c.dir, &c.mlp, &mut unsaved, None);
    assert_eq!(a, unsaved);
}

#[test]
fn samples_with_zero_gradient_are_skipped_exactly() {
    let c = case(4);
    let s = c.pos.len() / 3;
    let stride = c.layout.saved_per_sample();
    let mut out = vec![0.0; 4 * s];
    let mut saved = vec![0.0; s * stride];
    c.layout.forward(&c.pos, &c.foot, &c.dir, &c.table, &c.mlp, &mut out, Some(&mut saved));
    let keep: Vec<usize> = (0..s).filter(|i| i % 3 != 1).collect();
    let mut grad = c.weights.clone();
    for i in (0..s).filter(|i| i % 3 == 1) {
        grad[4 * i..4 * i + 4].fill(0.0);
    }
    let (mut gt, mut gm) = (vec![0.0; c.table.len()], vec![0.0; c.mlp.len()]);
    c.layout.backward(&c.pos, &c.foot, &c.mlp, &saved, &grad, &mut gt, &mut gm);
    let sub = |v: &[f32], w: usize| gather_rows(v, w, &keep);
    let (mut rt, mut rm) = (vec![0.0; c.table.len()], vec![0.0; c.mlp.len()]);
    c.layout.backward(
        &sub(&c.pos, 3),
        &sub(&c.foot, 1),
        &c.mlp,
        &sub(&saved, stride),
        &sub(&grad, 4),
        &mut rt,
        &mut rm,
    );
    assert_eq!(gt, rt);
    assert_eq!(gm, rm);
}

#[test]
fn backward_matches_finite_differences() {
    for seed in [2, 3] {
        let c = case(seed);
        let s = c.pos.len() / 3;
        let mut out = vec![0.0; 4 * s];
        let mut saved = vec![0.0; s * c.layout.saved_per_sample()];
        c.layout.forward(&c.pos, &c.foot, &c.dir, &c.table, &c.mlp, &mut out, Some(&mut saved));
        let mut gt = vec![0.0; c.table.len()];
        let mut gm = vec![0.0; c.mlp.len()];
        c.layout.backward(&c.pos, &c.foot, &c.mlp, &saved, &c.weights, &mut gt, &mut gm);
        let eps = 1e-3f32;
        let base = loss(&c, &c.table, &c.mlp);
        let mut kinks = 0;
        let mut check = |name: &str, i: usize, analytic: f32, plus: f64, minus: f64| {
            // A ReLU switching inside [−ε, ε] makes the loss non-differentiable there;
            // one-sided slopes that disagree reveal it, and such points are skipped.
            let (right, left) = ((plus - base) / eps as f64, (base - minus) / eps as f64);
            if (right - left).abs() > 1e-2 * (1.0 + right.abs()) {
                kinks += 1;
                return;
            }
            let fd = (plus - minus) / (2.0 * eps as f64);
            // f32 forward passes: about 1e-3 relative noise in a central difference of 1e-3.
            assert!((fd - analytic as f64).abs() < 5e-3 * (1.0 + fd.abs()), "{name}[{i}]: fd {fd} vs {analytic}");
        };
        for i in 0..c.mlp.len() {
            let (mut p, mut m) = (c.mlp.clone(), c.mlp.clone());
            p[i] += eps;
            m[i] -= eps;
            check("mlp", i, gm[i], loss(&c, &c.table, &p), loss(&c, &c.table, &m));
        }
        let touched: Vec<usize> = (0..c.table.len()).filter(|&i| gt[i] != 0.0).collect();
        assert!(touched.len() > 20, "the samples reach many table entries");
        for &i in &touched {
            let (mut p, mut m) = (c.table.clone(), c.table.clone());
            p[i] += eps;
            m[i] -= eps;
            check("table", i, gt[i], loss(&c, &p, &c.mlp), loss(&c, &m, &c.mlp));
        }
        assert!(kinks <= 3, "{kinks} parameters sit on a ReLU kink: the test case is degenerate");
    }
}
