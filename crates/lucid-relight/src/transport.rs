//! Light transport from an OLAT set: the images of one view under each light are the columns
//! of the transport matrix `T` (pixels × lights), and the view under any lighting is
//! `p = T·l`. For an environment map, `l` holds per light the map's radiance over the
//! light's share of the sphere divided by the light's irradiance: a directional light of
//! irradiance `E` from `dₖ` stands for all light within its spherical Voronoi cell.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lucid_image::{Image, read_image};
use lucid_scene::{Dataset, Frame, Split};
use rayon::prelude::*;

use crate::RelightError;
use crate::envmap::{lookup, pixel_direction, pixel_solid_angle};
use crate::voronoi::{nearest, voronoi_solid_angles};

/// The OLAT frames of one view and the environment-lit truths the dataset holds for it.
pub struct OlatView {
    /// Unit directions towards the lights.
    pub directions: Vec<Vec3>,
    /// One linear HDR image per light.
    pub images: Vec<Image>,
    /// Irradiance each light gives a surface facing it.
    pub irradiance: f32,
    /// `(environment map path, path-traced image under it)`.
    pub truths: Vec<(PathBuf, Image)>,
}

/// How the environment is turned into light weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weighting {
    /// Each light gets the map's integral over its Voronoi cell (every map pixel goes to its
    /// nearest light): no light between the samples is lost.
    CellIntegral,
    /// Each light gets the map's radiance at its direction times its cell's solid angle (the
    /// spherical Voronoi cells of [`voronoi_solid_angles`]).
    PointSample,
    /// Each map pixel's light is shared among the three lights nearest to it, by the
    /// barycentric coordinates of its direction in their triangle: light between two OLAT
    /// directions becomes a blend of their images instead of jumping to the nearest one, so
    /// small sources (a sun) cast shadows in between.
    Barycentric,
}

/// Weights `(k, w)` of the three lights nearest to `d` whose triangle holds it: barycentric
/// coordinates (`d = Σ wᵢ dᵢ` up to scale, negatives clamped, normalised to sum to 1).
fn barycentric(directions: &[Vec3], d: Vec3) -> [(usize, f32); 3] {
    let mut best = [(0usize, f32::NEG_INFINITY); 3];
    for (k, dk) in directions.iter().enumerate() {
        let c = d.dot(*dk);
        if c > best[2].1 {
            best[2] = (k, c);
            best.sort_by(|a, b| b.1.total_cmp(&a.1));
        }
    }
    let m = glam::Mat3::from_cols(directions[best[0].0], directions[best[1].0], directions[best[2].0]);
    let w = if m.determinant().abs() > 1e-8 { m.inverse() * d } else { Vec3::X };
    let w = w.max(Vec3::ZERO);
    let sum = w.x + w.y + w.z;
    let w = if sum > 0.0 { w / sum } else { Vec3::X };
    [(best[0].0, w.x), (best[1].0, w.y), (best[2].0, w.z)]
}

/// Reads the OLAT frames (those with a light direction) of view `view` of `split`, grouped by
/// camera pose, and the light irradiance from `dataset.toml` (π, the generator's, if absent).
pub fn load_view(root: &Path, split: Split, view: usize) -> Result<OlatView, RelightError> {
    load_view_with(root, split, view, None)
}

/// [`load_view`] with the light directions of `directions` (by light name, as
/// `lucid lightstage calibrate` writes them) instead of those the dataset records.
pub fn load_view_with(
    root: &Path,
    split: Split,
    view: usize,
    given: Option<&std::collections::HashMap<String, Vec3>>,
) -> Result<OlatView, RelightError> {
    let dataset = Dataset::open(root)?;
    let views: Vec<Vec<&Frame>> = group_by_pose(dataset.frames(split))
        .into_iter()
        .filter(|fs| fs.iter().any(|f| f.extras.light_direction.is_some()))
        .collect();
    if views.is_empty() {
        return Err(RelightError::Invalid(format!(
            "{}: no frame of the {} split has a light_direction (make an OLAT set with `lucid gen SCENE --rig olat`)",
            root.display(),
            split.name()
        )));
    }
    let Some(frames) = views.get(view) else {
        return Err(RelightError::Invalid(format!(
            "{}: view {view} is out of range: the {} split has {} OLAT views",
            root.display(),
            split.name(),
            views.len()
        )));
    };
    let mut directions = Vec::new();
    let mut images = Vec::new();
    let mut truths = Vec::new();
    for f in frames {
        // The HDR image when the dataset has one (OLAT frames are linear), else the PNG.
        let path = f.extras.hdr_path.clone().unwrap_or_else(|| f.image_path.clone());
        if f.extras.held_out_light {
            // Not a column of this capture's transport matrix (a test of relighting models).
            continue;
        }
        if let Some(d) = f.extras.light_direction {
            let d = match given {
                None => d.normalize(),
                Some(map) => {
                    let name = crate::lightstage::capture::light_name(&f.file_path).ok_or_else(|| {
                        RelightError::Invalid(format!("{}: not named as an OLAT frame (…_l<k>)", f.file_path))
                    })?;
                    *map.get(&name).ok_or_else(|| {
                        RelightError::Invalid(format!("no direction was recovered for light {name} ({})", f.file_path))
                    })?
                }
            };
            directions.push(d);
            images.push(read_image(&path)?);
        } else if let Some(env) = &f.extras.environment_path {
            truths.push((env.clone(), read_image(&path)?));
        }
    }
    let size = images[0].dimensions();
    if let Some((k, img)) = images.iter().enumerate().find(|(_, i)| i.dimensions() != size) {
        return Err(RelightError::Invalid(format!(
            "{}: OLAT image {k} of view {view} is {}x{}, the first is {}x{}",
            root.display(),
            img.width(),
            img.height(),
            size.0,
            size.1
        )));
    }
    Ok(OlatView { directions, images, irradiance: light_irradiance(root), truths })
}

