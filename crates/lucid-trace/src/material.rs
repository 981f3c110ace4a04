//! Materials (what the scene file names) and textures; a material evaluated at a surface
//! point gives a BSDF.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::bsdf::{
    AshikhminShirley, BlinnPhongLobe, Bsdf, BsdfSample, CookTorranceLobe, DiffuseAndLobe, GgxDistribution,
    LafortuneLobes, LafortuneTerm, Lambertian, MicrofacetConductor, PhongLobe, SmoothDielectric, SmoothPlastic,
    WardLobe,
    hair::{HairModel, HairSurface, KajiyaKay},
    kubelka_munk::{KmLayer, stack_reflectance},
    measured::{MeasuredBrdf, MerlTable},
    metallic_roughness::MetallicRoughness,
    neural::{NeuralBrdf, NeuralBrdfModel},
    poulin_fournier::PoulinFournier,
};

/// A colour that may vary over the surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// One colour.
    Constant(Vec3),
    /// Two colours in a checkerboard of `scale` squares per unit of texture coordinate.
    Checker {
        /// Even squares.
        a: Vec3,
        /// Odd squares.
        b: Vec3,
        /// Squares per unit of uv.
        scale: f32,
    },
    /// An image, bilinearly filtered.
    Image(Arc<ImageTexture>),
}

/// What happens outside `[0,1]²` of an image texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile the image.
    Repeat,
    /// Extend the edge texels.
    Clamp,
}

/// A linear RGB image used as a texture; `(u, v) = (0, 0)` is the bottom-left corner (the
/// OBJ convention), texel centres at half-integers.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
    wrap: Wrap,
    scale: Vec2,
}

impl ImageTexture {
    /// From a linear image; `scale` multiplies the texture coordinates (tiling).
    pub fn new(image: &lucid_image::Image, wrap: Wrap, scale: Vec2) -> Self {
        let texels = image.pixels().iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        Self { width: image.width(), height: image.height(), texels, wrap, scale }
    }

    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let (x, y) = match self.wrap {
            Wrap::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
            Wrap::Clamp => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
        };
        self.texels[(y * w + x) as usize]
    }

    /// Bilinearly filtered colour at `uv`.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let uv = uv * self.scale;
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0) * (1.0 - fx) + self.texel(x0 + 1, y0) * fx;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The largest value of any channel (for energy checks).
    pub fn max_value(&self) -> f32 {
        self.texels.iter().map(|t| t.max_element()).fold(0.0, f32::max)
    }
}

impl Texture {
    /// The colour at texture coordinates `uv`.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { a, b, scale } => {
                let cell = (uv * *scale).floor();
                if (cell.x as i64 + cell.y as i64).rem_euclid(2) == 0 { *a } else { *b }
            }
            Texture::Image(image) => image.eval(uv),
        }
    }
}

