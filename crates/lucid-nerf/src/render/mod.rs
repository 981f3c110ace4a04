//! Volume rendering: ray marching through the occupancy grid, packing samples, compositing,
//! and whole views from a trained model.

pub mod batch;
pub mod composite;
pub mod march;
pub mod rounds;
pub mod view;
