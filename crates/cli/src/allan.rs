//! `navfuse allan`: overlapping Allan deviation of a static IMU log with
//! fitted noise terms ([`navfuse_pipeline::allan`]: input formats, fits).
//!
//! Writes `allan.csv` (τ and σ of the six axes), `allan_noise.toml` (the
//! fitted terms as a `[filter.imu_noise]` block in datasheet keys that a
//! `navfuse run` configuration takes as is; also to `--toml FILE`) and
//! `allan.svg` (log–log plot) to `--out`.

use crate::fail::Fail;
use clap::Args as ClapArgs;
use navfuse_pipeline::allan::analyse;
use std::path::PathBuf;

/// Overlapping Allan deviation of an IMU log with fitted noise terms.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Static IMU log (VN-310 CSV, navfuse imu.csv or KF-GINS IMU text).
    pub imu_file: PathBuf,
    /// Input format: auto, vn310, sim, kfgins.
    #[arg(long, default_value = "auto")]
    pub format: String,
    /// Output folder for allan.csv, allan_noise.toml, allan.svg.
    #[arg(long, default_value = "out/allan")]
    pub out: PathBuf,
    /// Also write the fitted `[filter.imu_noise]` block (datasheet keys) to
    /// this file, to paste into a run configuration.
    #[arg(long)]
    pub toml: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), Fail> {
    let r = analyse(&args.imu_file, &args.format).map_err(|e| Fail::input(String::from(e)))?;
    println!("Allan deviation of {}", args.imu_file.display());
    println!("{}", r.table());
    std::fs::create_dir_all(&args.out).map_err(Fail::io(&args.out))?;
    for (name, text) in [
        ("allan.csv", r.csv()),
        (
            "allan_noise.toml",
            r.toml(&args.imu_file.display().to_string()),
        ),
        ("allan.svg", r.svg()),
    ] {
        let p = args.out.join(name);
        navfuse_io::atomic::write_atomic(&p, text).map_err(Fail::io(&p))?;
    }
    if let Some(p) = &args.toml {
        let text = r.toml(&args.imu_file.display().to_string());
        navfuse_io::atomic::write_atomic(p, text).map_err(Fail::io(p))?;
        println!(
            "wrote {} ([filter.imu_noise] for a run configuration)",
            p.display()
        );
    }
    println!(
        "wrote {}/allan.csv, allan_noise.toml, allan.svg",
        args.out.display()
    );
    Ok(())
}
