//! Lucid's session layer, between the method crates and the command line.
//!
//! - [`registry`] opens any model file as a [`SceneModel`] to render and score, whatever
//!   trained it;
//! - [`train`] sets up a training run of any [`Method`] from a [`RunRequest`] (configuration,
//!   datasets, memory check, run folder, resume or extend, budget, manifest), runs it through
//!   the one training loop ([`lucid_burn::run`]) and reports what happens as typed [`Event`]s
//!   to a [`Listener`] (a progress display, a live viewer, a benchmark's recorder).

pub mod curve;
pub mod events;
pub mod method;
pub mod methods;
pub mod registry;
pub mod request;
mod session;

pub use events::{Event, Listener, Listeners};
pub use lucid_scene::scene_model::{RenderOptions, SceneModel};
pub use method::{Method, TrainSettings};
pub use request::RunRequest;
pub use session::train;

use lucid_burn::run::{ModelError, RunError};

/// Why a run could not be set up or did not finish.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The request or the configuration is not valid (the message names the flag, key or
    /// file).
    #[error("{0}")]
    Invalid(String),
    /// An input could not be read.
    #[error("{context}: {source}")]
    Read {
        /// What was being read.
        context: String,
        /// The cause.
        source: ModelError,
    },
    /// The training loop or its folder failed.
    #[error(transparent)]
    Run(#[from] RunError),
}

impl SessionError {
    /// An error reading `what`.
    pub fn read(what: impl Into<String>, source: impl Into<ModelError>) -> Self {
        Self::Read { context: what.into(), source: source.into() }
    }
}
