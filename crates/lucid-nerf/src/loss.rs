//! The colour losses of a training batch, on burn tensors (burn differentiates them).

use burn::tensor::Tensor;

/// Huber's δ: errors above it count linearly.
pub const HUBER_DELTA: f32 = 0.1;

/// Per pixel and channel, the expectation of the squared error over a background drawn
/// uniformly in `[0, 1]` per channel, from the difference on a grey (½) background
/// `grey_diff` (`pixels×3`) and the truth's alpha minus the render's, `alpha_error`
/// (`pixels×1`).
///
/// The difference on background `b` is `(d + Δ/2) + Δ(b − ½)`, whose second term has mean 0
/// and variance `Δ²/12`, so the expectation is `(d + Δ/2)² + Δ²/12`: the random background's
/// objective (the model cannot paint the background into the scene) without the noise that
/// drawing a background per ray adds to every gradient of a ray that sees it.
pub fn squared_error_over_random_background(grey_diff: Tensor<2>, alpha_error: Tensor<2>) -> Tensor<2> {
    grey_diff.square() + alpha_error.square().div_scalar(12.0)
}

/// The mean of Huber's loss with δ = [`HUBER_DELTA`] over the differences `diff`.
pub fn huber(diff: Tensor<2>) -> Tensor<1> {
    let a = diff.abs();
    let q = a.clone().clamp_max(HUBER_DELTA);
    (q.clone().square() * 0.5 + (a - q) * HUBER_DELTA).mean()
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Tensor, TensorData};
    use lucid_scene::sampling::Rng;

    use super::{huber, squared_error_over_random_background};

    fn tensor(values: &[f32], shape: [usize; 2]) -> Tensor<2> {
        Tensor::from_data(TensorData::new(values.to_vec(), shape), &crate::backend::training_device())
    }

    fn values(t: Tensor<2>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().unwrap()
    }

    /// The closed form matches the mean squared error over many drawn backgrounds.
    #[test]
    fn the_random_background_expectation_matches_sampling() {
        // (premultiplied colour, alpha) of render and truth, per pixel.
        let pixels = [([0.3f32, 0.1, 0.6], 0.8f32, [0.2f32, 0.2, 0.5], 0.6f32), ([0.0; 3], 0.1, [0.9, 0.4, 0.0], 1.0)];
        let mut grey = Vec::new();
        let mut alpha_error = Vec::new();
        for (c, a, tc, ta) in pixels {
            grey.extend((0..3).map(|k| (c[k] + 0.5 * (1.0 - a)) - (tc[k] + 0.5 * (1.0 - ta))));
            alpha_error.push(ta - a);
        }
        let closed = values(squared_error_over_random_background(tensor(&grey, [2, 3]), tensor(&alpha_error, [2, 1])));
        let mut rng = Rng::new(7, 1);
        let draws = 2_000_000;
        let mut sampled = [0.0f64; 6];
        for _ in 0..draws {
            for (i, (c, a, tc, ta)) in pixels.iter().enumerate() {
                for k in 0..3 {
                    let b = rng.uniform();
                    let d = (c[k] + b * (1.0 - a)) - (tc[k] + b * (1.0 - ta));
                    sampled[i * 3 + k] += (d * d) as f64 / draws as f64;
                }
            }
        }
        for (c, s) in closed.iter().zip(sampled) {
            assert!((*c as f64 - s).abs() < 4e-3 * s.max(1e-2), "closed form {c} against sampled {s}");
        }
        // Without an alpha error it is the grey background's squared error.
        let same = values(squared_error_over_random_background(tensor(&grey, [2, 3]), tensor(&[0.0, 0.0], [2, 1])));
        assert_eq!(same, grey.iter().map(|g| g * g).collect::<Vec<_>>());
    }

    /// Quadratic below δ, linear above it, continuous at δ.
    #[test]
    fn huber_is_quadratic_then_linear() {
        let loss = |d: f32| huber(tensor(&[d], [1, 1])).into_data().try_to_vec::<f32>().unwrap()[0];
        assert!((loss(0.05) - 0.5 * 0.05 * 0.05).abs() < 1e-7);
        assert!((loss(-0.3) - (0.5 * 0.01 + 0.2 * 0.1)).abs() < 1e-7);
        assert!((loss(0.1) - 0.005).abs() < 1e-7);
    }
}
