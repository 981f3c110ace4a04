//! Input encodings: the multiresolution hash grid for positions, spherical harmonics for
//! directions.

pub mod hash_grid;
pub mod spherical_harmonics;
