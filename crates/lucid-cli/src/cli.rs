//! The argument grammar of `lucid` (clap derive).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

mod tools;
pub use tools::*;

/// Lucid: neural scene representations (NeRF, 3D Gaussian splatting) trained on the CPU from
/// physically based synthetic datasets.
#[derive(Debug, Parser)]
#[command(name = "lucid", version, about, propagate_version = true)]
pub struct Cli {
    /// More log output (-v debug, -vv trace). `LUCID_LOG` overrides, e.g. `LUCID_LOG=debug`.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Generate a small dataset end to end and print its metrics (the quick demo).
    Demo(DemoArgs),
    /// Convert an image between formats (.exr, .pfm, .hdr, .png, .jpg), with exposure and a
    /// tone curve when going from HDR to LDR.
    Convert(ConvertArgs),
    /// PSNR and SSIM of two images, or of two folders of images matched by file stem.
    Metrics(MetricsArgs),
    /// Describe a dataset folder (transforms_*.json): frames, resolution, intrinsics, bounds;
    /// or a checkpoint: its kind, steps and training time.
    Info(InfoArgs),
    /// Path-trace a scene file (configs/scenes/*.toml) to EXR + PNG with depth, normal and
    /// albedo buffers.
    Render(RenderArgs),
    /// Benchmarks with fixed seeds: `trace` renders the reference Cornell box.
    Bench(BenchArgs),
    /// Refocus a light field by shift-and-add at a focus distance and aperture.
    Refocus(RefocusArgs),
    /// Generate a dataset: render a scene (a built-in name or a .toml file) from a camera rig
    /// into the NeRF-synthetic layout.
    Gen(GenArgs),
    /// Train a model on a dataset folder.
    Train(TrainArgs),
    /// Evaluate a checkpoint on a dataset split: renders, depth and error maps, PSNR/SSIM per
    /// view and averaged, render time per view.
    Eval(EvalArgs),
    /// HDR tools: merge exposure brackets into radiance (camera response recovery) or fuse
    /// them into one display image.
    Hdr(HdrArgs),
    /// Tone map an HDR image to a display image with a global or local operator.
    Tonemap(TonemapArgs),
    /// Relight a view of an OLAT dataset under an environment map (light transport matrix).
    Relight(RelightArgs),
    /// Environment-map tools: mirror ball <-> lat-long, SH projection and irradiance, median cut.
    Envmap(EnvmapArgs),
    /// Serve an interactive viewer of a trained model (NeRF or splats) on a local web page:
    /// orbit, zoom, refocus, depth, and comparison with a dataset's images.
    View(ViewArgs),
    /// Export a trained model for use outside Lucid: `web` writes 3D Gaussian splats as a
    /// self-contained WebGL2 page.
    Export(ExportArgs),
    /// Measured BRDFs in the MERL format: `tabulate` a scene file's material into a table,
    /// `pca` builds a basis of tables and fits one in it.
    Brdf(BrdfArgs),
    /// Light-stage tools: `calibrate` finds each OLAT light's direction from the highlights
    /// on chrome reference spheres.
    Lightstage(LightstageArgs),
    /// Dual photography: measure the transport from a scene's projector light to its camera
    /// (one projector pixel at a time, or adaptively) and form the image the projector would
    /// see if the camera were the light.
    Dual(DualArgs),
}

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

/// A dataset split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SplitArg {
    /// Training views.
    Train,
    /// Validation views.
    Val,
    /// Test views.
    Test,
}

impl From<SplitArg> for lucid_scene::Split {
    fn from(s: SplitArg) -> Self {
        match s {
            SplitArg::Train => Self::Train,
            SplitArg::Val => Self::Val,
            SplitArg::Test => Self::Test,
        }
    }
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

/// `lucid train`.
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// What to train.
    #[command(subcommand)]
    pub model: TrainModel,
}

/// The trainable models.
#[derive(Debug, Subcommand)]
pub enum TrainModel {
    /// Hash-grid NeRF (instant-ngp style) with an occupancy grid.
    Nerf(TrainModelArgs),
    /// 3D Gaussian splatting (tile rasterizer, densification; exports a standard .ply).
    Splat(TrainModelArgs),
    /// Inverse tone mapping network (LDR to HDR) on `brackets` datasets.
    Itm(TrainItmArgs),
    /// Neural relighting on an `olat` dataset: 3DGS geometry, then per-Gaussian features
    /// decoded with the light direction; renders novel views under novel lights and
    /// environment maps.
    Relight(TrainModelArgs),
}

