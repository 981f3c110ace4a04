//! A procedurally generated set of SVBRDF maps — base colour, roughness, metallic and a
//! tangent-space normal map — for tests and scenes that need spatially varying materials
//! without image files: glazed tiles in a rough grout, every few tiles metal, bevelled edges.
//! The maps agree with each other (one layout), and are the same for every run.

use glam::Vec3;
use lucid_image::Image;

use crate::sampling::mix;

/// Which map of the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileMap {
    /// Base colour (albedo, sRGB-free linear values).
    BaseColor,
    /// Roughness in the red channel.
    Roughness,
    /// Metallic in the red channel.
    Metallic,
    /// Tangent-space normal, encoded as (n + 1)/2.
    Normal,
}

/// Tiles per texture repeat along each axis.
const TILES: u32 = 4;
/// Grout width and bevel width, as fractions of a tile.
const GROUT: f32 = 0.06;
const BEVEL: f32 = 0.08;

fn tile_hash(x: u32, y: u32) -> u64 {
    mix(((x as u64) << 32) | y as u64 | 0x5449_4C45_0000_0000)
}

/// Height of the tile surface at texture coordinates (u, v) ∈ [0, 1)²: 0 in the grout, 1 on a
/// tile's face, a smooth bevel between.
fn height(u: f32, v: f32) -> f32 {
    let (fu, fv) = ((u * TILES as f32).fract(), (v * TILES as f32).fract());
    let edge = fu.min(1.0 - fu).min(fv).min(1.0 - fv);
    let t = ((edge - GROUT / 2.0) / BEVEL).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The `size × size` map `which` of the tile set.
pub fn tiles(which: TileMap, size: usize) -> Image {
    let mut pixels = Vec::with_capacity(size * size);
    let step = 1.0 / size as f32;
    for j in 0..size {
        for i in 0..size {
            let (u, v) = ((i as f32 + 0.5) * step, (j as f32 + 0.5) * step);
            let (tx, ty) = ((u * TILES as f32) as u32, (v * TILES as f32) as u32);
            let h = tile_hash(tx, ty);
            let on_tile = height(u, v) > 0.0;
            let metal = on_tile && h.is_multiple_of(5);
            let shade = ((h >> 8) & 0xff) as f32 / 255.0;
            let value = match which {
                TileMap::BaseColor => {
                    if !on_tile {
                        Vec3::splat(0.35)
                    } else if metal {
                        Vec3::new(0.95, 0.78, 0.35)
                    } else {
                        Vec3::new(0.15, 0.35, 0.6).lerp(Vec3::new(0.75, 0.72, 0.65), shade)
                    }
                }
                TileMap::Roughness => Vec3::splat(if on_tile { 0.15 + 0.25 * shade } else { 0.9 }),
                TileMap::Metallic => Vec3::splat(if metal { 1.0 } else { 0.0 }),
                TileMap::Normal => {
                    // Central differences of the height field, scaled to a bevel of 45° at most.
                    let (du, dv) = (
                        (height(u + step, v) - height(u - step, v)) / (2.0 * step),
                        (height(u, v + step) - height(u, v - step)) / (2.0 * step),
                    );
                    let slope = BEVEL / TILES as f32 * 0.5;
                    let n = Vec3::new(-du * slope, -dv * slope, 1.0).normalize();
                    (n + Vec3::ONE) * 0.5
                }
            };
            pixels.push(value.extend(1.0).to_array());
        }
    }
    Image::from_pixels(size, size, pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_maps_share_one_layout_and_hold_valid_values() {
        let size = 128;
        let [albedo, rough, metal, normal] =
            [TileMap::BaseColor, TileMap::Roughness, TileMap::Metallic, TileMap::Normal].map(|m| tiles(m, size));
        let (mut tiles_seen, mut metal_seen, mut tilted) = (0, 0, 0);
        for (k, ((a, r), (m, n))) in
            albedo.pixels().iter().zip(rough.pixels()).zip(metal.pixels().iter().zip(normal.pixels())).enumerate()
        {
            assert!(a[..3].iter().chain(&r[..1]).chain(&m[..1]).all(|x| (0.0..=1.0).contains(x)), "pixel {k}");
            let n = Vec3::new(n[0], n[1], n[2]) * 2.0 - Vec3::ONE;
            assert!((n.length() - 1.0).abs() < 1e-4 && n.z > 0.7, "pixel {k}: normal {n}");
            // Grout is rough, flat-shaded and never metal; metal tiles are gold.
            if r[0] > 0.8 {
                assert_eq!(m[0], 0.0);
            } else {
                tiles_seen += 1;
            }
            if m[0] == 1.0 {
                metal_seen += 1;
                assert!(a[0] > a[2]);
            }
            tilted += usize::from(n.z < 0.999);
        }
        assert!(tiles_seen > size * size / 2 && metal_seen > 0 && tilted > 0);
        assert_eq!(tiles(TileMap::Normal, 16).pixels(), tiles(TileMap::Normal, 16).pixels());
    }
}
