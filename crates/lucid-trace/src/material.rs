//! Materials (what the scene file names) and textures; a material evaluated at a surface
//! point gives a BSDF.

use glam::{Vec2, Vec3};

use crate::bsdf::{
    AshikhminShirley, BlinnPhongLobe, Bsdf, BsdfSample, CookTorranceLobe, DiffuseAndLobe, GgxDistribution,
    LafortuneLobes, LafortuneTerm, Lambertian, MicrofacetConductor, PhongLobe, SmoothDielectric, SmoothPlastic,
    WardLobe,
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
            | Material::CookTorrance { kd, ks, .. } => kd.eval(uv) + *ks,
            Material::Lafortune { kd, .. } => kd.eval(uv),
            Material::AshikhminShirley { rd, rs, .. } => rd.eval(uv) + *rs,
            Material::Conductor { eta, k, .. } => crate::bsdf::fresnel::fresnel_conductor(1.0, *eta, *k),
            Material::Dielectric { transmittance, .. } => *transmittance,
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
