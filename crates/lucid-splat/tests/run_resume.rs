//! 3DGS training through Lucid's one loop: a run stopped and resumed from its checkpoint
//! (mid-way through densification's statistics) ends with the same cloud and log as an
//! uninterrupted one.

use std::path::Path;

use lucid_burn::run::{NoObserver, RunOptions, log_without_seconds, run};
use lucid_datasets_gen::builtin::object_orbit_spec;
use lucid_datasets_gen::{AnalyticScene, Shard, generate_dataset};
use lucid_scene::dataset::images::{ImageSet, scene_box};
use lucid_scene::{Dataset, Split};
use lucid_splat::config::SplatConfig;
use lucid_splat::run::SplatRun;
use lucid_splat::trainer::{SplatTrainer, initial_cloud};

fn options(dir: &Path, until: Option<usize>) -> RunOptions {
    RunOptions::in_folder(dir, 16, until, 2)
}

#[test]
fn a_resumed_run_ends_where_an_uninterrupted_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("ds");
    generate_dataset(&root, &object_orbit_spec(24, [4, 0, 0], 3), &AnalyticScene::default(), Shard::ALL, &|_, _| {})
        .unwrap();
    let dataset = Dataset::open(&root).unwrap();
    let data = ImageSet::load(dataset.frames(Split::Train)).unwrap();
    let mut config = SplatConfig::default();
    config.train.steps = 16;
    config.train.sh_degree_every = 4;
    config.densify.from = 2;
    config.densify.every = 4;
    config.densify.until = 14;
    config.densify.opacity_reset_every = 10;
    config.densify.grad_threshold = 1e-7;
    let cloud = initial_cloud(&config, &dataset, &data).unwrap();
    let (lo, hi) = scene_box(&dataset);
    let device = lucid_burn::backend::training_device();
    let fresh = || SplatTrainer::new(config.clone(), &cloud, &data, (lo + hi) * 0.5, device.clone());

    let (whole_dir, split_dir) = (dir.path().join("whole"), dir.path().join("split"));
    std::fs::create_dir_all(&whole_dir).unwrap();
    std::fs::create_dir_all(&split_dir).unwrap();
    let mut whole = SplatRun { trainer: fresh(), data: &data, held_out: None, export: None };
    run(&mut whole, &options(&whole_dir, None), &mut NoObserver).unwrap();
    assert!(whole.trainer.model.len() != cloud.len(), "densification ran");
    // Stopped between two densifications (every 4 steps), with their statistics half
    // gathered; at a log row, since a row's means cover the steps since the last row that
    // this process logged.
    let mut first = SplatRun { trainer: fresh(), data: &data, held_out: None, export: None };
    assert!(run(&mut first, &options(&split_dir, Some(6)), &mut NoObserver).unwrap().interrupted);

    let loaded = lucid_splat::checkpoint::load(&split_dir.join("checkpoint.lucid"), &device).unwrap();
    assert_eq!(loaded.trainer.step, 6);
    let mut resumed = SplatRun { trainer: loaded.trainer, data: &data, held_out: None, export: None };
    let options = RunOptions { elapsed: loaded.header.elapsed, resumed: true, ..options(&split_dir, None) };
    run(&mut resumed, &options, &mut NoObserver).unwrap();

    let (a, b) = (resumed.trainer.model.to_cloud(), whole.trainer.model.to_cloud());
    assert_eq!(a.len(), b.len());
    assert_eq!(a.params().means, b.params().means, "bit-identical means");
    assert_eq!(a.params().opacities, b.params().opacities);
    let steps_and_losses = |d: &Path| log_without_seconds(&d.join("train_log.csv")).unwrap();
    assert_eq!(steps_and_losses(&split_dir), steps_and_losses(&whole_dir));
}
