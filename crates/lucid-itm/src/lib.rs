//! Inverse tone mapping with a small convolutional network on burn.
//!
//! An LDR image loses information only where it clips; elsewhere the inverse camera response
//! recovers the exposure. So the network ([`model::ItmNet`], a two-level U-Net over the
//! display values) predicts a log gain `r` per pixel and channel, and the HDR estimate is
//! `H = f⁻¹(y)·(1 + α·(eʳ − 1))` with `α` the soft mask of near-saturated pixels
//! ([`lucid_hdr::itm::clip_mask`]): exactly the linearised input where `α = 0`, the network's
//! `f⁻¹(y)·eʳ` where the input is clipped (Eilertsen et al. 2017). Trained on the generator's
//! `brackets` datasets (one LDR exposure → the path-traced radiance times its exposure time)
//! with a log-domain loss weighted by `α` ([`trainer`]), evaluated against the analytic
//! baseline ([`lucid_hdr::itm::analytic_itm`]) in [`eval`].

pub mod checkpoint;
pub mod config;
pub mod data;
pub mod eval;
pub mod model;
pub mod run;
pub mod trainer;

pub use config::ItmConfig;
pub use model::ItmNet;