/// `lucid train itm`.
#[derive(Debug, Args)]
pub struct TrainItmArgs {
    /// Dataset folders made by the `brackets` rig (several scenes; their train splits train,
    /// their test splits evaluate).
    #[arg(required = true)]
    pub datasets: Vec<PathBuf>,
    /// Output folder: checkpoint.lucid, config.toml, train_log.csv, run.json,
    /// eval_test/metrics.json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Configuration file (configs/itm/default.toml); defaults are used for missing keys.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override any configuration key, e.g. `--set train.batch=4` (repeatable; TOML values).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Budget, resume and evaluation.
    #[command(flatten)]
    pub run: RunArgs,
}

/// How a dataset without split files (a lone transforms.json, a COLMAP capture) is split,
/// and at what scale a capture's photographs are read.
#[derive(Clone, Copy, Debug, Args)]
pub struct DatasetArgs {
    /// Without split files: every Nth image by sorted name is a test view (the Mip-NeRF 360 /
    /// LLFF convention); 0 holds none out. Use the same value to train and to evaluate.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub holdout_every: usize,
    /// Captures: read the photographs at 1/N size, from images_N/ where it exists, else
    /// resized on reading.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64))]
    pub downscale: Option<u32>,
    /// Which description of the cameras to read where a folder holds both (nerfstudio's
    /// layout): transforms files, or the COLMAP model. Default: transforms files first.
    #[arg(long, value_enum)]
    pub format: Option<DatasetFormatArg>,
}

/// `--format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DatasetFormatArg {
    /// transforms_*.json or transforms.json.
    Transforms,
    /// sparse/0 (COLMAP, binary or text).
    Colmap,
}

impl DatasetArgs {
    /// The reader's options.
    pub fn options(&self) -> lucid_scene::dataset::OpenOptions {
        use lucid_scene::dataset::DatasetFormat;
        let format = self.format.map(|f| match f {
            DatasetFormatArg::Transforms => DatasetFormat::Transforms,
            DatasetFormatArg::Colmap => DatasetFormat::Colmap,
        });
        lucid_scene::dataset::OpenOptions { holdout_every: self.holdout_every, downscale: self.downscale, format }
    }
}

/// `lucid train nerf|splat|relight`.
#[derive(Debug, Args)]
pub struct TrainModelArgs {
    /// Dataset folder: transforms_train.json (or transforms.json) and images, or a capture
    /// (a COLMAP model in sparse/0 and images/).
    pub dataset: PathBuf,
    /// Output folder: checkpoint.lucid, config.toml, train_log.csv, run.json, eval results.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Configuration file (configs/nerf/*.toml, configs/splat/*.toml); defaults are used
    /// for missing keys.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override any configuration key, e.g. `--set train.batch_samples=32768` (NeRF),
    /// `--set densify.grad_threshold=0.0003` (splat) (repeatable; TOML values).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Budget, resume and evaluation.
    #[command(flatten)]
    pub run: RunArgs,
    /// Splits and scale of captures.
    #[command(flatten)]
    pub data: DatasetArgs,
    /// NeRF and splats: serve the viewer's page while training, on 127.0.0.1:PORT (7007
    /// without a value; 0: any free port): the model as it trains, the step, the loss and the
    /// held-out PSNR. Its renders and scores take at most 6.5 % of the wall time from training.
    #[arg(long, value_name = "PORT", num_args = 0..=1, default_missing_value = "7007")]
    pub view: Option<u16>,
}

