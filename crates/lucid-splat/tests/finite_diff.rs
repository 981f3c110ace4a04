//! The rasterizer's backward against central finite differences, for every parameter kind.

use glam::Vec3;
use lucid_scene::Intrinsics;
use lucid_scene::camera::{PinholeCamera, look_at};
use lucid_splat::project::SH_REST;
use lucid_splat::{RenderSettings, SplatCamera, SplatCloud, render, render_backward};

fn pseudo(i: usize) -> f32 {
    // A fixed scramble to [-1, 1): reproducible without a generator.
    let x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17) ^ 0xD1B5_4A32_D192_ED03;
    (x >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

/// A small deterministic cloud: a few overlapping splats in front of the camera, one big splat
/// whose centre lies beyond the Jacobian's clamp to the left.
fn cloud() -> SplatCloud {
    let centres = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.15, 0.1, 0.05),
        Vec3::new(-0.2, -0.05, 0.1),
        Vec3::new(0.05, -0.15, -0.1),
        Vec3::new(-0.1, 0.2, -0.05),
        Vec3::new(0.0, -2.6, 0.0),
    ];
    let n = centres.len();
    let mut c = SplatCloud {
        means: centres.iter().flat_map(|v| v.to_array()).collect(),
        log_scales: (0..3 * n).map(|k| -1.9 + 0.3 * pseudo(k)).collect(),
        rotations: (0..4 * n).map(|k| if k % 4 == 0 { 1.0 } else { 0.4 * pseudo(100 + k) }).collect(),
        opacities: (0..n).map(|k| 0.4 * pseudo(200 + k)).collect(),
        sh_dc: (0..3 * n).map(|k| 0.6 + 0.3 * pseudo(300 + k)).collect(),
        sh_rest: (0..SH_REST * n).map(|k| 0.15 * pseudo(400 + k)).collect(),
    };
    // The far splat is large so that it still reaches the image.
    for a in 0..3 {
        c.log_scales[3 * (n - 1) + a] = -0.1;
    }
    c
}

fn camera() -> SplatCamera {
    let k = Intrinsics::from_fov_x(40, 28, 0.7);
    SplatCamera::from_pinhole(&PinholeCamera::new(k, look_at(Vec3::new(0.0, 2.5, 0.8), Vec3::ZERO, Vec3::Z)))
}

fn weights(len: usize) -> Vec<f32> {
    (0..len).map(|k| pseudo(10_000 + k)).collect()
}

fn loss(c: &SplatCloud, cam: &SplatCamera, s: &RenderSettings, w: &[f32]) -> f64 {
    let (image, _) = render(&c.params(), cam, s);
    image.iter().zip(w).map(|(a, b)| *a as f64 * *b as f64).sum()
}

fn check(name: &str, field: fn(&mut SplatCloud) -> &mut Vec<f32>, grad: fn(&lucid_splat::SplatGrads) -> &Vec<f32>) {
    let cam = camera();
    // The 1/255 blend threshold and the 3σ footprint make the image jump where a pixel
    // crosses them; finite differences need a continuous image, so both are pushed out of
    // the way (a threshold of 1e-7 and a 6σ footprint, where the weight is below it).
    let settings =
        RenderSettings { background: [0.2, 0.5, 0.9], min_alpha: 1e-7, extent_sigmas: 6.0, ..Default::default() };
    let mut c = cloud();
    let w = weights(cam.width as usize * cam.height as usize * 4);
    let (_, state) = render(&c.params(), &cam, &settings);
    assert!(state.projected.iter().filter(|p| p.radius > 0.0).count() == 6, "every splat must be on screen");
    let analytic = grad(&render_backward(&c.params(), &state, &w)).clone();
    let scale = analytic.iter().fold(0.0f32, |m, g| m.max(g.abs())).max(1e-3);
    let h = 2e-3;
    let mut nonzero = 0;
    for (k, &an) in analytic.iter().enumerate() {
        let orig = field(&mut c)[k];
        field(&mut c)[k] = orig + h;
        let plus = loss(&c, &cam, &settings, &w);
        field(&mut c)[k] = orig - h;
        let minus = loss(&c, &cam, &settings, &w);
        field(&mut c)[k] = orig;
        let fd = ((plus - minus) / (2.0 * h as f64)) as f32;
        let err = (fd - an).abs() / (0.02 * scale + 0.02 * fd.abs());
        assert!(err <= 1.0, "{name}[{k}]: finite difference {fd} vs analytic {an} (largest |grad| {scale})");
        if an.abs() > 1e-3 * scale {
            nonzero += 1;
        }
    }
    assert!(nonzero > analytic.len() / 2, "{name}: most gradients should be non-zero ({nonzero}/{})", analytic.len());
}

#[test]
fn means() {
    check("means", |c| &mut c.means, |g| &g.means);
}

#[test]
fn log_scales() {
    check("log_scales", |c| &mut c.log_scales, |g| &g.log_scales);
}

#[test]
fn rotations() {
    check("rotations", |c| &mut c.rotations, |g| &g.rotations);
}

#[test]
fn opacities() {
    check("opacities", |c| &mut c.opacities, |g| &g.opacities);
}

#[test]
fn sh_dc() {
    check("sh_dc", |c| &mut c.sh_dc, |g| &g.sh_dc);
}

#[test]
fn sh_rest() {
    check("sh_rest", |c| &mut c.sh_rest, |g| &g.sh_rest);
}