/// The irradiance of each OLAT light, from the dataset's `dataset.toml` (π, the generator's
/// default, if absent).
pub fn light_irradiance(root: &Path) -> f32 {
    std::fs::read_to_string(root.join("dataset.toml"))
        .ok()
        .and_then(|t| t.parse::<toml::Table>().ok())
        .and_then(|t| t.get("light_irradiance").and_then(|v| v.as_float()))
        .unwrap_or(std::f64::consts::PI) as f32
}

/// The frames grouped by camera (pose and intrinsics), in order of first appearance: the
/// frames of one view under each of its lights and environments.
pub fn group_by_pose(frames: &[Frame]) -> Vec<Vec<&Frame>> {
    let mut views: Vec<Vec<&Frame>> = Vec::new();
    for f in frames {
        match views.iter_mut().find(|list| list[0].camera == f.camera) {
            Some(list) => list.push(f),
            None => views.push(vec![f]),
        }
    }
    views
}

/// The light vector `l` (per light, per channel) for an environment map.
pub fn light_weights(
    directions: &[Vec3],
    irradiance: f32,
    env: &Image,
    weighting: Weighting,
) -> Result<Vec<[f32; 3]>, RelightError> {
    match weighting {
        Weighting::CellIntegral => {
            Ok(integrate(env, directions.len(), irradiance, |d| [(nearest(directions, d), 1.0), (0, 0.0), (0, 0.0)]))
        }
        Weighting::Barycentric => {
            if directions.len() < 3 {
                return light_weights(directions, irradiance, env, Weighting::CellIntegral);
            }
            Ok(integrate(env, directions.len(), irradiance, |d| barycentric(directions, d)))
        }
        Weighting::PointSample => {
            let cells = voronoi_solid_angles(directions)?;
            Ok(directions
                .iter()
                .zip(cells)
                .map(|(d, omega)| lookup(env, *d).map(|v| v * omega as f32 / irradiance))
                .collect())
        }
    }
}

/// `∫ L dω` of the map shared among `lights` lights — each pixel's direction gives up to three
/// `(light, share)` pairs — divided by the lights' irradiance.
fn integrate(env: &Image, lights: usize, irradiance: f32, share: impl Fn(Vec3) -> [(usize, f32); 3]) -> Vec<[f32; 3]> {
    let (w, h) = env.dimensions();
    let mut l = vec![[0.0f64; 3]; lights];
    for y in 0..h {
        let omega = pixel_solid_angle(y, w, h) as f64;
        for x in 0..w {
            let p = env.get(x, y);
            for (k, wk) in share(pixel_direction(x, y, w, h)) {
                for c in 0..3 {
                    l[k][c] += p[c] as f64 * omega * wk as f64;
                }
            }
        }
    }
    l.into_iter().map(|v| v.map(|x| (x / irradiance as f64) as f32)).collect()
}

/// `p = T·l`: the view relit by light weights `l` (one per OLAT image, per channel).
pub fn relight(images: &[Image], l: &[[f32; 3]]) -> Image {
    assert_eq!(images.len(), l.len(), "one weight per OLAT image");
    let (w, h) = images[0].dimensions();
    let pixels: Vec<[f32; 4]> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut out = [0.0f32, 0.0, 0.0, 0.0];
            for (img, lk) in images.iter().zip(l) {
                let p = img.pixels()[i];
                for c in 0..3 {
                    out[c] += lk[c] * p[c];
                }
                out[3] = out[3].max(p[3]);
            }
            out
        })
        .collect();
    Image::from_pixels(w, h, pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_hot_weights_reproduce_the_olat_image() {
        let images: Vec<Image> =
            (0..4).map(|k| Image::from_fn(5, 3, |x, y| [k as f32 + x as f32, y as f32, 0.5, 1.0])).collect();
        for k in 0..4 {
            let mut l = vec![[0.0f32; 3]; 4];
            l[k] = [1.0; 3];
            assert_eq!(relight(&images, &l), images[k]);
        }
    }

    /// Under a constant environment both weightings give each light `L·Ωₖ/E`, summing to `4πL/E`.
    #[test]
    fn constant_environment_weights_sum_to_the_sphere() {
        let dirs = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let env = Image::filled(64, 32, [2.0, 2.0, 2.0, 1.0]);
        for weighting in [Weighting::CellIntegral, Weighting::PointSample, Weighting::Barycentric] {
            let l = light_weights(&dirs, std::f32::consts::PI, &env, weighting).unwrap();
            let total: f32 = l.iter().map(|v| v[0]).sum();
            assert!((total - 8.0).abs() < 1e-3, "{weighting:?}: {total}");
        }
    }
}
