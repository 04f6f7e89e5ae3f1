//! `navfuse eval`: Evaluate a solution against a reference trajectory.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Evaluate a solution against a reference trajectory.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`eval` is not implemented yet".into())
}
