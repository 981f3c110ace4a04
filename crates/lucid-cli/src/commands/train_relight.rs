//! `lucid train relight OLAT_DATASET -o OUT`: the neural relighting head, in two stages
//! through the training loop. Stage 1 trains a splat cloud on the views lit uniformly
//! (`OUT/geometry.lucid`, a resumable splat checkpoint, `OUT/geometry_log.csv` and
//! `OUT/geometry.ply`); stage 2 trains the head over the frozen geometry
//! (`OUT/checkpoint.lucid`, kind `relight`, and `OUT/train_log.csv`); then the test split is
//! evaluated under its lights and environment maps (`OUT/eval_test`). The budget flags set
//! the head's budget; the geometry's is `geometry.train` of the configuration.

use anyhow::Context;
use lucid_burn::run::{Budget, NoObserver, RunFolder, RunOptions, Start, run};
use lucid_relight_head::checkpoint::{self, LightSet, RELIGHT_KIND};
use lucid_relight_head::config::RelightConfig;
use lucid_relight_head::data::OlatSet;
use lucid_relight_head::run::HeadRun;
use lucid_relight_head::trainer::RelightTrainer;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::{Dataset, Split};
use lucid_splat::run::SplatRun;
use lucid_splat::trainer::{SplatTrainer, initial_cloud};
use lucid_splat::view::SplatRenderer;

use lucid_session::RunRequest;
use lucid_session::request::{check_memory, training_pixels, write_config};

use crate::cli::TrainModelArgs;

/// Stage 1: trains (or resumes, or finds finished) the geometry.
fn geometry_stage(
    config: &RelightConfig,
    dataset: &Dataset,
    images: &ImageSet,
    folder: &RunFolder,
    request: &RunRequest,
    run_budget: Budget,
) -> anyhow::Result<(SplatTrainer, f64)> {
    let path = folder.path("geometry.lucid");
    let device = lucid_burn::backend::training_device();
    let g = config.geometry.train;
    let mut budget = Budget::from_limits(None, None, g.steps, g.time_limit).map_err(anyhow::Error::msg)?;
    // A run limited in time gives its geometry the share of the time that the geometry's
    // steps are of both stages' steps, so that the two stages together keep to the limit.
    if let Some(seconds) = run_budget.seconds() {
        let share = seconds * g.steps as f64 / (g.steps + config.train.steps).max(1) as f64;
        budget = budget.with_seconds(budget.seconds().map_or(share, |s| s.min(share)));
    }
    let resumed = request.resumes() && path.is_file();
    let (trainer, elapsed) = if resumed {
        let loaded = lucid_splat::checkpoint::load(&path, &device).context("resuming the geometry")?;
        (loaded.trainer, loaded.header.elapsed)
    } else {
        let cloud = initial_cloud(&config.geometry, dataset, images)
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("initialising from {}", dataset.root.display()))?;
        (SplatTrainer::for_dataset(config.geometry.clone(), &cloud, dataset, images, device), 0.0)
    };
    if budget.spent(trainer.step, elapsed) {
        return Ok((trainer, elapsed));
    }
    tracing::info!("geometry: {} uniformly lit views, {} Gaussians to start", images.len(), trainer.model.len());
    let options = RunOptions {
        checkpoint: Some(path),
        checkpoint_every: g.checkpoint_every,
        checkpoint_seconds: request.checkpoint_seconds,
        log: Some(folder.path("geometry_log.csv")),
        log_every: g.log_every,
        elapsed,
        resumed,
        label: "geometry".into(),
        ..RunOptions::new(budget)
    };
    let export = Some(folder.path("geometry.ply"));
    let mut model = SplatRun { trainer, data: images, held_out: None, export };
    let summary = run(&mut model, &options, &mut NoObserver)?;
    println!("geometry: {} steps in {:.1} s, {} Gaussians", summary.steps, summary.elapsed, model.trainer.model.len());
    Ok((model.trainer, summary.elapsed))
}

/// The geometry against the held-out views under uniform light (their OLAT frames summed),
/// where the test split has OLAT frames: the ceiling the head works under.
fn report_geometry(test: &OlatSet, trainer: &SplatTrainer) -> anyhow::Result<()> {
    if test.views.is_empty() || test.views.iter().any(|v| v.lights.is_empty()) {
        return Ok(());
    }
    let images = test.uniformly_lit()?;
    let cloud = trainer.model.to_cloud();
    let renderer = SplatRenderer { cloud: &cloud, settings: trainer.eval_settings() };
    let (_, summary) = lucid_scene::evaluation::evaluate(&renderer, &images, None, |_, _, _, _| {});
    println!(
        "geometry on {} held-out views under uniform light: PSNR {:.2} dB, SSIM {:.4}",
        summary.views, summary.psnr, summary.ssim
    );
    Ok(())
}

