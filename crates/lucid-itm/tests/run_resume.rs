//! ITM training through Lucid's one loop: a run stopped and resumed from its checkpoint ends
//! with the same network and log as an uninterrupted one.

use std::path::Path;

use burn::tensor::{Tensor, TensorData};
use lucid_burn::run::{NoObserver, RunOptions, log_without_seconds, run};
use lucid_image::Image;
use lucid_itm::config::ItmConfig;
use lucid_itm::data::ItmImage;
use lucid_itm::run::ItmRun;
use lucid_itm::trainer::ItmTrainer;

fn options(dir: &Path, until: Option<usize>) -> RunOptions {
    RunOptions::in_folder(dir, 10, until, 2)
}

/// A smooth HDR gradient and its exposure clipped at 1: half of each image clips.
fn pair(seed: usize) -> ItmImage {
    let truth = Image::from_fn(24, 24, |x, y| {
        let v = 0.1 + 0.09 * (x + y + seed) as f32;
        [v, 0.8 * v, 0.6 * v + 0.05 * seed as f32, 1.0]
    });
    let ldr = truth.map(|p| p.map(|c| c.min(1.0)));
    ItmImage::new(format!("pair {seed}"), &ldr, &truth, 0.9)
}

#[test]
fn a_resumed_run_ends_where_an_uninterrupted_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<ItmImage> = (0..3).map(pair).collect();
    assert!(data.iter().all(|i| !i.clipped.is_empty()));
    let mut config = ItmConfig::default();
    config.model.width = 4;
    config.train.batch = 2;
    config.train.patch = 8;
    let device = lucid_burn::backend::training_device();
    let fresh = || ItmTrainer::new(config.clone(), device.clone());

    let (whole_dir, split_dir) = (dir.path().join("whole"), dir.path().join("split"));
    std::fs::create_dir_all(&whole_dir).unwrap();
    std::fs::create_dir_all(&split_dir).unwrap();
    let mut whole = ItmRun { trainer: fresh(), data: &data, held_out: &[] };
    run(&mut whole, &options(&whole_dir, None), &mut NoObserver).unwrap();
    let mut first = ItmRun { trainer: fresh(), data: &data, held_out: &[] };
    assert!(run(&mut first, &options(&split_dir, Some(4)), &mut NoObserver).unwrap().interrupted);

    let loaded = lucid_itm::checkpoint::load(&split_dir.join("checkpoint.lucid"), &device).unwrap();
    assert_eq!(loaded.trainer.step, 4);
    let mut resumed = ItmRun { trainer: loaded.trainer, data: &data, held_out: &[] };
    let options = RunOptions { elapsed: loaded.header.elapsed, resumed: true, ..options(&split_dir, None) };
    run(&mut resumed, &options, &mut NoObserver).unwrap();
    assert_eq!(resumed.trainer.step, 10);

    // The networks agree bit for bit on an input: their weights (and Adam's state, which the
    // later steps used) are the same.
    let input: Vec<f32> = (0..3 * 16 * 16).map(|i| (i % 97) as f32 / 97.0).collect();
    let output = |t: &ItmTrainer| {
        let x = Tensor::<4>::from_data(TensorData::new(input.clone(), [1, 3, 16, 16]), &device);
        t.net.forward(x).into_data().try_to_vec::<f32>().unwrap()
    };
    let (a, b) = (output(&resumed.trainer), output(&whole.trainer));
    assert_eq!(a, b, "bit-identical networks");
    assert_ne!(a, output(&fresh()), "training changed the network");
    let steps_and_losses = |d: &Path| log_without_seconds(&d.join("train_log.csv")).unwrap();
    let log = steps_and_losses(&split_dir);
    assert_eq!(log, steps_and_losses(&whole_dir));
    assert_eq!(log.len(), 6, "a header and a row every 2 steps: {log:?}");
}
