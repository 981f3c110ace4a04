//! The loop on a toy model: stochastic gradient descent on a quadratic whose targets are
//! drawn per step from the step number, with a learning rate that decays with the schedule
//! position, so that resuming, budgets and schedules are all visible in its parameters.

use std::path::Path;
use std::time::Duration;

use super::*;
use crate::checkpoint::{read_kind_sections, write_sections};

#[derive(Clone, Debug, PartialEq)]
struct Toy {
    w: [f64; 3],
    step: usize,
    /// Sleep per step, to make time budgets testable.
    pause: Duration,
    /// The step whose loss is NaN.
    diverge_at: Option<usize>,
    /// The step after which `unused` is NaN (the loss stays finite).
    poison_at: Option<usize>,
    /// A parameter the loss does not see, like a Gaussian culled from every view.
    unused: f64,
    /// Schedule positions seen.
    progress: Vec<f64>,
    saves: usize,
}

impl Toy {
    fn new(pause_ms: u64) -> Self {
        Self {
            w: [0.0; 3],
            step: 0,
            pause: Duration::from_millis(pause_ms),
            diverge_at: None,
            poison_at: None,
            unused: 0.0,
            progress: vec![],
            saves: 0,
        }
    }

    fn load(path: &Path) -> (Self, f64) {
        let (header, _) = read_kind_sections(path, "toy").unwrap();
        let w: Vec<f64> = serde_json::from_value(header["w"].clone()).unwrap();
        let mut toy = Self::new(0);
        toy.w = [w[0], w[1], w[2]];
        toy.step = header["step"].as_u64().unwrap() as usize;
        (toy, header["elapsed"].as_f64().unwrap())
    }
}

impl Trainable for Toy {
    fn steps_taken(&self) -> usize {
        self.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        std::thread::sleep(self.pause);
        self.progress.push(progress);
        let mut rng = splitmix(self.step as u64);
        let target = [1.0 + rng(), -2.0 + rng(), 0.5 + rng()];
        let lr = 0.3 * 0.1f64.powf(progress);
        let mut loss = 0.0;
        for (w, t) in self.w.iter_mut().zip(target) {
            loss += (*w - t) * (*w - t);
            *w -= lr * 2.0 * (*w - t);
        }
        self.step += 1;
        if self.diverge_at == Some(self.step) {
            loss = f64::NAN;
        }
        if self.poison_at == Some(self.step) {
            self.unused = f64::NAN;
        }
        StepReport { loss: loss as f32, psnr: None, columns: vec![lr], phases: vec![("update", 1e-6)] }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &["learning_rate"]
    }

    fn non_finite(&self) -> Option<String> {
        self.w.iter().chain([&self.unused]).any(|w| !w.is_finite()).then(|| "w".to_string())
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        let header = serde_json::json!({"kind": "toy", "w": self.w, "step": self.step, "elapsed": elapsed});
        write_sections(path, &[header.to_string().as_bytes()])
    }
}

/// Counts saves (the toy's `save` takes `&self`).
struct Counting(Toy);

impl Trainable for Counting {
    fn steps_taken(&self) -> usize {
        self.0.steps_taken()
    }
    fn step(&mut self, progress: f64) -> StepReport {
        self.0.step(progress)
    }
    fn log_columns(&self) -> &'static [&'static str] {
        self.0.log_columns()
    }
    fn non_finite(&self) -> Option<String> {
        self.0.non_finite()
    }
    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        let n: usize = std::fs::read_to_string(path.with_extension("count")).map_or(0, |s| s.parse().unwrap());
        std::fs::write(path.with_extension("count"), (n + 1).to_string()).unwrap();
        self.0.save(path, elapsed)
    }
}

