//! Multi-view OLAT data in memory: for each view (frames grouped by camera) its images under
//! each light, linear and premultiplied (the background black), its coverage, and the
//! path-traced truths under environment maps that the dataset holds for it.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lucid_image::color::srgb_encode;
use lucid_image::{Image, read_image};
use lucid_relight::RelightError;
use lucid_relight::transport::{group_by_pose, light_irradiance};
use lucid_relight::voronoi::voronoi_solid_angles;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::{Dataset, Frame, PinholeCamera, Split};
use rayon::prelude::*;

/// One view under one light.
#[derive(Clone, Debug)]
pub struct LitImage {
    /// Unit direction towards the light.
    pub direction: Vec3,
    /// Linear radiance premultiplied by coverage, `H×W×3` row-major.
    pub rgb: Vec<f32>,
    /// The light is not one of the training lights (`held_out_light` in the dataset).
    pub held_out: bool,
    /// The source file.
    pub path: PathBuf,
}

/// A path-traced view under an environment map.
#[derive(Clone, Debug)]
pub struct EnvironmentTruth {
    /// The map (lat-long, linear).
    pub environment: PathBuf,
    /// The render (straight alpha).
    pub image: Image,
    /// The source file.
    pub path: PathBuf,
}

/// Every frame of one camera.
#[derive(Clone, Debug)]
pub struct CapturedView {
    /// The camera.
    pub camera: PinholeCamera,
    /// Coverage per pixel (the mean over the view's OLAT frames).
    pub alpha: Vec<f32>,
    /// The OLAT frames.
    pub lights: Vec<LitImage>,
    /// The environment-lit truths.
    pub environments: Vec<EnvironmentTruth>,
}

/// The views of one split of an OLAT dataset.
#[derive(Clone, Debug)]
pub struct OlatSet {
    /// Views with at least one OLAT frame or environment truth.
    pub views: Vec<CapturedView>,
    /// Irradiance of each OLAT light on a surface facing it.
    pub irradiance: f32,
}

fn invalid(msg: String) -> RelightError {
    RelightError::Invalid(msg)
}

/// The image of a frame: its linear HDR file when it has one, else its image file.
fn linear_path(f: &Frame) -> PathBuf {
    f.extras.hdr_path.clone().unwrap_or_else(|| f.image_path.clone())
}

fn load_view(frames: &[&Frame]) -> Result<CapturedView, RelightError> {
    let camera = frames[0].camera;
    let (w, h) = (camera.intrinsics.width as usize, camera.intrinsics.height as usize);
    let images: Vec<Result<Image, RelightError>> = frames
        .par_iter()
        .map(|f| {
            let path = linear_path(f);
            let image = read_image(&path)?;
            if image.dimensions() != (w, h) {
                return Err(invalid(format!(
                    "{}: the image is {}x{}, its camera says {w}x{h}",
                    path.display(),
                    image.width(),
                    image.height()
                )));
            }
            if !image.is_finite() {
                return Err(invalid(format!("{}: the image holds NaN or infinite values", path.display())));
            }
            Ok(image)
        })
        .collect();
    let mut view = CapturedView { camera, alpha: vec![0.0; w * h], lights: Vec::new(), environments: Vec::new() };
    for (f, image) in frames.iter().zip(images) {
        let image = image?;
        let path = linear_path(f);
        if let Some(d) = f.extras.light_direction {
            if !(d.is_finite() && d.length() > 0.0) {
                return Err(invalid(format!("{}: light_direction {d} is not a direction", f.image_path.display())));
            }
            let rgb = image.pixels().iter().flat_map(|p| [p[0] * p[3], p[1] * p[3], p[2] * p[3]]).collect();
            let held_out = f.extras.held_out_light;
            if !held_out {
                for (a, p) in view.alpha.iter_mut().zip(image.pixels()) {
                    *a += p[3];
                }
            }
            view.lights.push(LitImage { direction: d.normalize(), rgb, path, held_out });
        } else if let Some(env) = &f.extras.environment_path {
            view.environments.push(EnvironmentTruth { environment: env.clone(), image, path });
        }
    }
    let n = view.lights.iter().filter(|l| !l.held_out).count().max(1) as f32;
    view.alpha.iter_mut().for_each(|a| *a /= n);
    Ok(view)
}