/// What every `lucid train` shares: the budget, resuming, the output folder's handling.
///
/// The budget has one meaning for every model: `--steps N` alone trains N steps;
/// `--time-limit S` alone trains S seconds, with the schedules (learning-rate decay,
/// densification, SH degrees) stretched over them; both: whichever ends first; neither: the
/// configuration's `train.steps` (and `train.time_limit` where set: whichever ends first).
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Optimiser steps (train.steps); alone, the run ends after them.
    #[arg(long)]
    pub steps: Option<usize>,
    /// Seconds of training; alone, the run ends after them, however many steps that is.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Random seed (train.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Stop at this step and save, as if interrupted there: the schedules still span the
    /// budget, and `--resume` continues (training in stages).
    #[arg(long)]
    pub until: Option<usize>,
    /// Continue the run in OUTPUT from its checkpoint (its configuration and budget win;
    /// --steps or --time-limit set a new budget).
    #[arg(long, conflicts_with = "overwrite")]
    pub resume: bool,
    /// Replace the run in OUTPUT: its files (checkpoint, config, log, run.json, splats.ply,
    /// eval_*/) are removed first. Without it, a folder holding a run is refused.
    #[arg(long)]
    pub overwrite: bool,
    /// Seconds of training between checkpoints (also every train.checkpoint_every steps, and
    /// at the end); 0: not by time.
    #[arg(long, default_value_t = lucid_burn::run::DEFAULT_CHECKPOINT_SECONDS)]
    pub checkpoint_seconds: f64,
    /// Skip the evaluation on the test split at the end.
    #[arg(long)]
    pub no_eval: bool,
}

/// `lucid eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// A checkpoint written by `lucid train`.
    pub checkpoint: PathBuf,
    /// The dataset folder to evaluate on.
    pub dataset: PathBuf,
    /// Which split.
    #[arg(long, default_value = "test")]
    pub split: String,
    /// Output folder for renders, depth and error maps, and metrics.json (default: beside
    /// the checkpoint, `eval_<split>`).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Evaluate only the first N views.
    #[arg(long)]
    pub limit: Option<usize>,
    /// Render every view with a pinhole, even where the dataset gives a thin lens
    /// (`aperture_radius`, `focus_distance`) for it.
    #[arg(long)]
    pub pinhole: bool,
    /// How a NeRF checkpoint's rays are cast.
    #[command(flatten)]
    pub nerf: NerfViewArgs,
    /// Print the results as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Splits and scale of captures (as the run was trained with).
    #[command(flatten)]
    pub data: DatasetArgs,
}

/// Camera rigs of `lucid gen`.
#[derive(Clone, Copy, Debug, ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RigArg {
    /// Cameras on the upper hemisphere (or sphere) around the origin, looking at it.
    Orbit,
    /// Orbit cameras, each view also recorded as LDR frames at several exposure times
    /// through a camera response curve with sensor noise (HDR truth kept beside them).
    Brackets,
    /// A U×V grid of parallel cameras (sub-aperture views, the training split) and thin-lens
    /// ground truths from its centre (the test split), for refocusing.
    Lightfield,
    /// Orbit views, each rendered once per directional light spread over the sphere (one light
    /// at a time, linear HDR), plus the validation and test views under held-out lights and
    /// environment maps.
    Olat,
    /// A capture: photographs from a hand-held ring (`images/`) with the sparse COLMAP model
    /// structure-from-motion would make of them (`sparse/0/`), for unbounded scenes such as
    /// `garden`.
    Capture,
}

/// Camera response curves of the brackets rig.
#[derive(Clone, Copy, Debug, ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ResponseArg {
    /// The sRGB transfer function.
    Srgb,
    /// A film-like S-curve.
    Scurve,
}

