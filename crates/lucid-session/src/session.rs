//! One way to set up and run training, for every method.

use std::marker::PhantomData;
use std::path::Path;
use std::time::Instant;

use lucid_burn::run::{ModelError, Observer, RunFolder, RunSummary, Start, StepReport, Trainable};

use crate::events::{Event, Listener};
use crate::method::Method;
use crate::request::{check_memory, checkpoint_to_resume, write_config};
use crate::{RunRequest, SessionError};

/// Runs `request` with method `M`: a new run, the folder's run continued or replaced, as the
/// request says; everything is read and checked before the folder is touched, and `listener`
/// hears what happens. Returns what the run did.
pub fn train<M: Method>(request: &RunRequest, listener: &mut dyn Listener) -> Result<RunSummary, SessionError> {
    let load_start = Instant::now();
    // A bad configuration fails before anything is read or written.
    let config = match request.start {
        Start::Resume => None,
        Start::New | Start::Overwrite => {
            let (text, origin) = request.config_text()?;
            Some(M::parse_config(&text, &origin).map_err(SessionError::Invalid)?)
        }
    };
    let mut method = M::open(request, config.as_ref())?;
    if let Some(config) = &config {
        check_memory(&method.memory_estimate(config))?;
    }
    let mut folder = RunFolder::open(&request.output, M::KIND, request.start)?;
    folder.check_dataset(method.fingerprint()?)?;
    request.refuse_resume_changes(&folder)?;
    method.load()?;
    let (mut trainer, elapsed) = match config {
        None => {
            let checkpoint = checkpoint_to_resume(&folder)?;
            let (mut trainer, elapsed) = method.resume(&checkpoint)?;
            tracing::info!("resuming {} at step {}", checkpoint.display(), trainer.steps_taken());
            if let Some(steps) = request.steps {
                M::set_steps(&mut trainer, steps);
            }
            (trainer, elapsed)
        }
        Some(config) => (method.init(config)?, 0.0),
    };
    let settings = M::settings(&trainer);
    let budget = request.budget(&folder, settings.steps, settings.time_limit)?;
    let ready = Event::Ready {
        kind: M::KIND,
        step: trainer.steps_taken(),
        budget,
        folder: folder.dir(),
        model: &|| M::snapshot(&trainer),
        dataset: method.dataset(),
    };
    listener.on(&ready).map_err(|e| SessionError::read("starting the run", e))?;
    folder.write_manifest(M::KIND, budget)?;
    write_config(&folder, M::config(&trainer))?;
    tracing::info!(
        "{}; loaded in {:.1} s; {}",
        method.describe(&trainer),
        load_start.elapsed().as_secs_f64(),
        budget.describe()
    );
    let every = (settings.checkpoint_every, settings.log_every);
    let options = request.options(&folder, budget, elapsed, every, M::LABEL)?;
    let summary = lucid_burn::run::run(&mut trainer, &options, &mut Relay::<M> { listener, method: PhantomData })?;
    let checkpoint = folder.checkpoint();
    listener
        .on(&Event::Finished { summary: &summary, checkpoint: &checkpoint, model: &|| M::snapshot(&trainer) })
        .map_err(|e| SessionError::read("finishing the run", e))?;
    Ok(summary)
}

/// The training loop's callbacks as a session's events.
struct Relay<'l, M> {
    listener: &'l mut dyn Listener,
    method: PhantomData<M>,
}

impl<'t, M: Method> Observer<M::Trainer<'t>> for Relay<'_, M> {
    fn after_step(&mut self, trainer: &M::Trainer<'t>, report: &StepReport, elapsed: f64) -> Result<(), ModelError> {
        let step = trainer.steps_taken();
        self.listener.on(&Event::Step { step, elapsed, report, model: &|| M::snapshot(trainer) })
    }

    fn logged(&mut self, step: usize, elapsed: f64, loss: f64, psnr: Option<f64>) -> Result<(), ModelError> {
        self.listener.on(&Event::Losses { step, elapsed, loss, psnr })
    }

    fn checkpointed(&mut self, path: &Path, step: usize) -> Result<(), ModelError> {
        self.listener.on(&Event::Checkpoint { path, step })
    }
}
