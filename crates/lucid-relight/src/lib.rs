//! Image-based relighting.
//!
//! - [`envmap`]: lat-long environment maps: directions and solid angles of pixels, bilinear
//!   lookup, mirror-ball conversion both ways.
//! - [`voronoi`]: the solid angle of each light's spherical Voronoi cell, through `spade`'s
//!   planar Delaunay triangulation of a stereographic projection.
//! - [`transport`]: the light transport matrix of an OLAT set and relighting `p = T·l` under an
//!   environment map.
//! - [`sh`]: projection onto the 9 spherical harmonics of bands 0–2 and the irradiance they
//!   give (Ramamoorthi and Hanrahan 2001).
//! - [`median_cut`]: Debevec's median-cut extraction of point lights from a map.

pub mod envmap;
pub mod lightstage;
pub mod median_cut;
pub mod sh;
pub mod sun;
pub mod transport;
pub mod voronoi;

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
pub enum RelightError {
    /// An image could not be read or written.
    #[error(transparent)]
    Image(#[from] lucid_image::ImageError),
    /// A dataset could not be read.
    #[error(transparent)]
    Dataset(#[from] lucid_scene::DatasetError),
    /// Inputs that do not fit.
    #[error("{0}")]
    Invalid(String),
}
