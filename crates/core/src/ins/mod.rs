//! Strapdown INS: mechanization, alignment, IMU error model (`SEEDS.md §1`).

pub mod align;
pub mod mech;
pub mod yaw_gsf;

pub use mech::{mechanize, NavState};
