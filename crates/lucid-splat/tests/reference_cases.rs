//! Reference cases for the rasterizer: a single Gaussian's footprint against the analytic 2D
//! Gaussian, and one cloud rendered at two resolutions.

use glam::Vec3;
use lucid_image::Image;
use lucid_image::metrics::psnr;
use lucid_scene::Intrinsics;
use lucid_scene::camera::{PinholeCamera, look_at};
use lucid_splat::{RenderSettings, SplatCamera, SplatCloud, render};

fn camera(width: u32, height: u32) -> SplatCamera {
    let k = Intrinsics::from_fov_x(width, height, 0.6);
    SplatCamera::from_pinhole(&PinholeCamera::new(k, look_at(Vec3::new(0.0, -3.0, 0.0), Vec3::ZERO, Vec3::Z)))
}

/// An isotropic Gaussian of std σ at depth d on the optical axis projects to a circular
/// Gaussian of variance (fσ/d)² + 0.3 px² centred on the principal point; over a black
/// background with colour 1 the image is exactly `opacity · exp(−r²/2s²)` wherever that is
/// at least 1/255.
#[test]
fn single_gaussian_footprint_is_the_analytic_2d_gaussian() {
    let cam = camera(64, 48);
    let (sigma, opacity) = (0.05, 0.8);
    let mut cloud = SplatCloud::default();
    cloud.push(Vec3::ZERO, sigma, opacity, [1.0, 1.0, 1.0]);
    let settings = RenderSettings { background: [0.0; 3], ..Default::default() };
    let (image, _) = render(&cloud.params(), &cam, &settings);
    let s2 = (cam.fx * sigma / 3.0).powi(2) + settings.low_pass;
    let mut checked = 0;
    for y in 0..48 {
        for x in 0..64 {
            let (dx, dy) = (x as f32 + 0.5 - cam.cx, y as f32 + 0.5 - cam.cy);
            let want = opacity * (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
            let got = &image[4 * (y * 64 + x)..4 * (y * 64 + x) + 4];
            if want >= 1.05 / 255.0 && (dx * dx + dy * dy) < 9.0 * s2 {
                for (c, v) in got.iter().enumerate() {
                    assert!((v - want).abs() < 1e-5, "pixel ({x}, {y}) channel {c}: {v} vs {want}");
                }
                checked += 1;
            } else if want < 0.95 / 255.0 {
                assert_eq!(got[3], 0.0, "pixel ({x}, {y}) should be untouched");
            }
        }
    }
    assert!(checked > 50, "only {checked} pixels inside the footprint");
}

/// A long, thin splat lying diagonally on screen: its screen box, the rasterizer's 8-pixel
/// runs and the lane masks must lose no pixel above the blend threshold and touch none below
/// it; the image equals `opacity · exp(power)` from the projected conic, computed here for
/// every pixel.
#[test]
fn diagonal_anisotropic_splat_is_complete() {
    let cam = camera(96, 80);
    let mut cloud = SplatCloud::default();
    cloud.push(Vec3::ZERO, 0.02, 0.3, [1.0, 1.0, 1.0]);
    cloud.log_scales[0] = 0.35f32.ln();
    // 35° about the viewing axis (y): the long x axis turns towards z on screen.
    let half = 35f32.to_radians() / 2.0;
    cloud.rotations.copy_from_slice(&[half.cos(), 0.0, half.sin(), 0.0]);
    let settings = RenderSettings { background: [0.0; 3], ..Default::default() };
    let params = cloud.params();
    let s = lucid_splat::project::project_one(&params, 0, &cam, &settings);
    assert!(s.radius > 0.0);
    let (image, _) = render(&params, &cam, &settings);
    let [a, b, c] = s.conic;
    let (mut inside, mut checked) = (0, 0);
    for y in 0..80 {
        for x in 0..96 {
            let (dx, dy) = (x as f32 + 0.5 - s.mean.x, y as f32 + 0.5 - s.mean.y);
            let want = s.opacity * (-0.5 * (a * dx * dx + c * dy * dy) - b * dx * dy).exp();
            let got = image[4 * (y * 96 + x) + 3];
            if want >= 1.02 / 255.0 {
                assert!((got - want).abs() < 1e-5, "pixel ({x}, {y}): {got} vs {want}");
                inside += 1;
            } else if want < 0.98 / 255.0 {
                assert_eq!(got, 0.0, "pixel ({x}, {y}) should be untouched");
            }
            checked += 1;
        }
    }
    let (w, h) = (2.0 * s.half_extent.x, 2.0 * s.half_extent.y);
    println!("{inside} pixels inside the splat, bounding box {w:.0}x{h:.0}, {checked} checked");
    assert!(inside > 150 && (inside as f32) < 0.5 * w * h, "a thin diagonal splat: {inside} of {w}x{h}");
}

fn cloud() -> SplatCloud {
    let mut c = SplatCloud::default();
    let mut rng = lucid_scene::sampling::Rng::new(7, 1);
    for _ in 0..300 {
        let p = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 1.2;
        c.push(
            p,
            0.02 + 0.05 * rng.uniform(),
            0.2 + 0.7 * rng.uniform(),
            [rng.uniform(), rng.uniform(), rng.uniform()],
        );
    }
    for (k, q) in c.rotations.chunks_exact_mut(4).enumerate() {
        q[1 + k % 3] = 0.5;
    }
    for (k, s) in c.log_scales.iter_mut().enumerate() {
        *s += 0.4 * ((k % 5) as f32 - 2.0) / 2.0;
    }
    c
}

fn to_image(v: &[f32], w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let p = &v[4 * (y * w + x)..4 * (y * w + x) + 4];
        [p[0], p[1], p[2], 1.0]
    })
}

