//! Volume rendering: ray marching through the occupancy grid and compositing.

pub mod composite;
pub mod march;
