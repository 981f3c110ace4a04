//! `lucid train nerf DATASET -o OUT`: a hash-grid NeRF through the training loop (budget,
//! progress, CSV log, checkpoints by steps and time, resume) and a closing evaluation on the
//! test split.

use std::time::Instant;

use anyhow::Context;
use lucid_burn::run::{NoObserver, RunFolder, Start, run};
use lucid_nerf::checkpoint::{self, NERF_KIND};
use lucid_nerf::config::NerfConfig;
use lucid_nerf::data::ImageSet;
use lucid_nerf::run::NerfRun;
use lucid_nerf::trainer::NerfTrainer;
use lucid_scene::Split;

use crate::cli::TrainModelArgs;
use crate::commands::view::live;
use crate::loaded_model::ModelRef;
use crate::training;

pub fn run_nerf(args: TrainModelArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let start = training::start(&args.run);
    // A bad configuration fails before anything is read or written.
    let config = match start {
        Start::Resume => None,
        _ => {
            let (text, origin) = training::config_text(args.config.as_deref(), &args.overrides, &args.run)?;
            Some(NerfConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?)
        }
    };
    let dataset = training::open_dataset(&args.dataset, &args.data.options())?;
    if let Some(config) = &config {
        training::check_memory(&config.memory_estimate(training::training_pixels(&dataset).0))?;
    }
    let mut folder = RunFolder::open(&args.output, NERF_KIND, start)?;
    folder.check_dataset(dataset.fingerprint())?;
    training::refuse_resume_changes(&args.run, args.config.as_deref(), &args.overrides, &folder)?;
    let data = ImageSet::load(dataset.frames(Split::Train)).context("loading training images")?;
    let device = lucid_nerf::backend::training_device();
    let (trainer, elapsed) = match config {
        None => {
            let mut loaded =
                checkpoint::load(&training::checkpoint_to_resume(&folder)?, &device).context("resuming")?;
            tracing::info!("resuming {} at step {}", folder.checkpoint().display(), loaded.trainer.step);
            training::extend_steps(&args.run, &mut loaded.trainer.config.train.steps);
            (loaded.trainer, loaded.header.elapsed)
        }
        Some(config) => (NerfTrainer::for_dataset(config, &dataset, &data, device), 0.0),
    };
    let t = trainer.config.train;
    let budget = training::budget(&args.run, &folder, t.steps, t.time_limit)?;
    // The viewer's port first: a port in use fails before the run writes anything.
    let mut live = live::for_run(args.view, &args.output, ModelRef::Nerf(&trainer), &dataset)?;
    folder.write_manifest(NERF_KIND, budget)?;
    training::write_config(&folder, &trainer.config)?;
    let (lo, hi) = trainer.grid.bounds();
    tracing::info!(
        "{} training views loaded in {:.1} s; box {:?}..{:?}; {}, {} samples a step",
        data.len(),
        load_start.elapsed().as_secs_f64(),
        lo.to_array(),
        hi.to_array(),
        budget.describe(),
        t.batch_samples
    );
    let options = training::options(&args.run, &folder, budget, elapsed, (t.checkpoint_every, t.log_every), "nerf")?;
    let mut model = NerfRun { trainer, data: &data, held_out: Some(&dataset) };
    let summary = run(&mut model, &options, live::observer::<NerfRun>(&mut live, &mut NoObserver))?;
    training::print_summary(&summary, "a NeRF", &folder.checkpoint());
    Ok(())
}
