//! What a session reports while it runs, to whoever listens: typed events, in order
//! ([`Event::Ready`] once; [`Event::Step`] after every step, with [`Event::Losses`] at each
//! log row and [`Event::Checkpoint`] after each checkpoint; [`Event::Finished`] once).

use std::path::Path;

use lucid_burn::run::{Budget, ModelError, RunSummary, StepReport};
use lucid_scene::Dataset;
use lucid_scene::scene_model::SceneModel;

/// The model of a run as it is now, made when a listener needs it (none for methods that do
/// not render views).
pub type Snapshot<'a> = &'a dyn Fn() -> Option<Box<dyn SceneModel>>;

/// One thing that happened in a run.
pub enum Event<'a> {
    /// Everything is read and checked and nothing is written yet: a listener that fails here
    /// (a viewer whose port is taken) stops the run before it touches its folder.
    Ready {
        /// The checkpoint kind of the method.
        kind: &'static str,
        /// Steps already taken (a resumed run's).
        step: usize,
        /// What ends the run.
        budget: Budget,
        /// The run's folder.
        folder: &'a Path,
        /// The model as it starts.
        model: Snapshot<'a>,
        /// The dataset it trains on, where it trains on one.
        dataset: Option<&'a Dataset>,
    },
    /// A step was taken.
    Step {
        /// Steps taken so far.
        step: usize,
        /// Training seconds so far.
        elapsed: f64,
        /// What the step reported.
        report: &'a StepReport,
        /// The model after the step.
        model: Snapshot<'a>,
    },
    /// A log row: the mean loss and batch PSNR of the steps since the last row.
    Losses {
        /// Steps taken so far.
        step: usize,
        /// Training seconds so far.
        elapsed: f64,
        /// Mean loss.
        loss: f64,
        /// Mean batch PSNR in dB, where the method measures one.
        psnr: Option<f64>,
    },
    /// A checkpoint was written.
    Checkpoint {
        /// The file.
        path: &'a Path,
        /// The step it holds.
        step: usize,
    },
    /// The run ended (its budget spent, or stopped at the requested step) and its last
    /// checkpoint, exports and evaluation are written.
    Finished {
        /// What the run did.
        summary: &'a RunSummary,
        /// The last checkpoint.
        checkpoint: &'a Path,
        /// The trained model.
        model: Snapshot<'a>,
    },
}

/// Receives a run's events; its time is not counted as training time. An error stops the
/// run.
pub trait Listener {
    /// Called for each event, in order.
    fn on(&mut self, event: &Event<'_>) -> Result<(), ModelError>;
}

/// Any closure of an event listens.
impl<F: FnMut(&Event<'_>) -> Result<(), ModelError>> Listener for F {
    fn on(&mut self, event: &Event<'_>) -> Result<(), ModelError> {
        self(event)
    }
}

/// Several listeners, each told every event in turn.
#[derive(Default)]
pub struct Listeners<'a>(pub Vec<&'a mut dyn Listener>);

impl Listener for Listeners<'_> {
    fn on(&mut self, event: &Event<'_>) -> Result<(), ModelError> {
        self.0.iter_mut().try_for_each(|l| l.on(event))
    }
}
