//! Debevec's median-cut light extraction (2005): the lat-long map is split recursively into
//! regions of equal energy (always cutting the region with the most energy across its longer
//! side, the width measured at its latitude), and each region becomes one directional light
//! at its energy centroid carrying the region's whole `∫ L dω` per channel. The lights' total
//! equals the map's integral exactly.

use glam::Vec3;
use lucid_image::Image;
use lucid_image::color::luminance;

use crate::envmap::{pixel_direction, pixel_solid_angle};

/// One extracted light: its direction and `∫ L dω` over its region (the irradiance it gives
/// a surface facing it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutLight {
    /// Unit direction towards the light.
    pub direction: Vec3,
    /// Per-channel integral of radiance over the region.
    pub energy: [f32; 3],
    /// The region `[x0, x1) × [y0, y1)` of the map.
    pub region: [usize; 4],
}

/// `n` lights from the map (`n ≥ 1`; fewer when the map cannot be split further).
pub fn median_cut(map: &Image, n: usize) -> Vec<CutLight> {
    let (w, h) = map.dimensions();
    // Per pixel: luminance × solid angle, the energy the cuts balance.
    let energy: Vec<f64> = (0..w * h)
        .map(|i| {
            let p = map.pixels()[i];
            luminance([p[0], p[1], p[2]]).max(0.0) as f64 * pixel_solid_angle(i / w, w, h) as f64
        })
        .collect();
    let sum = |r: [usize; 4]| -> f64 {
        let mut s = 0.0;
        for y in r[2]..r[3] {
            for x in r[0]..r[1] {
                s += energy[y * w + x];
            }
        }
        s
    };
    let mut regions = vec![[0, w, 0, h]];
    while regions.len() < n.max(1) {
        // The splittable region with the most energy.
        let Some((k, _)) = regions
            .iter()
            .enumerate()
            .filter(|(_, r)| r[1] - r[0] > 1 || r[3] - r[2] > 1)
            .map(|(k, r)| (k, sum(*r)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let r = regions.swap_remove(k);
        // Width in radians at the region's middle latitude, against its height.
        let theta = ((r[2] + r[3]) as f32 * 0.5 / h as f32) * std::f32::consts::PI;
        let width = (r[1] - r[0]) as f32 / w as f32 * std::f32::consts::TAU * theta.sin();
        let height = (r[3] - r[2]) as f32 / h as f32 * std::f32::consts::PI;
        let across_x = (width >= height && r[1] - r[0] > 1) || r[3] - r[2] <= 1;
        let total = sum(r);
        let (lo, hi) = if across_x { (r[0], r[1]) } else { (r[2], r[3]) };
        // The cut where the cumulative energy passes half (at least one pixel each side).
        let mut acc = 0.0;
        let mut cut = lo + 1;
        for c in lo..hi - 1 {
            let slice = if across_x { sum([c, c + 1, r[2], r[3]]) } else { sum([r[0], r[1], c, c + 1]) };
            acc += slice;
            cut = c + 1;
            if acc >= 0.5 * total {
                break;
            }
        }
        if across_x {
            regions.push([r[0], cut, r[2], r[3]]);
            regions.push([cut, r[1], r[2], r[3]]);
        } else {
            regions.push([r[0], r[1], r[2], cut]);
            regions.push([r[0], r[1], cut, r[3]]);
        }
    }
    regions
        .into_iter()
        .map(|r| {
            let mut e = [0.0f64; 3];
            let mut centroid = Vec3::ZERO;
            for y in r[2]..r[3] {
                let omega = pixel_solid_angle(y, w, h) as f64;
                for x in r[0]..r[1] {
                    let p = map.get(x, y);
                    for c in 0..3 {
                        e[c] += p[c] as f64 * omega;
                    }
                    centroid += pixel_direction(x, y, w, h) * (energy[y * w + x] as f32 + 1e-12);
                }
            }
            CutLight { direction: centroid.normalize_or(Vec3::Z), energy: e.map(|v| v as f32), region: r }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_cut_preserves_energy_and_finds_the_sun() {
        let sun = Vec3::new(0.5, 0.3, 0.8).normalize();
        let map = Image::from_fn(128, 64, |x, y| {
            let d = pixel_direction(x, y, 128, 64);
            let l = 0.2 + if d.dot(sun) > 0.995 { 200.0 } else { 0.0 };
            [l, l * 0.9, l * 0.8, 1.0]
        });
        let total = crate::envmap::integral(&map);
        for n in [1, 7, 16, 64] {
            let lights = median_cut(&map, n);
            assert_eq!(lights.len(), n);
            for (c, want) in total.iter().enumerate() {
                let sum: f64 = lights.iter().map(|l| l.energy[c] as f64).sum();
                assert!((sum - want).abs() / want < 1e-4, "{n} lights, channel {c}: {sum} vs {want}");
            }
        }
        // With enough lights the brightest one sits on the sun.
        let lights = median_cut(&map, 16);
        let brightest = lights.iter().max_by(|a, b| a.energy[0].total_cmp(&b.energy[0])).unwrap();
        assert!(brightest.direction.dot(sun) > 0.99, "{:?}", brightest.direction);
    }
}