/// `lucid gen`.
#[derive(Debug, Args)]
pub struct GenArgs {
    /// A built-in scene (cornell, spheres, materials, media, object, studio, garden, trophy, toys,
    /// caustic, door, many-lights, materials2) or a scene .toml file.
    pub scene: String,
    /// The camera rig: orbit, brackets, lightfield, olat, or a rig file (configs/rigs/*.toml)
    /// whose `type` is one of those and whose keys set the options below (options given on
    /// the command line win).
    #[arg(long, default_value = "orbit")]
    pub rig: String,
    /// Output dataset folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Views in the train, val and test splits, as TRAIN,VAL,TEST (the Blender set's split).
    #[arg(long, default_value = "100,100,200", value_parser = parse_split_counts)]
    pub views: [usize; 3],
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 200)]
    pub res: u32,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Seed of the rig and of the renders (default: the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Light-transport algorithm of the renders (default: the scene's integrator.type):
    /// path, bdpt, light-tracing, sppm, vpl, lightcuts, irradiance-cache or pssmlt, with their default parameters.
    #[arg(long, value_parser = parse_integrator)]
    pub integrator: Option<lucid_trace::Integrator>,
    /// Distance of the orbit cameras from the origin.
    #[arg(long, default_value_t = 4.0)]
    pub radius: f32,
    /// Horizontal field of view in degrees.
    #[arg(long, default_value_t = 40.0)]
    pub fov: f32,
    /// Cameras on the whole sphere instead of the upper hemisphere.
    #[arg(long)]
    pub full_sphere: bool,
    /// Render only shard I of N (every N-th frame starting at I), e.g. `--shard 0/4`, so that
    /// N machines split one dataset; run with `--merge` (or once more unsharded) at the end.
    #[arg(long, value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// Render nothing: check that every frame exists and write the transforms files and
    /// `points3d.ply` (the last step of a sharded generation).
    #[arg(long, conflicts_with = "shard")]
    pub merge: bool,
    /// Brackets rig: exposures in stops relative to 1 s, e.g. `-2,0,2`.
    #[arg(long, value_delimiter = ',', default_value = "-2,0,2", allow_negative_numbers = true)]
    pub exposures: Vec<f32>,
    /// Brackets rig: the camera response curve.
    #[arg(long, value_enum, default_value_t = ResponseArg::Srgb)]
    pub response: ResponseArg,
    /// Brackets rig: electrons at full well (shot noise); 0 disables sensor noise.
    #[arg(long, default_value_t = 4000.0)]
    pub full_well: f32,
    /// Brackets rig: read noise, standard deviation in full-well units.
    #[arg(long, default_value_t = 0.002)]
    pub read_noise: f32,
    /// Light-field rig: cameras along U and V, as U,V.
    #[arg(long, value_delimiter = ',', num_args = 1, default_value = "9,9")]
    pub grid: Vec<usize>,
    /// Light-field rig: distance between neighbouring cameras.
    #[arg(long, default_value_t = 0.1)]
    pub spacing: f32,
    /// Light-field rig: focus distances of the thin-lens ground truths.
    #[arg(long, value_delimiter = ',', default_value = "3.5,4.5")]
    pub focus: Vec<f32>,
    /// Light-field rig: aperture radii of the thin-lens ground truths.
    #[arg(long, value_delimiter = ',', default_value = "0.2,0.4")]
    pub apertures: Vec<f32>,
    /// OLAT rig: number of directional lights, spread over the sphere.
    #[arg(long, default_value_t = 32)]
    pub lights: usize,
    /// OLAT rig: irradiance of each light (π: a white diffuse surface facing it renders 1).
    #[arg(long, default_value_t = std::f32::consts::PI)]
    pub light_irradiance: f32,
    /// OLAT rig: further lights, between the training ones, that light only the validation and test views
    /// (each on its own): held-out light directions for evaluating relighting models.
    #[arg(long, default_value_t = 8)]
    pub held_out_lights: usize,
    /// A reference sphere added to the scene for light-stage tools (repeat for more):
    /// `chrome` or `diffuse`, optionally `@X,Y,Z` or `@X,Y,Z,R` in world units; spheres without
    /// a place take four corners around the object in turn (radius 0.18). Recorded in
    /// dataset.toml for `lucid lightstage calibrate`.
    #[arg(long = "reference-sphere", value_name = "KIND[@X,Y,Z[,R]]")]
    pub reference_spheres: Vec<lucid_datasets_gen::reference_spheres::SphereArg>,
    /// Capture rig: number of photographs (every 8th by name is held out when training).
    #[arg(long, default_value_t = 120)]
    pub images: usize,
    /// Capture rig: image height in pixels (default: --res, square).
    #[arg(long)]
    pub height: Option<u32>,
    /// Capture rig: the lens's radial distortion (COLMAP's SIMPLE_RADIAL k); 0 is a pinhole.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub k1: f32,
    /// Capture rig: standard deviation of the orientation error SfM leaves, in degrees.
    #[arg(long, default_value_t = 0.0)]
    pub pose_noise: f32,
    /// Capture rig: standard deviation of the position error, as a fraction of --radius.
    #[arg(long, default_value_t = 0.0)]
    pub position_noise: f32,
    /// Capture rig: standard deviation of the sparse points' position error, world units.
    #[arg(long, default_value_t = 0.0)]
    pub point_noise: f32,
    /// Capture rig: sparse points to aim for.
    #[arg(long, default_value_t = 20000)]
    pub points: usize,
}

/// `lucid refocus`.
#[derive(Debug, Args)]
pub struct RefocusArgs {
    /// A light-field dataset (`lucid gen --rig lightfield`, or any set of parallel cameras).
    pub dataset: PathBuf,
    /// Distance of the plane in focus along the optical axis.
    #[arg(long, allow_negative_numbers = true)]
    pub focus: f32,
    /// Radius of the synthetic aperture (cameras within it are averaged).
    #[arg(long, allow_negative_numbers = true)]
    pub aperture: f32,
    /// Output image (.exr keeps HDR; .png is clipped and sRGB-encoded).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Parses `I/N` with `I < N`.
fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let (i, n) = text.split_once('/').ok_or_else(|| format!("expected I/N, got {text:?}"))?;
    let i: usize = i.trim().parse().map_err(|_| format!("{i:?} is not a shard index"))?;
    let n: usize = n.trim().parse().map_err(|_| format!("{n:?} is not a shard count"))?;
    if n == 0 || i >= n {
        return Err(format!("shard {i}/{n} does not exist (need 0 <= I < N)"));
    }
    Ok((i, n))
}

/// What to benchmark.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum BenchTarget {
    /// The path tracer on the reference Cornell box (256x256, 64 spp, max depth 8).
    Trace,
    /// NeRF on the default object orbit set (200x200, 100 training views): held-out PSNR
    /// after 30 s, 1, 2, 5 and 10 min of training, throughput, time per phase, render time.
    Nerf,
    /// 3DGS on the same set: held-out PSNR after 30 s .. 10 min, time per phase, and the
    /// rasterizer's blends/s/core and images/s at 200x200 and 800x800 for 100k Gaussians.
    Splat,
    /// The HDR toolkit at 1 megapixel: response recovery and merge of 5 brackets, Mertens
    /// fusion, every tone-mapping operator.
    Hdr,
    /// Every light-transport integrator at equal render time on `--scenes` (default cornell
    /// and caustic): relative MSE against a long reference render, the time to reach the
    /// path tracer's error, and how the error falls with time.
    Integrators,
    /// Lightcuts against brute-force summation over the same point lights and VPLs on
    /// `--scenes` (default many-lights) at `--width`, 4 spp: render time, shadow rays and
    /// per-pixel relative difference.
    Lightcuts,
    /// The path tracer's time per sample with each material of issue 31 on a sphere, against
    /// the same sphere as a GGX conductor, and the fibre materials on a hairy ball against
    /// GGX-conductor fibres (128x96, 32 spp, median of 5 alternating rounds).
    Materials,
    /// Every benchmark above in turn, with one JSON file and one HTML report (in `--report`,
    /// default `out/bench`).
    All,
}

