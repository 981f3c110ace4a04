//! The viewer's page served while a model trains (`lucid train nerf|splat ... --view [PORT]`),
//! showing the model as it is now, the step, the loss and the held-out PSNR over time.
//!
//! The training loop calls [`LiveView`] after every step (an observer of the run, whose time
//! the run does not count as training time). It answers at most one waiting request per step,
//! and only when the time it expects the answer to take (the cost per pixel a small probe
//! render measured, times the request's pixels) fits in the credit of its [`TimeShare`]: time
//! earned at [`VIEW_SHARE`] of the wall time, banked only up to what the waiting request
//! needs (or [`IDLE_BANK`] when none waits). Otherwise the request waits and the steps go
//! first. So one expensive render (an early NeRF marches through a grid that is still all
//! occupied) is not followed by another until training has earned it, and a page opened after
//! an hour of training does not spend the hour's share in a burst. Every [`HELD_OUT_EVERY`]
//! seconds, within a share of its own ([`SCORE_SHARE`]), it scores a few held-out views.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use lucid_burn::run::StepReport;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::evaluate;
use lucid_scene::{Dataset, Intrinsics, PinholeCamera, Split};
use serde_json::{Value, json};

use super::answers::ViewedScene;
use super::queue::Job;
use super::requests::Route;
use super::{ViewError, ViewServer, info};
use lucid_scene::scene_model::SceneModel;

/// The model of a run as it is now, made when a render needs it.
pub type Snapshot<'m> = &'m dyn Fn() -> Box<dyn SceneModel>;

/// The most of the wall time the viewer may take from training for the page's renders, and
/// for the held-out scores: 6.5 % together, leaving room under the 10 % the viewer may cost
/// for the browser, which shares the CPU. Separate shares, so neither starves the other.
pub const VIEW_SHARE: f64 = 0.05;
/// See [`VIEW_SHARE`].
pub const SCORE_SHARE: f64 = 0.015;
/// Seconds of credit a [`TimeShare`] keeps while nothing waits: a page opened late gets its
/// first frames at once, but not a burst of frames paid for by the time it was closed.
pub const IDLE_BANK: f64 = 0.25;
/// Seconds between held-out scores.
pub const HELD_OUT_EVERY: f64 = 10.0;
/// Held-out views scored each time (spread over the validation split, else the test split).
const HELD_OUT_VIEWS: usize = 3;
/// Seconds between probes of the cost of a render, and the probe's side in pixels.
const PROBE_EVERY: f64 = 5.0;
const PROBE_SIDE: u32 = 32;

fn pixels_of(set: &ImageSet) -> f64 {
    (0..set.len()).map(|i| set.size(i)).map(|(w, h)| (w * h) as f64).sum()
}

/// A share of the wall time for one kind of work: credit earned at `share` seconds per wall
/// second, banked up to the larger of [`IDLE_BANK`] and the expected cost of what waits.
#[derive(Debug)]
struct TimeShare {
    share: f64,
    credit: f64,
    earned_until: Instant,
    /// Seconds spent in all.
    spent: f64,
}

impl TimeShare {
    fn new(share: f64) -> Self {
        Self { share, credit: 0.0, earned_until: Instant::now(), spent: 0.0 }
    }

    /// Adds what the wall time since the last call earned; `waiting` is the expected cost of
    /// the work that waits for it (0 when none does).
    fn earn(&mut self, now: Instant, waiting: f64) {
        let cap = if waiting.is_finite() { waiting.max(IDLE_BANK) } else { IDLE_BANK };
        self.credit = (self.credit + self.share * (now - self.earned_until).as_secs_f64()).min(cap);
        self.earned_until = now;
    }

    fn allows(&self, cost: f64) -> bool {
        cost <= self.credit
    }

    /// Pays the wall time since `began` out of the credit (which may go below zero: the
    /// estimate was short, and the steps get the difference back before the next job).
    fn pay(&mut self, began: Instant) {
        self.pay_seconds(began.elapsed().as_secs_f64());
    }

    fn pay_seconds(&mut self, seconds: f64) {
        self.credit -= seconds;
        self.spent += seconds;
    }
}

