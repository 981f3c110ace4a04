//! Materials (what the scene file names) and textures; a material evaluated at a surface
//! point gives a BSDF.

use glam::{Vec2, Vec3};

use crate::bsdf::{
    Bsdf, BsdfSample, GgxDistribution, Lambertian, MicrofacetConductor, SmoothDielectric, SmoothPlastic,
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
        }
    }

    /// The colour reported in the albedo AOV.
    pub fn albedo(&self, uv: Vec2) -> Vec3 {
        match self {
            Material::Lambertian { albedo } | Material::Plastic { albedo, .. } => albedo.eval(uv),
            Material::Conductor { eta, k, .. } => crate::bsdf::fresnel::fresnel_conductor(1.0, *eta, *k),
            Material::Dielectric { transmittance, .. } => *transmittance,
        }
    }
}

impl Bsdf for SurfaceBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            SurfaceBsdf::Lambertian(b) => b.eval(wo, wi),
            SurfaceBsdf::Conductor(b) => b.eval(wo, wi),
            SurfaceBsdf::Dielectric(b) => b.eval(wo, wi),
            SurfaceBsdf::Plastic(b) => b.eval(wo, wi),
        }
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        match self {
            SurfaceBsdf::Lambertian(b) => b.sample(wo, u, uc),
            SurfaceBsdf::Conductor(b) => b.sample(wo, u, uc),
            SurfaceBsdf::Dielectric(b) => b.sample(wo, u, uc),
            SurfaceBsdf::Plastic(b) => b.sample(wo, u, uc),
        }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            SurfaceBsdf::Lambertian(b) => b.pdf(wo, wi),
            SurfaceBsdf::Conductor(b) => b.pdf(wo, wi),
            SurfaceBsdf::Dielectric(b) => b.pdf(wo, wi),
            SurfaceBsdf::Plastic(b) => b.pdf(wo, wi),
        }
    }

    fn is_specular(&self) -> bool {
        match self {
            SurfaceBsdf::Lambertian(b) => b.is_specular(),
            SurfaceBsdf::Conductor(b) => b.is_specular(),
            SurfaceBsdf::Dielectric(b) => b.is_specular(),
            SurfaceBsdf::Plastic(b) => b.is_specular(),
        }
    }
}
