//! Many-light rendering: instant radiosity (Keller 1997) and lightcuts (Walter et al. 2005).
//!
//! Each pass traces light paths that leave virtual point lights (VPLs) at the non-specular
//! surfaces they reach, then one camera path per pixel to its visible points (as photon
//! mapping does, through specular bounces), where emitters seen and one light sample of direct
//! light are added as in SPPM and the VPLs light the point:
//! - `vpl` sums every VPL of the pass at every visible point with a shadow ray each, VPLs
//!   reflecting with their surface's full BSDF. A VPL's geometric term has its squared
//!   distance floored at (clamp · scene radius)², which keeps VPLs from lighting nearby
//!   surfaces as bright spots; the clamp darkens corners (a bias that vanishes with the clamp,
//!   a test shows the sequence). Caustics seen by the camera (light reaching a diffuse surface
//!   only through specular ones) are missing, as in every instant radiosity.
//! - `lightcuts` sums the scene's point and spot lights and diffuse VPLs through a cut of
//!   their light trees ([`tree`]), each node's error bounded by a fraction (`error`, 2 %) of
//!   the estimate; its VPLs reflect as Lambertian surfaces with their material's diffuse part,
//!   as Walter et al.'s (glossy interreflection is dropped). Other lights (area, directional,
//!   environment) are sampled one at a time. With `error = 0` it sums every light: brute
//!   force, for comparison.
//!
//! Both are biased (clamp; lightcuts' bounded error) and consistent in their passes' noise
//! only: images are bit-identical for any number of threads.

mod bound;
mod tree;
mod virtual_light;

use glam::Vec3;
use lucid_scene::Ray;
use rayon::prelude::*;

use crate::render::{PixelSum, RenderCamera, RenderOutput, RenderSettings, output_from_pixels};
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::visible::{LightChoice, VisiblePoint, camera_path, pass_seed};
use tree::LightTree;
use virtual_light::{VirtualLight, VplKind, trace_vpls};

/// Parameters of instant radiosity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstantRadiosity {
    /// Light paths traced per pass, each leaving a VPL at every non-specular surface it meets.
    pub light_paths: u32,
    /// Floor of a VPL's distance in its geometric term, as a fraction of the scene's radius
    /// (0: no clamp, unbiased but spiky).
    pub clamp: f32,
}

impl InstantRadiosity {
    /// 128 light paths per pass, clamp at 1 % of the scene's radius.
    pub const DEFAULT: InstantRadiosity = InstantRadiosity { light_paths: 128, clamp: 0.01 };
}

impl Default for InstantRadiosity {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Parameters of lightcuts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lightcuts {
    /// VPLs (light paths per pass, 0: direct light only) and their clamp.
    pub vpls: InstantRadiosity,
    /// Each cut node's error bound as a fraction of the estimate (0: every light, brute force).
    pub error: f32,
}

impl Lightcuts {
    /// 256 light paths per pass, clamp at 1 % of the scene's radius, 2 % error per node.
    pub const DEFAULT: Lightcuts = Lightcuts { vpls: InstantRadiosity { light_paths: 256, clamp: 0.01 }, error: 0.02 };
}

impl Default for Lightcuts {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How the visible points gather the pass's lights.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Gather {
    /// Every VPL (full BSDFs); all the scene's lights sampled one at a time.
    Vpl(InstantRadiosity),
    /// A cut of the light trees over point and spot lights and diffuse VPLs.
    Lightcuts(Lightcuts),
}

/// The lights of one pass and how to sum them.
struct PassLights {
    lights: Vec<VirtualLight>,
    tree: Option<LightTree>,
    clamp2: f32,
    error: f32,
    /// Path length limit applied per visible point (instant radiosity; lightcuts' trees cannot
    /// drop lights per point and take the pass's VPLs, cut for a camera path of one segment).
    max_depth: Option<u32>,
}

impl PassLights {
    /// The light they send to `vp`.
    fn at(&self, scene: &Scene, vp: &VisiblePoint, rays: &mut u32) -> Vec3 {
        match &self.tree {
            Some(tree) => tree.estimate(scene, &self.lights, vp, self.clamp2, self.error, rays).0,
            None => self
                .lights
                .iter()
                .filter(|l| self.max_depth.is_none_or(|d| l.segments + 1 + vp.segments <= d))
                .map(|l| l.contribution(scene, vp, self.clamp2, rays))
                .sum(),
        }
    }
}

/// Renders `settings.spp` passes.
pub(crate) fn render(
    scene: &Scene,
    camera: &RenderCamera,
    settings: &RenderSettings,
    gather: Gather,
    progress: &(dyn Fn(usize) + Sync),
) -> RenderOutput {
    let k = camera.pinhole().intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let forward = camera.pinhole().forward();
    let passes = settings.spp.max(1);
    let (vpls, kind, error) = match gather {
        Gather::Vpl(p) => (p, VplKind::Surface, 0.0),
        Gather::Lightcuts(p) => (p.vpls, VplKind::Diffuse, p.error),
    };
    let (sampled, scene_lights) = match gather {
        Gather::Vpl(_) => (LightChoice::all(scene), Vec::new()),
        Gather::Lightcuts(_) => {
            (LightChoice::only(scene, |l| !VirtualLight::represents(l)), VirtualLight::from_scene(scene))
        }
    };
    let clamp = vpls.clamp * scene.radius;
    let max_depth = settings.path.max_depth;
    let mut pixels = vec![PixelSum::default(); w * h];
    let mut light_rays = 0u64;
    for pass in 0..passes {
        let pass_seed = pass_seed(settings.seed, pass);
        let (mut lights, rays) = trace_vpls(scene, settings, vpls.light_paths, pass_seed, kind);
        light_rays += rays;
        // A VPL lights a visible point over one more segment; the camera adds at least one.
        lights.retain(|l| l.segments + 2 <= max_depth);
        lights.extend_from_slice(&scene_lights);
        let tree = (kind == VplKind::Diffuse && error > 0.0).then(|| LightTree::build(&lights, pass_seed));
        let exact_depth = (kind == VplKind::Surface).then_some(max_depth);
        let pass_lights = PassLights { lights, tree, clamp2: clamp * clamp, error, max_depth: exact_depth };
        pixels.par_iter_mut().enumerate().for_each(|(p, pixel)| {
            let (i, j) = (p % w, p / w);
            let mut rng = Rng::new(pass_seed, p as u64);
            let ray: Ray = camera.sample_ray(i, j, &mut rng);
            let mut cp = camera_path(scene, settings, &sampled, ray, p as u32, 1.0 / k.fx, &mut rng);
            for vp in &cp.points {
                cp.sample.radiance += vp.beta * pass_lights.at(scene, vp, &mut cp.sample.rays);
            }
            pixel.add(&ray, &cp.sample, forward);
        });
        progress((pass + 1) as usize * h / passes as usize);
    }
    let rays = light_rays + pixels.iter().map(|p| p.rays).sum::<u64>();
    let finished = pixels.iter().map(|p| p.finish(passes, settings.path.hide_emitters));
    output_from_pixels(w, h, finished, (w * h) as u64 * passes as u64, rays)
}
