//! `navfuse bench`: Measure estimator throughput (IMU samples per second).
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Measure estimator throughput (IMU samples per second).
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`bench` is not implemented yet".into())
}
