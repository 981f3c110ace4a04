//! The renderable scene: primitives in a BVH, materials and lights, built with
//! [`SceneBuilder`].

use glam::Vec3;

use crate::geometry::procedural::TriangleMesh;
use crate::geometry::{Bvh, Primitive, Shape};
use crate::light::Light;
use crate::material::Material;
use crate::medium::HomogeneousMedium;

/// Everything the integrator needs.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Geometry (primitives in BVH order).
    pub bvh: Bvh,
    /// Materials, indexed by [`Primitive::material`].
    pub materials: Vec<Material>,
    /// Lights, indexed by [`Primitive::light`] for area lights.
    pub lights: Vec<Light>,
    /// Index of the environment light, if any.
    pub environment: Option<usize>,
    /// Radius of a sphere around the scene's geometry.
    pub radius: f32,
    /// Participating media, indexed by [`Primitive::interior_medium`].
    pub media: Vec<HomogeneousMedium>,
    /// The medium filling the scene (where the camera is), if any.
    pub global_medium: Option<u32>,
    /// Rays may cross media or index-matched boundaries (computed once by the builder).
    has_media: bool,
    /// Some material scatters below its surface.
    has_subsurface: bool,
}

impl Scene {
    /// The same geometry and materials under other lights (point, spot, directional or
    /// environment): for one-light-at-a-time captures and relighting ground truth. Scenes with
    /// emissive shapes cannot be relit, since their emitters are part of the geometry.
    pub fn relit(&self, lights: Vec<Light>) -> Result<Scene, String> {
        if self.bvh.primitives().iter().any(|p| p.light.is_some()) {
            return Err("the scene has emissive shapes; relighting replaces lights, not geometry".into());
        }
        if lights.iter().any(|l| matches!(l, Light::Area { .. })) {
            return Err("area lights need emissive shapes; use point, spot, directional or environment lights".into());
        }
        let environment =
            lights.iter().position(|l| matches!(l, Light::ConstantEnvironment { .. } | Light::EnvironmentMap(_)));
        Ok(Scene { lights, environment, ..self.clone() })
    }

    /// Whether some material scatters light below its surface (only the path tracer follows it).
    pub fn has_subsurface(&self) -> bool {
        self.has_subsurface
    }

    /// Whether rays may cross media or index-matched boundaries (shadow rays then need
    /// transmittance rather than a plain occlusion test).
    pub fn has_media(&self) -> bool {
        self.has_media
    }
}

enum PendingLight {
    Ready(Light),
    Area { radiance: Vec3, two_sided: bool },
}

/// Collects shapes, materials and lights, then builds the BVH and the area lights.
#[derive(Default)]
pub struct SceneBuilder {
    primitives: Vec<Primitive>,
    materials: Vec<Material>,
    lights: Vec<PendingLight>,
    media: Vec<HomogeneousMedium>,
    global_medium: Option<u32>,
}

/// What a shape emits, if anything.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// Radiance.
    pub radiance: Vec3,
    /// Both sides emit.
    pub two_sided: bool,
}

