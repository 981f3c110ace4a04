//! `lucid bench nerf`: the NeRF benchmark. Generates (or reuses) the default
//! `object` orbit set at 200×200 (100 training views, 200 test views), trains with the default
//! configuration for a fixed wall-clock budget, and evaluates held-out PSNR/SSIM at fixed
//! times (30 s, 1, 2, 5 and 10 min of training; evaluation time is not counted), then prints
//! the curve, the training throughput, the time per phase, and the render time of one view.

use anyhow::Context;
use lucid_burn::run::ModelError;
use lucid_nerf::config::NerfConfig;
use lucid_nerf::data::ImageSet;
use lucid_nerf::profile::time_kernels;
use lucid_nerf::run::LOG_COLUMNS;
use lucid_nerf::trained::TrainedNerf;
use lucid_nerf::trainer::StepTimings;
use lucid_scene::Split;
use lucid_session::events::Event;
use lucid_session::methods::Nerf;
use serde_json::json;

use lucid_session::Listener;
use lucid_session::curve::{BudgetCurve, CurvePoint};

/// Options of the NeRF benchmark.
pub struct NerfBench {
    /// The dataset.
    pub dataset: super::BenchDataset,
    /// Smoke version: tiny dataset, 20 s of training.
    pub quick: bool,
    /// Configuration overrides (`--set`).
    pub overrides: Vec<String>,
    /// Test views scored at the intermediate points (all of them at the end).
    pub curve_views: usize,
}

pub fn run(bench: NerfBench) -> anyhow::Result<serde_json::Value> {
    let (dataset, ceiling) = bench.dataset.open(bench.quick)?;
    let test = ImageSet::load(dataset.frames(Split::Test))?;
    let val = ImageSet::load(dataset.frames(Split::Val))?;
    let mut curve = BudgetCurve::benchmark(bench.quick, &test, Some(&val), bench.curve_views);
    let samples_column = LOG_COLUMNS.iter().position(|c| *c == "samples").expect("a samples column");
    let mut samples = 0usize;
    let mut trained = None;
    let total = curve.total();
    let mut listener = |event: &Event<'_>| -> Result<(), ModelError> {
        match *event {
            Event::Step { report, .. } => samples += report.columns[samples_column] as usize,
            Event::Finished { model, .. } => trained = model(),
            _ => {}
        }
        curve.on(event)
    };
    // Time ends the run, and the learning rate decays over it.
    let folder = tempfile::tempdir().context("a folder for the benchmark's run")?;
    let request = super::timed_request(&bench.dataset, &bench.overrides, total, folder.path());
    let summary = lucid_session::train::<Nerf>(&request, &mut listener)?;
    let trained = trained.context("the trained model")?;
    let nerf = trained.as_any().downcast_ref::<TrainedNerf>().context("a NeRF")?;
    let last = curve.last.take().context("the last budget point is scored")?;
    let last_val = curve.last_val.take();
    // Best of 7: a call takes ~0.1 s and this machine's hiccups last longer than that.
    let kernel = time_kernels(&nerf.config().field, 1 << 16, 7);
    let phases = StepTimings::from_named(&summary.phases);
    println!("lucid bench nerf{}: {}", if bench.quick { " --quick" } else { "" }, bench.dataset.describe());
    let note = super::ceiling_note(ceiling.as_ref());
    let trainer = (nerf.config(), summary.steps);
    let mut out = report(trainer, &curve.points, &last, &phases, samples, summary.elapsed, kernel, bench.quick, &note);
    out["dataset"] = json!(bench.dataset.root.display().to_string());
    out["scene"] = json!(bench.dataset.built_in);
    out["ceiling"] = json!(ceiling);
    if let Some(val) = &last_val {
        super::print_validation(val);
        out["final_val"] = json!(val);
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn report(
    (config, steps): (&NerfConfig, usize),
    curve: &[CurvePoint],
    last: &lucid_nerf::eval::EvalSummary,
    phases: &StepTimings,
    samples: usize,
    trained: f64,
    kernel: lucid_nerf::profile::KernelTimes,
    quick: bool,
    ceiling_note: &str,
) -> serde_json::Value {
    println!("backend {}", lucid_nerf::backend::backend_name());
    println!("{:>10} {:>7} {:>9} {:>8}", "train (s)", "step", "PSNR", "SSIM");
    for p in curve {
        println!("{:>10.1} {:>7} {:>9.2} {:>8.4}", p.seconds, p.step, p.psnr, p.ssim);
    }
    let rate = samples as f64 / trained.max(1e-9);
    println!("final: {} test views, PSNR {:.2} dB{ceiling_note}, SSIM {:.4}", last.views, last.psnr, last.ssim);
    println!("training throughput: {:.0} samples/s over {steps} steps", rate);
    println!("render time per held-out view: {:.3} s", last.seconds_per_view);
    // Split the field's share between encoding and MLP with the kernel timings' ratios.
    let total: f64 = phases.named().iter().map(|p| p.1).sum::<f64>().max(1e-9);
    // The encoding alone can time slower than the whole fused field (its output leaves the
    // cache; the fused kernel keeps each chunk in it), so the ratios are capped at 1.
    let enc_fwd = (kernel.encoding / kernel.field_forward_saving.max(1e-9)).min(1.0);
    let enc_bwd = (kernel.encoding_backward / kernel.field_backward.max(1e-9)).min(1.0);
    let shares = json!({
        "encoding": (phases.field * enc_fwd + phases.backward * enc_bwd) / total,
        "mlp": (phases.field * (1.0 - enc_fwd) + phases.backward * (1.0 - enc_bwd)) / total,
        "compositing_and_loss": phases.composite / total,
        "optimizer": phases.optimizer / total,
        "ray_marching": phases.march / total,
        "cut_at_termination": phases.cut / total,
        "occupancy_grid": phases.occupancy / total,
    });
    println!("time per phase:");
    for (k, v) in shares.as_object().expect("object") {
        println!("  {k:<22} {:>5.1}%", 100.0 * v.as_f64().unwrap_or(0.0));
    }
    json!({
        "benchmark": "nerf", "quick": quick, "backend": lucid_nerf::backend::backend_name(),
        "threads": rayon::current_num_threads(), "curve": curve, "final": last,
        "samples_per_second": rate, "steps": steps, "training_seconds": trained,
        "time_shares": shares, "kernel_seconds_per_65536_samples": kernel,
        "config": config,
    })
}