impl BenchArgs {
    /// The NeRF and 3DGS benchmarks' scenes.
    pub fn trainer_scenes(&self) -> Vec<String> {
        self.scenes.clone().unwrap_or_else(|| vec!["trophy".into(), "toys".into()])
    }
}

/// `lucid bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Which benchmark.
    #[arg(value_enum)]
    pub target: BenchTarget,
    /// A short smoke version (smaller image, fewer samples).
    #[arg(long)]
    pub quick: bool,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write `results.json` and an HTML report with plots (`report.html`) into this folder
    /// (`all` does so in `out/bench` by default).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// nerf, splat: a dataset to benchmark on, used as it is (a rendered set or a capture);
    /// where the folder does not exist, the first of --scenes is rendered into it.
    #[arg(long)]
    pub dataset: Option<PathBuf>,
    /// nerf, splat: the built-in sets to benchmark on, each rendered once into out/bench/SCENE
    /// (trophy at 384 spp, toys at 512, their noise ceiling measured; object: the older 32-spp
    /// set); default trophy,toys. integrators: built-in scenes or scene files; default
    /// cornell,caustic. lightcuts: default many-lights.
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// integrators: which (default all of them).
    #[arg(long, value_delimiter = ',', value_parser = parse_integrator)]
    pub integrators: Option<Vec<lucid_trace::Integrator>>,
    /// integrators: render time of each integrator on each scene, in seconds.
    #[arg(long, default_value_t = 20.0)]
    pub seconds: f64,
    /// integrators, lightcuts: image width (the height keeps the scene's aspect).
    #[arg(long, default_value_t = 128)]
    pub width: u32,
    /// integrators: render time of a reference that is not cached yet, in multiples of
    /// `--seconds` (references are kept in out/bench/integrators).
    #[arg(long, default_value_t = 30.0)]
    pub reference_factor: f64,
    /// Splits and scale of a capture given with --dataset.
    #[command(flatten)]
    pub data: DatasetArgs,
    /// nerf, splat: configuration overrides, as for `lucid train nerf|splat --set`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// nerf, splat: test views scored at each point of the curve (all of them at the end).
    #[arg(long, default_value_t = 50)]
    pub curve_views: usize,
    /// hdr: also write the bracket (`frame_0.png` ..) and the Mertens fusion of it
    /// (`fused.pfm`, display values) into this folder, for comparing with other tools
    /// (`scripts/compare-opencv-mertens.py`). The folder must not exist yet.
    #[arg(long, value_name = "DIR")]
    pub write_stack: Option<PathBuf>,
}

