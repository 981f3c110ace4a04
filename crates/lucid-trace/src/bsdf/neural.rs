//! The reference notes' neural BRDF (after Sztrajman et al. 2021): a small multilayer
//! perceptron with ReLU hidden layers and an exponential output, `f = exp(o) − 1` per channel,
//! from Rusinkiewicz's half/difference angles encoded as `(sin θh, cos θh, sin θd cos φd,
//! sin θd sin φd, cos θd)`. `lucid brdf fit-neural` trains one on a measured table; here it
//! is read from its JSON file and evaluated in plain Rust (a few hundred weights: a forward
//! pass per lookup is cheaper than the table's trilinear fetch from 17 MB). Sampling is the
//! measured tables' (a cosine lobe and half vectors by θh band), the bands weighted by the
//! network's own mean values.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

use super::half_vector::{BANDS, HalfVectorDistribution, band_edge, normal_incidence_albedo};
use super::measured::{from_half_diff, half_diff};
use super::{Bsdf, BsdfSample, upper_pair};

/// Inputs of the encoding.
pub const INPUTS: usize = 5;
/// Widest layer a file may have (the forward pass keeps activations on the stack).
pub const MAX_WIDTH: usize = 256;
const FORMAT: &str = "lucid neural brdf";

/// Why a network file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum NeuralBrdfError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// The file is not a neural BRDF this version reads.
    #[error("{path}: not a neural BRDF: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// A fully connected layer: `out = bias + in · weights`, weights row-major `[inputs][outputs]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DenseLayer {
    /// Input width.
    pub inputs: usize,
    /// Output width.
    pub outputs: usize,
    /// `inputs × outputs` weights.
    pub weights: Vec<f32>,
    /// `outputs` biases.
    pub bias: Vec<f32>,
}

/// The file: the layers and what produced them.
#[derive(Debug, Serialize, Deserialize)]
struct NeuralBrdfFile {
    format: String,
    version: u32,
    layers: Vec<DenseLayer>,
    #[serde(default)]
    source: Option<String>,
}

/// The network.
#[derive(Clone, Debug, PartialEq)]
pub struct NeuralBrdfNet {
    layers: Vec<DenseLayer>,
}

/// The encoding of a pair of directions (both above the surface).
pub fn encode(wo: Vec3, wi: Vec3) -> [f32; INPUTS] {
    let (theta_h, theta_d, phi_d) = half_diff(wo, wi);
    encode_angles(theta_h, theta_d, phi_d)
}

/// The encoding of Rusinkiewicz's angles.
pub fn encode_angles(theta_h: f32, theta_d: f32, phi_d: f32) -> [f32; INPUTS] {
    let (sh, ch) = theta_h.sin_cos();
    let (sd, cd) = theta_d.sin_cos();
    let (sp, cp) = phi_d.sin_cos();
    [sh, ch, sd * cp, sd * sp, cd]
}

impl NeuralBrdfNet {
    /// From layers whose widths chain from [`INPUTS`] to 3, every value finite.
    pub fn new(layers: Vec<DenseLayer>) -> Result<Self, String> {
        if layers.is_empty() {
            return Err("no layers".into());
        }
        let mut width = INPUTS;
        for (i, l) in layers.iter().enumerate() {
            if l.inputs != width {
                return Err(format!("layer {i} takes {} inputs, the one before gives {width}", l.inputs));
            }
            if l.outputs == 0 || l.outputs > MAX_WIDTH {
                return Err(format!("layer {i} has {} outputs (1 to {MAX_WIDTH})", l.outputs));
            }
            if l.weights.len() != l.inputs * l.outputs || l.bias.len() != l.outputs {
                return Err(format!(
                    "layer {i} has {} weights and {} biases for {}×{}",
                    l.weights.len(),
                    l.bias.len(),
                    l.inputs,
                    l.outputs
                ));
            }
            if !l.weights.iter().chain(&l.bias).all(|v| v.is_finite()) {
                return Err(format!("layer {i} holds a value that is not finite"));
            }
            width = l.outputs;
        }
        if width != 3 {
            return Err(format!("the last layer gives {width} outputs, not 3 (RGB)"));
        }
        Ok(Self { layers })
    }

