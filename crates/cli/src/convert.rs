//! `navfuse convert`: Convert between trajectory/sensor file formats (format from extension or given).
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Convert between trajectory/sensor file formats (format from extension or given).
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`convert` is not implemented yet".into())
}