/// `lucid render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene description (TOML) to path-trace, or a checkpoint (`.lucid`) of a trained
    /// model to render novel views from along a camera path.
    pub scene: PathBuf,
    /// Output image (.exr or .png); the other format and the `_depth`, `_normal`, `_albedo`
    /// EXR buffers are written beside it.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel (overrides the scene's integrator.spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Light-transport algorithm (overrides the scene's integrator.type): path, bdpt,
    /// light-tracing, sppm, vpl, lightcuts, irradiance-cache or pssmlt, with their default parameters.
    #[arg(long, value_parser = parse_integrator)]
    pub integrator: Option<lucid_trace::Integrator>,
    /// Image width (overrides the camera's; the horizontal field of view is kept).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (overrides the camera's).
    #[arg(long)]
    pub height: Option<u32>,
    /// Seed of the random streams (overrides the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Longest path in segments (overrides the scene's).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Checkpoints: the camera path around the scene centre.
    #[arg(long, value_enum, default_value_t = CameraPathArg::Orbit)]
    pub path: CameraPathArg,
    /// Checkpoints: render the cameras of this `camera_path.json` (nerfstudio's format, in
    /// the dataset's own frame) instead of an orbit or spiral; every render writes its path
    /// there too.
    #[arg(long, conflicts_with_all = ["radius", "elevation"])]
    pub camera_path: Option<PathBuf>,
    /// Checkpoints: also write the frames as one video at the path's frame rate (30 fps for an
    /// orbit or spiral): an animated PNG (.png or .apng, looping), or with ffmpeg on PATH an
    /// .mp4, .webm, .mkv or .mov.
    #[arg(long)]
    pub video: Option<PathBuf>,
    /// Checkpoints: frames along the path (the output is a folder of numbered PNGs and depth EXRs).
    #[arg(long, default_value_t = 60)]
    pub frames: usize,
    /// Checkpoints: camera distance from the scene centre, in the dataset's units (default:
    /// the training cameras').
    #[arg(long)]
    pub radius: Option<f32>,
    /// Checkpoints: camera elevation in degrees (the orbit's; the spiral swings around it).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    pub elevation: f32,
    /// Checkpoints: thin-lens aperture radius (world units) for depth of field; needs --focus.
    #[arg(long, requires = "focus")]
    pub aperture: Option<f32>,
    /// Checkpoints: distance of the plane of focus along the optical axis.
    #[arg(long, requires = "aperture")]
    pub focus: Option<f32>,
    /// Checkpoints: rays per pixel over the lens.
    #[arg(long, default_value_t = 32)]
    pub lens_rays: usize,
    /// How a NeRF checkpoint's rays are cast.
    #[command(flatten)]
    pub nerf: NerfViewArgs,
}

