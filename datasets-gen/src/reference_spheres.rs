//! Reference spheres for light-stage captures: chrome balls whose highlights give each
//! light's direction (`lucid lightstage calibrate`) and diffuse balls whose shading gives a
//! light's strength. They are added to any scene as spheres of two reserved materials and
//! recorded in `dataset.toml`, so that the tools know where they are.

use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// What a reference sphere is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SphereKind {
    /// A near-mirror metal: a directional light shows as a small highlight.
    Chrome,
    /// A white Lambertian ball (albedo [`DIFFUSE_ALBEDO`]).
    Diffuse,
}

/// A reference sphere in world space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceSphere {
    /// Its material.
    pub kind: SphereKind,
    /// Centre.
    pub centre: [f32; 3],
    /// Radius.
    pub radius: f32,
}

/// Where spheres go that were given without a place: the corners of a square around the
/// object, low and inside the NeRF-synthetic `[-1.5, 1.5]³` box, so that orbit cameras at the
/// default radius and field of view (4, 40°) see most of them whole from every side.
pub const DEFAULT_PLACES: [[f32; 3]; 4] =
    [[0.95, 0.95, -0.75], [-0.95, 0.95, -0.75], [-0.95, -0.95, -0.75], [0.95, -0.95, -0.75]];

/// Radius of spheres given without one: about 16 pixels across at 256² from the orbit.
pub const DEFAULT_RADIUS: f32 = 0.18;

/// GGX roughness of the chrome (α = 0.09): a mirror would reflect a directional light as a
/// Dirac delta that no camera ray finds, and a lobe narrower than a pixel puts the highlight
/// at a pixel centre (at 256² a pixel of a default sphere spans 6.5° of reflected
/// directions). At 0.1 a test ball's lights came out 0.4–2.5° off, at 0.3 within 0.8°, at
/// 0.45 up to 2.5° off again (the lobe runs into the silhouette).
pub const CHROME_ROUGHNESS: f32 = 0.3;

/// Albedo of the diffuse spheres.
pub const DIFFUSE_ALBEDO: f32 = 0.8;

/// The reserved material names.
pub const CHROME_MATERIAL: &str = "lucid_reference_chrome";
/// See [`CHROME_MATERIAL`].
pub const DIFFUSE_MATERIAL: &str = "lucid_reference_diffuse";

/// A sphere as written on the command line: `chrome` or `diffuse`, optionally followed by
/// `@x,y,z` and `,r`; without a place, the next free default place is filled in by
/// [`place_spheres`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereArg {
    /// Material.
    pub kind: SphereKind,
    /// Centre, if given.
    pub centre: Option<[f32; 3]>,
    /// Radius, if given.
    pub radius: Option<f32>,
}

impl FromStr for SphereArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (kind, place) = s.split_once('@').map_or((s, None), |(k, p)| (k, Some(p)));
        let kind = match kind.trim() {
            "chrome" => SphereKind::Chrome,
            "diffuse" => SphereKind::Diffuse,
            other => return Err(format!("{other:?} is not a sphere kind (chrome or diffuse)")),
        };
        let Some(place) = place else { return Ok(Self { kind, centre: None, radius: None }) };
        let numbers: Vec<f32> = place
            .split(',')
            .map(|x| x.trim().parse::<f32>().map_err(|_| format!("{x:?} in {s:?} is not a number")))
            .collect::<Result<_, _>>()?;
        if numbers.iter().any(|x| !x.is_finite()) {
            return Err(format!("{s:?}: numbers must be finite"));
        }
        match numbers[..] {
            [x, y, z] => Ok(Self { kind, centre: Some([x, y, z]), radius: None }),
            [x, y, z, r] if r > 0.0 => Ok(Self { kind, centre: Some([x, y, z]), radius: Some(r) }),
            _ => Err(format!("{s:?}: give KIND@x,y,z or KIND@x,y,z,r with r > 0")),
        }
    }
}

