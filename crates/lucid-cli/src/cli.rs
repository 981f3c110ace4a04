//! The argument grammar of `lucid` (clap derive).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

mod generate;
mod hdr;
pub mod numbers;
mod tools;
mod train;
pub use generate::*;
pub use hdr::*;
pub use tools::*;
pub use train::*;

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
    /// The layer (or part) of every OpenEXR file read to take the image from, as an error
    /// lists them (`ViewLayer.Combined`, `AOV`); by default the plain R, G, B channels, else
    /// a Combined/Image/beauty layer, else the only colour layer.
    #[arg(long, global = true, value_name = "NAME")]
    pub exr_layer: Option<String>,
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
    /// The path tracer's time per sample with each material model (layered, SVBRDF, measured,
    /// neural, Poulin–Fournier, subsurface) on a sphere, against
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
    #[arg(long, value_parser = numbers::image_side)]
    pub width: Option<u32>,
    /// Image height (overrides the camera's).
    #[arg(long, value_parser = numbers::image_side)]
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
    #[arg(long, default_value_t = 60, value_parser = numbers::frames)]
    pub frames: usize,
    /// Checkpoints: camera distance from the scene centre, in the dataset's units (default:
    /// the training cameras').
    #[arg(long, value_parser = numbers::positive)]
    pub radius: Option<f32>,
    /// Checkpoints: camera elevation in degrees (the orbit's; the spiral swings around it).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true, value_parser = numbers::elevation)]
    pub elevation: f32,
    /// Checkpoints: thin-lens aperture radius (world units) for depth of field; needs --focus.
    #[arg(long, requires = "focus", value_parser = numbers::non_negative)]
    pub aperture: Option<f32>,
    /// Checkpoints: distance of the plane of focus along the optical axis.
    #[arg(long, requires = "aperture", value_parser = numbers::positive)]
    pub focus: Option<f32>,
    /// Checkpoints: rays per pixel over the lens.
    #[arg(long, default_value_t = 32, value_parser = numbers::lens_rays)]
    pub lens_rays: usize,
    /// How a NeRF checkpoint's rays are cast.
    #[command(flatten)]
    pub nerf: NerfViewArgs,
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

/// Parses an integrator's name.
fn parse_integrator(text: &str) -> Result<lucid_trace::Integrator, String> {
    lucid_trace::Integrator::from_name(text)
        .ok_or_else(|| format!("unknown integrator {text:?} (one of {})", lucid_trace::Integrator::names()))
}

/// Parses `TRAIN,VAL,TEST` view counts.
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
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = numbers::stops)]
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
