//! `navfuse experiment`: Reproduce a seed paper's experiment and print its table beside ours.
//! (placeholder: implemented by its issue)

use clap::Args as ClapArgs;

/// Reproduce a seed paper's experiment and print its table beside ours.
#[derive(ClapArgs, Debug)]
pub struct Args {}

pub fn run(_args: Args) -> Result<(), String> {
    Err("`experiment` is not implemented yet".into())
}
