//! `navfuse allan`: Overlapping Allan deviation of an IMU log with fitted noise terms.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Overlapping Allan deviation of an IMU log with fitted noise terms.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`allan` is not implemented yet".into())
}
