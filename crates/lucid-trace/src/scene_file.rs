//! The scene description format: TOML with a camera, an integrator, named materials, shapes
//! and lights. Unknown keys, wrong types, and non-finite or out-of-range values are errors
//! naming the file and the key.
//!
//! ```toml
//! [camera]                       # pinhole unless aperture_radius > 0
//! position = [0, 0, 3.9]
//! look_at = [0, 0, 0]
//! up = [0, 1, 0]
//! fov = 39.3077                  # horizontal, degrees
//! width = 256
//! height = 256
//! aperture_radius = 0.0          # thin lens when > 0
//! focus_distance = 3.9
//!
//! [integrator]
//! type = "path"                  # path | bdpt | light-tracing | sppm | vpl | lightcuts
//!                                # | irradiance-cache | pssmlt (all but path and pssmlt: no media)
//! # sppm only: photons = 65536 (per pass; default four per pixel), radius = 0.02 (initial,
//! # world units; default two pixel widths at each visible point), alpha = 0.6667
//! # vpl and lightcuts: light_paths = 128 (per pass; lightcuts 256, 0 for direct light only),
//! # clamp = 0.01 (VPL distance floor, fraction of the scene's radius); lightcuts: error = 0.02
//! # irradiance-cache: error = 0.2 (Ward's a; 0: no interpolation), gather = 1024 (rays per record)
//! # pssmlt (spp = mutations per pixel): bootstrap = 0 (a quarter of the mutations, ≥ 100000),
//! # chains = 0 (one per 10000 mutations, 16 to 1000), large_step = 0.3, sigma = 0.01
//! spp = 64
//! max_depth = 8                  # path segments, camera ray included
//! rr_depth = 5
//! hide_emitters = false
//! seed = 0
//!
//! [materials.white]
//! type = "lambertian"            # lambertian | conductor | dielectric | plastic | phong | blinn_phong
//!                                # | lafortune | ward | ashikhmin_shirley | cook_torrance | interface
//!                                # | layered (Kubelka–Munk films over a base: base = albedo, and
//!                                # layers = [{ absorption = [..], scattering = [..], thickness = 0.1 }
//!                                # or { reflectance = [..], transmittance = [..] }, ...], top first)
//!                                # | svbrdf (metallic-roughness GGX: base_color, roughness,
//!                                # metallic = 0.0, normal = { file = "n.png" }; maps may be numbers,
//!                                # textures (data files linear by default) or { procedural = "tiles" })
//!                                # | measured (file = "gold-paint.binary": a MERL BRDF table, or
//!                                # tabulate = { type = "cook_torrance", .. }: the table of an
//!                                # isotropic, uniform, non-specular material, made at load)
//!                                # | neural (file = "gold-paint.json": a neural BRDF that
//!                                # `lucid brdf fit-neural` fitted to a table; "builtin:NAME" is
//!                                # one compiled in, e.g. "builtin:neural/plum-lacquer.json")
//!                                # | subsurface (translucent: a smooth boundary of index eta = 1.33
//!                                # over a dipole + single-scattering BSSRDF; sigma_a and reduced
//!                                # sigma_s per unit length, or albedo and mfp (mean free path);
//!                                # scale = 1 multiplies the coefficients; path and pssmlt only)
//!                                # | hair (fibres after Marschner, d'Eon et al.: one of color = [..]
//!                                # (Chiang et al.'s mapping), sigma_a = [..] (per fibre radius) or
//!                                # eumelanin/pheomelanin; beta_m = 0.3, beta_n = 0.3 (roughness),
//!                                # alpha = 2 (cuticle tilt, degrees), eta = 1.55)
//!                                # | kajiya_kay (fibres: kd, ks, exponent of the specular cone)
//!                                # | poulin_fournier (cylindrical grooves along the surface's
//!                                # tangent: kd, ks (kd + ks ≤ 1), d = period and h = height of the
//!                                # groove circles' centres above the plane, in groove radii
//!                                # (h in [0, 0.99), d ≥ 2·√(1 − h²)), sigma_x, sigma_y = GGX
//!                                # roughness along and across the grooves, in [0.01, 1])
//! albedo = [0.8, 0.8, 0.8]       # or { a = [..], b = [..], scale = 8 } for a checkerboard, or
//!                                # { file = "t.png", colorspace = "srgb", wrap = "repeat", scale = [1, 1] }
//!
//! [[shapes]]
//! type = "quad"                  # quad | cube | sphere | torus | torus_knot | mesh (file = "x.obj"/.ply)
//!                                # | hair (groom = "ball" (from the unit sphere) | "tress" (from a
//!                                # parting along x at z = 0, hanging down), fibres = 2000,
//!                                # segments = 8, length = 0.5, radius = 0.004 (of each fibre),
//!                                # curl = 0.3 (0..2), seed = 0; rays hit fibres only entering them)
//! material = "white"
//! translate = [0, -1, 0]         # transform: scale, then rotate (degrees about x, y, z), then translate
//! rotate = [-90, 0, 0]
//! scale = [1, 1, 1]
//! emission = [0, 0, 0]           # radiance; > 0 makes the shape an area light
//!
//! [[lights]]
//! type = "point"                 # point | spot | directional | environment | projector
//! position = [0, 2, 0]
//! intensity = [10, 10, 10]
//!
//! [media.smoke]                  # homogeneous: absorption, scattering (per unit length), HG g
//! sigma_a = [0.05, 0.05, 0.05]
//! sigma_s = [1.0, 1.0, 1.0]
//! g = 0.3
//! # a closed shape with `interior = "smoke"` (material type = "interface" for an invisible
//! # boundary, or e.g. a dielectric) holds it; `global_medium = "smoke"` at the top fills the scene
//!
//! [[lights]]                     # a grid of count[0] × count[1] point lights over the
//! type = "point_grid"            # parallelogram corner + s·edge_u + t·edge_v, each moved
//! corner = [-2, 3, -2]           # within its cell by up to `jitter` (0..1) and tinted by
//! edge_u = [4, 0, 0]             # up to ±`tint` per channel, from `seed`
//! edge_v = [0, 0, 4]
//! count = [64, 64]
//! intensity = [0.01, 0.01, 0.01]
//! jitter = 0.8
//! tint = 0.5
//!
//! [[lights]]                     # a pinhole projector: intensity (W/sr) × the image's pixel
//! type = "projector"             # that each direction passes through (LDR images decoded
//! position = [0, 1, 3]           # from sRGB), nothing outside its frustum; resolution = [M, N]
//! look_at = [0, 0, 0]            # without an image projects white; pixel = [i, j] (from the
//! up = [0, 1, 0]                 # top left) lights only that pixel
//! fov = 30.0                     # horizontal, degrees
//! image = "slide.png"
//! intensity = [5, 5, 5]
//!
//! [[lights]]
//! type = "environment"           # radiance = [r, g, b] or file = "sky.exr" (lat-long, relative
//! file = "sky.exr"               # to the scene file) or sky = { zenith = [..], horizon = [..],
//!                                # ground = [..] }, with scale and rotate = [x, y, z] degrees
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{EulerRot, Mat3, Mat4, Quat, Vec3};
use lucid_scene::{Intrinsics, PinholeCamera, ThinLensCamera, look_at};
use serde::Deserialize;

