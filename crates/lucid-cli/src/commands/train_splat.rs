//! `lucid train splat DATASET -o OUT`: 3D Gaussian splatting through the training loop
//! (budget, progress, CSV log, checkpoints by steps and time, resume), the standard `.ply`
//! export (`OUT/splats.ply`) and a closing evaluation on the test split.

use std::time::Instant;

use anyhow::Context;
use lucid_burn::run::{NoObserver, RunFolder, Start, run};
use lucid_scene::Split;
use lucid_scene::dataset::images::ImageSet;
use lucid_splat::checkpoint::{self, SPLAT_KIND};
use lucid_splat::config::SplatConfig;
use lucid_splat::run::SplatRun;
use lucid_splat::trainer::{SplatTrainer, initial_cloud};

use crate::cli::TrainModelArgs;
use crate::commands::view::live;
use crate::loaded_model::ModelRef;
use crate::training;

pub fn run_splat(args: TrainModelArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let start = training::start(&args.run);
    let config = match start {
        Start::Resume => None,
        _ => {
            let (text, origin) = training::config_text(args.config.as_deref(), &args.overrides, &args.run)?;
            Some(SplatConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?)
        }
    };
    let dataset = training::open_dataset(&args.dataset, &args.data.options())?;
    if let Some(config) = &config {
        let (pixels, largest) = training::training_pixels(&dataset);
        training::check_memory(&config.memory_estimate(config.init.random_points, pixels, largest))?;
    }
    let mut folder = RunFolder::open(&args.output, SPLAT_KIND, start)?;
    folder.check_dataset(dataset.fingerprint())?;
    training::refuse_resume_changes(&args.run, args.config.as_deref(), &args.overrides, &folder)?;
    let loaded = ImageSet::load(dataset.frames(Split::Train)).context("loading training images")?;
    // The rasterizer projects through pinholes: distorted captures train on undistorted crops.
    let data = loaded.undistorted();
    let device = lucid_burn::backend::training_device();
    let (trainer, elapsed) = match config {
        None => {
            let mut loaded =
                checkpoint::load(&training::checkpoint_to_resume(&folder)?, &device).context("resuming")?;
            tracing::info!("resuming {} at step {}", folder.checkpoint().display(), loaded.trainer.step);
            training::extend_steps(&args.run, &mut loaded.trainer.config.train.steps);
            (loaded.trainer, loaded.header.elapsed)
        }
        Some(config) => {
            let cloud = initial_cloud(&config, &dataset, &data)
                .map_err(anyhow::Error::msg)
                .with_context(|| format!("initialising from {}", dataset.root.display()))?;
            (SplatTrainer::for_dataset(config, &cloud, &dataset, &data, device), 0.0)
        }
    };
    let t = trainer.config.train;
    let budget = training::budget(&args.run, &folder, t.steps, t.time_limit)?;
    // The viewer's port first: a port in use fails before the run writes anything.
    let mut live = live::for_run(args.view, &args.output, ModelRef::Splat(&trainer), &dataset)?;
    folder.write_manifest(SPLAT_KIND, budget)?;
    training::write_config(&folder, &trainer.config)?;
    tracing::info!(
        "{} training views loaded in {:.1} s; {} Gaussians to start; scene extent {:.3}; {}",
        data.len(),
        load_start.elapsed().as_secs_f64(),
        trainer.model.len(),
        trainer.extent,
        budget.describe()
    );
    let options = training::options(&args.run, &folder, budget, elapsed, (t.checkpoint_every, t.log_every), "splat")?;
    let export = Some(folder.path("splats.ply"));
    let mut model = SplatRun { trainer, data: &data, held_out: Some(&dataset), export };
    let summary = run(&mut model, &options, live::observer::<SplatRun>(&mut live, &mut NoObserver))?;
    training::print_summary(&summary, "3D Gaussian splats", &folder.checkpoint());
    Ok(())
}