/// Rendering at 2× and averaging 2×2 blocks agrees with rendering at 1× (the screen-space
/// low-pass is in pixels, so the two differ slightly at the smallest splats).
#[test]
fn two_resolutions_agree_after_downsampling() {
    let c = cloud();
    let settings = RenderSettings::default();
    let (small, _) = render(&c.params(), &camera(80, 60), &settings);
    let (big, _) = render(&c.params(), &camera(160, 120), &settings);
    let mut down = vec![0.0f32; 80 * 60 * 4];
    for y in 0..60 {
        for x in 0..80 {
            for ch in 0..4 {
                let mut s = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    s += big[4 * ((2 * y + dy) * 160 + 2 * x + dx) + ch];
                }
                down[4 * (y * 80 + x) + ch] = s / 4.0;
            }
        }
    }
    let p = psnr(&to_image(&small, 80, 60), &to_image(&down, 80, 60), None).unwrap();
    println!("PSNR 1x vs 2x downsampled: {p:.2} dB");
    assert!(p > 30.0, "{p} dB");
}

/// Many overlapping anisotropic splats, composited per pixel here the plain way — every
/// splat in depth order, its weight from the projected conic wherever the pixel lies in its
/// screen box and the weight reaches the blend threshold, stopping where the transmittance
/// would fall below 1e-4 — equal the tile rasterizer's image, which skips rows, runs and
/// lanes the splat cannot reach.
#[test]
fn tile_rasterizer_equals_per_pixel_compositing() {
    let (w, h) = (72usize, 56usize);
    let cam = camera(w as u32, h as u32);
    let mut c = cloud();
    for o in c.opacities.iter_mut().step_by(3) {
        *o += 3.0;
    }
    let settings = RenderSettings::default();
    let params = c.params();
    let (image, _) = render(&params, &cam, &settings);
    let mut splats: Vec<_> = (0..c.len())
        .map(|i| lucid_splat::project::project_one(&params, i, &cam, &settings))
        .filter(|s| s.radius > 0.0)
        .collect();
    splats.sort_by(|a, b| a.depth.total_cmp(&b.depth));
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let (mut t, mut rgb) = (1.0f32, [0.0f32; 3]);
            for s in &splats {
                let (dx, dy) = (px - s.mean.x, py - s.mean.y);
                if dx.abs() > s.half_extent.x || dy.abs() > s.half_extent.y {
                    continue;
                }
                let [a, b, cc] = s.conic;
                let power = -0.5 * (a * dx * dx + cc * dy * dy) - b * dx * dy;
                let alpha = (s.opacity * lucid_splat::blend::fast_exp(power)).min(0.99);
                if alpha < settings.min_alpha {
                    continue;
                }
                if t * (1.0 - alpha) < 1e-4 {
                    break;
                }
                for (v, col) in rgb.iter_mut().zip(s.colour) {
                    *v += col * alpha * t;
                }
                t *= 1.0 - alpha;
            }
            let got = &image[4 * (y * w + x)..4 * (y * w + x) + 4];
            for ch in 0..3 {
                worst = worst.max((got[ch] - (rgb[ch] + t * settings.background[ch])).abs());
            }
            worst = worst.max((got[3] - (1.0 - t)).abs());
        }
    }
    assert!(worst < 2e-5, "largest difference {worst}");
}