impl SceneBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its index.
    pub fn material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        (self.materials.len() - 1) as u32
    }

    /// Adds a medium and returns its index.
    pub fn medium(&mut self, medium: HomogeneousMedium) -> u32 {
        self.media.push(medium);
        (self.media.len() - 1) as u32
    }

    /// Fills the scene (outside every closed mesh that has its own medium) with a medium.
    pub fn global_medium(&mut self, medium: u32) {
        self.global_medium = Some(medium);
    }

    /// Adds a point, spot, directional or environment light.
    pub fn light(&mut self, light: Light) {
        self.lights.push(PendingLight::Ready(light));
    }

    fn area_light(&mut self, emission: Option<Emission>) -> Option<u32> {
        emission.filter(|e| e.radiance.max_element() > 0.0).map(|e| {
            self.lights.push(PendingLight::Area { radiance: e.radiance, two_sided: e.two_sided });
            (self.lights.len() - 1) as u32
        })
    }

    /// Adds a triangle mesh; an emissive one becomes one area light.
    pub fn mesh(&mut self, mesh: &TriangleMesh, material: u32, emission: Option<Emission>) {
        self.mesh_with_medium(mesh, material, emission, None);
    }

    /// Adds a closed triangle mesh whose inside is filled with `interior` (outward normals).
    pub fn mesh_with_medium(
        &mut self,
        mesh: &TriangleMesh,
        material: u32,
        emission: Option<Emission>,
        interior: Option<u32>,
    ) {
        let light = self.area_light(emission);
        let has_normals = mesh.normals.len() == mesh.positions.len();
        let has_uvs = mesh.uvs.len() == mesh.positions.len();
        for tri in &mesh.indices {
            let p = tri.map(|i| mesh.positions[i as usize]);
            if (p[1] - p[0]).cross(p[2] - p[0]).length_squared() == 0.0 {
                continue; // degenerate: no area, never hit, would break area sampling
            }
            let n = has_normals.then(|| tri.map(|i| mesh.normals[i as usize]));
            let uv = has_uvs.then(|| tri.map(|i| mesh.uvs[i as usize]));
            let shape = Shape::Triangle { p, n, uv };
            self.primitives.push(Primitive {
                shape,
                material,
                light,
                interior_medium: interior,
                exterior_medium: None,
            });
        }
    }

    /// Adds a sphere.
    pub fn sphere(&mut self, centre: Vec3, radius: f32, material: u32, emission: Option<Emission>) {
        self.sphere_with_medium(centre, radius, material, emission, None);
    }

    /// Adds a sphere filled with `interior`.
    pub fn sphere_with_medium(
        &mut self,
        centre: Vec3,
        radius: f32,
        material: u32,
        emission: Option<Emission>,
        interior: Option<u32>,
    ) {
        let light = self.area_light(emission);
        let shape = Shape::Sphere { centre, radius };
        self.primitives.push(Primitive { shape, material, light, interior_medium: interior, exterior_medium: None });
    }

    /// Adds fibres (polylines, root first) of one radius, each cut into its segments.
    pub fn fibres(&mut self, fibres: &[Vec<Vec3>], radius: f32, material: u32, emission: Option<Emission>) {
        let light = self.area_light(emission);
        for points in fibres {
            let segments = points.len().saturating_sub(1).max(1) as f32;
            for (k, w) in points.windows(2).enumerate() {
                if (w[1] - w[0]).length_squared() == 0.0 {
                    continue;
                }
                let u = glam::Vec2::new(k as f32 / segments, (k + 1) as f32 / segments);
                let shape = Shape::Fibre { a: w[0], b: w[1], radius, u };
                self.primitives.push(Primitive {
                    shape,
                    material,
                    light,
                    interior_medium: None,
                    exterior_medium: None,
                });
            }
        }
    }

    /// Builds the scene.
    pub fn build(mut self) -> Scene {
        for p in &mut self.primitives {
            p.exterior_medium = self.global_medium;
        }
        let bvh = Bvh::new(self.primitives);
        let bounds = bvh.bounds();
        let radius = if bounds.min.x.is_finite() { 0.5 * (bounds.max - bounds.min).length() } else { 1.0 };
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); self.lights.len()];
        for (i, p) in bvh.primitives().iter().enumerate() {
            if let Some(l) = p.light {
                members[l as usize].push(i as u32);
            }
        }
        let mut environment = None;
        let lights = self
            .lights
            .into_iter()
            .zip(members)
            .enumerate()
            .map(|(i, (pending, prims))| match pending {
                PendingLight::Ready(light) => {
                    if matches!(light, Light::ConstantEnvironment { .. } | Light::EnvironmentMap(_)) {
                        environment = Some(i);
                    }
                    light
                }
                PendingLight::Area { radiance, two_sided } => Light::area(bvh.primitives(), prims, radiance, two_sided),
            })
            .collect();
        let has_media = !self.media.is_empty() || self.materials.iter().any(|m| matches!(m, Material::Interface));
        let has_subsurface = self.materials.iter().any(|m| matches!(m, Material::Subsurface { .. }));
        Scene {
            has_media,
            has_subsurface,
            bvh,
            materials: self.materials,
            lights,
            environment,
            radius,
            media: self.media,
            global_medium: self.global_medium,
        }
    }
}
