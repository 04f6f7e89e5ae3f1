//! navfuse-sim: trajectories, ideal and erroneous sensors, deterministic from a seed.
pub mod carrier_phase;
