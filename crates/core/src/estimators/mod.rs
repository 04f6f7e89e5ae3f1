//! The four estimators: eskf (`SEEDS.md §1`), pf_lc (§2), cp_attitude (§3), accel_dr (§4).

pub mod accel_dr;
pub mod adaptive;
pub mod consistency;
pub mod cp_att_stream;
pub mod cp_attitude;
pub mod eskf;
pub mod pf_lc;
