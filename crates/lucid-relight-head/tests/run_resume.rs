//! The relighting head's training through Lucid's one loop: a run stopped and resumed from its
//! checkpoint ends with the same head and log as an uninterrupted one.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lucid_burn::run::{NoObserver, RunOptions, log_without_seconds, run};
use lucid_relight_head::checkpoint::LightSet;
use lucid_relight_head::config::RelightConfig;
use lucid_relight_head::data::{CapturedView, LitImage, OlatSet};
use lucid_relight_head::run::HeadRun;
use lucid_relight_head::trainer::RelightTrainer;
use lucid_scene::{Intrinsics, PinholeCamera, look_at};
use lucid_splat::cloud::SplatCloud;
use lucid_splat::project::RenderSettings;

fn options(dir: &Path, until: Option<usize>) -> RunOptions {
    RunOptions::in_folder(dir, 8, until, 2)
}

/// Two views of three lights each; the targets are smooth, light-dependent colour ramps.
fn olat_set(directions: &[Vec3]) -> OlatSet {
    let (w, h) = (20, 16);
    let views = [Vec3::new(0.3, -2.5, 0.8), Vec3::new(-2.0, -1.2, 1.0)]
        .into_iter()
        .map(|eye| CapturedView {
            camera: PinholeCamera::new(Intrinsics::from_fov_x(w, h, 0.8), look_at(eye, Vec3::ZERO, Vec3::Z)),
            alpha: vec![1.0; (w * h) as usize],
            lights: directions
                .iter()
                .map(|d| LitImage {
                    direction: *d,
                    rgb: (0..(w * h) as usize * 3)
                        .map(|i| {
                            0.2 + 0.3 * d.x.abs() * ((i / 3) % w as usize) as f32 / w as f32 + 0.1 * (i % 3) as f32
                        })
                        .collect(),
                    held_out: false,
                    path: PathBuf::from("synthetic.exr"),
                })
                .collect(),
            environments: Vec::new(),
        })
        .collect();
    OlatSet { views, irradiance: 1.0 }
}

#[test]
fn a_resumed_run_ends_where_an_uninterrupted_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let directions = [Vec3::X, Vec3::new(0.2, -0.5, 0.8).normalize(), Vec3::new(-0.6, 0.6, 0.1).normalize()];
    let data = olat_set(&directions);
    let lights = LightSet { directions: directions.to_vec(), irradiance: 1.0 };
    let mut cloud = SplatCloud::random_in_box(200, Vec3::splat(-0.5), Vec3::splat(0.5), 3);
    cloud.log_scales.iter_mut().for_each(|s| *s = (0.08f32).ln());
    let mut config = RelightConfig::default();
    config.train.lights_per_step = 2;
    let device = lucid_burn::backend::training_device();
    let fresh = || RelightTrainer::new(config.clone(), cloud.clone(), RenderSettings::default(), device.clone());

    let (whole_dir, split_dir) = (dir.path().join("whole"), dir.path().join("split"));
    std::fs::create_dir_all(&whole_dir).unwrap();
    std::fs::create_dir_all(&split_dir).unwrap();
    let head_run = |trainer| HeadRun { trainer, data: &data, lights: &lights, held_out: None };
    let mut whole = head_run(fresh());
    run(&mut whole, &options(&whole_dir, None), &mut NoObserver).unwrap();
    let mut first = head_run(fresh());
    assert!(run(&mut first, &options(&split_dir, Some(4)), &mut NoObserver).unwrap().interrupted);

    let loaded = lucid_relight_head::checkpoint::load(&split_dir.join("checkpoint.lucid"), &device).unwrap();
    assert_eq!(loaded.trainer.step, 4);
    assert_eq!(loaded.lights.directions, lights.directions);
    let mut resumed = head_run(loaded.trainer);
    let options = RunOptions { elapsed: loaded.header.elapsed, resumed: true, ..options(&split_dir, None) };
    run(&mut resumed, &options, &mut NoObserver).unwrap();
    assert_eq!(resumed.trainer.step, 8);

    // The heads' radiance agrees bit for bit under a light none of them trained with.
    let camera = &data.views[0].camera;
    let radiance = |t: &RelightTrainer| {
        let dirs = t.geometry.view_directions(camera);
        let light = Vec3::new(0.1, 0.9, 0.4).normalize();
        t.head.radiance(&t.config, &dirs, light, &device).into_data().try_to_vec::<f32>().unwrap()
    };
    let (a, b) = (radiance(&resumed.trainer), radiance(&whole.trainer));
    assert_eq!(a, b, "bit-identical heads");
    assert_ne!(a, radiance(&fresh()), "training changed the head");
    let steps_and_losses = |d: &Path| log_without_seconds(&d.join("train_log.csv")).unwrap();
    let log = steps_and_losses(&split_dir);
    assert_eq!(log, steps_and_losses(&whole_dir));
    assert_eq!(log.len(), 5, "a header and a row every 2 steps: {log:?}");
}
