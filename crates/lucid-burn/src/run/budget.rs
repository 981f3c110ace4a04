//! What ends a run, and how far along its schedule a run is.
//!
//! One meaning for every trainer:
//! - `--steps N` alone: N steps; the schedules (learning-rate decay, densification phases, SH
//!   degrees) span them.
//! - `--time-limit S` alone: S seconds of training, however many steps that is; the schedules
//!   are stretched over the seconds.
//! - both: whichever ends first; the schedules follow whichever is further along.
//! - neither: the configuration's `train.steps`, and `train.time_limit` too where it is set
//!   (then whichever ends first).

use serde::{Deserialize, Serialize};

/// The budget of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Budget {
    /// A step count.
    Steps {
        /// Steps in all.
        steps: usize,
    },
    /// Wall-clock seconds of training.
    Seconds {
        /// Seconds in all.
        seconds: f64,
    },
    /// Whichever ends first.
    First {
        /// Steps in all.
        steps: usize,
        /// Seconds in all.
        seconds: f64,
    },
}

impl Budget {
    /// The budget given `--steps` and `--time-limit` (each where given) over a configuration's
    /// `train.steps` and `train.time_limit` (0: none).
    pub fn from_limits(
        steps: Option<usize>,
        seconds: Option<f64>,
        config_steps: usize,
        config_seconds: f64,
    ) -> Result<Self, String> {
        let budget = match (steps, seconds) {
            (Some(steps), None) => Self::Steps { steps },
            (None, Some(seconds)) => Self::Seconds { seconds },
            (Some(steps), Some(seconds)) => Self::First { steps, seconds },
            (None, None) if config_seconds > 0.0 => Self::First { steps: config_steps, seconds: config_seconds },
            (None, None) => Self::Steps { steps: config_steps },
        };
        budget.validate()?;
        Ok(budget)
    }

    /// `Ok` if every limit is positive and finite.
    pub fn validate(&self) -> Result<(), String> {
        if self.steps() == Some(0) {
            return Err("the step budget must be at least 1 step".into());
        }
        match self.seconds() {
            Some(s) if !(s.is_finite() && s > 0.0) => {
                Err(format!("the time limit must be a positive number of seconds, got {s}"))
            }
            _ => Ok(()),
        }
    }

    /// The step limit, if any.
    pub fn steps(&self) -> Option<usize> {
        match *self {
            Self::Steps { steps } | Self::First { steps, .. } => Some(steps),
            Self::Seconds { .. } => None,
        }
    }

    /// The time limit in seconds, if any.
    pub fn seconds(&self) -> Option<f64> {
        match *self {
            Self::Seconds { seconds } | Self::First { seconds, .. } => Some(seconds),
            Self::Steps { .. } => None,
        }
    }

    /// The same step limit with a time limit of `seconds` (in place of any it had).
    pub fn with_seconds(self, seconds: f64) -> Self {
        match self.steps() {
            Some(steps) => Self::First { steps, seconds },
            None => Self::Seconds { seconds },
        }
    }

    /// The fraction of the budget used after `step` steps and `elapsed` seconds, in [0, 1]:
    /// the schedules' position.
    pub fn progress(&self, step: usize, elapsed: f64) -> f64 {
        let by_steps = self.steps().map_or(0.0, |n| step as f64 / n as f64);
        let by_time = self.seconds().map_or(0.0, |s| elapsed / s);
        by_steps.max(by_time).clamp(0.0, 1.0)
    }

    /// Whether the budget is spent.
    pub fn spent(&self, step: usize, elapsed: f64) -> bool {
        self.steps().is_some_and(|n| step >= n) || self.seconds().is_some_and(|s| elapsed >= s)
    }

    /// One line for logs and messages.
    pub fn describe(&self) -> String {
        match *self {
            Self::Steps { steps } => format!("{steps} steps"),
            Self::Seconds { seconds } => format!("{seconds} s"),
            Self::First { steps, seconds } => format!("{steps} steps or {seconds} s, whichever ends first"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_and_configuration_give_the_documented_budgets() {
        assert_eq!(Budget::from_limits(None, Some(600.0), 3000, 0.0), Ok(Budget::Seconds { seconds: 600.0 }));
        assert_eq!(Budget::from_limits(Some(50), None, 3000, 120.0), Ok(Budget::Steps { steps: 50 }));
        assert_eq!(Budget::from_limits(Some(50), Some(9.0), 3000, 0.0), Ok(Budget::First { steps: 50, seconds: 9.0 }));
        assert_eq!(Budget::from_limits(None, None, 3000, 0.0), Ok(Budget::Steps { steps: 3000 }));
        assert_eq!(Budget::from_limits(None, None, 3000, 60.0), Ok(Budget::First { steps: 3000, seconds: 60.0 }));
        for bad in [Budget::from_limits(Some(0), None, 1, 0.0), Budget::from_limits(None, Some(f64::NAN), 1, 0.0)] {
            assert!(bad.is_err(), "{bad:?}");
        }
        assert!(Budget::from_limits(None, Some(-1.0), 1, 0.0).unwrap_err().contains("-1"));
    }

    #[test]
    fn progress_and_the_end_follow_the_mode() {
        let steps = Budget::Steps { steps: 100 };
        assert_eq!(steps.progress(25, 1e6), 0.25);
        assert!(!steps.spent(99, 1e9) && steps.spent(100, 0.0));
        // A time budget ignores the step count, however large.
        let time = Budget::Seconds { seconds: 10.0 };
        assert_eq!(time.progress(1_000_000, 2.5), 0.25);
        assert!(!time.spent(usize::MAX, 9.99) && time.spent(0, 10.0));
        let first = Budget::First { steps: 100, seconds: 10.0 };
        assert_eq!(first.progress(50, 2.0), 0.5);
        assert_eq!(first.progress(10, 8.0), 0.8);
        assert!(first.spent(100, 0.0) && first.spent(0, 10.0) && !first.spent(99, 9.0));
        assert_eq!(first.progress(1000, 1000.0), 1.0);
    }
}
