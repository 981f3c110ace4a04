//! A running average of the parameters over the end of the budget, the model that is
//! evaluated and rendered.
//!
//! Adam's steps keep the hash table and the MLP jittering about the minimum the learning rate
//! allows them to reach, and a held-out view sees that jitter as noise: the mean of the last
//! few thousand iterates sits closer to the minimum than any one of them (Polyak averaging;
//! measured on the benchmark sets' validation views in the README). Training goes on from the
//! raw parameters; only evaluation, rendering and export use the average.

use thiserror::Error;

/// Steps between updates: the parameters drift by far less than the window between two of
/// them, and each update copies the whole table.
pub const AVERAGE_EVERY: usize = 4;

/// How many windows before the end of the budget the average starts: the start's weight in
/// the final average is then below e⁻³.
const START_WINDOWS: f64 = 4.0;

/// The averaged parameters and where the average stands.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterAverage {
    /// Where the average stands (a checkpoint's header records it).
    pub state: AverageState,
    /// The averaged hash table.
    pub table: Vec<f32>,
    /// The averaged MLP weights.
    pub mlp: Vec<f32>,
}

/// A damaged average in a checkpoint.
#[derive(Debug, Error, PartialEq)]
#[error("parameter average: {0}")]
pub struct AverageError(String);

impl ParameterAverage {
    /// Whether an average of time constant `window` runs at budget fraction `progress`.
    pub fn active(window: f64, progress: f64) -> bool {
        window > 0.0 && progress >= 1.0 - START_WINDOWS * window
    }

    /// An average that starts from these parameters.
    pub fn start(progress: f64, table: Vec<f32>, mlp: Vec<f32>) -> Self {
        Self { state: AverageState { progress, updates: 1 }, table, mlp }
    }

    /// Takes in the parameters at budget fraction `progress`: over the first window the
    /// average is the plain mean of the parameters it saw, afterwards an exponential moving
    /// average whose time constant is the window (each update weighs the budget fraction
    /// since the last one, over the window). A run resumed with a larger budget goes back in
    /// `progress`: the average starts again from these parameters. `window` is the run's
    /// current one (the configuration's, not recorded beside the average): a run resumed with
    /// another `train.average_window` goes on with it.
    pub fn update(&mut self, table: &[f32], mlp: &[f32], progress: f64, window: f64) {
        use rayon::prelude::*;
        assert_eq!((table.len(), mlp.len()), (self.table.len(), self.mlp.len()), "parameter shapes changed");
        assert!(window > 0.0, "an average needs a positive window");
        let state = &mut self.state;
        if progress < state.progress {
            *self = Self::start(progress, table.to_vec(), mlp.to_vec());
            return;
        }
        state.updates += 1;
        let weight = ((progress - state.progress) / window).max(1.0 / state.updates as f64).min(1.0) as f32;
        state.progress = progress;
        let blend = |avg: &mut [f32], new: &[f32]| {
            for (a, &x) in avg.iter_mut().zip(new) {
                *a += weight * (x - *a);
            }
        };
        self.table.par_chunks_mut(1 << 16).zip(table.par_chunks(1 << 16)).for_each(|(a, x)| blend(a, x));
        blend(&mut self.mlp, mlp);
    }

    /// The averaged parameters as bytes (little-endian `f32`, table then MLP) for a
    /// checkpoint section; the header keeps the rest ([`AverageState`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        self.table.iter().chain(&self.mlp).flat_map(|v| v.to_le_bytes()).collect()
    }

    /// An average from its state and the values of a section written by [`Self::to_bytes`],
    /// for a model of `table` and `mlp` parameters.
    pub fn from_parts(
        state: AverageState,
        mut values: Vec<f32>,
        table: usize,
        mlp: usize,
    ) -> Result<Self, AverageError> {
        if values.len() != table + mlp {
            return Err(AverageError(format!("{} values, the model has {}", values.len(), table + mlp)));
        }
        if !state.progress.is_finite() {
            return Err(AverageError(format!("progress {}", state.progress)));
        }
        let mlp = values.split_off(table);
        Ok(Self { state, table: values, mlp })
    }
}