/// Uniform numbers in [0, 1) from a seed (SplitMix64).
fn splitmix(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn options(dir: &Path, budget: Budget) -> RunOptions {
    RunOptions {
        checkpoint: Some(dir.join("checkpoint.lucid")),
        log: Some(dir.join("train_log.csv")),
        log_every: 5,
        checkpoint_every: 10,
        ..RunOptions::new(budget)
    }
}

fn log_steps(dir: &Path) -> (Vec<String>, Vec<usize>) {
    let text = std::fs::read_to_string(dir.join("train_log.csv")).unwrap();
    let headers = text.lines().filter(|l| l.starts_with("step")).map(String::from).collect();
    let steps = text.lines().filter_map(|l| l.split(',').next()?.parse().ok()).collect();
    (headers, steps)
}

#[test]
fn a_run_stopped_and_resumed_ends_where_an_uninterrupted_one_does() {
    let budget = Budget::Steps { steps: 60 };
    let whole_dir = tempfile::tempdir().unwrap();
    let mut whole = Toy::new(0);
    let summary = run(&mut whole, &options(whole_dir.path(), budget), &mut NoObserver).unwrap();
    assert_eq!((summary.steps, summary.interrupted), (60, false));

    let dir = tempfile::tempdir().unwrap();
    let mut first = Toy::new(0);
    let stopped = run(&mut first, &RunOptions { until: Some(23), ..options(dir.path(), budget) }, &mut NoObserver);
    assert!(stopped.unwrap().interrupted);
    // As if killed after step 27: log rows past the checkpoint (23) that a resume must drop.
    let mut log = std::fs::read_to_string(dir.path().join("train_log.csv")).unwrap();
    log.push_str("25,0.1,1,,0.1\n27,0.1");
    std::fs::write(dir.path().join("train_log.csv"), log).unwrap();

    let (mut resumed, elapsed) = Toy::load(&dir.path().join("checkpoint.lucid"));
    assert_eq!(resumed.step, 23);
    let options = RunOptions { elapsed, resumed: true, ..options(dir.path(), budget) };
    run(&mut resumed, &options, &mut NoObserver).unwrap();
    assert_eq!(resumed.w, whole.w, "bit-identical parameters");
    assert_eq!(Toy::load(&dir.path().join("checkpoint.lucid")).0.w, whole.w);

    let (headers, steps) = log_steps(dir.path());
    assert_eq!(headers, ["step,seconds,loss,psnr,learning_rate"]);
    assert!(steps.windows(2).all(|w| w[0] < w[1]), "{steps:?}");
    assert_eq!(steps, log_steps(whole_dir.path()).1);
}

#[test]
fn each_budget_mode_ends_and_schedules_as_documented() {
    let dir = tempfile::tempdir().unwrap();
    // Steps: exactly that many, the schedule at k/N before step k.
    let mut toy = Toy::new(1);
    run(&mut toy, &RunOptions::new(Budget::Steps { steps: 8 }), &mut NoObserver).unwrap();
    assert_eq!(toy.step, 8);
    assert_eq!(toy.progress, (0..8).map(|k| k as f64 / 8.0).collect::<Vec<_>>());

    // Seconds: as many steps as fit, however many; the schedule spans the seconds.
    let mut toy = Toy::new(2);
    let summary = run(&mut toy, &RunOptions::new(Budget::Seconds { seconds: 0.2 }), &mut NoObserver).unwrap();
    assert!(summary.elapsed >= 0.2 && summary.elapsed < 0.4, "{}", summary.elapsed);
    assert!(toy.step >= 20, "{} steps", toy.step);
    let last = *toy.progress.last().unwrap();
    assert!(last > 0.8 && last < 1.0, "schedule reached {last}");
    assert!(toy.progress.windows(2).all(|w| w[0] < w[1]));

    // The last step of a time budget gets a log row whatever its number.
    let options = RunOptions {
        log: Some(dir.path().join("train_log.csv")),
        log_every: 1000,
        ..RunOptions::new(Budget::Seconds { seconds: 0.05 })
    };
    let mut toy = Toy::new(2);
    run(&mut toy, &options, &mut NoObserver).unwrap();
    assert_eq!(log_steps(dir.path()).1, [toy.step]);

    // Both: whichever ends first.
    let mut toy = Toy::new(1);
    run(&mut toy, &RunOptions::new(Budget::First { steps: 5, seconds: 100.0 }), &mut NoObserver).unwrap();
    assert_eq!(toy.step, 5);
    let mut toy = Toy::new(2);
    let budget = Budget::First { steps: 1_000_000, seconds: 0.05 };
    let summary = run(&mut toy, &RunOptions::new(budget), &mut NoObserver).unwrap();
    assert!(toy.step < 1000 && summary.elapsed >= 0.05);
    drop(dir);
}

#[test]
fn checkpoints_come_by_time_as_well_as_by_steps() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("checkpoint.lucid");
    let count = || std::fs::read_to_string(path.with_extension("count")).unwrap().parse::<usize>().unwrap();
    // No step interval: a save every 50 ms of training, and one at the end.
    let options = RunOptions {
        checkpoint: Some(path.clone()),
        checkpoint_seconds: 0.05,
        ..RunOptions::new(Budget::Seconds { seconds: 0.3 })
    };
    run(&mut Counting(Toy::new(5)), &options, &mut NoObserver).unwrap();
    assert!((5..=8).contains(&count()), "{} saves", count());
    std::fs::remove_file(path.with_extension("count")).unwrap();
    let options = RunOptions { checkpoint_seconds: 0.0, ..options };
    run(&mut Counting(Toy::new(5)), &options, &mut NoObserver).unwrap();
    assert_eq!(count(), 1);
}

