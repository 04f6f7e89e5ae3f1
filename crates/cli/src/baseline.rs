//! `navfuse baseline`: Carrier-phase baseline between two RINEX observation files.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Carrier-phase baseline between two RINEX observation files.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`baseline` is not implemented yet".into())
}