impl OlatSet {
    /// Reads the OLAT frames (those with a `light_direction`) and environment truths (those
    /// with an `environment_file_path`) of `split`.
    pub fn load(root: &Path, split: Split) -> Result<Self, RelightError> {
        let dataset = Dataset::open(root)?;
        let views: Vec<CapturedView> = group_by_pose(dataset.frames(split))
            .into_iter()
            .filter(|fs| fs.iter().any(|f| f.extras.light_direction.is_some() || f.extras.environment_path.is_some()))
            .map(|fs| load_view(&fs))
            .collect::<Result<_, _>>()?;
        Ok(Self { views, irradiance: light_irradiance(root) })
    }

    /// Drops the frames under held-out lights (a training set learns from the others).
    pub fn without_held_out_lights(mut self) -> Self {
        for v in &mut self.views {
            v.lights.retain(|l| !l.held_out);
        }
        self
    }

    /// Checks that every view has OLAT frames (a training set).
    pub fn require_lights(&self, root: &Path, split: Split) -> Result<(), RelightError> {
        if self.views.is_empty() || self.views.iter().any(|v| v.lights.is_empty()) {
            return Err(invalid(format!(
                "{}: the {} split needs OLAT frames (with light_direction) for every view; make one with \
                 `lucid gen SCENE --rig olat`",
                root.display(),
                split.name()
            )));
        }
        Ok(())
    }

    /// Each view under a uniform white environment of radiance 1, from its OLAT frames
    /// weighted by the solid angles of their lights' spherical Voronoi cells (`Ωₖ/E`): the
    /// images the geometry stage is trained on, sRGB-encoded with straight alpha like
    /// [`ImageSet::load`]'s.
    pub fn uniformly_lit(&self) -> Result<ImageSet, RelightError> {
        let mut set = ImageSet::default();
        for view in &self.views {
            let lights: Vec<&LitImage> = view.lights.iter().filter(|l| !l.held_out).collect();
            let dirs: Vec<Vec3> = lights.iter().map(|l| l.direction).collect();
            let weights: Vec<f32> =
                voronoi_solid_angles(&dirs)?.into_iter().map(|o| o as f32 / self.irradiance).collect();
            let pixels = view
                .alpha
                .par_iter()
                .enumerate()
                .map(|(i, &a)| {
                    let mut c = [0.0f32; 3];
                    for (l, w) in lights.iter().zip(&weights) {
                        for (k, ck) in c.iter_mut().enumerate() {
                            *ck += w * l.rgb[3 * i + k];
                        }
                    }
                    let straight = |v: f32| if a > 1e-4 { srgb_encode((v / a).max(0.0)).min(1.0) } else { 0.0 };
                    [straight(c[0]), straight(c[1]), straight(c[2]), a.clamp(0.0, 1.0)]
                })
                .collect();
            set.cameras.push(view.camera);
            set.pixels.push(pixels);
            set.paths.push(view.lights[0].path.clone());
            set.lenses.push(None);
        }
        Ok(set)
    }

    /// Number of OLAT frames over all views.
    pub fn lit_images(&self) -> usize {
        self.views.iter().map(|v| v.lights.len()).sum()
    }

    /// Every distinct direction of the non-held-out lights, in order of first appearance.
    pub fn directions(&self) -> Vec<Vec3> {
        let mut out: Vec<Vec3> = Vec::new();
        for l in self.views.iter().flat_map(|v| &v.lights).filter(|l| !l.held_out) {
            if !out.iter().any(|d| d.dot(l.direction) > 1.0 - 1e-6) {
                out.push(l.direction);
            }
        }
        out
    }
}
