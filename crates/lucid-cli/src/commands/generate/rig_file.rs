//! Rig files (`configs/rigs/*.toml`): a rig type and its options, applied to `lucid gen`
//! wherever the command line did not set the option itself.

use std::path::Path;

use anyhow::{Context, bail};
use clap::parser::ValueSource;
use serde::Deserialize;

use crate::cli::{GenArgs, ResponseArg, RigArg};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile {
    #[serde(rename = "type")]
    kind: RigArg,
    views: Option<[usize; 3]>,
    res: Option<u32>,
    fov: Option<f32>,
    radius: Option<f32>,
    full_sphere: Option<bool>,
    exposures: Option<Vec<f32>>,
    response: Option<ResponseArg>,
    full_well: Option<f32>,
    read_noise: Option<f32>,
    grid: Option<[usize; 2]>,
    spacing: Option<f32>,
    focus: Option<Vec<f32>>,
    apertures: Option<Vec<f32>>,
    lights: Option<usize>,
    light_irradiance: Option<f32>,
    held_out_lights: Option<usize>,
    images: Option<usize>,
    height: Option<u32>,
    k1: Option<f32>,
    pose_noise: Option<f32>,
    position_noise: Option<f32>,
    point_noise: Option<f32>,
    points: Option<usize>,
    reference_spheres: Option<Vec<String>>,
}

/// The rig type named by `--rig`, after applying a rig file's options to `args`.
pub fn resolve_rig(args: &mut GenArgs, matches: &clap::ArgMatches) -> anyhow::Result<RigArg> {
    match args.rig.as_str() {
        "orbit" => return Ok(RigArg::Orbit),
        "brackets" => return Ok(RigArg::Brackets),
        "lightfield" => return Ok(RigArg::Lightfield),
        "olat" => return Ok(RigArg::Olat),
        "capture" => return Ok(RigArg::Capture),
        _ => {}
    }
    let path = Path::new(&args.rig);
    if !path.is_file() {
        bail!("{}: not a rig (orbit, brackets, lightfield, olat, capture) nor a rig file", args.rig);
    }
    let text = lucid_scene::text_file::read_text(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let file: RigFile = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim().replace('\n', " ")))?;
    let from_file = |id: &str| matches.value_source(id) != Some(ValueSource::CommandLine);
    macro_rules! apply {
        ($($field:ident),*) => {$(
            if let Some(v) = file.$field.clone() && from_file(stringify!($field)) {
                args.$field = v.into();
            }
        )*};
    }
    apply!(
        views,
        res,
        fov,
        radius,
        full_sphere,
        exposures,
        response,
        full_well,
        read_noise,
        spacing,
        focus,
        apertures,
        lights,
        light_irradiance,
        held_out_lights,
        images,
        k1,
        pose_noise,
        position_noise,
        point_noise,
        points
    );
    if let Some(h) = file.height
        && from_file("height")
    {
        args.height = Some(h);
    }
    if let Some(spheres) = &file.reference_spheres
        && from_file("reference_spheres")
    {
        args.reference_spheres = spheres
            .iter()
            .map(|s| s.parse().map_err(|e| anyhow::anyhow!("{}: reference_spheres: {e}", path.display())))
            .collect::<anyhow::Result<_>>()?;
    }
    if let Some(grid) = file.grid
        && from_file("grid")
    {
        args.grid = grid.to_vec();
    }
    Ok(file.kind)
}
