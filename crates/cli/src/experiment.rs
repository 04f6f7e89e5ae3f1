//! `navfuse experiment`: reproduce a seed paper's experiment and print its
//! table beside ours. One subcommand per experiment; each runs library code
//! of [`navfuse_pipeline::experiments`].

use clap::{Args as ClapArgs, Subcommand};
use navfuse_pipeline::experiments::{aiding, rtk, seed002, seed003, seed004, tight};

/// Reproduce a seed paper's experiment and print its table beside ours.
#[derive(ClapArgs, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

#[derive(Subcommand, Debug)]
pub enum Which {
    /// Seed 002 (PF-LC): PF GPS compensation + loosely coupled GPS/INS (sim + drive_0708).
    Seed002(seed002::Options),
    /// Seed 003 (CP-ATT): Table 1, LAMBDA vs the paper, GEONET real baseline.
    Seed003(seed003::Options),
    /// Seed 004 (GPS-ACC): Tables 3 and 4, GPS + accelerometer dead reckoning.
    Seed004(seed004::Options),
    /// Generalisation matrix: platform × IMU grade × GNSS × time offset, default vs oracle vs KF-GINS model.
    Generalise(crate::exp_platform::GeneraliseArgs),
    /// Alignment check: pedestrian and car starting in motion, default configuration.
    Align(crate::exp_platform::AlignArgs),
    /// Issue 17: odometer drift in a 60 s outage and dual-antenna yaw at standstill (simulated car, consumer MEMS).
    Aiding(aiding::Options),
    /// Issue 14: tightly vs loosely coupled under a 2/3-satellite sky (simulated car, consumer MEMS, raw GNSS).
    Tight(tight::Options),
    /// Issue 15: RTK/INS against a simulated base (car, industrial and consumer MEMS): first fix, re-fix after an outage, wrong fixes.
    Rtk(rtk::Options),
    /// Soak `navfuse live` against a looping replay server: memory, CPU, latency, reconnects.
    Soak(crate::live::soak::Args),
}

pub fn run(args: Args) -> Result<(), String> {
    match args.which {
        Which::Seed002(a) => Ok(seed002::run(a)?),
        Which::Seed003(a) => Ok(seed003::run(a)?),
        Which::Seed004(a) => Ok(seed004::run(a)?),
        Which::Generalise(a) => crate::exp_platform::generalise(a),
        Which::Align(a) => crate::exp_platform::align(a),
        Which::Aiding(a) => Ok(aiding::run(a)?),
        Which::Tight(a) => Ok(tight::run(a)?),
        Which::Rtk(a) => Ok(rtk::run(a)?),
        Which::Soak(a) => crate::live::soak::run(a),
    }
}
