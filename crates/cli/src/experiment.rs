//! `navfuse experiment <seed>`: reproduce a seed paper's experiment and print
//! its table beside ours. (Interim dispatcher written by the seed 002 helper;
//! the experiment restructuring adds the other seeds here.)

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
    /// Seed 002: PF GPS compensation + loosely coupled GPS/INS (sim + drive_0708).
    Seed002(crate::exp_seed002::Args),
}

pub fn run(args: Args) -> Result<(), String> {
    match args.which {
        Which::Seed002(a) => crate::exp_seed002::run(a),
    }
}
