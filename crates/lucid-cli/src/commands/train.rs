//! `lucid train nerf|splat|itm DATASET... -o OUT`: one path for every method — the session
//! layer sets the run up and trains it (budget, progress, CSV log, checkpoints by steps and
//! time, resume, the closing evaluation), and this command maps the flags, serves the live
//! viewer where asked and prints the summary.

use lucid_burn::run::ModelError;
use lucid_session::events::Event;
use lucid_session::{Listener, Method, RunRequest};

use lucid_view::live::LiveView;

/// Trains `request` with method `M`, serving the viewer's page on `view` while it trains.
pub fn run<M: Method>(request: RunRequest, view: Option<u16>) -> anyhow::Result<()> {
    let mut listener = TrainListener { view, live: None };
    let summary = lucid_session::train::<M>(&request, &mut listener)?;
    crate::training::print_summary(&summary, M::WHAT, &request.output.join(lucid_burn::run::CHECKPOINT));
    Ok(())
}

/// What the command does with a run's events: the live viewer, if asked for.
struct TrainListener {
    view: Option<u16>,
    live: Option<LiveView>,
}

impl Listener for TrainListener {
    fn on(&mut self, event: &Event<'_>) -> Result<(), ModelError> {
        match *event {
            // The viewer's port first: a port in use fails before the run writes anything.
            Event::Ready { folder, model, dataset, .. } => {
                let Some(port) = self.view else { return Ok(()) };
                let (Some(model), Some(dataset)) = (model(), dataset) else {
                    return Err("--view shows NeRF and splat runs; this method has no view of its own to serve".into());
                };
                let name = format!("training {}", folder.display());
                let live = LiveView::start(port, &name, &*model, dataset.clone())?;
                println!("viewing the run at {} (the page follows the training)", live.url());
                self.live = Some(live);
            }
            Event::Step { step, elapsed, report, model } => {
                if let Some(live) = &mut self.live {
                    live.observe(step, &|| model().expect("a run the viewer shows has a model"), report, elapsed);
                }
            }
            _ => {}
        }
        Ok(())
    }
}
