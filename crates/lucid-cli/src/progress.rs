//! Progress bars on stderr; indicatif hides them when stderr is not a terminal.

use indicatif::ProgressBar;

/// A bar for `total` steps with a message, in the style of the training loop's bars.
pub fn bar(total: u64, message: &str) -> ProgressBar {
    lucid_burn::run::progress_bar(total, message, "")
}

/// Runs `work` with a progress callback (done, to do) drawn as a bar labelled `label`,
/// cleared when it returns.
pub fn with_bar<R>(label: &str, work: impl FnOnce(&(dyn Fn(usize, usize) + Sync)) -> R) -> R {
    let bar = bar(0, label);
    let result = work(&|done, to_do| {
        bar.set_length(to_do as u64);
        bar.set_position(done as u64)
    });
    bar.finish_and_clear();
    result
}
