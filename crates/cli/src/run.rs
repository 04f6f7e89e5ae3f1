//! `navfuse run`: the ESKF (or PF-LC / GPS-ACC) on IMU/GNSS recordings with a
//! TOML config ([`navfuse_pipeline::RunConfig`]); the work is
//! [`navfuse_pipeline::run()`], this adds the optional HTML report.

use crate::fail::Fail;
use clap::Args as ClapArgs;
use navfuse_pipeline::{resolve_path, RunConfig, RunOptions};
use std::path::{Path, PathBuf};

/// Run the ESKF on IMU/GNSS recordings with a TOML config.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// TOML run configuration (paths inside are relative to it). See docs/config.md;
    /// `navfuse init` writes a commented template.
    pub config: PathBuf,
    /// Output folder (default: `output` from the config, else `./navfuse-out`).
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Estimator (overrides `[filter] estimator`): eskf, pf-lc (seed 002), gps-acc (seed 004), cp-att (seed 003: carrier-phase attitude from `[input] carrier_phase`).
    #[arg(long)]
    pub estimator: Option<String>,
    /// Also write the HTML report (OUTPUT/report/index.html and SVG plots).
    #[arg(long)]
    pub report: bool,
    /// Reference trajectory for the report's errors (.nav, .pos, .csv).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Do not write the σ files (solution.std, solution_smoothed.std).
    #[arg(long)]
    pub no_std: bool,
}

pub fn run(args: Args) -> Result<(), Fail> {
    let cfg = RunConfig::from_toml_file(&args.config)?;
    let base = args
        .config
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let opts = RunOptions {
        output: args.output.clone(),
        estimator: args.estimator.clone(),
        no_std: args.no_std,
    };
    let out = navfuse_pipeline::run(&cfg, &base, &opts)?;
    eprintln!("{}", out.message);
    if args.report {
        run_report(
            &out.out_dir,
            args.truth.as_deref(),
            &resolve_path(&base, &cfg.input.gnss),
        )
        .map_err(Fail::input)?;
    }
    Ok(())
}

/// The HTML report of a run folder (solutions, summary), with the GNSS input
/// as the fixes and an optional reference.
fn run_report(out_dir: &Path, truth: Option<&Path>, gnss: &Path) -> Result<(), String> {
    let opt = navfuse_report::LoadOptions {
        truth: truth.map(Path::to_path_buf),
        fixes: Some(gnss.to_path_buf()),
        ..Default::default()
    };
    let mut inp = navfuse_report::load_run_dir(out_dir, &opt)?;
    inp.title = format!("navfuse run — {}", out_dir.display());
    let sum = navfuse_report::write_report(&out_dir.join("report"), &inp)?;
    eprintln!("report: {}", sum.html.display());
    Ok(())
}
