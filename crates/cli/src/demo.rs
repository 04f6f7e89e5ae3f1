//! `navfuse demo`: Simulate a drive, run every estimator on it, write outputs and a report.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Simulate a drive, run every estimator on it, write outputs and a report.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`demo` is not implemented yet".into())
}