/// Where an average stands, recorded in a checkpoint's header beside its parameters. Its
/// time constant is the configuration's `train.average_window` (headers written before
/// 2026-12-05 also hold a `window`, which is read past).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AverageState {
    /// Budget fraction at the last update.
    pub progress: f64,
    /// Updates so far.
    pub updates: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_four_windows_before_the_end_and_only_when_on() {
        assert!(!ParameterAverage::active(0.1, 0.59));
        assert!(ParameterAverage::active(0.1, 0.6));
        assert!(ParameterAverage::active(0.1, 1.3));
        assert!(!ParameterAverage::active(0.0, 1.0));
        assert!(ParameterAverage::active(0.5, 0.0));
    }

    /// Within the first window the average is the arithmetic mean of what it saw.
    #[test]
    fn the_first_window_is_the_plain_mean() {
        let mut avg = ParameterAverage::start(0.6, vec![1.0, -2.0], vec![0.5]);
        let values = [(3.0f32, 4.0f32, 1.5f32), (-1.0, 0.0, 2.5), (7.0, 1.0, -0.5)];
        for (i, &(a, b, c)) in values.iter().enumerate() {
            avg.update(&[a, b], &[c], 0.6 + 0.01 * (i + 1) as f64, 0.1);
        }
        let mean = |f: fn(&(f32, f32, f32)) -> f32, first: f32| (values.iter().map(f).sum::<f32>() + first) / 4.0;
        assert!((avg.table[0] - mean(|v| v.0, 1.0)).abs() < 1e-6, "{:?}", avg.table);
        assert!((avg.table[1] - mean(|v| v.1, -2.0)).abs() < 1e-6, "{:?}", avg.table);
        assert!((avg.mlp[0] - mean(|v| v.2, 0.5)).abs() < 1e-6, "{:?}", avg.mlp);
    }

    /// Past its first window the average is an exponential moving average of time constant
    /// `window`: following a parameter that rises steadily by 1 per unit of budget, it lags
    /// behind it by the window (the steady state of dA/dt = (x − A)/w for x = t).
    #[test]
    fn then_it_lags_a_ramp_by_its_window() {
        let window = 0.05;
        let mut avg = ParameterAverage::start(0.0, vec![0.0], vec![0.0]);
        let dt = 1e-4;
        let mut t = 0.0;
        while t < 1.0 {
            t += dt;
            avg.update(&[t as f32], &[2.0 * t as f32], t, window);
        }
        let lag = t - avg.table[0] as f64;
        assert!((lag - window).abs() < 0.02 * window, "lag {lag} against window {window}");
        assert!((2.0 * t - avg.mlp[0] as f64 - 2.0 * window).abs() < 0.04 * window);
    }

    /// A run resumed with another window goes on with it: after five of the new windows the
    /// average lags a ramp by the new window, not the one it started with.
    #[test]
    fn a_changed_window_takes_over() {
        let mut avg = ParameterAverage::start(0.0, vec![0.0], vec![0.0]);
        let dt = 1e-4;
        let mut t = 0.0;
        while t < 1.0 {
            t += dt;
            avg.update(&[t as f32], &[0.0], t, if t < 0.5 { 0.05 } else { 0.1 });
        }
        let lag = t - avg.table[0] as f64;
        assert!((lag - 0.1).abs() < 0.002, "lag {lag} against the new window 0.1");
    }

    #[test]
    fn a_larger_budget_starts_it_again() {
        let mut avg = ParameterAverage::start(0.9, vec![1.0], vec![2.0]);
        avg.update(&[3.0], &[4.0], 0.95, 0.1);
        avg.update(&[5.0], &[6.0], 0.7, 0.1);
        assert_eq!(avg, ParameterAverage::start(0.7, vec![5.0], vec![6.0]));
    }

    #[test]
    fn round_trips_through_bytes_and_rejects_damage() {
        let mut avg = ParameterAverage::start(0.7, vec![1.0, 2.0, 3.0], vec![4.0, 5.0]);
        avg.update(&[0.0, 0.0, 0.0], &[1.0, 1.0], 0.71, 0.1);
        let values = crate::checkpoint::le_f32s(&avg.to_bytes()).expect("whole values");
        assert_eq!(ParameterAverage::from_parts(avg.state, values.clone(), 3, 2), Ok(avg.clone()));
        let short = ParameterAverage::from_parts(avg.state, values[..4].to_vec(), 3, 2).unwrap_err();
        assert!(short.to_string().contains("4 values, the model has 5"), "{short}");
        let bad = AverageState { progress: f64::NAN, ..avg.state };
        assert!(ParameterAverage::from_parts(bad, values, 3, 2).is_err());
    }
}
