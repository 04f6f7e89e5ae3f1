//! `navfuse sim`: Simulate a trajectory and its sensors from a scenario file.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Simulate a trajectory and its sensors from a scenario file.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`sim` is not implemented yet".into())
}
