//! What every `lucid train` command prints at the end of a run.

use std::path::Path;

use lucid_burn::run::RunSummary;

/// Prints what a run did.
pub fn print_summary(summary: &RunSummary, what: &str, checkpoint: &Path) {
    println!("trained {what} {} steps in {:.1} s -> {}", summary.steps, summary.elapsed, checkpoint.display());
    if !summary.phases.is_empty() {
        println!("time per phase: {}", summary.phase_shares());
    }
    if summary.interrupted {
        println!("stopped at step {}; continue with --resume", summary.steps);
    }
    for line in &summary.report {
        println!("{line}");
    }
}