/// The spheres of `args`, those without a place at the default places in turn (skipping
/// places that a sphere given a place would overlap); an error if too few places are left or
/// two spheres overlap.
pub fn place_spheres(args: &[SphereArg]) -> Result<Vec<ReferenceSphere>, String> {
    let placed: Vec<(glam::Vec3, f32)> = args
        .iter()
        .filter_map(|a| a.centre.map(|c| (glam::Vec3::from(c), a.radius.unwrap_or(DEFAULT_RADIUS))))
        .collect();
    let mut free = DEFAULT_PLACES
        .iter()
        .filter(|p| placed.iter().all(|(c, r)| c.distance(glam::Vec3::from(**p)) >= r + DEFAULT_RADIUS));
    let spheres: Vec<ReferenceSphere> = args
        .iter()
        .map(|a| {
            let centre = match a.centre {
                Some(c) => c,
                None => {
                    *free.next().ok_or("more spheres without a place than free default places (give KIND@x,y,z)")?
                }
            };
            Ok(ReferenceSphere { kind: a.kind, centre, radius: a.radius.unwrap_or(DEFAULT_RADIUS) })
        })
        .collect::<Result<_, String>>()?;
    for (i, a) in spheres.iter().enumerate() {
        for b in &spheres[i + 1..] {
            let d = glam::Vec3::from(a.centre).distance(glam::Vec3::from(b.centre));
            if d < a.radius + b.radius {
                return Err(format!("reference spheres at {:?} and {:?} overlap", a.centre, b.centre));
            }
        }
    }
    Ok(spheres)
}

/// `scene` (a scene file's text) with the spheres and their materials added.
pub fn add_to_scene(scene: &str, spheres: &[ReferenceSphere]) -> Result<String, String> {
    let mut table: toml::Table = scene.parse().map_err(|e: toml::de::Error| e.to_string())?;
    let materials = table
        .entry("materials")
        .or_insert_with(|| toml::Value::Table(Default::default()))
        .as_table_mut()
        .ok_or("`materials` is not a table")?;
    for name in [CHROME_MATERIAL, DIFFUSE_MATERIAL] {
        if materials.contains_key(name) {
            return Err(format!("the scene already has a material named {name} (reserved for reference spheres)"));
        }
    }
    let numbers = |v: &[f32]| toml::Value::Array(v.iter().map(|&x| toml::Value::Float(x as f64)).collect());
    let mut chrome = toml::Table::new();
    chrome.insert("type".into(), "conductor".into());
    chrome.insert("eta".into(), numbers(&[1.5; 3]));
    chrome.insert("k".into(), numbers(&[7.0; 3]));
    chrome.insert("roughness".into(), toml::Value::Float(CHROME_ROUGHNESS as f64));
    let mut diffuse = toml::Table::new();
    diffuse.insert("type".into(), "lambertian".into());
    diffuse.insert("albedo".into(), numbers(&[DIFFUSE_ALBEDO; 3]));
    materials.insert(CHROME_MATERIAL.into(), toml::Value::Table(chrome));
    materials.insert(DIFFUSE_MATERIAL.into(), toml::Value::Table(diffuse));
    let shapes = table
        .entry("shapes")
        .or_insert_with(|| toml::Value::Array(Vec::new()))
        .as_array_mut()
        .ok_or("`shapes` is not an array of tables")?;
    for s in spheres {
        let mut shape = toml::Table::new();
        shape.insert("type".into(), "sphere".into());
        let material = match s.kind {
            SphereKind::Chrome => CHROME_MATERIAL,
            SphereKind::Diffuse => DIFFUSE_MATERIAL,
        };
        shape.insert("material".into(), material.into());
        shape.insert("radius".into(), toml::Value::Float(s.radius as f64));
        shape.insert("translate".into(), numbers(&s.centre));
        shapes.push(toml::Value::Table(shape));
    }
    toml::to_string(&table).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests;