use crate::environment::EnvironmentMap;
use crate::geometry::mesh_file::load_mesh;
use crate::geometry::procedural::{self, TriangleMesh};
use crate::light::Light;
use crate::light_grid::{MAX_GRID_LIGHTS, PointLightGrid};
use crate::medium::{HenyeyGreenstein, HomogeneousMedium};
use crate::render::{RenderCamera, RenderSettings};
use crate::scene::{Emission, Scene, SceneBuilder};
use crate::scene_integrator::IntegratorSection;
use materials::MaterialSection;

mod materials;
mod projector_light;

/// Why a scene file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// Reading failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// TOML syntax or schema error (the message has the key and line).
    #[error("{}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value is out of range.
    #[error("{}: {key}: {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The key, e.g. `shapes[2].material`.
        key: String,
        /// What is wrong.
        reason: String,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: CameraSection,
    #[serde(default)]
    integrator: IntegratorSection,
    #[serde(default)]
    materials: BTreeMap<String, MaterialSection>,
    #[serde(default)]
    shapes: Vec<ShapeSection>,
    #[serde(default)]
    lights: Vec<LightSection>,
    #[serde(default)]
    media: BTreeMap<String, MediumSection>,
    #[serde(default)]
    global_medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumSection {
    sigma_a: [f32; 3],
    sigma_s: [f32; 3],
    #[serde(default)]
    g: f32,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSection {
    position: [f32; 3],
    look_at: [f32; 3],
    #[serde(default = "default_up")]
    up: [f32; 3],
    fov: f32,
    width: u32,
    height: u32,
    #[serde(default)]
    aperture_radius: f32,
    focus_distance: Option<f32>,
}

pub(super) fn default_up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeSection {
    #[serde(rename = "type")]
    kind: String,
    material: String,
    #[serde(default)]
    translate: Option<[f32; 3]>,
    #[serde(default)]
    rotate: Option<[f32; 3]>,
    #[serde(default)]
    scale: Option<ScaleValue>,
    #[serde(default)]
    matrix: Option<[[f32; 4]; 4]>,
    #[serde(default)]
    emission: Option<[f32; 3]>,
    #[serde(default)]
    two_sided: bool,
    #[serde(default)]
    interior: Option<String>,
    // Shape parameters.
    file: Option<String>,
    radius: Option<f32>,
    minor_radius: Option<f32>,
    p: Option<u32>,
    q: Option<u32>,
    segments: Option<u32>,
    sides: Option<u32>,
    groom: Option<String>,
    fibres: Option<u32>,
    length: Option<f32>,
    curl: Option<f32>,
    seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum ScaleValue {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum LightSection {
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    Spot {
        position: [f32; 3],
        look_at: [f32; 3],
        intensity: [f32; 3],
        cone_angle: f32,
        falloff_angle: Option<f32>,
    },
    Directional {
        direction: [f32; 3],
        irradiance: [f32; 3],
    },
    PointGrid {
        corner: [f32; 3],
        edge_u: [f32; 3],
        edge_v: [f32; 3],
        count: [u32; 2],
        intensity: [f32; 3],
        #[serde(default)]
        jitter: f32,
        #[serde(default)]
        tint: f32,
        #[serde(default)]
        seed: u64,
    },
    Projector(projector_light::ProjectorSection),
    Environment {
        radiance: Option<[f32; 3]>,
        file: Option<String>,
        sky: Option<SkySection>,
        #[serde(default = "default_scale")]
        scale: f32,
        #[serde(default)]
        rotate: [f32; 3],
    },
}

fn default_scale() -> f32 {
    1.0
}

/// A procedural sky: radiance blends from `horizon` to `zenith` above the horizon and is
/// `ground` below it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SkySection {
    zenith: [f32; 3],
    horizon: [f32; 3],
    ground: [f32; 3],
}

impl SkySection {
    /// The sky as a lat-long map (+Z up, the mapping of [`EnvironmentMap`]).
    fn image(&self) -> lucid_image::Image {
        let (w, h) = (256, 128);
        let (zenith, horizon, ground) = (Vec3::from(self.zenith), Vec3::from(self.horizon), Vec3::from(self.ground));
        lucid_image::Image::from_fn(w, h, |_, y| {
            let cos_theta = (std::f32::consts::PI * (y as f32 + 0.5) / h as f32).cos();
            // A square root keeps the bright band near the horizon narrow, as in a clear sky.
            let c = if cos_theta > 0.0 { horizon.lerp(zenith, cos_theta.sqrt()) } else { ground };
            [c.x, c.y, c.z, 1.0]
        })
    }
}

/// A loaded scene with its camera and render settings.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The geometry, materials and lights.
    pub scene: Scene,
    /// The camera.
    pub camera: RenderCamera,
    /// Samples, seed and integrator settings.
    pub settings: RenderSettings,
}

/// Reads and validates a scene file.
pub fn load_scene(path: &Path) -> Result<LoadedScene, SceneFileError> {
    let text = lucid_scene::text_file::read_text(path)
        .map_err(|source| SceneFileError::Io { path: path.to_path_buf(), source })?;
    parse_scene(&text, path)
}

/// Parses scene text; `path` is only used in error messages.
pub fn parse_scene(text: &str, path: &Path) -> Result<LoadedScene, SceneFileError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneFileError::Parse {
        path: path.to_path_buf(),
        message: e.to_string().trim().replace('\n', " "),
    })?;
    Builder { path }.build(file)
}

