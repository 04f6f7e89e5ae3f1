//! `navfuse init`: write a commented `navfuse run` TOML template for a
//! platform ([`navfuse_pipeline::template::run_template`]), optionally with
//! a column map guessed from a CSV IMU log
//! ([`navfuse_pipeline::csv_sniff::sniff_csv`]).

use clap::Args as ClapArgs;
use navfuse_pipeline::csv_sniff::sniff_csv;
use navfuse_pipeline::profile::Platform;
use navfuse_pipeline::template::run_template;
use std::path::{Path, PathBuf};

/// Write a commented run configuration template (see docs/config.md).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Platform profile: car, robot, pedestrian, uav, marine, static.
    #[arg(long)]
    pub platform: Platform,
    /// IMU noise preset by sensor (default: phone, the conservative MEMS).
    #[arg(long)]
    pub imu_preset: Option<String>,
    /// A CSV IMU log: its header and first rows give a proposed `[input.csv]`.
    #[arg(long)]
    pub imu: Option<PathBuf>,
    /// Output file (refuses to overwrite an existing one).
    #[arg(short, long, default_value = "run.toml")]
    pub output: PathBuf,
}

/// `csv` as written into a config at `out`: as given when both are in the
/// current folder or `csv` is absolute, else absolute.
fn path_in_config(csv: &Path, out: &Path) -> String {
    let out_dir = out.parent().filter(|d| !d.as_os_str().is_empty());
    if csv.is_absolute() || out_dir.is_none() {
        return csv.display().to_string();
    }
    std::fs::canonicalize(csv)
        .unwrap_or_else(|_| csv.to_path_buf())
        .display()
        .to_string()
}

pub fn run(args: Args) -> Result<(), String> {
    if args.output.exists() {
        return Err(format!(
            "{}: exists; remove it or give another -o",
            args.output.display()
        ));
    }
    let guess = match &args.imu {
        Some(p) => Some((
            path_in_config(p, &args.output),
            sniff_csv(p).map_err(|e| e.to_string())?,
        )),
        None => None,
    };
    let text = run_template(
        args.platform,
        args.imu_preset.as_deref(),
        guess.as_ref().map(|(p, g)| (p.as_str(), g)),
    )
    .map_err(|e| e.to_string())?;
    navfuse_io::atomic::write_atomic(&args.output, text)
        .map_err(|e| format!("{}: {e}", args.output.display()))?;
    eprintln!(
        "wrote {} ({} profile); set the lines marked EDIT{}",
        args.output.display(),
        args.platform,
        if args.imu.is_some() {
            " and check the guessed [input.csv]"
        } else {
            ""
        }
    );
    Ok(())
}
