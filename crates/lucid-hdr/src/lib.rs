//! Lucid's HDR toolkit.
//!
//! - [`stack`]: a set of LDR exposures of one scene with their exposure times, as 8-bit codes.
//! - [`response`]: the camera response recovered from such a stack, by Debevec and Malik's
//!   least squares or Robertson's iteration, or given in closed form.
//! - [`merge`]: the weighted log-domain merge of a stack into scene radiance.
//! - [`fusion`]: Mertens' exposure fusion, straight to a display image.
//! - [`tonemap`]: global (linear, Reinhard, Drago, ACES filmic) and local (Reinhard's
//!   photographic dodge-and-burn, Durand–Dorsey bilateral) tone-mapping operators.

pub mod blur;
pub mod error;
pub mod fusion;
pub mod itm;
pub mod merge;
pub mod pyramid;
pub mod response;
pub mod stack;
pub mod tonemap;

pub use error::HdrError;
pub use response::ResponseCurve;
pub use stack::ExposureStack;
