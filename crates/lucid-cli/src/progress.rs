//! Progress bars on stderr; indicatif hides them when stderr is not a terminal.

use indicatif::ProgressBar;

/// A bar for `total` steps with a message, in the style of the training loop's bars.
pub fn bar(total: u64, message: &str) -> ProgressBar {
    lucid_burn::run::progress_bar(total, message, "")
}
