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

/// `∂loss/∂field[k]` by central differences with step `h`.
fn central_difference(
    c: &mut SplatCloud,
    field: fn(&mut SplatCloud) -> &mut Vec<f32>,
    k: usize,
    h: f32,
    (cam, settings, w): (&SplatCamera, &RenderSettings, &[f32]),
) -> f32 {
    let orig = field(c)[k];
    field(c)[k] = orig + h;
    let plus = loss(c, cam, settings, w);
    field(c)[k] = orig - h;
    let minus = loss(c, cam, settings, w);
    field(c)[k] = orig;
    ((plus - minus) / (2.0 * h as f64)) as f32
}

/// The analytic gradient agrees with the finite difference to 2 % of itself plus 2 % of the
/// largest gradient of the kind (`scale`).
fn assert_close(what: &str, fd: f32, an: f32, scale: f32) {
    let err = (fd - an).abs() / (0.02 * scale + 0.02 * fd.abs());
    assert!(err <= 1.0, "{what}: finite difference {fd} vs analytic {an} (largest |grad| {scale})");
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
        let fd = central_difference(&mut c, field, k, h, (&cam, &settings, &w));
        assert_close(&format!("{name}[{k}]"), fd, an, scale);
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

/// Many splats stacked over a few tiles, opaque enough that most pixels stop early: tile lists
/// longer than the kernels' gather blocks, rows whose pixels all stopped, runs at every offset.
fn crowd() -> SplatCloud {
    let n = 160;
    let mut c = SplatCloud::default();
    for k in 0..n {
        let p = Vec3::new(0.5 * pseudo(500 + k), 0.6 * pseudo(700 + k), 0.35 * pseudo(900 + k));
        c.push(p, 0.04 + 0.04 * (pseudo(1100 + k) + 1.0), 0.75 + 0.2 * pseudo(1300 + k), [0.5, 0.4, 0.3]);
    }
    for k in 0..4 * n {
        if k % 4 != 0 {
            c.rotations[k] = 0.6 * pseudo(1500 + k);
        }
    }
    for k in 0..3 * n {
        c.log_scales[k] += 0.4 * pseudo(1700 + k);
        c.sh_dc[k] = 0.5 * pseudo(1900 + k);
    }
    c
}

#[test]
fn long_tile_lists_and_stopped_pixels() {
    let cam = camera();
    let settings =
        RenderSettings { background: [0.2, 0.5, 0.9], min_alpha: 1e-7, extent_sigmas: 6.0, ..Default::default() };
    let mut c = crowd();
    let w = weights(cam.width as usize * cam.height as usize * 4);
    let (image, state) = render(&c.params(), &cam, &settings);
    assert!(state.bins.offsets.windows(2).any(|o| o[1] - o[0] > 130), "some tile lists span several gather blocks");
    // Pixels stop before their transmittance would fall below 1e-4.
    let stopped = (0..image.len() / 4).filter(|&p| image[4 * p + 3] > 1.0 - 1e-3).count();
    assert!(stopped > image.len() / 4 / 16, "many pixels stop early ({stopped})");
    let g = render_backward(&c.params(), &state, &w);
    let scale = g.opacities.iter().chain(&g.means).fold(0.0f32, |m, v| m.max(v.abs())).max(1e-3);
    // Opacities and the mean's x (the camera looks along −y and down; x leaves the depth
    // order alone, whose swaps would make the image jump).
    let h = 1e-3;
    let mut fd_of = |field: fn(&mut SplatCloud) -> &mut Vec<f32>, k: usize| {
        central_difference(&mut c, field, k, h, (&cam, &settings, &w))
    };
    for k in 0..160 {
        for (name, fd, an) in [
            ("opacity", fd_of(|c| &mut c.opacities, k), g.opacities[k]),
            ("mean x", fd_of(|c| &mut c.means, 3 * k), g.means[3 * k]),
        ] {
            assert_close(&format!("splat {k} {name}"), fd, an, scale);
        }
    }
}