    /// The layers.
    pub fn layers(&self) -> &[DenseLayer] {
        &self.layers
    }

    /// Number of weights and biases.
    pub fn parameters(&self) -> usize {
        self.layers.iter().map(|l| l.weights.len() + l.bias.len()).sum()
    }

    /// The BRDF value for an encoded pair: ReLU between layers, `exp(o) − 1` (at least 0) out.
    pub fn forward(&self, x: &[f32; INPUTS]) -> Vec3 {
        let mut a = [0.0f32; MAX_WIDTH];
        let mut b = [0.0f32; MAX_WIDTH];
        a[..INPUTS].copy_from_slice(x);
        let last = self.layers.len() - 1;
        for (i, l) in self.layers.iter().enumerate() {
            let out = &mut b[..l.outputs];
            out.copy_from_slice(&l.bias);
            for (j, &v) in a[..l.inputs].iter().enumerate() {
                if v != 0.0 {
                    for (o, w) in out.iter_mut().zip(&l.weights[j * l.outputs..(j + 1) * l.outputs]) {
                        *o += v * w;
                    }
                }
            }
            if i != last {
                for o in out.iter_mut() {
                    *o = o.max(0.0);
                }
            }
            std::mem::swap(&mut a, &mut b);
        }
        Vec3::new(a[0].exp() - 1.0, a[1].exp() - 1.0, a[2].exp() - 1.0).max(Vec3::ZERO)
    }

    /// Reads a network file.
    pub fn read(path: &Path) -> Result<Self, NeuralBrdfError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| NeuralBrdfError::Io { path: path.to_path_buf(), source })?;
        Self::parse(&text, path)
    }

    /// Parses a network file's text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, NeuralBrdfError> {
        let format = |reason: String| NeuralBrdfError::Format { path: path.to_path_buf(), reason };
        let file: NeuralBrdfFile = serde_json::from_str(text).map_err(|e| format(e.to_string()))?;
        if file.format != FORMAT || file.version != 1 {
            return Err(format(format!(
                "format {:?} version {} (expected {FORMAT:?} version 1)",
                file.format, file.version
            )));
        }
        Self::new(file.layers).map_err(format)
    }

    /// Writes the network (through a temporary name, then renamed); `source` says what it was
    /// fitted to.
    pub fn write(&self, path: &Path, source: &str) -> Result<(), NeuralBrdfError> {
        let io = |source| NeuralBrdfError::Io { path: path.to_path_buf(), source };
        let file = NeuralBrdfFile {
            format: FORMAT.into(),
            version: 1,
            layers: self.layers.clone(),
            source: Some(source.into()),
        };
        let text = serde_json::to_string(&file).expect("plain data serialises");
        let tmp = path.with_extension("json.partial");
        std::fs::write(&tmp, text).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }
}

/// A network ready to render with: its sampling distribution and albedo worked out.
pub struct NeuralBrdfModel {
    net: NeuralBrdfNet,
    half_vectors: HalfVectorDistribution,
    normal_albedo: Vec3,
}

/// Models are compared by identity, as measured tables are.
impl PartialEq for NeuralBrdfModel {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl std::fmt::Debug for NeuralBrdfModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "NeuralBrdfModel({} parameters)", self.net.parameters())
    }
}

impl NeuralBrdfModel {
    /// Weighs the θh bands by the network's mean luminance over 16 × 16 (θd, φd) points each.
    pub fn new(net: NeuralBrdfNet) -> Self {
        const N: usize = 16;
        let weights: Vec<f32> = (0..BANDS)
            .map(|k| {
                let theta_h = 0.5 * (band_edge(k) + band_edge(k + 1));
                let mut sum = 0.0;
                for a in 0..N {
                    for b in 0..N {
                        let theta_d = (a as f32 + 0.5) / N as f32 * std::f32::consts::FRAC_PI_2;
                        let phi_d = (b as f32 + 0.5) / N as f32 * std::f32::consts::PI;
                        let v = net.forward(&encode_angles(theta_h, theta_d, phi_d));
                        sum += v.dot(Vec3::new(0.2126, 0.7152, 0.0722));
                    }
                }
                sum / (N * N) as f32
            })
            .collect();
        let half_vectors = HalfVectorDistribution::from_band_weights(&weights);
        let normal_albedo = normal_incidence_albedo(|wo, wi| net.forward(&encode(wo, wi)));
        Self { net, half_vectors, normal_albedo }
    }

