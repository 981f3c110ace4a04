//! A session driven by a small method with no model: the order of its events, the three
//! budget modes, resuming, and checkpoints by time.

use std::path::Path;
use std::time::Duration;

use lucid_burn::checkpoint::CheckpointError;
use lucid_burn::memory::MemoryEstimate;
use lucid_burn::run::{Budget, ModelError, Start, StepReport, Trainable};
use lucid_session::events::Event;
use lucid_session::{Method, RunRequest, SessionError, TrainSettings};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct CountConfig {
    train: CountTrain,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct CountTrain {
    steps: usize,
    time_limit: f64,
    seed: u64,
    checkpoint_every: usize,
    /// Milliseconds each step sleeps (a step that takes time, for the time budgets).
    step_ms: u64,
}

impl Default for CountTrain {
    fn default() -> Self {
        Self { steps: 10, time_limit: 0.0, seed: 0, checkpoint_every: 0, step_ms: 0 }
    }
}

/// Counts its steps; its loss is a function of the step and the schedule position.
struct Counter {
    config: CountConfig,
    step: usize,
}

impl Trainable for Counter {
    fn steps_taken(&self) -> usize {
        self.step
    }

    fn step(&mut self, progress: f64) -> StepReport {
        std::thread::sleep(Duration::from_millis(self.config.train.step_ms));
        self.step += 1;
        StepReport { loss: 1.0 / self.step as f32, columns: vec![progress], ..StepReport::default() }
    }

    fn log_columns(&self) -> &'static [&'static str] {
        &["progress"]
    }

    fn non_finite(&self) -> Option<String> {
        None
    }

    fn save(&self, path: &Path, elapsed: f64) -> Result<(), CheckpointError> {
        let header =
            serde_json::json!({ "kind": "count", "step": self.step, "elapsed": elapsed, "config": self.config });
        lucid_burn::checkpoint::write_sections(path, &[header.to_string().as_bytes()])
    }
}

struct Count;

impl Method for Count {
    type Config = CountConfig;
    type Trainer<'a> = Counter;
    const KIND: &'static str = "count";
    const LABEL: &'static str = "";
    const WHAT: &'static str = "a counter";

    fn parse_config(text: &str, origin: &str) -> Result<CountConfig, String> {
        toml::from_str(text).map_err(|e| format!("{origin}: {e}"))
    }

    fn open(_: &RunRequest, _: Option<&CountConfig>) -> Result<Self, SessionError> {
        Ok(Count)
    }

    fn memory_estimate(&self, _: &CountConfig) -> MemoryEstimate {
        MemoryEstimate::default()
    }

    fn fingerprint(&self) -> Result<String, SessionError> {
        Ok("counting".into())
    }

    fn init(&self, config: CountConfig) -> Result<Counter, SessionError> {
        Ok(Counter { config, step: 0 })
    }

    fn resume(&self, checkpoint: &Path) -> Result<(Counter, f64), SessionError> {
        let header = lucid_burn::checkpoint::read_header(checkpoint).map_err(|e| SessionError::read("resuming", e))?;
        let config = serde_json::from_value(header["config"].clone()).map_err(|e| SessionError::read("resuming", e))?;
        let step = header["step"].as_u64().unwrap() as usize;
        Ok((Counter { config, step }, header["elapsed"].as_f64().unwrap()))
    }

    fn settings(c: &Counter) -> TrainSettings {
        let t = &c.config.train;
        TrainSettings { steps: t.steps, time_limit: t.time_limit, checkpoint_every: t.checkpoint_every, log_every: 1 }
    }

    fn set_steps(c: &mut Counter, steps: usize) {
        c.config.train.steps = steps;
    }

    fn config(c: &Counter) -> &CountConfig {
        &c.config
    }

    fn describe(&self, c: &Counter) -> String {
        format!("counting from {}", c.step)
    }
}

/// What the listener heard, one word an event.
#[derive(Debug, PartialEq)]
enum Heard {
    Ready { step: usize, budget: Budget, model: bool },
    Step(usize),
    Losses(usize),
    Checkpoint(usize),
    Finished { steps: usize, interrupted: bool },
}

fn train(request: &RunRequest) -> Result<Vec<Heard>, SessionError> {
    let mut heard = Vec::new();
    let mut listener = |event: &Event<'_>| -> Result<(), ModelError> {
        heard.push(match *event {
            Event::Ready { step, budget, model, .. } => Heard::Ready { step, budget, model: model().is_some() },
            Event::Step { step, .. } => Heard::Step(step),
            Event::Losses { step, loss, .. } => {
                assert!((loss - 1.0 / step as f64).abs() < 1e-6, "a row of one step has that step's loss");
                Heard::Losses(step)
            }
            Event::Checkpoint { step, path } => {
                assert!(path.ends_with("checkpoint.lucid") && path.is_file());
                Heard::Checkpoint(step)
            }
            Event::Finished { summary, .. } => {
                Heard::Finished { steps: summary.steps, interrupted: summary.interrupted }
            }
        });
        Ok(())
    };
    lucid_session::train::<Count>(request, &mut listener)?;
    Ok(heard)
}

fn request(dir: &Path) -> RunRequest {
    RunRequest { evaluate: false, checkpoint_seconds: 0.0, ..RunRequest::new(dir.join("data"), dir.join("run")) }
}

