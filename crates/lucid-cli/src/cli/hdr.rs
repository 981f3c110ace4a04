//! `lucid hdr` and `lucid tonemap`.

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

use super::SplitArg;

/// `lucid hdr`.
#[derive(Debug, Args)]
pub struct HdrArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: HdrCommand,
}

/// HDR subcommands.
#[derive(Debug, Subcommand)]
pub enum HdrCommand {
    /// Merge LDR exposures of one view into an HDR radiance image (or fuse them with
    /// `--method mertens`).
    Merge(HdrMergeArgs),
}

/// How brackets become one image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MergeMethod {
    /// Recover the response by Debevec–Malik least squares, then merge.
    Debevec,
    /// Recover the response by Robertson's iteration, then merge.
    Robertson,
    /// Assume the sRGB response (no recovery), then merge.
    Srgb,
    /// Mertens exposure fusion: a display image directly, no response or times needed.
    Mertens,
}

/// `lucid hdr merge`.
#[derive(Debug, Args)]
pub struct HdrMergeArgs {
    /// LDR frames of one view (PNG/JPEG), or one dataset folder made by the `brackets` rig
    /// (exposure times are read from its transforms JSON).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Exposure times in seconds, one per frame, comma-separated (not with a dataset).
    #[arg(long, value_delimiter = ',')]
    pub times: Vec<f32>,
    /// Dataset input: which view's brackets (index in the split's order of views).
    #[arg(long, default_value_t = 0)]
    pub view: usize,
    /// Dataset input: which split.
    #[arg(long, value_enum, default_value_t = SplitArg::Train)]
    pub split: SplitArg,
    /// Output image: .exr, .hdr or .pfm for radiance; any format for `mertens`.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Merge method.
    #[arg(long, value_enum, default_value_t = MergeMethod::Debevec)]
    pub method: MergeMethod,
    /// Debevec–Malik smoothness weight λ.
    #[arg(long, default_value_t = 50.0)]
    pub lambda: f32,
    /// Pixels sampled per channel for response recovery.
    #[arg(long, default_value_t = 200)]
    pub samples: usize,
    /// Also write the recovered response curve as CSV (code, ln exposure per channel).
    #[arg(long)]
    pub response_out: Option<PathBuf>,
}

/// Tone-mapping operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TonemapOp {
    /// Exposure then clip.
    Linear,
    /// Reinhard's global photographic operator (key, white point, log-average luminance).
    Reinhard,
    /// Drago's adaptive logarithmic mapping.
    Drago,
    /// ACES filmic fit.
    Aces,
    /// Reinhard's local dodge-and-burn (multi-scale centre-surround).
    Photographic,
    /// Durand–Dorsey bilateral base/detail decomposition.
    Bilateral,
}

/// `lucid tonemap`.
#[derive(Debug, Args)]
pub struct TonemapArgs {
    /// HDR input (.exr, .hdr, .pfm; LDR files work too).
    pub input: PathBuf,
    /// Output display image (.png, .jpg; .exr keeps the display values as floats).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Operator.
    #[arg(long, value_enum, default_value_t = TonemapOp::Reinhard)]
    pub op: TonemapOp,
    /// Exposure in stops before the curve (linear, drago, aces).
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Key value: the display luminance of the scene's log-average (reinhard, photographic;
    /// default 0.18).
    #[arg(long)]
    pub key: Option<f32>,
    /// Scaled luminance that maps to white (reinhard; default the image's maximum).
    #[arg(long)]
    pub white: Option<f32>,
    /// Logarithm bias in (0, 1) (drago; default 0.85).
    #[arg(long)]
    pub bias: Option<f32>,
    /// Sharpening φ (photographic; default 8).
    #[arg(long)]
    pub sharpening: Option<f32>,
    /// Centre-surround threshold ε (photographic; default 0.05).
    #[arg(long)]
    pub threshold: Option<f32>,
    /// Contrast ratio of the compressed base layer (bilateral; default 5).
    #[arg(long)]
    pub contrast: Option<f32>,
    /// Spatial σ as a fraction of the image size (bilateral; default 0.02).
    #[arg(long)]
    pub spatial_sigma: Option<f32>,
    /// Range σ in log10 luminance (bilateral; default 0.4).
    #[arg(long)]
    pub range_sigma: Option<f32>,
    /// Colour saturation: 1 keeps the input's ratios, below 1 desaturates.
    #[arg(long, default_value_t = 1.0)]
    pub saturation: f32,
}