    /// The network.
    pub fn net(&self) -> &NeuralBrdfNet {
        &self.net
    }

    /// Hemispherical reflectance at normal incidence.
    pub fn normal_albedo(&self) -> Vec3 {
        self.normal_albedo
    }

    /// The model of `path`, read once per process and kept (BSDFs borrow it).
    pub fn load_shared(path: &Path) -> Result<&'static NeuralBrdfModel, NeuralBrdfError> {
        let io = |source| NeuralBrdfError::Io { path: path.to_path_buf(), source };
        super::shared_file::load_shared(path, io, |p| NeuralBrdfNet::read(p).map(Self::new))
    }

    /// The built-in network `name` (see [`crate::assets`]), made once per process.
    pub fn load_builtin(name: &str) -> Result<&'static NeuralBrdfModel, NeuralBrdfError> {
        let label = std::path::PathBuf::from(format!("{}{name}", crate::assets::PREFIX));
        let Some(text) = crate::assets::text(name) else {
            let known: Vec<&str> = crate::assets::names().filter(|n| n.starts_with("neural/")).collect();
            return Err(NeuralBrdfError::Format {
                path: label,
                reason: format!("no such built-in network (there are {known:?})"),
            });
        };
        super::shared_file::load_named(&label.to_string_lossy(), || NeuralBrdfNet::parse(text, &label).map(Self::new))
    }
}

/// The neural BRDF at a surface point.
#[derive(Clone, Copy, Debug)]
pub struct NeuralBrdf {
    /// The model.
    pub model: &'static NeuralBrdfModel,
}

impl Bsdf for NeuralBrdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return Vec3::ZERO };
        self.model.net.forward(&encode(wo, wi))
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let up = if flip { -wo } else { wo };
        let wi = self.model.half_vectors.sample_direction(up, u, uc)?;
        let pdf = self.model.half_vectors.direction_pdf(up, wi);
        let f = self.model.net.forward(&encode(up, wi));
        let wi = if flip { -wi } else { wi };
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, specular: false, transmission: false })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi)) = upper_pair(wo, wi) else { return 0.0 };
        self.model.half_vectors.direction_pdf(wo, wi)
    }
}

/// A pair of directions at Rusinkiewicz's angles (re-exported for the trainer).
pub fn directions(theta_h: f32, theta_d: f32, phi_d: f32) -> (Vec3, Vec3) {
    from_half_diff(theta_h, theta_d, phi_d)
}

#[cfg(test)]
mod tests {
    use super::super::testing::*;
    use super::*;
    use crate::bsdf::chi_square::chi_square_p_value;

    /// A network whose output is the constant `c` whatever the input: zero weights, biases
    /// ln(1 + c) at the end.
    fn constant(c: Vec3) -> NeuralBrdfNet {
        let hidden = DenseLayer { inputs: INPUTS, outputs: 4, weights: vec![0.3; INPUTS * 4], bias: vec![0.1; 4] };
        let out = DenseLayer {
            inputs: 4,
            outputs: 3,
            weights: vec![0.0; 12],
            bias: vec![(1.0 + c.x).ln(), (1.0 + c.y).ln(), (1.0 + c.z).ln()],
        };
        NeuralBrdfNet::new(vec![hidden, out]).unwrap()
    }

