//! `lucid train` and `lucid eval`: the models, the budget, the datasets' options.

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

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

impl TrainItmArgs {
    /// The session's request.
    pub fn request(&self) -> lucid_session::RunRequest {
        self.run.request(self.datasets.clone(), &self.output, &self.config, &self.overrides)
    }
}

impl TrainModelArgs {
    /// The session's request.
    pub fn request(&self) -> lucid_session::RunRequest {
        let mut request = self.run.request(vec![self.dataset.clone()], &self.output, &self.config, &self.overrides);
        request.dataset = self.data.options();
        request
    }
}

impl RunArgs {
    /// A request for a run of `datasets` into `output` with these flags.
    pub fn request(
        &self,
        datasets: Vec<PathBuf>,
        output: &std::path::Path,
        config: &Option<PathBuf>,
        overrides: &[String],
    ) -> lucid_session::RunRequest {
        use lucid_burn::run::Start;
        lucid_session::RunRequest {
            datasets,
            output: output.to_path_buf(),
            config: config.clone(),
            overrides: overrides.to_vec(),
            steps: self.steps,
            time_limit: self.time_limit,
            seed: self.seed,
            until: self.until,
            start: match (self.resume, self.overwrite) {
                (true, _) => Start::Resume,
                (false, true) => Start::Overwrite,
                (false, false) => Start::New,
            },
            checkpoint_seconds: self.checkpoint_seconds,
            evaluate: !self.no_eval,
            records: true,
            dataset: lucid_scene::dataset::OpenOptions::default(),
        }
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
    /// Continue the run in OUTPUT from its checkpoint, on the dataset it trained on (its
    /// configuration and budget win; --steps or --time-limit set a new budget; --config,
    /// --set and --seed may repeat the run's settings but not change them).
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
    #[arg(long, value_parser = super::numbers::at_least_one)]
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
