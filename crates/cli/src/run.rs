//! `navfuse run`: Run an estimator on IMU/GNSS recordings with a TOML config.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Run an estimator on IMU/GNSS recordings with a TOML config.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`run` is not implemented yet".into())
}
