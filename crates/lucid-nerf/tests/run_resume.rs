//! NeRF training through Lucid's one loop: a run stopped and resumed from its checkpoint ends
//! with the same parameters, occupancy grid and log as an uninterrupted one.

use std::path::Path;

use lucid_burn::run::{NoObserver, RunOptions, log_without_seconds, run};
use lucid_datasets_gen::builtin::object_orbit_spec;
use lucid_datasets_gen::{AnalyticScene, Shard, generate_dataset};
use lucid_nerf::config::NerfConfig;
use lucid_nerf::data::ImageSet;
use lucid_nerf::run::NerfRun;
use lucid_nerf::trainer::NerfTrainer;
use lucid_scene::{Dataset, Split};

fn options(dir: &Path, until: Option<usize>) -> RunOptions {
    RunOptions::in_folder(dir, 12, until, 2)
}

#[test]
fn a_resumed_run_ends_where_an_uninterrupted_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("ds");
    generate_dataset(&root, &object_orbit_spec(24, [4, 0, 0], 3), &AnalyticScene::default(), Shard::ALL, &|_, _| {})
        .unwrap();
    let dataset = Dataset::open(&root).unwrap();
    let data = ImageSet::load(dataset.frames(Split::Train)).unwrap();
    let mut config = NerfConfig::default();
    config.field.grid.log2_table_size = 10;
    config.field.grid.levels = 4;
    config.train.batch_samples = 2048;
    config.train.initial_rays = 256;
    config.occupancy.warmup_steps = 4;
    config.occupancy.update_every = 2;
    let device = lucid_nerf::backend::training_device();
    let fresh = || NerfTrainer::for_dataset(config.clone(), &dataset, &data, device.clone());

    let (whole_dir, split_dir) = (dir.path().join("whole"), dir.path().join("split"));
    std::fs::create_dir_all(&whole_dir).unwrap();
    std::fs::create_dir_all(&split_dir).unwrap();
    let mut whole = NerfRun { trainer: fresh(), data: &data, held_out: None };
    run(&mut whole, &options(&whole_dir, None), &mut NoObserver).unwrap();
    // Stopped at a log row: a row's means cover the steps since the last row this process
    // logged.
    let mut first = NerfRun { trainer: fresh(), data: &data, held_out: None };
    assert!(run(&mut first, &options(&split_dir, Some(6)), &mut NoObserver).unwrap().interrupted);

    let loaded = lucid_nerf::checkpoint::load(&split_dir.join("checkpoint.lucid"), &device).unwrap();
    assert_eq!(loaded.trainer.step, 6);
    // The finest resolution the views chose (left at 0 in the configuration) is the one the
    // checkpoint keeps, so the resumed run and every render use the same levels.
    let (lo, hi) = lucid_nerf::data::scene_box(&dataset);
    let radius = lucid_nerf::data::ViewInfo::from_cameras(&data.cameras, (lo + hi) * 0.5).radius;
    let chosen = config.field.grid.finest_for_views((hi - lo).max_element(), data.pixel_angle(), radius);
    assert!(chosen > config.field.grid.base_resolution && chosen != config.field.grid.finest(), "{chosen}");
    assert_eq!(loaded.header.config.field.grid.finest_resolution, chosen);
    assert_eq!(loaded.trainer.config.field.grid.finest_resolution, chosen);
    let mut resumed = NerfRun { trainer: loaded.trainer, data: &data, held_out: None };
    let options = RunOptions { elapsed: loaded.header.elapsed, resumed: true, ..options(&split_dir, None) };
    run(&mut resumed, &options, &mut NoObserver).unwrap();

    let values = |t: &NerfTrainer| {
        let mut v = t.model.table.val().into_data().try_to_vec::<f32>().unwrap();
        v.extend(t.model.mlp.val().into_data().try_to_vec::<f32>().unwrap());
        v
    };
    assert_eq!(values(&resumed.trainer), values(&whole.trainer), "bit-identical parameters");
    assert_eq!(resumed.trainer.grid, whole.trainer.grid);
    let steps_and_losses = |d: &Path| log_without_seconds(&d.join("train_log.csv")).unwrap();
    assert_eq!(steps_and_losses(&split_dir), steps_and_losses(&whole_dir));
}
