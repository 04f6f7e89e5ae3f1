//! `navfuse attitude`: Carrier-phase multi-antenna attitude on a simulated scene (seed 003).
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Carrier-phase multi-antenna attitude on a simulated scene (seed 003).
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`attitude` is not implemented yet".into())
}
