//! A small scene shared by material tests and benchmarks: one object of material `ball` on a
//! checkered floor under a sun and a sky. Callers add `[materials.ball]`.

/// The object as a sphere of radius 0.6 resting on the floor.
pub const SPHERE: &str = "type = \"sphere\"\nmaterial = \"ball\"\nradius = 0.6\ntranslate = [0.0, 0.0, 0.6]";

/// The scene around `object` (the lines of its `[[shapes]]` entry), seen at `width`×`height`
/// with paths of at most `max_depth` segments.
pub fn object_on_floor(object: &str, width: u32, height: u32, max_depth: u32) -> String {
    format!(
        r#"
[camera]
position = [0.0, -3.0, 1.2]
look_at = [0.0, 0.0, 0.3]
up = [0.0, 0.0, 1.0]
fov = 40.0
width = {width}
height = {height}

[integrator]
max_depth = {max_depth}

[materials.floor]
type = "lambertian"
albedo = {{ a = [0.7, 0.7, 0.7], b = [0.2, 0.2, 0.2], scale = 6.0 }}

[[shapes]]
type = "quad"
material = "floor"
scale = [3.0, 3.0, 1.0]

[[shapes]]
{object}

[[lights]]
type = "directional"
direction = [-0.4, -0.6, 0.7]
irradiance = [3.0, 2.9, 2.7]

[[lights]]
type = "environment"
radiance = [0.35, 0.42, 0.55]
"#
    )
}