#[test]
fn events_arrive_in_order_and_a_step_budget_takes_its_steps() {
    let dir = tempfile::tempdir().unwrap();
    let heard = train(&RunRequest { steps: Some(4), ..request(dir.path()) }).unwrap();
    let budget = Budget::Steps { steps: 4 };
    let mut expected = vec![Heard::Ready { step: 0, budget, model: false }];
    // A log row every step, then the step; the one checkpoint at the end.
    expected.extend((1..=4).flat_map(|k| [Heard::Losses(k), Heard::Step(k)]));
    expected.push(Heard::Checkpoint(4));
    expected.push(Heard::Finished { steps: 4, interrupted: false });
    assert_eq!(heard, expected);
    // The run's folder: its configuration (the request's steps in it), log and checkpoint.
    let run = dir.path().join("run");
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(config.contains("steps = 4"), "{config}");
    let log = std::fs::read_to_string(run.join("train_log.csv")).unwrap();
    assert_eq!(log.lines().count(), 5, "{log}");
    assert!(log.starts_with("step,seconds,loss,psnr,progress"), "{log}");
    assert_eq!(lucid_burn::checkpoint::read_header(&run.join("checkpoint.lucid")).unwrap()["step"], 4);
}

#[test]
fn time_budgets_end_on_time_and_both_limits_end_at_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let slow = vec!["train.step_ms=5".to_string()];
    let timed = RunRequest { time_limit: Some(0.1), overrides: slow.clone(), ..request(dir.path()) };
    let heard = train(&timed).unwrap();
    let Some(Heard::Finished { steps, interrupted: false }) = heard.last() else { panic!("{heard:?}") };
    // At least 5 ms a step for 0.1 s: at most 20 steps and the one that crosses the limit.
    assert!((2..=21).contains(steps), "{steps} steps");
    assert_eq!(heard[0], Heard::Ready { step: 0, budget: Budget::Seconds { seconds: 0.1 }, model: false });

    let dir = tempfile::tempdir().unwrap();
    let both = RunRequest { steps: Some(3), time_limit: Some(60.0), overrides: slow, ..request(dir.path()) };
    let heard = train(&both).unwrap();
    assert_eq!(heard.last(), Some(&Heard::Finished { steps: 3, interrupted: false }));
    assert_eq!(heard[0], Heard::Ready { step: 0, budget: Budget::First { steps: 3, seconds: 60.0 }, model: false });
}

#[test]
fn a_run_stopped_early_resumes_where_it_stopped_and_refuses_changes() {
    let dir = tempfile::tempdir().unwrap();
    let first = RunRequest { steps: Some(6), until: Some(2), ..request(dir.path()) };
    let heard = train(&first).unwrap();
    assert_eq!(heard.last(), Some(&Heard::Finished { steps: 2, interrupted: true }));
    // A second new run into the folder is refused; a resume continues to the budget.
    let again = train(&RunRequest { steps: Some(6), ..request(dir.path()) }).unwrap_err().to_string();
    assert!(again.contains("run"), "{again}");
    let resume = RunRequest { start: Start::Resume, ..request(dir.path()) };
    let heard = train(&resume).unwrap();
    assert_eq!(heard[0], Heard::Ready { step: 2, budget: Budget::Steps { steps: 6 }, model: false });
    assert_eq!(heard[1..3], [Heard::Losses(3), Heard::Step(3)]);
    assert_eq!(heard.last(), Some(&Heard::Finished { steps: 6, interrupted: false }));
    let log = std::fs::read_to_string(dir.path().join("run/train_log.csv")).unwrap();
    let steps: Vec<&str> = log.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect();
    assert_eq!(steps, ["1", "2", "3", "4", "5", "6"]);
    // A resume that would change the configuration is refused, naming the key.
    let changed = RunRequest { overrides: vec!["train.step_ms=1".into()], ..resume };
    let err = train(&changed).unwrap_err().to_string();
    assert!(err.contains("train.step_ms"), "{err}");
}

#[test]
fn checkpoints_are_written_by_training_time() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let checkpoint = run.join("checkpoint.lucid");
    let request = RunRequest {
        steps: Some(30),
        checkpoint_seconds: 0.02,
        overrides: vec!["train.step_ms=5".into()],
        ..request(dir.path())
    };
    let (mut saved_at, mut announced) = (Vec::new(), Vec::new());
    let mut listener = |event: &Event<'_>| -> Result<(), ModelError> {
        match *event {
            Event::Step { step, .. } => {
                if let Ok(header) = lucid_burn::checkpoint::read_header(&checkpoint) {
                    saved_at.push((step, header["step"].as_u64().unwrap() as usize));
                }
            }
            Event::Checkpoint { step, .. } => announced.push(step),
            _ => {}
        }
        Ok(())
    };
    lucid_session::train::<Count>(&request, &mut listener).unwrap();
    // Every 0.02 s of 5-ms steps: a checkpoint every few steps, the first long before the end.
    let first = saved_at.first().expect("a checkpoint before the end").0;
    assert!(first < 15, "first checkpoint after step {first}");
    let distinct: std::collections::BTreeSet<usize> = saved_at.iter().map(|s| s.1).collect();
    assert!(distinct.len() >= 3, "{saved_at:?}");
    // Each checkpoint was announced, the last one at the end.
    assert!(distinct.iter().all(|s| announced.contains(s)), "{announced:?} {saved_at:?}");
    assert_eq!(announced.last(), Some(&30));
}

#[test]
fn a_bad_configuration_fails_before_the_folder_is_touched() {
    let dir = tempfile::tempdir().unwrap();
    let bad = RunRequest { overrides: vec!["train.stepz=3".into()], ..request(dir.path()) };
    let err = train(&bad).unwrap_err().to_string();
    assert!(err.contains("stepz"), "{err}");
    assert!(!dir.path().join("run").exists());
}