/// The materials of the scene description.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Ideal diffuse.
    Lambertian {
        /// Albedo.
        albedo: Texture,
    },
    /// Metal: GGX microfacets with complex Fresnel; roughness 0 is a mirror.
    Conductor {
        /// Real index per channel.
        eta: Vec3,
        /// Absorption per channel.
        k: Vec3,
        /// GGX α along x and y.
        alpha: Vec2,
    },
    /// Smooth glass-like interface.
    Dielectric {
        /// Index of refraction (inside over outside).
        eta: f32,
        /// Tint of transmitted light.
        transmittance: Vec3,
    },
    /// Diffuse base under a smooth coating.
    Plastic {
        /// Base albedo.
        albedo: Texture,
        /// Coating index.
        eta: f32,
    },
    /// Energy-conserving Phong (Lafortune–Willems).
    Phong {
        /// Diffuse albedo.
        kd: Texture,
        /// Specular albedo.
        ks: Vec3,
        /// Exponent.
        exponent: f32,
    },
    /// Blinn–Phong normalised to albedo `ks` at normal incidence.
    BlinnPhong {
        /// Diffuse albedo.
        kd: Texture,
        /// Specular albedo.
        ks: Vec3,
        /// Exponent.
        exponent: f32,
    },
    /// Lafortune generalised cosine lobes.
    Lafortune {
        /// Diffuse albedo.
        kd: Texture,
        /// The lobes (at most four).
        lobes: Vec<LafortuneTerm>,
    },
    /// Ward anisotropic Gaussian (bounded-albedo normalisation).
    Ward {
        /// Diffuse albedo.
        kd: Texture,
        /// Specular albedo.
        ks: Vec3,
        /// Roughness along the tangent and bitangent.
        alpha: Vec2,
    },
    /// Ashikhmin–Shirley anisotropic Phong.
    AshikhminShirley {
        /// Diffuse reflectance.
        rd: Texture,
        /// Specular reflectance at normal incidence.
        rs: Vec3,
        /// Exponents along the tangent and bitangent.
        exponents: Vec2,
    },
    /// An index-matched boundary that light crosses unchanged: the surface of a medium.
    Interface,
    /// Spatially varying metallic–roughness microfacets with an optional tangent-space normal
    /// map (red channel of `roughness` and `metallic`; the normal map encoded as (n + 1)/2).
    Svbrdf {
        /// Base colour.
        base_color: Texture,
        /// Roughness (α = roughness²).
        roughness: Texture,
        /// Metalness.
        metallic: Texture,
        /// Tangent-space normal map.
        normal: Option<Texture>,
    },
    /// Poulin–Fournier cylindrical grooves along the tangent (see [`PoulinFournier`]).
    PoulinFournier {
        /// Diffuse albedo of the grooved surface's material.
        kd: Texture,
        /// Specular albedo.
        ks: Vec3,
        /// Groove period, in groove radii.
        d: f32,
        /// Height of the grooves' circle centres above the plane, in radii.
        h: f32,
        /// GGX roughness along and across the grooves.
        sigma: Vec2,
    },
    /// A fibre after Marschner et al. (see [`HairModel`]), for hair shapes.
    Hair {
        /// The fibre's material.
        model: HairModel,
        /// Its colour, for the albedo buffer.
        colour: Vec3,
    },
    /// Kajiya–Kay fibres (see [`KajiyaKay`]), for hair shapes.
    KajiyaKay {
        /// Diffuse albedo.
        kd: Texture,
        /// Specular albedo.
        ks: Vec3,
        /// Variance of the specular cone.
        v: f32,
    },
    /// A translucent object: a smooth dielectric boundary over a scattering interior whose
    /// light comes back out through a BSSRDF (see [`crate::subsurface`]).
    Subsurface {
        /// The tabulated radial profile (shared: building it takes milliseconds).
        profile: Arc<crate::subsurface::SubsurfaceProfile>,
        /// Its diffuse reflectance, for the albedo buffer.
        colour: Vec3,
    },
    /// A neural BRDF fitted to a measured one (`lucid brdf fit-neural`).
    Neural {
        /// The network, loaded once per process.
        model: &'static NeuralBrdfModel,
    },
    /// A measured isotropic BRDF (a MERL table).
    Measured {
        /// The table, loaded once per process.
        table: &'static MerlTable,
    },
    /// Kubelka–Munk films (top first) over an opaque diffuse base: Lambertian with the
    /// stack's reflectance.
    Layered {
        /// Reflectance of the base.
        base: Texture,
        /// The films.
        layers: Vec<KmLayer>,
    },
    /// Cook–Torrance with the Beckmann distribution.
    CookTorrance {
        /// Diffuse albedo.
        kd: Texture,
        /// Specular colour.
        ks: Vec3,
        /// RMS slope.
        m: f32,
        /// Index for the Fresnel term.
        eta: f32,
    },
}

/// A BSDF instantiated at a surface point (static dispatch over the kinds).
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)] // built on the stack per hit; boxing would allocate per hit
pub enum SurfaceBsdf {
    /// See [`Lambertian`].
    Lambertian(Lambertian),
    /// See [`MicrofacetConductor`].
    Conductor(MicrofacetConductor),
    /// See [`SmoothDielectric`].
    Dielectric(SmoothDielectric),
    /// See [`SmoothPlastic`].
    Plastic(SmoothPlastic),
    /// See [`PhongLobe`].
    Phong(DiffuseAndLobe<PhongLobe>),
    /// See [`BlinnPhongLobe`].
    BlinnPhong(DiffuseAndLobe<BlinnPhongLobe>),
    /// See [`LafortuneLobes`].
    Lafortune(DiffuseAndLobe<LafortuneLobes>),
    /// See [`WardLobe`].
    Ward(DiffuseAndLobe<WardLobe>),
    /// See [`AshikhminShirley`].
    AshikhminShirley(AshikhminShirley),
    /// See [`CookTorranceLobe`].
    CookTorrance(DiffuseAndLobe<CookTorranceLobe>),
    /// See [`MetallicRoughness`].
    MetallicRoughness(MetallicRoughness),
    /// See [`MeasuredBrdf`].
    Measured(MeasuredBrdf),
    /// See [`PoulinFournier`].
    PoulinFournier(PoulinFournier),
    /// See [`HairSurface`].
    Hair(HairSurface),
    /// See [`NeuralBrdf`].
    Neural(NeuralBrdf),
    /// See [`KajiyaKay`].
    KajiyaKay(KajiyaKay),
}

