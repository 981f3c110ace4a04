//! Input encodings of the NeRF model.

pub mod hash_grid;