    #[test]
    fn the_forward_pass_is_the_network_s() {
        // A constant network is a Lambertian BRDF.
        let albedo = Vec3::new(0.6, 0.4, 0.2);
        let model = Box::leak(Box::new(NeuralBrdfModel::new(constant(albedo / std::f32::consts::PI))));
        assert!((model.normal_albedo() - albedo).abs().max_element() < 1e-4, "{}", model.normal_albedo());
        // One hidden ReLU unit by hand: out = exp(w2·relu(w1·x + b1) + b2) − 1.
        let hidden =
            DenseLayer { inputs: INPUTS, outputs: 1, weights: vec![1.0, -2.0, 0.5, 0.0, 3.0], bias: vec![0.25] };
        let out = DenseLayer { inputs: 1, outputs: 3, weights: vec![0.5, -1.0, 0.0], bias: vec![0.0, 0.2, 0.1] };
        let net = NeuralBrdfNet::new(vec![hidden, out]).unwrap();
        let x = [0.3f32, 0.9, 0.2, 0.1, 0.4];
        let h = (0.3 - 1.8 + 0.1 + 1.2 + 0.25f32).max(0.0);
        let expected = Vec3::new((0.5 * h).exp() - 1.0, (-h + 0.2f32).exp() - 1.0, 0.1f32.exp() - 1.0).max(Vec3::ZERO);
        assert!((net.forward(&x) - expected).length() < 1e-6, "{} vs {expected}", net.forward(&x));
        assert_eq!(net.parameters(), 6 + 6);
    }

    #[test]
    fn sampling_matches_the_density() {
        // A glossy network: the value grows towards the half vector's pole.
        let hidden = DenseLayer {
            inputs: INPUTS,
            outputs: 2,
            weights: vec![0.0, 0.0, 6.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            bias: vec![-5.0, -2.0],
        };
        let out = DenseLayer { inputs: 2, outputs: 3, weights: vec![1.0, 1.0, 1.0, 0.3, 0.3, 0.3], bias: vec![0.0; 3] };
        let model: &'static NeuralBrdfModel =
            Box::leak(Box::new(NeuralBrdfModel::new(NeuralBrdfNet::new(vec![hidden, out]).unwrap())));
        let bsdf = NeuralBrdf { model };
        for wo in outgoing_directions() {
            sample_matches_eval(&bsdf, wo, 2000);
            // Half vectors may reflect below the horizon: those samples fail, the rest integrate
            // to what is left.
            let pdf = pdf_integral(&bsdf, wo, 400_000);
            assert!(pdf <= 1.02 && pdf > 0.5, "∫ pdf = {pdf}");
            let sampled = albedo_by_sampling(&bsdf, wo, 200_000).x;
            let uniform = albedo_by_uniform(&bsdf, wo, 1_000_000).x;
            assert!((sampled - uniform).abs() < 0.02 + 0.03 * uniform, "{sampled} vs {uniform}");
            let p = chi_square_p_value(
                300_000,
                5,
                |rng| bsdf.sample(wo, rng.uniform2(), rng.uniform()).map(|s| s.wi),
                |wi| bsdf.pdf(wo, wi),
            );
            assert!(p > 1e-4, "chi-square p = {p}");
        }
    }

    #[test]
    fn files_round_trip_and_bad_ones_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("n.json");
        let net = constant(Vec3::splat(0.2));
        net.write(&path, "test").unwrap();
        assert_eq!(NeuralBrdfNet::read(&path).unwrap(), net);
        for (text, needle) in [
            ("not json", "not a neural BRDF"),
            (r#"{"format":"other","version":1,"layers":[]}"#, "format"),
            (r#"{"format":"lucid neural brdf","version":1,"layers":[]}"#, "no layers"),
            (
                r#"{"format":"lucid neural brdf","version":1,"layers":[{"inputs":4,"outputs":3,"weights":[0,0,0,0,0,0,0,0,0,0,0,0],"bias":[0,0,0]}]}"#,
                "takes 4 inputs",
            ),
            (
                r#"{"format":"lucid neural brdf","version":1,"layers":[{"inputs":5,"outputs":2,"weights":[0,0,0,0,0,0,0,0,0,0],"bias":[0,0]}]}"#,
                "not 3",
            ),
            (
                r#"{"format":"lucid neural brdf","version":1,"layers":[{"inputs":5,"outputs":3,"weights":[0,0,0],"bias":[0,0,0]}]}"#,
                "weights",
            ),
        ] {
            std::fs::write(&path, text).unwrap();
            let err = NeuralBrdfNet::read(&path).unwrap_err().to_string();
            assert!(err.contains("n.json") && err.contains(needle), "{text}: {err}");
        }
    }
}
