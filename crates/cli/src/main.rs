//! `navfuse`: the command-line tool. Thin: parses arguments, wires readers,
//! estimators and writers together. Each subcommand lives in its own module
//! with an `Args` struct and a `run(args) -> Result<(), Fail>` (or `String`
//! for commands whose failures are not classified: exit code 1).

use clap::{Parser, Subcommand};
use fail::{Fail, FailureKind};
use std::process::ExitCode;

mod allan;
mod baseline;
mod bench;
mod convert;
mod demo;
mod eval;
mod exp_platform;
mod experiment;
mod fail;
mod init;
mod kf_gins;
mod live;
mod report;
mod run;
mod sim;
mod smooth_gps;
mod spp;

/// GNSS/INS navigation toolkit: fuse IMU and GNSS recordings into a trajectory
/// with attitude, and tell how good it is.
#[derive(Parser, Debug)]
#[command(name = "navfuse", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
#[allow(clippy::large_enum_variant)] // parsed once; boxing clap args gains nothing
enum Command {
    /// Convert between trajectory/sensor file formats (format from extension or given).
    Convert(convert::Args),
    /// Run an estimator on IMU/GNSS recordings with a TOML config.
    Run(run::Args),
    /// Write a commented `navfuse run` TOML template for a platform.
    Init(init::Args),
    /// Run a KF-GINS YAML configuration (drop-in replacement for KF-GINS).
    KfGins(kf_gins::Args),
    /// Evaluate a solution against a reference trajectory.
    Eval(eval::Args),
    /// Measure estimator throughput (IMU samples per second).
    Bench(bench::Args),
    /// Simulate a trajectory and its sensors from a scenario file.
    Sim(sim::Args),
    /// Overlapping Allan deviation of an IMU log with fitted noise terms.
    Allan(allan::Args),
    /// Simulate a drive, run every estimator on it, write outputs and a report.
    Demo(demo::Args),
    /// Carrier-phase multi-antenna attitude on a simulated scene (seed 003).
    Attitude(navfuse_pipeline::experiments::attitude::Options),
    /// Carrier-phase baseline between two RINEX observation files.
    Baseline(baseline::Args),
    /// Reproduce a seed paper's experiment and print its table beside ours.
    Experiment(experiment::Args),
    /// Compensate GNSS positions with the seed 002 algorithm (or a SIR particle filter).
    SmoothGps(smooth_gps::Args),
    /// Self-contained HTML report and SVG plots of a run directory.
    Report(report::Args),
    /// Fuse live GNSS (gpsd, NMEA) and IMU streams; solutions at the IMU rate.
    Live(live::Args),
    /// Single-point positions from RINEX observations and broadcast ephemerides (RTKLIB .pos).
    Spp(spp::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse(); // usage errors: clap prints them and exits with 2
                            // A panic is a bug: its message is printed by the default hook, and the
                            // exit code says "internal" (70) instead of Rust's 101.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli)))
        .unwrap_or_else(|_| {
            Err(Fail::new(
                FailureKind::Internal,
                "internal error (a bug: please report it with the command line)",
            ))
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("navfuse: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// Run the command; exit codes in docs/exit-codes.md.
fn dispatch(cli: Cli) -> Result<(), Fail> {
    match cli.command {
        Command::Convert(a) => convert::run(a),
        Command::Run(a) => run::run(a),
        Command::Init(a) => Ok(init::run(a)?),
        Command::KfGins(a) => kf_gins::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Bench(a) => Ok(bench::run(a)?),
        Command::Sim(a) => Ok(sim::run(a)?),
        Command::Allan(a) => allan::run(a),
        Command::Demo(a) => Ok(demo::run(a)?),
        Command::Attitude(a) => {
            navfuse_pipeline::experiments::attitude::run(a).map_err(|e| Fail::from(String::from(e)))
        }
        Command::Baseline(a) => baseline::run(a),
        Command::Experiment(a) => Ok(experiment::run(a)?),
        Command::SmoothGps(a) => Ok(smooth_gps::run(a)?),
        Command::Report(a) => Ok(report::run(a)?),
        Command::Live(a) => live::run(a),
        Command::Spp(a) => spp::run(a),
    }
}