/// Calls `$body` with the concrete BSDF of any variant bound to `$b`.
macro_rules! each_bsdf {
    ($self:expr, $b:ident => $body:expr) => {
        match $self {
            SurfaceBsdf::Lambertian($b) => $body,
            SurfaceBsdf::Conductor($b) => $body,
            SurfaceBsdf::Dielectric($b) => $body,
            SurfaceBsdf::Plastic($b) => $body,
            SurfaceBsdf::Phong($b) => $body,
            SurfaceBsdf::BlinnPhong($b) => $body,
            SurfaceBsdf::Lafortune($b) => $body,
            SurfaceBsdf::Ward($b) => $body,
            SurfaceBsdf::AshikhminShirley($b) => $body,
            SurfaceBsdf::CookTorrance($b) => $body,
            SurfaceBsdf::MetallicRoughness($b) => $body,
            SurfaceBsdf::Measured($b) => $body,
            SurfaceBsdf::PoulinFournier($b) => $body,
            SurfaceBsdf::Hair($b) => $body,
            SurfaceBsdf::Neural($b) => $body,
            SurfaceBsdf::KajiyaKay($b) => $body,
        }
    };
}

impl Material {
    /// The BSDF at texture coordinates `uv`.
    pub fn bsdf(&self, uv: Vec2) -> SurfaceBsdf {
        match self {
            Material::Lambertian { albedo } => SurfaceBsdf::Lambertian(Lambertian { albedo: albedo.eval(uv) }),
            Material::Conductor { eta, k, alpha } => SurfaceBsdf::Conductor(MicrofacetConductor {
                distribution: GgxDistribution { alpha_x: alpha.x, alpha_y: alpha.y },
                eta: *eta,
                k: *k,
            }),
            Material::Dielectric { eta, transmittance } => {
                SurfaceBsdf::Dielectric(SmoothDielectric { eta: *eta, transmittance: *transmittance })
            }
            Material::Plastic { albedo, eta } => SurfaceBsdf::Plastic(SmoothPlastic::new(albedo.eval(uv), *eta)),
            Material::Phong { kd, ks, exponent } => SurfaceBsdf::Phong(DiffuseAndLobe {
                diffuse: kd.eval(uv),
                lobe: PhongLobe { ks: *ks, exponent: *exponent },
            }),
            Material::BlinnPhong { kd, ks, exponent } => SurfaceBsdf::BlinnPhong(DiffuseAndLobe {
                diffuse: kd.eval(uv),
                lobe: BlinnPhongLobe::new(*ks, *exponent),
            }),
            Material::Lafortune { kd, lobes } => {
                SurfaceBsdf::Lafortune(DiffuseAndLobe { diffuse: kd.eval(uv), lobe: LafortuneLobes::new(lobes) })
            }
            Material::Ward { kd, ks, alpha } => SurfaceBsdf::Ward(DiffuseAndLobe {
                diffuse: kd.eval(uv),
                lobe: WardLobe { ks: *ks, alpha_x: alpha.x, alpha_y: alpha.y },
            }),
            Material::AshikhminShirley { rd, rs, exponents } => SurfaceBsdf::AshikhminShirley(AshikhminShirley {
                rd: rd.eval(uv),
                rs: *rs,
                nu: exponents.x,
                nv: exponents.y,
            }),
            // Crossing unchanged is refraction with η = 1 and no reflection; the integrator
            // skips interfaces before asking for a BSDF, this keeps the two consistent.
            Material::Interface => SurfaceBsdf::Dielectric(SmoothDielectric { eta: 1.0, transmittance: Vec3::ONE }),
            Material::Layered { base, layers } => {
                SurfaceBsdf::Lambertian(Lambertian { albedo: stack_reflectance(layers, base.eval(uv)) })
            }
            Material::Measured { table } => SurfaceBsdf::Measured(MeasuredBrdf { table }),
            Material::Neural { model } => SurfaceBsdf::Neural(NeuralBrdf { model }),
            Material::Hair { model, .. } => SurfaceBsdf::Hair(HairSurface { model: *model }),
            Material::Subsurface { profile, .. } => {
                SurfaceBsdf::Dielectric(SmoothDielectric { eta: profile.eta, transmittance: Vec3::ONE })
            }
            Material::KajiyaKay { kd, ks, v } => SurfaceBsdf::KajiyaKay(KajiyaKay { kd: kd.eval(uv), ks: *ks, v: *v }),
            Material::PoulinFournier { kd, ks, d, h, sigma } => {
                SurfaceBsdf::PoulinFournier(PoulinFournier::new(kd.eval(uv), *ks, *d, *h, *sigma))
            }
            Material::Svbrdf { base_color, roughness, metallic, normal } => {
                let n = normal.as_ref().map_or(Vec3::Z, |t| t.eval(uv) * 2.0 - Vec3::ONE);
                SurfaceBsdf::MetallicRoughness(MetallicRoughness::new(
                    base_color.eval(uv),
                    metallic.eval(uv).x.clamp(0.0, 1.0),
                    roughness.eval(uv).x.clamp(0.0, 1.0),
                    n,
                ))
            }
            Material::CookTorrance { kd, ks, m, eta } => SurfaceBsdf::CookTorrance(DiffuseAndLobe {
                diffuse: kd.eval(uv),
                lobe: CookTorranceLobe { ks: *ks, m: *m, eta: *eta },
            }),
        }
    }

