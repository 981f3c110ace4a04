//! The scene file's materials: their TOML sections (documented in the parent module) and how
//! each becomes a [`Material`].

use std::path::Path;

use glam::{Vec2, Vec3};
use serde::Deserialize;

use super::{Builder, SceneFileError};
use crate::bsdf::LafortuneTerm;
use crate::bsdf::kubelka_munk::KmLayer;
use crate::material::{ImageTexture, Material, Texture, Wrap};
use crate::texture_set::TileMap;

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum ColourOrChecker {
    Colour([f32; 3]),
    Checker {
        a: [f32; 3],
        b: [f32; 3],
        scale: f32,
    },
    Image {
        file: String,
        #[serde(default)]
        colorspace: Option<String>,
        #[serde(default)]
        wrap: Option<String>,
        #[serde(default)]
        scale: Option<[f32; 2]>,
    },
    /// A map of a generated texture set (see [`crate::texture_set`]).
    Procedural {
        procedural: String,
        #[serde(default)]
        scale: Option<[f32; 2]>,
    },
}

/// A scalar map: a number, or a texture whose red channel holds it.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum MapSection {
    Scalar(f32),
    Map(ColourOrChecker),
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
#[allow(clippy::large_enum_variant)] // parsed once per material; boxing buys nothing
pub(super) enum MaterialSection {
    Lambertian {
        albedo: ColourOrChecker,
    },
    Conductor {
        eta: [f32; 3],
        k: [f32; 3],
        #[serde(default)]
        roughness: f32,
        anisotropy: Option<f32>,
    },
    Dielectric {
        #[serde(default = "default_ior")]
        ior: f32,
        transmittance: Option<[f32; 3]>,
    },
    Plastic {
        albedo: ColourOrChecker,
        #[serde(default = "default_ior")]
        ior: f32,
    },
    Phong {
        kd: ColourOrChecker,
        ks: [f32; 3],
        exponent: f32,
    },
    BlinnPhong {
        kd: ColourOrChecker,
        ks: [f32; 3],
        exponent: f32,
    },
    Lafortune {
        kd: ColourOrChecker,
        lobes: Vec<LafortuneSection>,
    },
    Ward {
        kd: ColourOrChecker,
        ks: [f32; 3],
        alpha_x: f32,
        alpha_y: f32,
    },
    AshikhminShirley {
        rd: ColourOrChecker,
        rs: [f32; 3],
        nu: f32,
        nv: f32,
    },
    CookTorrance {
        kd: ColourOrChecker,
        ks: [f32; 3],
        roughness: f32,
        #[serde(default = "default_ior")]
        ior: f32,
    },
    Interface,
    Layered {
        base: ColourOrChecker,
        layers: Vec<KmLayerSection>,
    },
    Measured {
        file: Option<String>,
        tabulate: Option<Box<MaterialSection>>,
    },
    Neural {
        file: String,
    },
    Subsurface {
        sigma_a: Option<[f32; 3]>,
        sigma_s: Option<[f32; 3]>,
        albedo: Option<[f32; 3]>,
        mfp: Option<[f32; 3]>,
        #[serde(default = "default_subsurface_ior")]
        eta: f32,
        #[serde(default = "one")]
        scale: f32,
    },
    Hair {
        color: Option<[f32; 3]>,
        sigma_a: Option<[f32; 3]>,
        eumelanin: Option<f32>,
        pheomelanin: Option<f32>,
        #[serde(default = "default_hair_roughness")]
        beta_m: f32,
        #[serde(default = "default_hair_roughness")]
        beta_n: f32,
        #[serde(default = "default_cuticle_tilt")]
        alpha: f32,
        #[serde(default = "default_hair_ior")]
        eta: f32,
    },
    KajiyaKay {
        kd: ColourOrChecker,
        ks: [f32; 3],
        exponent: f32,
    },
    PoulinFournier {
        kd: ColourOrChecker,
        ks: [f32; 3],
        d: f32,
        h: f32,
        sigma_x: f32,
        sigma_y: f32,
    },
    Svbrdf {
        base_color: ColourOrChecker,
        roughness: MapSection,
        #[serde(default = "no_metal")]
        metallic: MapSection,
        normal: Option<ColourOrChecker>,
    },
}

