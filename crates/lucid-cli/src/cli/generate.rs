//! `lucid gen`: the camera rigs and the generator's options.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::{parse_integrator, parse_split_counts};

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
