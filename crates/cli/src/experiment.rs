//! `navfuse experiment`: Reproduce a seed paper's experiment and print its table beside ours.
//! (TEMPORARY dispatch added on branch `gpsacc` until the subcommand enum lands.)

use clap::{Args as ClapArgs, Subcommand};

/// Reproduce a seed paper's experiment and print its table beside ours.
#[derive(ClapArgs, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

/// The experiments.
#[derive(Subcommand, Debug)]
pub enum Which {
    /// Seed 004: GPS + accelerometer dead reckoning, Tables 3 and 4.
    Seed004(crate::exp_seed004::Args),
}

pub fn run(args: Args) -> Result<(), String> {
    match args.which {
        Which::Seed004(a) => crate::exp_seed004::run(a),
    }
}
