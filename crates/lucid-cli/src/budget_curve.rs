//! The benchmarks' held-out curve: a trained model scored each time its training seconds
//! pass one of a list of budgets (30 s, 1, 2, 5, 10 min), on the same first test views at
//! every point; the last point scores the whole test split too, and the validation split,
//! which is what settings are to be chosen on (the test split only reports).

use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::{EvalSummary, ViewModel, ViewScore, evaluate};
use serde_json::{Value, json};

/// Prints the validation split's scores, the ones settings are to be chosen on.
pub fn print_validation(val: &EvalSummary) {
    println!(
        "validation split (choose settings on this): {} views, PSNR {:.2} dB, SSIM {:.4}",
        val.views, val.psnr, val.ssim
    );
}

/// The curve of one benchmark run.
pub struct BudgetCurve<'a> {
    budgets: Vec<f64>,
    test: &'a ImageSet,
    val: Option<&'a ImageSet>,
    curve_views: usize,
    /// The scored points: seconds, step, PSNR, SSIM, views (and what the caller adds).
    pub points: Vec<Value>,
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

    /// Scores `renderer` for the next point, reached at `seconds` and `step`; `extra` fields
    /// join the point.
    pub fn score(&mut self, renderer: &dyn ViewModel, seconds: f64, step: usize, extra: Value) {
        let all = self.points.len() + 1 == self.budgets.len();
        let (scores, summary) =
            evaluate(renderer, self.test, if all { None } else { Some(self.curve_views) }, |_, _, _, _| {});
        let head = &scores[..self.curve_views.min(scores.len())];
        let mean = |f: &dyn Fn(&ViewScore) -> f64| head.iter().map(f).sum::<f64>() / head.len() as f64;
        let mut point = json!({
            "seconds": seconds, "step": step, "psnr": mean(&|v| v.psnr), "ssim": mean(&|v| v.ssim),
            "views": head.len(),
        });
        if let (Some(p), Value::Object(extra)) = (point.as_object_mut(), extra) {
            p.extend(extra);
        }
        self.points.push(point);
        if all {
            self.last = Some(summary);
            self.last_val = self.val.map(|val| evaluate(renderer, val, None, |_, _, _, _| {}).1);
        }
    }
}