    /// The colour reported in the albedo AOV.
    pub fn albedo(&self, uv: Vec2) -> Vec3 {
        match self {
            Material::Lambertian { albedo } | Material::Plastic { albedo, .. } => albedo.eval(uv),
            Material::Phong { kd, ks, .. }
            | Material::BlinnPhong { kd, ks, .. }
            | Material::Ward { kd, ks, .. }
            | Material::CookTorrance { kd, ks, .. }
            | Material::PoulinFournier { kd, ks, .. }
            | Material::KajiyaKay { kd, ks, .. } => kd.eval(uv) + *ks,
            Material::Hair { colour, .. } | Material::Subsurface { colour, .. } => *colour,
            Material::Lafortune { kd, .. } => kd.eval(uv),
            Material::Interface => Vec3::ZERO,
            Material::Layered { base, layers } => stack_reflectance(layers, base.eval(uv)),
            Material::Svbrdf { base_color, .. } => base_color.eval(uv),
            // The albedo buffer shows the hemispherical reflectance at normal incidence.
            Material::Measured { table } => table.normal_albedo(),
            Material::Neural { model } => model.normal_albedo(),
            Material::AshikhminShirley { rd, rs, .. } => rd.eval(uv) + *rs,
            Material::Conductor { eta, k, .. } => crate::bsdf::fresnel::fresnel_conductor(1.0, *eta, *k),
            Material::Dielectric { transmittance, .. } => *transmittance,
        }
    }
}

impl SurfaceBsdf {
    /// Whether `f(ωo, ωi) = f(ωi, ωo)`. Fibres are not: their value is the scattering
    /// function divided by the shading cosine of `ωi`, and the offset across the fibre is
    /// read from `ωo`.
    pub fn is_reciprocal(&self) -> bool {
        !matches!(self, SurfaceBsdf::Hair(_) | SurfaceBsdf::KajiyaKay(_))
    }

    /// The value a light path needs where light arrives along `wo` and leaves along `wi`:
    /// the BSDF in camera-side order, `f(ωi, ωo)`.
    pub fn eval_adjoint(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.is_reciprocal() { self.eval(wo, wi) } else { self.eval(wi, wo) }
    }

    /// A sample's value on a light path (see [`SurfaceBsdf::eval_adjoint`]).
    pub fn sample_value_adjoint(&self, wo: Vec3, sample: &BsdfSample) -> Vec3 {
        if sample.specular || self.is_reciprocal() { sample.f } else { self.eval(sample.wi, wo) }
    }

    /// Factor that turns a sample's radiance weight into its importance weight (light paths):
    /// refraction scales radiance by 1/η² across the interface, importance not.
    pub(crate) fn adjoint_scale(&self, wo: Vec3, sample: &BsdfSample) -> f32 {
        match self {
            SurfaceBsdf::Dielectric(d) if sample.transmission => {
                let eta = if wo.z > 0.0 { d.eta } else { 1.0 / d.eta };
                eta * eta
            }
            _ => 1.0,
        }
    }
}

impl Bsdf for SurfaceBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        each_bsdf!(self, b => b.eval(wo, wi))
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        each_bsdf!(self, b => b.sample(wo, u, uc))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        each_bsdf!(self, b => b.pdf(wo, wi))
    }

    fn is_specular(&self) -> bool {
        each_bsdf!(self, b => b.is_specular())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_textures_interpolate_and_wrap() {
        // 2x2: top row red, green; bottom row blue, white.
        let img = lucid_image::Image::from_pixels(
            2,
            2,
            vec![[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]],
        );
        let t = ImageTexture::new(&img, Wrap::Repeat, Vec2::ONE);
        // Texel centres: (0.25, 0.75) is the top-left texel (v up).
        assert!((t.eval(Vec2::new(0.25, 0.75)) - Vec3::X).length() < 1e-6);
        assert!((t.eval(Vec2::new(0.75, 0.25)) - Vec3::ONE).length() < 1e-6);
        // Halfway between red and green.
        assert!((t.eval(Vec2::new(0.5, 0.75)) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
        // Repeat: one period over is the same point.
        assert!((t.eval(Vec2::new(1.25, -0.25)) - t.eval(Vec2::new(0.25, 0.75))).length() < 1e-6);
        // Clamp: far outside takes the edge texel.
        let c = ImageTexture::new(&img, Wrap::Clamp, Vec2::ONE);
        assert!((c.eval(Vec2::new(-3.0, 5.0)) - Vec3::X).length() < 1e-6);
    }
}
