//! Strapdown INS: mechanization, alignment, IMU error model (`SEEDS.md §1`).

pub mod align;
pub mod mech;
#[cfg(feature = "alloc")]
pub mod time_offset;
#[cfg(feature = "alloc")]
pub mod time_offset_vel;
pub mod yaw_gsf;

pub use mech::{mechanize, NavState};