/// How `lucid eval` and `lucid render` cast a NeRF's rays (an error for splat checkpoints).
#[derive(Args, Clone, Debug, Default)]
pub struct NerfViewArgs {
    /// NeRF checkpoints: rays per pixel, on a regular grid over its area, averaged (default:
    /// the run's `train.eval_pixel_rays`).
    #[arg(long)]
    pub pixel_rays: Option<usize>,
    /// NeRF checkpoints: march the rays at this fraction of the training steps, in (0, 1]
    /// (default: the run's `march.render_step_scale`; finer is closer to what the model
    /// learnt and slower).
    #[arg(long)]
    pub step_scale: Option<f32>,
}

/// Camera paths for rendering trained models.
#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
pub enum CameraPathArg {
    /// A circle at fixed elevation.
    Orbit,
    /// Two turns with the elevation swinging ±20° around --elevation.
    Spiral,
}

/// `lucid demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 96)]
    pub size: u32,
    /// Views in the train, val and test splits, as TRAIN,VAL,TEST.
    #[arg(long, default_value = "24,4,8", value_parser = parse_split_counts)]
    pub views: [usize; 3],
    /// Seed of the camera rig and the renders.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Samples per pixel of the path tracer.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// NeRF training steps (default configuration otherwise); 0 skips the NeRF.
    #[arg(long, default_value_t = 500)]
    pub nerf_steps: usize,
    /// 3DGS training steps (the default schedule scaled to them); 0 skips the splats.
    #[arg(long, default_value_t = 1500)]
    pub splat_steps: usize,
    /// The benchmark's sizes instead: 200×200 pixels, 100/0/200 views, 32 spp, 4000 NeRF and
    /// 7000 3DGS steps (replaces --size, --views, --spp, --nerf-steps and --splat-steps).
    #[arg(long)]
    pub full: bool,
}

/// Parses `TRAIN,VAL,TEST` view counts.
fn parse_integrator(text: &str) -> Result<lucid_trace::Integrator, String> {
    lucid_trace::Integrator::from_name(text)
        .ok_or_else(|| format!("unknown integrator {text:?} (one of {})", lucid_trace::Integrator::names()))
}

fn parse_split_counts(text: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [a, b, c] = parts.as_slice() else {
        return Err(format!("expected TRAIN,VAL,TEST (three counts), got {text:?}"));
    };
    let count = |s: &str| s.parse::<usize>().map_err(|_| format!("{s:?} is not a view count"));
    Ok([count(a)?, count(b)?, count(c)?])
}

/// Tone curves for HDR → LDR.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ToneCurveArg {
    /// Clip at 1.
    Clip,
    /// x / (1 + x).
    Reinhard,
    /// ACES filmic fit (Narkowicz).
    Aces,
}

/// `lucid convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input image.
    pub input: PathBuf,
    /// Output image; the format follows the extension.
    pub output: PathBuf,
    /// Exposure change in stops (multiplies linear radiance by 2^EV).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Tone curve applied when the output is LDR (.png, .jpg).
    #[arg(long, value_enum, default_value_t = ToneCurveArg::Clip)]
    pub tone_curve: ToneCurveArg,
    /// Write EXR with 16-bit half floats instead of 32-bit floats.
    #[arg(long)]
    pub half: bool,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    /// What transparent pixels are composited over when the output has no alpha channel
    /// (PFM, RGBE, JPEG): white, black, grey or R,G,B (linear). Without it they are
    /// composited over black (premultiplied colour), and a warning says so.
    #[arg(long)]
    pub background: Option<String>,
}

/// Colour space of the metrics.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SpaceArg {
    /// sRGB-encoded values (the NeRF literature's convention).
    Srgb,
    /// Linear values clipped to [0, 1].
    Linear,
}

/// `lucid metrics`.
#[derive(Debug, Args)]
pub struct MetricsArgs {
    /// Prediction: an image or a folder.
    pub prediction: PathBuf,
    /// Reference: an image or a folder.
    pub reference: PathBuf,
    /// Background that transparent pixels are composited onto: white, black, or R,G,B in [0,1].
    #[arg(long, default_value = "white")]
    pub background: String,
    /// Space the metrics are computed in.
    #[arg(long, value_enum, default_value_t = SpaceArg::Srgb)]
    pub space: SpaceArg,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `lucid info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A dataset folder, or a checkpoint file (`checkpoint.lucid`, or a run folder holding one).
    pub dataset: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Splits and scale of captures.
    #[command(flatten)]
    pub data: DatasetArgs,
}
