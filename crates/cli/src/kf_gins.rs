//! `navfuse kf-gins`: Run a KF-GINS YAML configuration (drop-in replacement for KF-GINS).
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Run a KF-GINS YAML configuration (drop-in replacement for KF-GINS).
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`kf-gins` is not implemented yet".into())
}
