//! The arguments of the tools beside training: relighting and environment maps, the light
//! stage, dual photography, measured BRDFs, the viewer and exports.

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

use super::{DatasetArgs, SplitArg};

/// `lucid dual`.
#[derive(Debug, Args)]
pub struct DualArgs {
    /// A scene file (or built-in scene) with a camera and a `projector` light (its first one
    /// is used; the scene's other lights are left out).
    pub scene: String,
    /// Output folder (new or empty): dual.exr (projector's view, lit from the camera),
    /// primal.exr (the camera's view under the whole projector), dual.json (the report).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Light groups of projector pixels whose camera footprints do not overlap instead of one
    /// pixel at a time.
    #[arg(long)]
    pub adaptive: bool,
    /// Adaptive: side of the projector blocks whose footprints are measured first.
    #[arg(long, default_value_t = 4)]
    pub block: usize,
    /// Adaptive: a camera pixel is in a footprint above this share of its brightest pixel.
    #[arg(long, default_value_t = 0.01)]
    pub threshold: f32,
    /// Samples per pixel of each render (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Also render the reciprocal image directly (from the projector, the camera a white
    /// light) at this many samples per pixel, write it as reciprocal.exr and score the dual
    /// against it.
    #[arg(long)]
    pub check_spp: Option<u32>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `lucid lightstage`.
#[derive(Debug, Args)]
pub struct LightstageArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: LightstageCommand,
}

/// `lucid lightstage` subcommands.
#[derive(Debug, Subcommand)]
pub enum LightstageCommand {
    /// Recover each light of an OLAT set from the highlights on its chrome reference spheres
    /// (`lucid gen SCENE --rig olat --reference-sphere chrome ...`): every frame's spheres,
    /// combined per light over spheres and views; reports each light's angular error against
    /// the direction the dataset records and writes the recovered ones for
    /// `lucid relight --directions`.
    Calibrate {
        /// The OLAT dataset.
        dataset: PathBuf,
        /// Which split's frames to use.
        #[arg(long, value_enum, default_value_t = SplitArg::Train)]
        split: SplitArg,
        /// Chrome spheres as X,Y,Z,R (world units), instead of those dataset.toml records.
        #[arg(long = "sphere", value_name = "X,Y,Z,R", value_parser = parse_sphere)]
        spheres: Vec<[f32; 4]>,
        /// Where to write the recovered directions (JSON; must not exist).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Print the results as JSON.
        #[arg(long)]
        json: bool,
    },
}

fn parse_sphere(s: &str) -> Result<[f32; 4], String> {
    let v: Vec<f32> =
        s.split(',').map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z, r] if v.iter().all(|a| a.is_finite()) && r > 0.0 => Ok([x, y, z, r]),
        _ => Err(format!("{s:?}: give X,Y,Z,R with a positive radius")),
    }
}

/// `lucid brdf`.
#[derive(Debug, Args)]
pub struct BrdfArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: BrdfCommand,
}