/// The live viewer of one training run.
pub struct LiveView {
    server: ViewServer,
    dataset: Dataset,
    status: Arc<Mutex<Value>>,
    held_out: Option<(Split, ImageSet)>,
    /// A request taken from the queue, waiting for the share to allow it.
    pending: Option<Job>,
    /// Seconds per rendered pixel, measured by the last probe, and when.
    seconds_per_pixel: Option<f64>,
    probed: Option<Instant>,
    started: Instant,
    /// Time for the page's renders (and probes), and for the held-out scores.
    viewing: TimeShare,
    scoring: TimeShare,
    last_score: Option<Instant>,
    scores: Vec<Value>,
    losses: Vec<Value>,
    /// Mean loss and batch PSNR since the last point of `losses`.
    window: (f64, f64, usize),
}

impl LiveView {
    /// The page's address.
    pub fn url(&self) -> &str {
        &self.server.url
    }

    /// Starts serving `model` (as it is before its first step) on 127.0.0.1:`port`.
    pub fn start(port: u16, name: &str, model: &dyn SceneModel, dataset: Dataset) -> Result<Self, ViewError> {
        let status = Arc::new(Mutex::new(json!({ "step": model.step(), "training": true })));
        let info = info(name, model, Some(&dataset), true);
        // One request waits; more are told to retry: the page keeps one in flight.
        let server = ViewServer::start("127.0.0.1", port, info, Some(status.clone()), 1)?;
        let held_out = [Split::Val, Split::Test].into_iter().find_map(|split| {
            let frames = dataset.frames(split);
            let n = frames.len().min(HELD_OUT_VIEWS);
            let chosen: Vec<_> = (0..n).map(|k| frames[k * frames.len() / n].clone()).collect();
            let set = ImageSet::load(&chosen).ok()?;
            (!set.is_empty()).then_some((split, set))
        });
        Ok(Self {
            server,
            dataset,
            status,
            held_out,
            pending: None,
            seconds_per_pixel: None,
            probed: None,
            started: Instant::now(),
            viewing: TimeShare::new(VIEW_SHARE),
            scoring: TimeShare::new(SCORE_SHARE),
            last_score: Some(Instant::now()),
            scores: Vec::new(),
            losses: Vec::new(),
            window: (0.0, 0.0, 0),
        })
    }

    /// Answers what waits and scores what is due after step `step`, within the time shares.
    pub fn observe(&mut self, step: usize, model: Snapshot, report: &StepReport, elapsed: f64) {
        let (loss, psnr, n) = &mut self.window;
        *loss += f64::from(report.loss);
        *psnr += report.psnr.map_or(0.0, f64::from);
        *n += 1;
        if step.is_multiple_of(25) {
            let (loss, psnr, n) = std::mem::take(&mut self.window);
            let n = n.max(1) as f64;
            self.losses.push(json!({ "step": step, "seconds": elapsed, "loss": loss / n, "psnr": psnr / n }));
        }
        let mut changed = step.is_multiple_of(10);
        if self.pending.is_none() {
            self.pending = self.server.queue.try_next();
        }
        if self.pending.as_ref().is_some_and(Job::abandoned) {
            self.pending = None;
        }
        // Before the first probe a render's cost is unknown (infinite); a request that renders
        // nothing (a dataset image) costs nothing.
        let per_pixel = self.seconds_per_pixel.unwrap_or(f64::INFINITY);
        let cost = |pixels: f64| if pixels > 0.0 { pixels * per_pixel } else { 0.0 };
        let score_due = self.score_is_due();
        let score_cost = self.held_out.as_ref().map_or(0.0, |(_, set)| cost(pixels_of(set)));
        let render_cost = self.pending.as_ref().map(|job| cost(self.pixels(&job.route)));
        let now = Instant::now();
        self.viewing.earn(now, render_cost.unwrap_or(0.0));
        self.scoring.earn(now, if score_due { score_cost } else { 0.0 });
        // The cost of a render changes as the model learns (an early NeRF marches through a
        // grid that is still all occupied): a small probe keeps the estimate current.
        if self.probed.is_none_or(|t| t.elapsed().as_secs_f64() >= PROBE_EVERY)
            && (self.pending.is_some() || score_due)
            && self.viewing.credit > 0.0
        {
            let began = Instant::now();
            self.seconds_per_pixel = self.probe(model);
            self.viewing.pay(began);
            self.probed = Some(Instant::now());
            return;
        }
        if score_due && self.scoring.allows(score_cost) {
            let began = Instant::now();
            self.score(step, model, elapsed);
            self.scoring.pay(began);
            self.last_score = Some(Instant::now());
            changed = true;
        } else if let Some(cost) = render_cost
            && self.viewing.allows(cost)
            && let Some(job) = self.pending.take()
        {
            let began = Instant::now();
            let dataset = Some(&self.dataset);
            job.answer_from(&ViewedScene { renderer: &*model(), dataset });
            self.viewing.pay(began);
        }
        if !changed {
            return;
        }
        if let Ok(mut status) = self.status.lock() {
            *status = json!({
                "training": true,
                "step": step,
                "seconds": elapsed,
                "loss": report.loss,
                "psnr": report.psnr,
                "losses": self.losses,
                "held_out": self.scores,
                "held_out_split": self.held_out.as_ref().map(|(s, _)| s.name()),
                "view_share": (self.viewing.spent + self.scoring.spent) / self.started.elapsed().as_secs_f64().max(1e-9),
            });
        }
    }

