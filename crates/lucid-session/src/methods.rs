//! The methods a session trains.

mod itm;
mod nerf;
mod splat;

pub use itm::Itm;
pub use nerf::Nerf;
pub use splat::Splat;