#[test]
fn a_diverging_run_fails_naming_the_step_and_keeps_the_last_good_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let mut toy = Toy::new(0);
    toy.diverge_at = Some(17);
    let err = run(&mut toy, &options(dir.path(), Budget::Steps { steps: 50 }), &mut NoObserver).unwrap_err();
    assert!(err.to_string().contains("diverged at step 17"), "{err}");
    assert_eq!(Toy::load(&dir.path().join("checkpoint.lucid")).0.step, 10);
}

#[test]
fn non_finite_parameters_stop_the_run_before_any_checkpoint_holds_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut toy = Toy::new(0);
    toy.poison_at = Some(17);
    let err = run(&mut toy, &options(dir.path(), Budget::Steps { steps: 50 }), &mut NoObserver).unwrap_err();
    // Found at the next log row (every 5 steps).
    assert!(err.to_string().contains("diverged by step 20: w holds NaN"), "{err}");
    let (kept, _) = Toy::load(&dir.path().join("checkpoint.lucid"));
    assert_eq!(kept.step, 10);
    assert!(kept.w.iter().all(|w| w.is_finite()), "the kept checkpoint is finite");
    // Poisoned just before a checkpoint is due: the checkpoint is not written.
    let dir = tempfile::tempdir().unwrap();
    let mut toy = Toy::new(0);
    toy.poison_at = Some(20);
    let options = RunOptions { log_every: 1000, ..options(dir.path(), Budget::Steps { steps: 50 }) };
    let err = run(&mut toy, &options, &mut NoObserver).unwrap_err();
    assert!(err.to_string().contains("step 20"), "{err}");
    assert_eq!(Toy::load(&dir.path().join("checkpoint.lucid")).0.step, 10);
}

#[test]
fn the_observers_time_is_not_training_time() {
    struct Slow(Vec<(usize, f64)>);
    impl Observer<Toy> for Slow {
        fn after_step(&mut self, model: &Toy, _: &StepReport, elapsed: f64) -> Result<(), ModelError> {
            std::thread::sleep(Duration::from_millis(20));
            self.0.push((model.step, elapsed));
            Ok(())
        }
    }
    let mut slow = Slow(Vec::new());
    let summary = run(&mut Toy::new(0), &RunOptions::new(Budget::Steps { steps: 10 }), &mut slow).unwrap();
    assert!(summary.elapsed < 0.1, "{}", summary.elapsed);
    assert_eq!(slow.0.iter().map(|s| s.0).collect::<Vec<_>>(), (1..=10).collect::<Vec<_>>());
    // And a failing observer stops the run with its message.
    struct Failing;
    impl Observer<Toy> for Failing {
        fn after_step(&mut self, _: &Toy, _: &StepReport, _: f64) -> Result<(), ModelError> {
            Err("no space left".into())
        }
    }
    let err = run(&mut Toy::new(0), &RunOptions::new(Budget::Steps { steps: 10 }), &mut Failing).unwrap_err();
    assert_eq!(err.to_string(), "after step 1: no space left");
}