struct Builder<'a> {
    path: &'a Path,
}

impl Builder<'_> {
    fn invalid(&self, key: impl Into<String>, reason: impl Into<String>) -> SceneFileError {
        SceneFileError::Invalid { path: self.path.to_path_buf(), key: key.into(), reason: reason.into() }
    }

    fn finite(&self, key: &str, v: &[f32]) -> Result<(), SceneFileError> {
        if v.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(self.invalid(key, "values must be finite numbers")) }
    }

    fn colour(&self, key: &str, c: [f32; 3]) -> Result<Vec3, SceneFileError> {
        self.finite(key, &c)?;
        if c.iter().any(|&x| x < 0.0) {
            return Err(self.invalid(key, "colour components must not be negative"));
        }
        Ok(Vec3::from(c))
    }

    fn build(&self, file: SceneFile) -> Result<LoadedScene, SceneFileError> {
        let camera = self.camera(&file.camera)?;
        let settings = file.integrator.settings(|key, reason| self.invalid(key, reason))?;
        let mut builder = SceneBuilder::new();
        let mut media = BTreeMap::new();
        for (name, m) in &file.media {
            let key = format!("media.{name}");
            let sigma_a = self.colour(&format!("{key}.sigma_a"), m.sigma_a)?;
            let sigma_s = self.colour(&format!("{key}.sigma_s"), m.sigma_s)?;
            if !(m.g.is_finite() && m.g.abs() < 1.0) {
                return Err(self.invalid(format!("{key}.g"), "must be in (-1, 1)"));
            }
            let medium = HomogeneousMedium { sigma_a, sigma_s, phase: HenyeyGreenstein { g: m.g } };
            media.insert(name.clone(), builder.medium(medium));
        }
        if let Some(name) = &file.global_medium {
            let id =
                media.get(name).ok_or_else(|| self.invalid("global_medium", format!("no medium named {name:?}")))?;
            builder.global_medium(*id);
        }
        let mut ids = BTreeMap::new();
        for (name, m) in &file.materials {
            ids.insert(name.clone(), builder.material(self.material(&format!("materials.{name}"), m)?));
        }
        for (k, s) in file.shapes.iter().enumerate() {
            self.shape(&mut builder, &ids, &media, &format!("shapes[{k}]"), s)?;
        }
        for (k, l) in file.lights.iter().enumerate() {
            let key = format!("lights[{k}]");
            match l {
                LightSection::PointGrid { .. } => {
                    for light in self.point_grid(&key, l)?.lights() {
                        builder.light(light);
                    }
                }
                _ => builder.light(self.light(&key, l)?),
            }
        }
        let scene = builder.build();
        settings.integrator.supports(&scene).map_err(|reason| self.invalid("integrator.type", reason))?;
        Ok(LoadedScene { scene, camera, settings })
    }

    fn camera(&self, c: &CameraSection) -> Result<RenderCamera, SceneFileError> {
        self.finite("camera", &[c.position, c.look_at, c.up].concat())?;
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return Err(self.invalid("camera.fov", format!("must be in (0, 180) degrees, got {}", c.fov)));
        }
        if c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384 {
            return Err(self.invalid("camera.width", "image size must be 1..=16384 pixels per side"));
        }
        let (eye, target, up) = (Vec3::from(c.position), Vec3::from(c.look_at), Vec3::from(c.up));
        if (target - eye).length() == 0.0 || (target - eye).normalize().cross(up.normalize_or_zero()).length() < 1e-4 {
            return Err(self.invalid("camera.up", "must not be parallel to the viewing direction"));
        }
        let pinhole =
            PinholeCamera::new(Intrinsics::from_fov_x(c.width, c.height, c.fov.to_radians()), look_at(eye, target, up));
        if !(c.aperture_radius.is_finite() && c.aperture_radius >= 0.0) {
            return Err(self.invalid("camera.aperture_radius", "must be a non-negative number"));
        }
        if c.aperture_radius == 0.0 {
            return Ok(RenderCamera::Pinhole(pinhole));
        }
        let focus = c.focus_distance.unwrap_or((target - eye).length());
        if !(focus.is_finite() && focus > 0.0) {
            return Err(self.invalid("camera.focus_distance", "must be positive"));
        }
        Ok(RenderCamera::ThinLens(ThinLensCamera::new(pinhole, c.aperture_radius, focus)))
    }

    fn transform(&self, key: &str, s: &ShapeSection) -> Result<Mat4, SceneFileError> {
        if let Some(m) = s.matrix {
            if s.translate.is_some() || s.rotate.is_some() || s.scale.is_some() {
                return Err(self.invalid(format!("{key}.matrix"), "give either matrix or translate/rotate/scale"));
            }
            self.finite(&format!("{key}.matrix"), &m.concat())?;
            let m = Mat4::from_cols_array_2d(&m).transpose();
            if m.determinant().abs() < 1e-12 {
                return Err(self.invalid(format!("{key}.matrix"), "is singular"));
            }
            return Ok(m);
        }
        let t = Vec3::from(s.translate.unwrap_or([0.0; 3]));
        let r = s.rotate.unwrap_or([0.0; 3]);
        let scale = match s.scale {
            None => Vec3::ONE,
            Some(ScaleValue::Uniform(v)) => Vec3::splat(v),
            Some(ScaleValue::PerAxis(v)) => Vec3::from(v),
        };
        self.finite(key, &[t.to_array(), r, scale.to_array()].concat())?;
        if scale.abs().min_element() == 0.0 {
            return Err(self.invalid(format!("{key}.scale"), "must not be zero"));
        }
        let rot = Quat::from_euler(EulerRot::ZYX, r[2].to_radians(), r[1].to_radians(), r[0].to_radians());
        Ok(Mat4::from_scale_rotation_translation(scale, rot, t))
    }

    fn shape(
        &self,
        builder: &mut SceneBuilder,
        ids: &BTreeMap<String, u32>,
        media: &BTreeMap<String, u32>,
        key: &str,
        s: &ShapeSection,
    ) -> Result<(), SceneFileError> {
        let interior = match &s.interior {
            Some(name) => Some(
                *media
                    .get(name)
                    .ok_or_else(|| self.invalid(format!("{key}.interior"), format!("no medium named {name:?}")))?,
            ),
            None => None,
        };
        let material = *ids
            .get(&s.material)
            .ok_or_else(|| self.invalid(format!("{key}.material"), format!("no material named {:?}", s.material)))?;
        let emission = match s.emission {
            Some(e) => Some(Emission { radiance: self.colour(&format!("{key}.emission"), e)?, two_sided: s.two_sided }),
            None => None,
        };
        let m = self.transform(key, s)?;
        let positive = |name: &str, v: Option<f32>, default: f32| -> Result<f32, SceneFileError> {
            let v = v.unwrap_or(default);
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(self.invalid(format!("{key}.{name}"), "must be positive"))
            }
        };
        let count = |name: &str, v: Option<u32>, default: u32| -> Result<u32, SceneFileError> {
            let v = v.unwrap_or(default);
            if (3..=4096).contains(&v) {
                Ok(v)
            } else {
                Err(self.invalid(format!("{key}.{name}"), "must be in 3..=4096"))
            }
        };
        self.shape_keys(key, s)?;
        let knot = |name: &str, v: Option<u32>, default: u32| -> Result<u32, SceneFileError> {
            let v = v.unwrap_or(default);
            if (1..=1024).contains(&v) {
                Ok(v)
            } else {
                Err(self.invalid(format!("{key}.{name}"), "must be in 1..=1024"))
            }
        };
        let mesh: TriangleMesh = match s.kind.as_str() {
            "sphere" => {
                let r = positive("radius", s.radius, 1.0)?;
                // Spheres stay analytic: transform the centre, scale the radius uniformly.
                let (scale, _, centre) = m.to_scale_rotation_translation();
                if (scale.x - scale.y).abs() > 1e-5 * scale.x.abs() || (scale.x - scale.z).abs() > 1e-5 * scale.x.abs()
                {
                    return Err(self.invalid(format!("{key}.scale"), "a sphere needs a uniform scale"));
                }
                builder.sphere_with_medium(centre, r * scale.x.abs(), material, emission, interior);
                return Ok(());
            }
            "hair" => {
                let groom_name = s.groom.as_deref().unwrap_or("ball");
                let groom = crate::geometry::fibres::Groom::parse(groom_name).ok_or_else(|| {
                    self.invalid(format!("{key}.groom"), format!("unknown groom {groom_name:?} (ball or tress)"))
                })?;
                let fibres = s.fibres.unwrap_or(2000);
                if !(1..=200_000).contains(&fibres) {
                    return Err(self.invalid(format!("{key}.fibres"), "must be in 1..=200000"));
                }
                let curl = s.curl.unwrap_or(0.3);
                if !(curl.is_finite() && (0.0..=2.0).contains(&curl)) {
                    return Err(self.invalid(format!("{key}.curl"), "must be in [0, 2]"));
                }
                let params = crate::geometry::fibres::FibreParams {
                    groom,
                    count: fibres,
                    segments: count("segments", s.segments, 8)?,
                    length: positive("length", s.length, 0.5)?,
                    curl,
                    seed: s.seed.unwrap_or(0),
                };
                let radius = positive("radius", s.radius, 0.004)?;
                let polylines: Vec<Vec<Vec3>> = crate::geometry::fibres::grow(&params)
                    .into_iter()
                    .map(|f| f.into_iter().map(|p| m.transform_point3(p)).collect())
                    .collect();
                // Fibres stay round: their radius takes the transform's mean scale.
                let (scale, _, _) = m.to_scale_rotation_translation();
                let mean_scale = (scale.x * scale.y * scale.z).abs().cbrt();
                builder.fibres(&polylines, radius * mean_scale, material, emission);
                return Ok(());
            }
            "mesh" => {
                let file = s
                    .file
                    .as_ref()
                    .ok_or_else(|| self.invalid(format!("{key}.file"), "a mesh needs a file (.obj or .ply)"))?;
                let path = self.path.parent().unwrap_or(Path::new(".")).join(file);
                load_mesh(&path).map_err(|e| self.invalid(format!("{key}.file"), e.to_string()))?
            }
            "quad" => procedural::quad(),
            "cube" => procedural::cube(),
            "torus" => procedural::torus(
                positive("radius", s.radius, 1.0)?,
                positive("minor_radius", s.minor_radius, 0.25)?,
                count("segments", s.segments, 96)?,
                count("sides", s.sides, 32)?,
            ),
            "torus_knot" => procedural::torus_knot(
                knot("p", s.p, 2)?,
                knot("q", s.q, 3)?,
                positive("radius", s.radius, 1.0)?,
                positive("minor_radius", s.minor_radius, 0.15)?,
                count("segments", s.segments, 256)?,
                count("sides", s.sides, 16)?,
            ),
            other => unreachable!("shape_keys refuses the shape {other:?}"),
        };
        builder.mesh_with_medium(&mesh.transformed(&m), material, emission, interior);
        Ok(())
    }

    /// Refuses an unknown shape type, and a parameter the shape does not take (a `radius` on a
    /// quad), naming the key and the shape's own parameters.
    fn shape_keys(&self, key: &str, s: &ShapeSection) -> Result<(), SceneFileError> {
        let allowed: &[&str] = match s.kind.as_str() {
            "quad" | "cube" => &[],
            "sphere" => &["radius"],
            "mesh" => &["file"],
            "torus" => &["radius", "minor_radius", "segments", "sides"],
            "torus_knot" => &["p", "q", "radius", "minor_radius", "segments", "sides"],
            "hair" => &["groom", "fibres", "segments", "length", "curl", "radius", "seed"],
            other => {
                return Err(self.invalid(
                    format!("{key}.type"),
                    format!("unknown shape {other:?} (expected quad, cube, sphere, torus, torus_knot, hair or mesh)"),
                ));
            }
        };
        let given = [
            ("file", s.file.is_some()),
            ("radius", s.radius.is_some()),
            ("minor_radius", s.minor_radius.is_some()),
            ("p", s.p.is_some()),
            ("q", s.q.is_some()),
            ("segments", s.segments.is_some()),
            ("sides", s.sides.is_some()),
            ("groom", s.groom.is_some()),
            ("fibres", s.fibres.is_some()),
            ("length", s.length.is_some()),
            ("curl", s.curl.is_some()),
            ("seed", s.seed.is_some()),
        ];
        match given.iter().find(|(name, set)| *set && !allowed.contains(name)) {
            None => Ok(()),
            Some((name, _)) => {
                let takes = if allowed.is_empty() { "none".to_string() } else { allowed.join(", ") };
                Err(self.invalid(
                    format!("{key}.{name}"),
                    format!("a {} takes no {name} (its parameters: {takes})", s.kind),
                ))
            }
        }
    }

    fn point_grid(&self, key: &str, l: &LightSection) -> Result<PointLightGrid, SceneFileError> {
        let LightSection::PointGrid { corner, edge_u, edge_v, count, intensity, jitter, tint, seed } = l else {
            unreachable!("called for point grids only")
        };
        self.finite(key, &[*corner, *edge_u, *edge_v].concat())?;
        let lights = count[0] as u64 * count[1] as u64;
        if lights == 0 || lights > MAX_GRID_LIGHTS {
            return Err(self.invalid(format!("{key}.count"), format!("must make 1..={MAX_GRID_LIGHTS} lights")));
        }
        for (name, v) in [("jitter", jitter), ("tint", tint)] {
            if !(0.0..=1.0).contains(v) {
                return Err(self.invalid(format!("{key}.{name}"), "must be in [0, 1]"));
            }
        }
        Ok(PointLightGrid {
            corner: Vec3::from(*corner),
            edge_u: Vec3::from(*edge_u),
            edge_v: Vec3::from(*edge_v),
            count: *count,
            intensity: self.colour(&format!("{key}.intensity"), *intensity)?,
            jitter: *jitter,
            tint: *tint,
            seed: *seed,
        })
    }

    fn light(&self, key: &str, l: &LightSection) -> Result<Light, SceneFileError> {
        Ok(match l {
            LightSection::Point { position, intensity } => {
                self.finite(key, position)?;
                Light::Point {
                    position: Vec3::from(*position),
                    intensity: self.colour(&format!("{key}.intensity"), *intensity)?,
                }
            }
            LightSection::Spot { position, look_at, intensity, cone_angle, falloff_angle } => {
                self.finite(key, &[*position, *look_at].concat())?;
                let outer = *cone_angle;
                let inner = falloff_angle.unwrap_or(outer * 0.8);
                if !(outer > 0.0 && outer <= 90.0 && inner >= 0.0 && inner <= outer) {
                    return Err(
                        self.invalid(format!("{key}.cone_angle"), "need 0 < falloff_angle ≤ cone_angle ≤ 90 degrees")
                    );
                }
                let direction = (Vec3::from(*look_at) - Vec3::from(*position)).normalize_or_zero();
                if direction == Vec3::ZERO {
                    return Err(self.invalid(format!("{key}.look_at"), "must differ from position"));
                }
                Light::Spot {
                    position: Vec3::from(*position),
                    direction,
                    intensity: self.colour(&format!("{key}.intensity"), *intensity)?,
                    cos_inner: inner.to_radians().cos(),
                    cos_outer: outer.to_radians().cos(),
                }
            }
            LightSection::PointGrid { .. } => unreachable!("the caller expands grids into many lights"),
            LightSection::Projector(p) => self.projector(key, p)?,
            LightSection::Directional { direction, irradiance } => {
                self.finite(key, direction)?;
                let d = Vec3::from(*direction).normalize_or_zero();
                if d == Vec3::ZERO {
                    return Err(self.invalid(format!("{key}.direction"), "must not be zero"));
                }
                Light::Directional { direction: d, irradiance: self.colour(&format!("{key}.irradiance"), *irradiance)? }
            }
            LightSection::Environment { radiance, file, sky, scale, rotate } => {
                if !(scale.is_finite() && *scale >= 0.0) {
                    return Err(self.invalid(format!("{key}.scale"), "must be a non-negative number"));
                }
                self.finite(&format!("{key}.rotate"), rotate)?;
                match (radiance, file, sky) {
                    (None, None, Some(sky)) => {
                        for (name, c) in [("zenith", sky.zenith), ("horizon", sky.horizon), ("ground", sky.ground)] {
                            self.colour(&format!("{key}.sky.{name}"), c)?;
                        }
                        let rot = Quat::from_euler(
                            EulerRot::ZYX,
                            rotate[2].to_radians(),
                            rotate[1].to_radians(),
                            rotate[0].to_radians(),
                        );
                        Light::EnvironmentMap(Box::new(EnvironmentMap::new(&sky.image(), *scale, Mat3::from_quat(rot))))
                    }
                    (Some(r), None, None) => {
                        Light::ConstantEnvironment { radiance: self.colour(&format!("{key}.radiance"), *r)? * *scale }
                    }
                    (None, Some(f), None) => {
                        let path = self.path.parent().unwrap_or(Path::new(".")).join(f);
                        let image = lucid_image::read_image(&path)
                            .map_err(|e| self.invalid(format!("{key}.file"), e.to_string()))?;
                        if !image.is_finite() {
                            return Err(self.invalid(
                                format!("{key}.file"),
                                format!("{} has NaN or infinite pixels", path.display()),
                            ));
                        }
                        let rot = Quat::from_euler(
                            EulerRot::ZYX,
                            rotate[2].to_radians(),
                            rotate[1].to_radians(),
                            rotate[0].to_radians(),
                        );
                        Light::EnvironmentMap(Box::new(EnvironmentMap::new(&image, *scale, Mat3::from_quat(rot))))
                    }
                    _ => return Err(self.invalid(key, "an environment needs exactly one of radiance, file or sky")),
                }
            }
        })
    }
}
