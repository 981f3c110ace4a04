use glam::{Vec2, Vec3};

use super::*;
use crate::sampling::{Rng, uniform_sphere};

/// A 5 × 3 projector at the origin looking along +y (up +z), a 50° field, pixels of
/// different intensities (one dark).
fn projector() -> Projector {
    let pixels = (0..15).map(|k| Vec3::new(k as f32 * 0.1, 1.0, 0.5) * if k == 7 { 0.0 } else { 1.0 }).collect();
    Projector::new(Vec3::ZERO, Vec3::Y, Vec3::Z, 50f32.to_radians(), 5, 3, pixels).unwrap()
}

#[test]
fn pixel_solid_angles_sum_to_the_frustum_and_match_a_count_of_directions() {
    let p = projector();
    let (tx, ty) = (p.half.x, p.half.y);
    let frustum = 4.0 * (tx * ty / (1.0 + tx * tx + ty * ty).sqrt()).atan();
    let sum: f32 = (0..5).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| p.pixel_solid_angle(i, j)).sum();
    assert!((sum - frustum).abs() < 1e-5 * frustum, "{sum} vs {frustum}");
    // A corner pixel's solid angle, by counting uniform directions that fall in it.
    let mut rng = Rng::new(3, 1);
    let n = 2_000_000;
    let hits =
        (0..n).filter(|_| p.pixel_towards(uniform_sphere(rng.uniform2())).is_some_and(|(ij, _)| ij == (4, 0))).count();
    let counted = 4.0 * PI * hits as f32 / n as f32;
    let exact = p.pixel_solid_angle(4, 0);
    assert!((counted - exact).abs() < 0.02 * exact, "{counted} vs {exact}");
}

#[test]
fn intensity_is_the_pixel_a_direction_passes_through_and_zero_outside() {
    let p = projector();
    // Pixel (0, 0) is the top left: left of the axis (−x, as right = forward × up = +x) and above it.
    for (i, j) in [(0usize, 0usize), (4, 0), (2, 1), (1, 2)] {
        let (a, b) = p.pixel_rect(i, j);
        let c = 0.5 * (a + b);
        let w = (c.x * p.right + c.y * p.up + p.forward).normalize();
        assert_eq!(p.pixel_towards(w).map(|(ij, _)| ij), Some((i, j)));
        assert_eq!(p.intensity(w), p.pixels[j * 5 + i]);
    }
    assert_eq!(p.right, Vec3::X);
    let (top_left, _) = p.pixel_rect(0, 0);
    assert!(top_left.x < 0.0);
    assert_eq!(p.intensity(-Vec3::Y), Vec3::ZERO);
    assert_eq!(p.intensity(Vec3::new(0.0, 1.0, 1.0).normalize()), Vec3::ZERO, "above a 50° × 31° frustum");
    // As a light: a point one metre out through pixel (3, 1) receives its intensity over d².
    let (a, b) = p.pixel_rect(3, 1);
    let c = 0.5 * (a + b);
    let point = 2.0 * (c.x * p.right + c.y * p.up + p.forward).normalize();
    let light = crate::light::Light::Projector(Box::new(p.clone()));
    let sample = light.sample(point, Vec2::ZERO).unwrap();
    assert!((sample.li - p.pixels[8] / 4.0).abs().max_element() < 1e-6 && sample.delta);
    assert!((light.power(1.0) - p.power()).abs().max_element() == 0.0);
}

#[test]
fn emitted_directions_have_the_reported_density_and_estimate_the_power() {
    let p = projector();
    let mut rng = Rng::new(5, 2);
    let n = 400_000;
    let mut sum = glam::DVec3::ZERO;
    for _ in 0..n {
        let (w, le, pdf) = p.sample_emission(rng.uniform2()).unwrap();
        assert!((pdf - p.emission_pdf(w)).abs() <= 1e-3 * pdf);
        sum += (le / pdf).as_dvec3();
    }
    let estimate = sum / n as f64;
    let power = p.power().as_dvec3();
    assert!((estimate - power).abs().max_element() < 0.005 * power.max_element(), "{estimate} vs {power}");
    // A projector that lights nothing emits nothing.
    assert!(p.with_pixels(vec![Vec3::ZERO; 15]).unwrap().sample_emission(Vec2::splat(0.5)).is_none());
}