    /// Pixels a request renders: its cost in units of the last render's cost per pixel.
    fn pixels(&self, route: &Route) -> f64 {
        let area = |k: lucid_scene::Intrinsics| f64::from(k.width) * f64::from(k.height);
        match route {
            Route::Render(view) => {
                let rays = if view.lens.is_some() { view.lens_rays } else { 1 };
                area(view.camera.intrinsics) * rays as f64
            }
            Route::Depth { .. } => 1.0,
            Route::Compare { frame, .. } => {
                self.dataset.frames(frame.split).get(frame.index).map_or(0.0, |f| area(f.camera.intrinsics))
            }
            _ => 0.0,
        }
    }

    fn score_is_due(&self) -> bool {
        self.held_out.is_some() && self.last_score.is_none_or(|t| t.elapsed().as_secs_f64() >= HELD_OUT_EVERY)
    }

    fn score(&mut self, step: usize, model: Snapshot, elapsed: f64) {
        let Some((_, set)) = &self.held_out else { return };
        let (_, summary) = evaluate(&*model(), set, None, |_, _, _, _| {});
        self.scores.push(json!({ "step": step, "seconds": elapsed, "psnr": summary.psnr }));
    }

    /// Seconds per pixel of a small render at a held-out camera (or at the first dataset
    /// camera), whose middle it covers.
    fn probe(&self, model: Snapshot) -> Option<f64> {
        let camera = match &self.held_out {
            Some((_, set)) => set.cameras[0],
            None => self.dataset.all_frames().next()?.camera,
        };
        let k = camera.intrinsics;
        let side = PROBE_SIDE.min(k.width).min(k.height);
        let middle = Intrinsics {
            width: side,
            height: side,
            cx: k.cx - (k.width - side) as f32 / 2.0,
            cy: k.cy - (k.height - side) as f32 / 2.0,
            ..k
        };
        let started = Instant::now();
        model().render_view(&PinholeCamera::new(middle, camera.camera_to_world), None, 1, 0);
        Some(started.elapsed().as_secs_f64() / f64::from(side * side))
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_time_share_banks_only_what_waits() {
        let mut share = TimeShare::new(0.05);
        let start = share.earned_until;
        let at = |seconds: u64| start + Duration::from_secs(seconds);
        // An hour with nothing waiting leaves the idle bank, not 180 s of renders.
        share.earn(at(3600), 0.0);
        assert_eq!(share.credit, IDLE_BANK);
        assert!(share.allows(IDLE_BANK) && !share.allows(0.3));
        // A 2-second render waits 40 s at 5 %, from the idle bank on, and is then allowed.
        share.earn(at(3630), 2.0);
        assert!((share.credit - (IDLE_BANK + 1.5)).abs() < 1e-9, "{}", share.credit);
        assert!(!share.allows(2.0));
        share.earn(at(3640), 2.0);
        assert_eq!(share.credit, 2.0);
        assert!(share.allows(2.0));
        // A render that took longer than expected leaves a debt the next one waits out.
        share.pay_seconds(2.5);
        assert!((share.credit + 0.5).abs() < 1e-9 && share.spent == 2.5);
        share.earn(at(3650), 0.1);
        assert!((share.credit - 0.0).abs() < 1e-9, "{}", share.credit);
        assert!(!share.allows(0.1));
        // An unknown cost (before the first probe) banks no more than the idle bank.
        share.earn(at(7200), f64::INFINITY);
        assert_eq!(share.credit, IDLE_BANK);
    }
}
