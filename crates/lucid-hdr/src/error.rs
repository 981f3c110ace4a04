//! Errors of the HDR toolkit.

/// What can go wrong with the inputs of a merge or a tone map.
#[derive(Debug, thiserror::Error)]
pub enum HdrError {
    /// The frames do not form a usable stack.
    #[error("{0}")]
    Stack(String),
    /// A parameter is out of its range.
    #[error("{0}")]
    Parameter(String),
    /// The linear solve of the response recovery failed.
    #[error("response recovery failed: {0}")]
    Solve(String),
}
