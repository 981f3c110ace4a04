//! The far background of an unbounded capture (sky, distant scenery): Gaussians on a large
//! sphere around the cameras, coloured by the photographs that see them. Structure from motion
//! triangulates nothing in the sky, so without them the sky would be painted by floaters in
//! front of the cameras, which break in every novel view.

use glam::Vec3;
use lucid_scene::dataset::images::ImageSet;

/// How far the sphere lies, in multiples of the farthest camera's distance from the centre:
/// beyond the scenery a capture walks around, where parallax between the cameras is small.
pub const BACKGROUND_DISTANCE: f32 = 50.0;

/// Up to `count` points spread evenly over the sphere of [`BACKGROUND_DISTANCE`] around
/// `centre`, each with the colour of the first training image that sees it (points no image
/// sees are left out).
pub fn background_points(data: &ImageSet, centre: Vec3, count: usize) -> Vec<(Vec3, [f32; 3])> {
    let reach = data.cameras.iter().map(|c| c.position().distance(centre)).fold(0.0f32, f32::max).max(1e-3);
    let radius = BACKGROUND_DISTANCE * reach;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .filter_map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f32;
            let p = centre + radius * Vec3::new(r * phi.cos(), r * phi.sin(), z);
            data.cameras.iter().zip(&data.pixels).find_map(|(camera, pixels)| {
                let k = camera.intrinsics;
                let uv = camera.project(p)?;
                let inside = uv.x >= 0.0 && uv.y >= 0.0 && uv.x < k.width as f32 && uv.y < k.height as f32;
                inside.then(|| {
                    let c = pixels[uv.y as usize * k.width as usize + uv.x as usize];
                    (p, [c[0], c[1], c[2]])
                })
            })
        })
        .collect()
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
}
