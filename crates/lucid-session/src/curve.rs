//! The benchmarks' held-out curve: a trained model scored each time its training seconds
//! pass one of a list of budgets (30 s, 1, 2, 5, 10 min), on the same first test views at
//! every point; the last point scores the whole test split too, and the validation split,
//! which is what settings are to be chosen on (the test split only reports). A session's
//! [`Listener`]: it scores the model its step events carry.

use lucid_burn::run::ModelError;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::{EvalSummary, ViewScore, evaluate};
use lucid_scene::scene_model::SceneModel;
use lucid_splat::trained::TrainedSplats;
use serde::Serialize;

use crate::events::{Event, Listener};

/// One point of a curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    /// Training seconds when it was scored.
    pub seconds: f64,
    /// Steps taken by then.
    pub step: usize,
    /// Mean PSNR (dB) of the curve's views.
    pub psnr: f64,
    /// Mean SSIM of the curve's views.
    pub ssim: f64,
    /// How many views.
    pub views: usize,
    /// Gaussians in the cloud, for splats.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gaussians: Option<usize>,
}

/// The curve of one benchmark run.
pub struct BudgetCurve<'a> {
    budgets: Vec<f64>,
    test: &'a ImageSet,
    val: Option<&'a ImageSet>,
    curve_views: usize,
    /// The scored points.
    pub points: Vec<CurvePoint>,
    /// The whole test split's scores at the last budget.
    pub last: Option<EvalSummary>,
    /// The whole validation split's scores at the last budget.
    pub last_val: Option<EvalSummary>,
}

impl<'a> BudgetCurve<'a> {
    /// The benchmarks' curve: at 30 s, 1, 2, 5 and 10 min (`quick`: 5, 10 and 20 s), on the
    /// first `curve_views` views of `test`; the last point also scores `val` where given.
    pub fn benchmark(quick: bool, test: &'a ImageSet, val: Option<&'a ImageSet>, curve_views: usize) -> Self {
        let budgets = if quick { vec![5.0, 10.0, 20.0] } else { vec![30.0, 60.0, 120.0, 300.0, 600.0] };
        let curve_views = curve_views.min(test.len()).max(1);
        let val = val.filter(|v| !v.is_empty());
        Self { budgets, test, val, curve_views, points: Vec::new(), last: None, last_val: None }
    }

    /// The last budget: the run's length.
    pub fn total(&self) -> f64 {
        *self.budgets.last().expect("at least one budget")
    }

    /// Whether a point is due after `seconds` of training.
    pub fn due(&self, seconds: f64) -> bool {
        self.budgets.get(self.points.len()).is_some_and(|&b| seconds >= b)
    }

    /// Scores `model` for the next point, reached at `seconds` and `step`.
    pub fn score(&mut self, model: &dyn SceneModel, seconds: f64, step: usize) {
        let all = self.points.len() + 1 == self.budgets.len();
        let (scores, summary) =
            evaluate(model, self.test, if all { None } else { Some(self.curve_views) }, |_, _, _, _| {});
        let head = &scores[..self.curve_views.min(scores.len())];
        let mean = |f: &dyn Fn(&ViewScore) -> f64| head.iter().map(f).sum::<f64>() / head.len() as f64;
        self.points.push(CurvePoint {
            seconds,
            step,
            psnr: mean(&|v| v.psnr),
            ssim: mean(&|v| v.ssim),
            views: head.len(),
            gaussians: model.as_any().downcast_ref::<TrainedSplats>().map(|s| s.cloud().len()),
        });
        if all {
            self.last = Some(summary);
            self.last_val = self.val.map(|val| evaluate(model, val, None, |_, _, _, _| {}).1);
        }
    }
}

impl Listener for BudgetCurve<'_> {
    /// Scores the points a step has made due.
    fn on(&mut self, event: &Event<'_>) -> Result<(), ModelError> {
        if let Event::Step { step, elapsed, model, .. } = *event {
            while self.due(elapsed) {
                self.score(&*model().ok_or("a model that renders views")?, elapsed, step);
            }
        }
        Ok(())
    }
}