pub fn run_relight(args: TrainModelArgs) -> anyhow::Result<()> {
    if args.view.is_some() {
        anyhow::bail!("--view shows NeRF and splat runs; the relighting head has no view of its own to serve");
    }
    let request = args.request();
    let config = match request.start {
        Start::Resume => None,
        // The budget flags set the head's `train` keys.
        _ => {
            let (text, origin) = request.config_text()?;
            Some(RelightConfig::from_toml(&text, &origin).map_err(anyhow::Error::msg)?)
        }
    };
    let dataset =
        Dataset::open(&args.dataset).with_context(|| format!("reading dataset {}", args.dataset.display()))?;
    let test = OlatSet::load(&args.dataset, Split::Test).context("loading the test views")?;
    let data = OlatSet::load(&args.dataset, Split::Train)
        .context("loading the OLAT training frames")?
        .without_held_out_lights();
    data.require_lights(&args.dataset, Split::Train)?;
    if let Some(config) = &config {
        let (pixels, largest) = training_pixels(&dataset);
        let olat_values: usize = data.views.iter().map(|v| v.lights.iter().map(|l| l.rgb.len()).sum::<usize>()).sum();
        check_memory(&config.memory_estimate(pixels, largest, olat_values))?;
    }
    let mut folder = RunFolder::open(&args.output, RELIGHT_KIND, request.start)?;
    folder.check_dataset(dataset.fingerprint())?;
    request.refuse_resume_changes(&folder)?;
    let device = lucid_burn::backend::training_device();
    let head_checkpoint = folder.checkpoint();
    let (trainer, lights, elapsed, budget) = if request.resumes() && head_checkpoint.is_file() {
        let mut loaded = checkpoint::load(&head_checkpoint, &device).context("resuming")?;
        tracing::info!("resuming {} at head step {}", head_checkpoint.display(), loaded.trainer.step);
        let t = &mut loaded.trainer.config.train;
        t.steps = request.steps.unwrap_or(t.steps);
        let budget = request.budget(&folder, t.steps, t.time_limit)?;
        folder.write_manifest(RELIGHT_KIND, budget)?;
        write_config(&folder, &loaded.trainer.config)?;
        (loaded.trainer, loaded.lights, loaded.header.elapsed, budget)
    } else {
        // A run killed in its geometry stage keeps its configuration in config.toml.
        let config = match config {
            Some(config) => config,
            None => {
                let path = folder.path("config.toml");
                let text = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
                let mut config =
                    RelightConfig::from_toml(&text, &path.display().to_string()).map_err(anyhow::Error::msg)?;
                config.train.steps = request.steps.unwrap_or(config.train.steps);
                config
            }
        };
        // Written first, so a run killed in its geometry stage can be resumed.
        let budget = request.budget(&folder, config.train.steps, config.train.time_limit)?;
        folder.write_manifest(RELIGHT_KIND, budget)?;
        write_config(&folder, &config)?;
        let images = data.uniformly_lit()?;
        let (geometry, geometry_seconds) = geometry_stage(&config, &dataset, &images, &folder, &request, budget)?;
        report_geometry(&test, &geometry)?;
        // The head has the time the geometry left (at least a tenth of the limit).
        let budget = match budget.seconds() {
            Some(seconds) => budget.with_seconds((seconds - geometry_seconds).max(0.1 * seconds)),
            None => budget,
        };
        let lights = LightSet { directions: data.directions(), irradiance: data.irradiance };
        let cloud = geometry.model.to_cloud();
        (RelightTrainer::new(config, cloud, geometry.eval_settings(), device), lights, 0.0, budget)
    };
    let t = trainer.config.train;
    tracing::info!(
        "head: {} OLAT frames of {} views, {} lights, {} Gaussians; {}",
        data.lit_images(),
        data.views.len(),
        lights.directions.len(),
        trainer.geometry.len(),
        budget.describe()
    );
    // A head resumed from step 0 (a run killed in its geometry stage) keeps no log rows.
    let options = request.options(&folder, budget, elapsed, (t.checkpoint_every, t.log_every), "relight")?;
    let held_out = Some((&test, head_checkpoint.clone()));
    let mut model = HeadRun { trainer, data: &data, lights: &lights, held_out };
    let summary = run(&mut model, &options, &mut NoObserver)?;
    crate::training::print_summary(&summary, "the relighting head", &head_checkpoint);
    Ok(())
}
