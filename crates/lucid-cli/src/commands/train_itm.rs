//! `lucid train itm DATASETS... -o OUT`: the inverse tone mapping network on the bracket
//! frames of several datasets, through the training loop (budget, progress, CSV log,
//! checkpoints by steps and time, resume), and a closing evaluation against the analytic
//! baseline on their test splits.

use anyhow::Context;
use lucid_burn::run::{NoObserver, RunFolder, Start, run};
use lucid_itm::checkpoint::{self, ITM_KIND};
use lucid_itm::config::ItmConfig;
use lucid_itm::data::{check_patch, load};
use lucid_itm::run::ItmRun;
use lucid_itm::trainer::ItmTrainer;
use lucid_scene::Split;

use crate::cli::TrainItmArgs;
use crate::training;

pub fn run_itm(args: TrainItmArgs) -> anyhow::Result<()> {
    let start = training::start(&args.run);
    let config = match start {
        Start::Resume => None,
        _ => {
            let (text, origin) = training::config_text(args.config.as_deref(), &args.overrides, &args.run)?;
            Some(ItmConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?)
        }
    };
    let threshold = config.as_ref().map(|c| c.model.mask_threshold);
    // Read before the folder is touched when the configuration is known (a new run).
    let early =
        threshold.map(|t| load(&args.datasets, Split::Train, t)).transpose().context("loading training pairs")?;
    if let (Some(train), Some(config)) = (&early, &config) {
        check_patch(train, config.train.patch)?;
        let pixels = train.iter().map(|i| i.width * i.height).sum();
        training::check_memory(&config.memory_estimate(pixels))?;
    }
    let mut folder = RunFolder::open(&args.output, ITM_KIND, start)?;
    folder.check_dataset(training::fingerprint_of(&args.datasets)?)?;
    training::refuse_resume_changes(&args.run, args.config.as_deref(), &args.overrides, &folder)?;
    let device = lucid_burn::backend::training_device();
    let (trainer, elapsed) = match config {
        None => {
            let mut loaded =
                checkpoint::load(&training::checkpoint_to_resume(&folder)?, &device).context("resuming")?;
            training::extend_steps(&args.run, &mut loaded.trainer.config.train.steps);
            (loaded.trainer, loaded.header.elapsed)
        }
        Some(config) => (ItmTrainer::new(config, device.clone()), 0.0),
    };
    let train = match early {
        Some(train) => train,
        None => {
            load(&args.datasets, Split::Train, trainer.config.model.mask_threshold).context("loading training pairs")?
        }
    };
    check_patch(&train, trainer.config.train.patch)?;
    let t = trainer.config.train.clone();
    let budget = training::budget(&args.run, &folder, t.steps, t.time_limit)?;
    folder.write_manifest(ITM_KIND, budget)?;
    training::write_config(&folder, &trainer.config)?;
    tracing::info!(
        "training ITM on {} pairs from {} dataset(s); {}",
        train.len(),
        args.datasets.len(),
        budget.describe()
    );
    // A row every step: an ITM step is short and its loss noisy.
    let options = training::options(&args.run, &folder, budget, elapsed, (t.checkpoint_every, 1), "itm")?;
    let mut model = ItmRun { trainer, data: &train, held_out: &args.datasets };
    let summary = run(&mut model, &options, &mut NoObserver)?;
    training::print_summary(&summary, "the ITM network", &folder.checkpoint());
    Ok(())
}
