//! `lucid brdf fit-neural`: trains the neural BRDF of `lucid_trace::bsdf::neural` on a MERL
//! table with burn. Pairs of directions are drawn uniformly in the table's own cell space
//! (θh on its square-root scale, θd, φd), above the horizon; the loss is the squared
//! difference of `ln(1 + f cos θi)` (Sztrajman et al.: the cosine-weighted logarithm keeps
//! both the peak and the tail). Adam, learning rate 5·10⁻³ decaying tenfold over the run.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use lucid_scene::sampling::Rng;
use lucid_trace::bsdf::measured::MerlTable;
use lucid_trace::bsdf::neural::{DenseLayer, INPUTS, NeuralBrdfNet, directions, encode_angles};

/// How to fit.
pub struct FitSettings {
    pub steps: usize,
    pub layers: usize,
    pub width: usize,
    pub batch: usize,
    pub seed: u64,
    /// Print the loss every 500 steps and the result.
    pub progress: bool,
}

#[derive(Module, Debug)]
struct BrdfMlp {
    layers: Vec<Linear>,
}

impl BrdfMlp {
    fn new(hidden: usize, width: usize, device: &Device) -> Self {
        let mut sizes = vec![INPUTS];
        sizes.extend(std::iter::repeat_n(width, hidden));
        sizes.push(3);
        Self { layers: sizes.windows(2).map(|w| LinearConfig::new(w[0], w[1]).init(device)).collect() }
    }

    /// The raw outputs `o` (the BRDF is `exp(o) − 1`).
    fn forward(&self, mut x: Tensor<2>) -> Tensor<2> {
        let last = self.layers.len() - 1;
        for (i, layer) in self.layers.iter().enumerate() {
            x = layer.forward(x);
            if i != last {
                x = relu(x);
            }
        }
        x
    }

    fn export(&self) -> anyhow::Result<NeuralBrdfNet> {
        let layers = self
            .layers
            .iter()
            .map(|l| {
                let [inputs, outputs] = l.weight.val().dims();
                let weights = lucid_burn::to_host_tensor(l.weight.val());
                let bias = l.bias.as_ref().map(|b| lucid_burn::to_host_tensor(b.val())).unwrap_or(vec![0.0; outputs]);
                DenseLayer { inputs, outputs, weights, bias }
            })
            .collect();
        NeuralBrdfNet::new(layers).map_err(|e| anyhow::anyhow!("the trained network is unusable: {e}"))
    }
}

/// Direction pairs and their table values: encodings, `cos θi`, values.
struct Samples {
    inputs: Vec<f32>,
    cosines: Vec<f32>,
    values: Vec<f32>,
}

fn draw(table: &MerlTable, n: usize, rng: &mut Rng) -> Samples {
    let mut s = Samples {
        inputs: Vec::with_capacity(n * INPUTS),
        cosines: Vec::with_capacity(n),
        values: Vec::with_capacity(n * 3),
    };
    while s.cosines.len() < n {
        let x = rng.uniform();
        let theta_h = x * x * std::f32::consts::FRAC_PI_2;
        let theta_d = rng.uniform() * std::f32::consts::FRAC_PI_2;
        let phi_d = rng.uniform() * std::f32::consts::PI;
        let (wo, wi) = directions(theta_h, theta_d, phi_d);
        if wo.z <= 0.02 || wi.z <= 0.02 {
            continue;
        }
        s.inputs.extend(encode_angles(theta_h, theta_d, phi_d));
        s.cosines.push(wi.z);
        s.values.extend(table.lookup(theta_h, theta_d, phi_d).to_array());
    }
    s
}

/// Relative RMS error `√(Σ|f̂ − f|² / Σ|f|²)` and the RMS of the loss's log difference.
fn errors(net: &NeuralBrdfNet, samples: &Samples) -> (f64, f64) {
    let (mut diff, mut norm, mut log) = (0.0f64, 0.0f64, 0.0f64);
    for (k, &cos) in samples.cosines.iter().enumerate() {
        let x: [f32; INPUTS] = samples.inputs[k * INPUTS..(k + 1) * INPUTS].try_into().expect("five inputs");
        let f = net.forward(&x);
        for c in 0..3 {
            let (p, t) = (f[c] as f64, samples.values[k * 3 + c] as f64);
            diff += (p - t) * (p - t);
            norm += t * t;
            let d = (1.0 + p * cos as f64).ln() - (1.0 + t * cos as f64).ln();
            log += d * d;
        }
    }
    ((diff / norm.max(1e-30)).sqrt(), (log / (3 * samples.cosines.len()) as f64).sqrt())
}

pub fn fit(table_path: &Path, output: &Path, settings: &FitSettings) -> anyhow::Result<()> {
    anyhow::ensure!(settings.steps > 0 && settings.batch > 0, "--steps and --batch must be positive");
    anyhow::ensure!(
        (1..=8).contains(&settings.layers) && (1..=256).contains(&settings.width),
        "--layers must be 1 to 8 and --width 1 to 256"
    );
    let table = MerlTable::read(table_path)?;
    let device = lucid_burn::backend::training_device();
    device.seed(settings.seed);
    let mut net = BrdfMlp::new(settings.layers, settings.width, &device);
    let mut optimizer = AdamConfig::new().init();
    let held_out = draw(&table, 20_000, &mut Rng::new(settings.seed ^ 0x5eed, u64::MAX));
    let started = Instant::now();
    let mut last_loss = f32::NAN;
    for step in 0..settings.steps {
        let s = draw(&table, settings.batch, &mut Rng::new(settings.seed, step as u64));
        let n = settings.batch;
        let x = Tensor::<2>::from_data(TensorData::new(s.inputs, [n, INPUTS]), &device);
        let cos = Tensor::<2>::from_data(TensorData::new(s.cosines, [n, 1]), &device);
        let truth = Tensor::<2>::from_data(TensorData::new(s.values, [n, 3]), &device);
        let predicted = net.forward(x).exp() - 1.0;
        let d = (predicted * cos.clone() + 1.0).log() - (truth * cos + 1.0).log();
        let loss = d.square().mean();
        last_loss = loss.clone().into_scalar::<f32>();
        anyhow::ensure!(last_loss.is_finite(), "the fit diverged at step {step} (loss {last_loss})");
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        let lr = 5e-3 * 0.1f64.powf(step as f64 / settings.steps as f64);
        net = optimizer.step(lr, net, grads);
        if settings.progress && ((step + 1) % 500 == 0 || step + 1 == settings.steps) {
            println!("step {:>6}/{}  loss {last_loss:.3e}", step + 1, settings.steps);
        }
    }
    let fitted = net.export()?;
    let (relative, log) = errors(&fitted, &held_out);
    fitted.write(output, &table_path.display().to_string()).with_context(|| format!("writing {}", output.display()))?;
    if settings.progress {
        println!(
            "fitted {} parameters to {} in {:.1} s: held-out relative RMS error {relative:.4}, log-cosine RMS {log:.4} (final loss {last_loss:.3e}); wrote {}",
            fitted.parameters(),
            table_path.display(),
            started.elapsed().as_secs_f64(),
            output.display()
        );
    }
    Ok(())
}