/// `c` with an image's colour space linear when not given (data maps, not colours).
fn linear_by_default(c: &ColourOrChecker) -> ColourOrChecker {
    match c {
        ColourOrChecker::Image { file, colorspace, wrap, scale } => ColourOrChecker::Image {
            file: file.clone(),
            colorspace: Some(colorspace.clone().unwrap_or_else(|| "linear".into())),
            wrap: wrap.clone(),
            scale: *scale,
        },
        ColourOrChecker::Colour(v) => ColourOrChecker::Colour(*v),
        ColourOrChecker::Checker { a, b, scale } => ColourOrChecker::Checker { a: *a, b: *b, scale: *scale },
        ColourOrChecker::Procedural { procedural, scale } => {
            ColourOrChecker::Procedural { procedural: procedural.clone(), scale: *scale }
        }
    }
}

fn no_metal() -> MapSection {
    MapSection::Scalar(0.0)
}

/// A Kubelka–Munk film: coefficients and thickness, or its reflectance and transmittance.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct KmLayerSection {
    absorption: Option<[f32; 3]>,
    scattering: Option<[f32; 3]>,
    thickness: Option<f32>,
    reflectance: Option<[f32; 3]>,
    transmittance: Option<[f32; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LafortuneSection {
    c: [f32; 3],
    exponent: f32,
    albedo: [f32; 3],
}

fn default_ior() -> f32 {
    1.5
}

fn default_subsurface_ior() -> f32 {
    1.33
}

fn one() -> f32 {
    1.0
}

fn default_hair_roughness() -> f32 {
    0.3
}

fn default_cuticle_tilt() -> f32 {
    2.0
}

fn default_hair_ior() -> f32 {
    1.55
}

impl Builder<'_> {
    fn albedo(&self, key: &str, c: &ColourOrChecker) -> Result<Texture, SceneFileError> {
        let check = |v: Vec3| -> Result<Vec3, SceneFileError> {
            if v.max_element() > 1.0 { Err(self.invalid(key, "albedo above 1 would create energy")) } else { Ok(v) }
        };
        Ok(match c {
            ColourOrChecker::Colour(c) => Texture::Constant(check(self.colour(key, *c)?)?),
            ColourOrChecker::Checker { a, b, scale } => {
                if !(scale.is_finite() && *scale > 0.0) {
                    return Err(self.invalid(key, "checker scale must be positive"));
                }
                Texture::Checker { a: check(self.colour(key, *a)?)?, b: check(self.colour(key, *b)?)?, scale: *scale }
            }
            ColourOrChecker::Procedural { procedural, scale } => {
                self.procedural(key, procedural, *scale, TileMap::BaseColor)?
            }
            ColourOrChecker::Image { file, colorspace, wrap, scale } => {
                let path = self.path.parent().unwrap_or(Path::new(".")).join(file);
                let mut image = lucid_image::read_image(&path).map_err(|e| self.invalid(key, e.to_string()))?;
                match colorspace.as_deref() {
                    None | Some("srgb") => {}
                    // LDR files are decoded as sRGB; "linear" data (masks, roughness) is re-encoded
                    // to the stored values.
                    Some("linear") if !lucid_image::ImageFormat::from_path(&path).is_ok_and(|f| f.is_hdr()) => {
                        use lucid_image::color::srgb_encode;
                        image = image.map(|p| [srgb_encode(p[0]), srgb_encode(p[1]), srgb_encode(p[2]), p[3]]);
                    }
                    Some("linear") => {}
                    Some(other) => return Err(self.invalid(key, format!("colorspace {other:?} is not srgb or linear"))),
                }
                let wrap = match wrap.as_deref() {
                    None | Some("repeat") => Wrap::Repeat,
                    Some("clamp") => Wrap::Clamp,
                    Some(other) => return Err(self.invalid(key, format!("wrap {other:?} is not repeat or clamp"))),
                };
                let scale = scale.unwrap_or([1.0, 1.0]);
                if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                    return Err(self.invalid(key, "texture scale must be finite and non-zero"));
                }
                let texture = ImageTexture::new(&image, wrap, Vec2::from(scale));
                if !image.is_finite() {
                    return Err(self.invalid(key, format!("{} has NaN or infinite pixels", path.display())));
                }
                if texture.max_value() > 1.0 {
                    return Err(self.invalid(
                        key,
                        format!("{} has values above 1: an albedo would create energy", path.display()),
                    ));
                }
                Texture::Image(std::sync::Arc::new(texture))
            }
        })
    }

    pub(super) fn material(&self, key: &str, m: &MaterialSection) -> Result<Material, SceneFileError> {
        let ior = |v: f32| -> Result<f32, SceneFileError> {
            if v.is_finite() && v > 1.0 && v < 5.0 {
                Ok(v)
            } else {
                Err(self.invalid(format!("{key}.ior"), "must be in (1, 5)"))
            }
        };
        Ok(match m {
            MaterialSection::Lambertian { albedo } => {
                Material::Lambertian { albedo: self.albedo(&format!("{key}.albedo"), albedo)? }
            }
            MaterialSection::Conductor { eta, k, roughness, anisotropy } => {
                if !(roughness.is_finite() && (0.0..=1.0).contains(roughness)) {
                    return Err(self.invalid(format!("{key}.roughness"), "must be in [0, 1]"));
                }
                let aniso = anisotropy.unwrap_or(0.0);
                if !(aniso.is_finite() && (-0.95..=0.95).contains(&aniso)) {
                    return Err(self.invalid(format!("{key}.anisotropy"), "must be in [-0.95, 0.95]"));
                }
                // Burley's anisotropy mapping of α = roughness².
                let a = roughness * roughness;
                let aspect = (1.0 - 0.9 * aniso.abs()).sqrt();
                let alpha =
                    if aniso >= 0.0 { Vec2::new(a / aspect, a * aspect) } else { Vec2::new(a * aspect, a / aspect) };
                Material::Conductor {
                    eta: self.colour(&format!("{key}.eta"), *eta)?,
                    k: self.colour(&format!("{key}.k"), *k)?,
                    alpha,
                }
            }
            MaterialSection::Dielectric { ior: v, transmittance } => Material::Dielectric {
                eta: ior(*v)?,
                transmittance: self.colour(&format!("{key}.transmittance"), transmittance.unwrap_or([1.0; 3]))?,
            },
            MaterialSection::Plastic { albedo, ior: v } => {
                Material::Plastic { albedo: self.albedo(&format!("{key}.albedo"), albedo)?, eta: ior(*v)? }
            }
            MaterialSection::Phong { kd, ks, exponent } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                Material::Phong { kd, ks, exponent: self.exponent(&format!("{key}.exponent"), *exponent)? }
            }
            MaterialSection::BlinnPhong { kd, ks, exponent } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                Material::BlinnPhong { kd, ks, exponent: self.exponent(&format!("{key}.exponent"), *exponent)? }
            }
            MaterialSection::Lafortune { kd, lobes } => {
                if lobes.is_empty() || lobes.len() > 4 {
                    return Err(self.invalid(format!("{key}.lobes"), "give one to four lobes"));
                }
                let mut terms = Vec::with_capacity(lobes.len());
                for (j, l) in lobes.iter().enumerate() {
                    let lk = format!("{key}.lobes[{j}]");
                    self.finite(&format!("{lk}.c"), &l.c)?;
                    terms.push(LafortuneTerm {
                        c: Vec3::from(l.c),
                        exponent: self.exponent(&format!("{lk}.exponent"), l.exponent)?,
                        albedo: self.colour(&format!("{lk}.albedo"), l.albedo)?,
                    });
                }
                Material::Lafortune { kd: self.albedo(&format!("{key}.kd"), kd)?, lobes: terms }
            }
            MaterialSection::Ward { kd, ks, alpha_x, alpha_y } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                let a = |name: &str, v: f32| -> Result<f32, SceneFileError> {
                    if v.is_finite() && v > 0.0 && v <= 1.0 {
                        Ok(v)
                    } else {
                        Err(self.invalid(format!("{key}.{name}"), "must be in (0, 1]"))
                    }
                };
                Material::Ward { kd, ks, alpha: Vec2::new(a("alpha_x", *alpha_x)?, a("alpha_y", *alpha_y)?) }
            }
            MaterialSection::AshikhminShirley { rd, rs, nu, nv } => {
                let (rd, rs) = self.diffuse_specular(key, "rd", rd, "rs", *rs)?;
                let nu = self.exponent(&format!("{key}.nu"), *nu)?;
                let nv = self.exponent(&format!("{key}.nv"), *nv)?;
                Material::AshikhminShirley { rd, rs, exponents: Vec2::new(nu, nv) }
            }
            MaterialSection::CookTorrance { kd, ks, roughness, ior: v } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                if !(roughness.is_finite() && *roughness > 0.0 && *roughness <= 1.0) {
                    return Err(self.invalid(format!("{key}.roughness"), "must be in (0, 1]"));
                }
                Material::CookTorrance { kd, ks, m: *roughness, eta: ior(*v)? }
            }
            MaterialSection::Interface => Material::Interface,
            MaterialSection::Measured { file, tabulate } => Material::Measured {
                table: match (file, tabulate) {
                    (Some(file), None) => {
                        if file.starts_with(crate::assets::PREFIX) {
                            return Err(self.invalid(
                                format!("{key}.file"),
                                "no measured table is built in (one is 35 MB); give a file or `tabulate`",
                            ));
                        }
                        let path = self.path.parent().unwrap_or(Path::new(".")).join(file);
                        crate::bsdf::measured::MerlTable::load_shared(&path)
                            .map_err(|e| self.invalid(format!("{key}.file"), e.to_string()))?
                    }
                    (None, Some(source)) => self.tabulated(&format!("{key}.tabulate"), source)?,
                    _ => return Err(self.invalid(key, "give one of `file` (a MERL table) and `tabulate`")),
                },
            },
            MaterialSection::Subsurface { sigma_a, sigma_s, albedo, mfp, eta, scale } => {
                if !(eta.is_finite() && (1.0..=3.0).contains(eta)) {
                    return Err(self.invalid(format!("{key}.eta"), "must be in [1, 3]"));
                }
                if !(scale.is_finite() && *scale > 0.0) {
                    return Err(self.invalid(format!("{key}.scale"), "must be positive"));
                }
                let non_negative = |name: &str, v: [f32; 3]| -> Result<Vec3, SceneFileError> {
                    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
                        Ok(Vec3::from(v))
                    } else {
                        Err(self.invalid(format!("{key}.{name}"), "must be finite and non-negative"))
                    }
                };
                let (sigma_a, sigma_s) = match (sigma_a, sigma_s, albedo, mfp) {
                    (Some(a), Some(s), None, None) => (non_negative("sigma_a", *a)?, non_negative("sigma_s", *s)?),
                    (None, None, Some(albedo), Some(mfp)) => {
                        let albedo = self.colour(&format!("{key}.albedo"), *albedo)?;
                        if albedo.max_element() > 1.0 {
                            return Err(self.invalid(format!("{key}.albedo"), "must be in [0, 1]"));
                        }
                        let mfp = non_negative("mfp", *mfp)?;
                        if mfp.min_element() <= 0.0 {
                            return Err(self.invalid(format!("{key}.mfp"), "must be positive"));
                        }
                        let sigma_t = mfp.recip();
                        (sigma_t * (Vec3::ONE - albedo), sigma_t * albedo)
                    }
                    _ => {
                        return Err(self.invalid(
                            key,
                            "give sigma_a and sigma_s (reduced scattering), or albedo and mfp (mean free path)",
                        ));
                    }
                };
                if (sigma_a + sigma_s).min_element() <= 0.0 {
                    return Err(self.invalid(key, "every channel needs some absorption or scattering"));
                }
                let profile = crate::subsurface::SubsurfaceProfile::new(sigma_a * *scale, sigma_s * *scale, *eta);
                let colour = profile.total();
                Material::Subsurface { profile: std::sync::Arc::new(profile), colour }
            }
            MaterialSection::Hair { color, sigma_a, eumelanin, pheomelanin, beta_m, beta_n, alpha, eta } => {
                let within = |name: &str, v: f32, lo: f32, hi: f32| -> Result<f32, SceneFileError> {
                    if v.is_finite() && (lo..=hi).contains(&v) {
                        Ok(v)
                    } else {
                        Err(self.invalid(format!("{key}.{name}"), format!("must be in [{lo}, {hi}]")))
                    }
                };
                let beta_m = within("beta_m", *beta_m, 0.05, 1.0)?;
                let beta_n = within("beta_n", *beta_n, 0.05, 1.0)?;
                let alpha = within("alpha", *alpha, -10.0, 10.0)?;
                let eta = within("eta", *eta, 1.0, 3.0)?;
                let melanin = eumelanin.is_some() || pheomelanin.is_some();
                let given = color.is_some() as u8 + sigma_a.is_some() as u8 + melanin as u8;
                if given != 1 {
                    return Err(self.invalid(key, "give one of color, sigma_a, or eumelanin/pheomelanin"));
                }
                let sigma_a = if let Some(c) = color {
                    let c = self.colour(&format!("{key}.color"), *c)?;
                    crate::bsdf::hair::HairModel::sigma_a_from_colour(c, beta_n)
                } else if let Some(s) = sigma_a {
                    self.finite(&format!("{key}.sigma_a"), s)?;
                    if s.iter().any(|v| *v < 0.0) {
                        return Err(self.invalid(format!("{key}.sigma_a"), "must not be negative"));
                    }
                    Vec3::from(*s)
                } else {
                    let e = within("eumelanin", eumelanin.unwrap_or(0.0), 0.0, 50.0)?;
                    let p = within("pheomelanin", pheomelanin.unwrap_or(0.0), 0.0, 50.0)?;
                    crate::bsdf::hair::HairModel::sigma_a_from_melanin(e, p)
                };
                let model = crate::bsdf::hair::HairModel::new(sigma_a, beta_m, beta_n, alpha.to_radians(), eta);
                Material::Hair { model, colour: crate::bsdf::hair::HairModel::colour_of(sigma_a, beta_n) }
            }
            MaterialSection::KajiyaKay { kd, ks, exponent } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                if !(exponent.is_finite() && (1.0..=10_000.0).contains(exponent)) {
                    return Err(self.invalid(format!("{key}.exponent"), "must be in [1, 10000]"));
                }
                Material::KajiyaKay { kd, ks, v: 1.0 / exponent }
            }
            MaterialSection::PoulinFournier { kd, ks, d, h, sigma_x, sigma_y } => {
                let (kd, ks) = self.diffuse_specular(key, "kd", kd, "ks", *ks)?;
                if !(h.is_finite() && (0.0..0.99).contains(h)) {
                    return Err(self.invalid(format!("{key}.h"), "must be in [0, 0.99)"));
                }
                let width = 2.0 * (1.0 - h * h).sqrt();
                if !(d.is_finite() && *d >= width - 1e-5 && *d <= 1000.0) {
                    return Err(self.invalid(
                        format!("{key}.d"),
                        format!("must be at least the groove width 2·√(1 − h²) = {width:.4} (and at most 1000)"),
                    ));
                }
                let sigma = |name: &str, v: f32| -> Result<f32, SceneFileError> {
                    if v.is_finite() && (0.01..=1.0).contains(&v) {
                        Ok(v)
                    } else {
                        Err(self.invalid(format!("{key}.{name}"), "must be in [0.01, 1]"))
                    }
                };
                let sigma = Vec2::new(sigma("sigma_x", *sigma_x)?, sigma("sigma_y", *sigma_y)?);
                Material::PoulinFournier { kd, ks, d: d.max(width), h: *h, sigma }
            }
            MaterialSection::Neural { file } => {
                use crate::bsdf::neural::NeuralBrdfModel;
                let model = match file.strip_prefix(crate::assets::PREFIX) {
                    Some(name) => NeuralBrdfModel::load_builtin(name),
                    None => NeuralBrdfModel::load_shared(&self.path.parent().unwrap_or(Path::new(".")).join(file)),
                };
                Material::Neural { model: model.map_err(|e| self.invalid(format!("{key}.file"), e.to_string()))? }
            }
            MaterialSection::Svbrdf { base_color, roughness, metallic, normal } => Material::Svbrdf {
                base_color: self.albedo(&format!("{key}.base_color"), base_color)?,
                roughness: self.scalar_map(&format!("{key}.roughness"), roughness, TileMap::Roughness)?,
                metallic: self.scalar_map(&format!("{key}.metallic"), metallic, TileMap::Metallic)?,
                normal: normal.as_ref().map(|n| self.normal_map(&format!("{key}.normal"), n)).transpose()?,
            },
            MaterialSection::Layered { base, layers } => Material::Layered {
                base: self.albedo(&format!("{key}.base"), base)?,
                layers: self.km_layers(key, layers)?,
            },
        })
    }

    /// The table of the material `source` (refused unless it is one isotropic, non-specular
    /// BRDF), made once per process for each scene folder and section.
    fn tabulated(
        &self,
        key: &str,
        source: &MaterialSection,
    ) -> Result<&'static crate::bsdf::measured::MerlTable, SceneFileError> {
        let material = self.material(key, source)?;
        // Relative files inside the section resolve against the scene's folder.
        let id = format!("{}: {source:?}", self.path.parent().unwrap_or(Path::new(".")).display());
        crate::tabulate::tabulate_shared(&id, &material).map_err(|e| self.invalid(key, e.to_string()))
    }

    /// A map of a generated texture set.
    fn procedural(
        &self,
        key: &str,
        name: &str,
        scale: Option<[f32; 2]>,
        which: TileMap,
    ) -> Result<Texture, SceneFileError> {
        if name != "tiles" {
            return Err(self.invalid(key, format!("unknown procedural texture set {name:?} (one of: tiles)")));
        }
        let scale = scale.unwrap_or([1.0, 1.0]);
        if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
            return Err(self.invalid(key, "texture scale must be finite and non-zero"));
        }
        let image = crate::texture_set::tiles(which, 512);
        Ok(Texture::Image(std::sync::Arc::new(ImageTexture::new(&image, Wrap::Repeat, Vec2::from(scale)))))
    }

    /// A roughness or metallic map: a number in [0, 1], a procedural map, or a texture (files
    /// are data: linear unless `colorspace` says otherwise).
    fn scalar_map(&self, key: &str, m: &MapSection, which: TileMap) -> Result<Texture, SceneFileError> {
        match m {
            MapSection::Scalar(x) if x.is_finite() && (0.0..=1.0).contains(x) => Ok(Texture::Constant(Vec3::splat(*x))),
            MapSection::Scalar(_) => Err(self.invalid(key, "must be in [0, 1]")),
            MapSection::Map(ColourOrChecker::Procedural { procedural, scale }) => {
                self.procedural(key, procedural, *scale, which)
            }
            MapSection::Map(c) => self.albedo(key, &linear_by_default(c)),
        }
    }

    /// A tangent-space normal map: a procedural map or an image file (linear unless told).
    fn normal_map(&self, key: &str, c: &ColourOrChecker) -> Result<Texture, SceneFileError> {
        match c {
            ColourOrChecker::Procedural { procedural, scale } => {
                self.procedural(key, procedural, *scale, TileMap::Normal)
            }
            ColourOrChecker::Image { .. } => self.albedo(key, &linear_by_default(c)),
            _ => Err(self.invalid(key, "a normal map is an image file or a procedural map")),
        }
    }

    fn km_layers(&self, key: &str, sections: &[KmLayerSection]) -> Result<Vec<KmLayer>, SceneFileError> {
        if sections.is_empty() || sections.len() > 16 {
            return Err(self.invalid(format!("{key}.layers"), "give 1 to 16 layers (top first)"));
        }
        let mut layers = Vec::with_capacity(sections.len());
        for (i, l) in sections.iter().enumerate() {
            let at = format!("{key}.layers[{i}]");
            let non_negative = |name: &str, v: [f32; 3]| -> Result<Vec3, SceneFileError> {
                if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
                    Ok(Vec3::from(v))
                } else {
                    Err(self.invalid(format!("{at}.{name}"), "values must be finite and ≥ 0"))
                }
            };
            let layer = match (l.absorption, l.scattering, l.thickness, l.reflectance, l.transmittance) {
                (Some(k), Some(s), Some(d), None, None) => {
                    if !(d.is_finite() && d > 0.0) {
                        return Err(self.invalid(format!("{at}.thickness"), "must be a positive number"));
                    }
                    KmLayer::from_coefficients(non_negative("absorption", k)?, non_negative("scattering", s)?, d)
                }
                (None, None, None, Some(r), Some(t)) => {
                    let (r, t) = (non_negative("reflectance", r)?, non_negative("transmittance", t)?);
                    if (r + t).max_element() > 1.0 {
                        return Err(self.invalid(&at, "reflectance + transmittance must not exceed 1 (energy)"));
                    }
                    KmLayer { reflectance: r, transmittance: t }
                }
                _ => {
                    return Err(self
                        .invalid(&at, "give absorption, scattering and thickness, or reflectance and transmittance"));
                }
            };
            layers.push(layer);
        }
        Ok(layers)
    }

    fn exponent(&self, key: &str, v: f32) -> Result<f32, SceneFileError> {
        if v.is_finite() && v > 0.0 && v <= 1e5 { Ok(v) } else { Err(self.invalid(key, "must be in (0, 100000]")) }
    }

    /// A diffuse texture and a specular colour whose sum must not exceed 1 (energy).
    fn diffuse_specular(
        &self,
        key: &str,
        kd_name: &str,
        kd: &ColourOrChecker,
        ks_name: &str,
        ks: [f32; 3],
    ) -> Result<(Texture, Vec3), SceneFileError> {
        let kd = self.albedo(&format!("{key}.{kd_name}"), kd)?;
        let ks = self.colour(&format!("{key}.{ks_name}"), ks)?;
        let kd_max = match &kd {
            Texture::Constant(c) => *c,
            Texture::Checker { a, b, .. } => a.max(*b),
            Texture::Image(image) => Vec3::splat(image.max_value()),
        };
        if (kd_max + ks).max_element() > 1.0 + 1e-6 {
            return Err(self.invalid(key, format!("{kd_name} + {ks_name} exceeds 1 and would create energy")));
        }
        Ok((kd, ks))
    }
}