/// `lucid brdf` subcommands.
#[derive(Debug, Subcommand)]
pub enum BrdfCommand {
    /// Tabulate a material of a scene file as a MERL `.binary` table (90 × 90 × 180 cells);
    /// refused for materials a table cannot hold (anisotropic, textured, specular, fibres).
    Tabulate {
        /// The scene file.
        scene: PathBuf,
        /// The material's name in the scene file.
        #[arg(long)]
        material: String,
        /// The table to write (must not exist).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Build a PCA basis of MERL tables: print each component's share of the variance and how
    /// well the basis reconstructs each table; with --fit, fit another table in the basis
    /// (non-negative) and write it to --output.
    Pca {
        /// The tables (at least two).
        #[arg(required = true, num_args = 2..)]
        tables: Vec<PathBuf>,
        /// Components to keep (fewer than the tables).
        #[arg(short, long)]
        k: usize,
        /// A table to fit in the basis.
        #[arg(long, requires = "output")]
        fit: Option<PathBuf>,
        /// Where to write the fitted table (must not exist).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Fit the reference notes' neural BRDF to a MERL table: an MLP with ReLU hidden layers and
    /// an exponential output from half/difference angles, trained with Adam on the log of
    /// cosine-weighted values; written as JSON for `type = "neural"` materials.
    FitNeural {
        /// The MERL table.
        table: PathBuf,
        /// The network to write (.json, must not exist).
        #[arg(short, long)]
        output: PathBuf,
        /// Optimiser steps.
        #[arg(long, default_value_t = 3000)]
        steps: usize,
        /// Hidden layers.
        #[arg(long, default_value_t = 2)]
        layers: usize,
        /// Units per hidden layer.
        #[arg(long, default_value_t = 21)]
        width: usize,
        /// Direction pairs per step.
        #[arg(long, default_value_t = 4096)]
        batch: usize,
        /// Seed of the initial weights and the samples.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
}

/// `lucid export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// What to export.
    #[command(subcommand)]
    pub command: ExportCommand,
}

/// Export formats.
#[derive(Debug, Subcommand)]
pub enum ExportCommand {
    /// A splat checkpoint as a folder any static web server serves (index.html, splats.js,
    /// splats.bin, scene.json), rendered in the browser with WebGL2.
    Web(ExportWebArgs),
}

/// `lucid export web`.
#[derive(Debug, Args)]
pub struct ExportWebArgs {
    /// A splat checkpoint written by `lucid train splat`.
    pub checkpoint: PathBuf,
    /// The folder to write (new, empty, or an earlier export, which is replaced).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// `lucid view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// A NeRF or splat checkpoint written by `lucid train`.
    pub checkpoint: PathBuf,
    /// A dataset to compare with: its cameras are drawn, and any of its images can be shown
    /// beside the render at the same camera, scored.
    #[arg(long)]
    pub dataset: Option<PathBuf>,
    /// TCP port (0: any free one; the URL printed says which).
    #[arg(long, default_value_t = 7007)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only; another address serves
    /// every machine that reaches it.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Splits and scale of captures (as the run was trained with).
    #[command(flatten)]
    pub data: DatasetArgs,
}

/// How environment maps become light weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum WeightingArg {
    /// The map integrated over each light's spherical Voronoi cell.
    Cell,
    /// The map's radiance at each light times its Voronoi cell's solid angle.
    Point,
    /// Each map direction shared among its three nearest lights by barycentric coordinates.
    Barycentric,
}

/// `lucid relight`.
#[derive(Debug, Args)]
pub struct RelightArgs {
    /// An OLAT dataset (`lucid gen SCENE --rig olat`).
    pub dataset: PathBuf,
    /// Environment map (lat-long EXR/HDR, +Z up). Without it, every environment the dataset
    /// has path-traced truths for is used and scored.
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// Output image (with --env).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Which view (index among the split's OLAT views).
    #[arg(long, default_value_t = 0)]
    pub view: usize,
    /// Which split.
    #[arg(long, value_enum, default_value_t = SplitArg::Test)]
    pub split: SplitArg,
    /// How the map becomes light weights.
    #[arg(long, value_enum, default_value_t = WeightingArg::Cell)]
    pub weights: WeightingArg,
    /// Light directions recovered by `lucid lightstage calibrate`, instead of those the
    /// dataset records.
    #[arg(long)]
    pub directions: Option<PathBuf>,
    /// Print the results as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `lucid envmap`.
#[derive(Debug, Args)]
pub struct EnvmapArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: EnvmapCommand,
}

/// Environment-map subcommands.
#[derive(Debug, Subcommand)]
pub enum EnvmapCommand {
    /// A lat-long map from a mirror-ball photograph (camera on +Y looking at the ball, +Z up).
    FromMirrorBall {
        /// Mirror-ball image (the ball filling the square image).
        input: PathBuf,
        /// Output lat-long map.
        #[arg(short, long)]
        output: PathBuf,
        /// Width of the map (height is half).
        #[arg(long, default_value_t = 512, value_parser = super::numbers::image_side_usize)]
        width: usize,
    },
    /// A mirror-ball image of a lat-long map.
    ToMirrorBall {
        /// Lat-long map.
        input: PathBuf,
        /// Output image.
        #[arg(short, long)]
        output: PathBuf,
        /// Side of the square image.
        #[arg(long, default_value_t = 512, value_parser = super::numbers::image_side_usize)]
        size: usize,
    },
    /// The 9 spherical-harmonic coefficients of a map, and optionally its irradiance map.
    Sh {
        /// Lat-long map.
        input: PathBuf,
        /// Also write the irradiance map (lat-long, same size) reconstructed from the SH.
        #[arg(long)]
        irradiance: Option<PathBuf>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Median-cut light extraction.
    MedianCut {
        /// Lat-long map.
        input: PathBuf,
        /// Number of lights.
        #[arg(long, default_value_t = 16)]
        lights: usize,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Solid angles of the spherical Voronoi cells of light directions (x,y,z;x,y,z;...).
    Voronoi {
        /// Directions, `x,y,z` separated by `;`.
        directions: String,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Restore the clipped sun of an HDR sky from a photograph of a diffuse ball of known
    /// albedo under it: the ball's shading beyond what the clipped map predicts is the missing
    /// sun, added back to the clipped pixels.
    FixSun {
        /// The clipped lat-long map (linear HDR, +Z up).
        input: PathBuf,
        /// The diffuse ball's image (linear): square, the ball filling it, photographed from
        /// far out on +Y looking along −Y with +Z up.
        #[arg(long)]
        sphere: PathBuf,
        /// The ball's albedo: one value, or r,g,b.
        #[arg(long, value_parser = parse_albedo)]
        albedo: [f32; 3],
        /// The fixed map to write (must not exist).
        #[arg(short, long)]
        output: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

fn parse_albedo(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> =
        s.split(',').map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}"))).collect::<Result<_, _>>()?;
    let rgb = match v[..] {
        [a] => [a; 3],
        [r, g, b] => [r, g, b],
        _ => return Err(format!("{s:?}: give one albedo or r,g,b")),
    };
    if rgb.iter().all(|a| a.is_finite() && *a > 0.0 && *a <= 1.0) {
        Ok(rgb)
    } else {
        Err(format!("{s:?}: albedo must be in (0, 1]"))
    }
}
