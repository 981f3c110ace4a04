//! The far background of an unbounded capture (sky, distant scenery): Gaussians on a large
//! sphere around the cameras, coloured by the photographs that see them. Structure from motion
//! triangulates nothing in the sky, so without them the sky would be painted by floaters in
//! front of the cameras, which break in every novel view.

use glam::Vec3;
use lucid_scene::dataset::images::ImageSet;
use rayon::prelude::*;

/// How far the sphere lies, in multiples of the farthest camera's distance from the centre:
/// beyond the scenery a capture walks around, where parallax between the cameras is small.
pub const BACKGROUND_DISTANCE: f32 = 50.0;

/// Up to `count` points spread evenly over the sphere of [`BACKGROUND_DISTANCE`] around
/// `centre`, each with the median colour of the training images that see it (points no image
/// sees are left out). The median rather than one image's colour: where a near object hides the
/// far scenery from a few cameras, the others outvote them. Masked pixels give no colour.
pub fn background_points(data: &ImageSet, centre: Vec3, count: usize) -> Vec<(Vec3, [f32; 3])> {
    let reach = data.cameras.iter().map(|c| c.position().distance(centre)).fold(0.0f32, f32::max).max(1e-3);
    let radius = BACKGROUND_DISTANCE * reach;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .into_par_iter()
        .filter_map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f32;
            let p = centre + radius * Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let seen: Vec<[f32; 4]> = data
                .cameras
                .iter()
                .zip(&data.pixels)
                .enumerate()
                .filter_map(|(view, (camera, pixels))| {
                    let k = camera.intrinsics;
                    let uv = camera.project(p)?;
                    let inside = uv.x >= 0.0 && uv.y >= 0.0 && uv.x < k.width as f32 && uv.y < k.height as f32;
                    let pixel = uv.y as usize * k.width as usize + uv.x as usize;
                    (inside && data.keeps(view, pixel)).then(|| pixels[pixel])
                })
                .collect();
            median_colour(seen).map(|c| (p, c))
        })
        .collect()
}

/// The colour of median luminance: one of the colours seen (a per-channel median would mix
/// the sky's blue with a wall's red).
fn median_colour(mut seen: Vec<[f32; 4]>) -> Option<[f32; 3]> {
    let luminance = |c: &[f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    seen.sort_by(|a, b| luminance(a).total_cmp(&luminance(b)));
    seen.get(seen.len() / 2).map(|c| [c[0], c[1], c[2]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use lucid_scene::{Intrinsics, PinholeCamera, look_at};

    #[test]
    fn points_take_the_colour_of_the_image_that_sees_them() {
        let camera = PinholeCamera::new(
            Intrinsics::from_fov_x(40, 30, 1.2),
            look_at(Vec3::new(2.0, 0.0, 0.0), Vec3::ZERO, Vec3::Z),
        );
        // The left half of the image red, the right half blue.
        let pixels =
            (0..30 * 40).map(|i| if i % 40 < 20 { [1.0, 0.0, 0.0, 1.0] } else { [0.0, 0.0, 1.0, 1.0] }).collect();
        let data = ImageSet { cameras: vec![camera], pixels: vec![pixels], lenses: vec![None], ..Default::default() };
        assert!(data.is_opaque());
        let points = background_points(&data, Vec3::ZERO, 4000);
        // A 1.2 rad by 0.9 rad view sees about 8% of the sphere.
        assert!((200..500).contains(&points.len()), "{}", points.len());
        for (p, c) in &points {
            assert!((p.length() - 100.0).abs() < 1e-2);
            let uv = camera.project(*p).unwrap();
            assert_eq!(*c, if uv.x < 20.0 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] });
        }
    }

    /// Five cameras at one place see the same far points: two the sky, one a near wall, two a
    /// magenta blot. Masked out, the blots give no colour and the sky outvotes the wall;
    /// unmasked, the blots and the wall outvote the sky.
    #[test]
    fn the_majority_of_unmasked_views_colours_the_sphere() {
        let camera = PinholeCamera::new(
            Intrinsics::from_fov_x(20, 20, 0.5),
            look_at(Vec3::ZERO, Vec3::new(0.0, 10.0, 0.0), Vec3::Z),
        );
        let (sky, wall, blot) = ([0.2, 0.4, 0.9, 1.0], [0.8, 0.3, 0.1, 1.0], [1.0, 0.0, 1.0, 1.0]);
        let mut data = ImageSet {
            cameras: vec![camera; 5],
            pixels: [sky, sky, wall, blot, blot].map(|c| vec![c; 400]).to_vec(),
            lenses: vec![None; 5],
            masks: vec![None, None, None, Some(vec![false; 400]), Some(vec![false; 400])],
            ..Default::default()
        };
        let colours = |data: &ImageSet| -> Vec<[f32; 3]> {
            background_points(data, Vec3::ZERO, 20000).into_iter().map(|(_, c)| c).collect()
        };
        let masked = colours(&data);
        assert!(masked.len() > 10);
        assert!(masked.iter().all(|c| *c == [0.2, 0.4, 0.9]), "the sky");
        data.masks.clear();
        assert!(colours(&data).iter().all(|c| *c == [0.8, 0.3, 0.1]), "the wall, the median of five");
    }
}
