//! `navfuse sim`: simulate a trajectory and its sensors from a scenario file.
//!
//! `navfuse sim SCENARIO.toml --seed N --out DIR [--imu PRESET] [--gnss PRESET] [--runs K]`
//! writes truth, ideal and measured IMU, and GNSS fixes (KF-GINS text and CSV,
//! see `navfuse_sim::output`). With `--runs K` it runs a Monte Carlo over the
//! seeds N … N+K−1 in parallel (one trajectory, K sensor draws) into
//! `DIR/seed_<n>/`, with a progress bar on a terminal.

use clap::Args as ClapArgs;
use indicatif::{ProgressBar, ProgressStyle};
use navfuse_sim::gnss_model::{gnss_preset, GNSS_PRESETS};
use navfuse_sim::imu_model::{imu_preset, IMU_PRESETS};
use navfuse_sim::{output, simulate_sensors, trajectory, Scenario};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Simulate a trajectory and its sensors from a scenario file.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Scenario: TOML (see scenarios/) or a gnss-ins-sim motion-definition .csv.
    #[arg(required_unless_present = "list_presets")]
    pub scenario: Option<PathBuf>,
    /// Seed of the random errors (same scenario + seed → identical files).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, default_value = "out/sim")]
    pub out: PathBuf,
    /// IMU error preset (overrides the scenario's).
    #[arg(long)]
    pub imu: Option<String>,
    /// GNSS error preset (overrides the scenario's).
    #[arg(long)]
    pub gnss: Option<String>,
    /// Monte Carlo: number of runs (seeds seed … seed+runs−1), in parallel.
    #[arg(long, default_value_t = 1)]
    pub runs: u64,
    /// Also write the run as a u-blox UBX stream (ESF-RAW IMU and wheel
    /// ticks, NAV-PVT, NAV-RELPOSNED heading) to this file (single run only).
    #[arg(long)]
    pub ubx: Option<PathBuf>,
    /// With `--ubx`: distance per wheel tick [m] (default 0.02: an ABS tone
    /// wheel of 48 teeth, both edges counted, on a 1.9 m tyre circumference).
    #[arg(long, default_value_t = 0.02)]
    pub ubx_metres_per_tick: f64,
    /// List the IMU and GNSS presets and exit.
    #[arg(long)]
    pub list_presets: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    if args.list_presets {
        println!("IMU presets:");
        for p in IMU_PRESETS {
            let s = imu_preset(p).map_err(|e| e.to_string())?;
            println!("  {p:<12} {} — {}", s.name, s.source);
        }
        println!("GNSS presets:");
        for p in GNSS_PRESETS {
            let s = gnss_preset(p).map_err(|e| e.to_string())?;
            println!("  {p:<12} {} Hz — {}", s.rate_hz, s.source);
        }
        return Ok(());
    }
    let path = args
        .scenario
        .as_ref()
        .ok_or("a scenario file is required")?;
    let mut sc = Scenario::from_file(path).map_err(|e| e.to_string())?;
    if let Some(p) = &args.imu {
        sc.imu.preset = p.clone();
        sc.imu.model = None;
    }
    if let Some(p) = &args.gnss {
        sc.gnss.preset = p.clone();
        sc.gnss.model = None;
    }
    let imu_spec = sc.imu_spec().map_err(|e| e.to_string())?;
    let gnss_spec = sc.gnss_spec().map_err(|e| e.to_string())?;
    if args.runs == 0 {
        return Err("--runs must be ≥ 1".into());
    }
    if args.ubx.is_some() && args.runs > 1 {
        return Err("--ubx writes a single run (not with --runs)".into());
    }
    let t0 = Instant::now();
    let traj = trajectory::generate(&sc.start, &sc.segment, sc.imu.rate_hz, sc.imu.substeps)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    if args.runs == 1 {
        let run = simulate_sensors(&sc, args.seed, imu_spec, gnss_spec, traj)
            .map_err(|e| e.to_string())?;
        output::write_run(&run, &args.out).map_err(|e| e.to_string())?;
        if let Some(p) = &args.ubx {
            navfuse_sim::ubx_out::write_ubx(&run, p, args.ubx_metres_per_tick)
                .map_err(|e| e.to_string())?;
        }
        println!("{}", run.summary());
        println!(
            "wrote {} in {:.2} s",
            args.out.display(),
            t0.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    let pb = ProgressBar::new(args.runs);
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed_precise} (eta {eta})")
            .map_err(|e| e.to_string())?,
    );
    let seeds: Vec<u64> = (args.seed..args.seed + args.runs).collect();
    let results: Vec<Result<(u64, f64, f64), String>> = seeds
        .par_iter()
        .map(|&seed| {
            let run =
                simulate_sensors(&sc, seed, imu_spec.clone(), gnss_spec.clone(), traj.clone())
                    .map_err(|e| format!("seed {seed}: {e}"))?;
            output::write_run(&run, &args.out.join(format!("seed_{seed}")))
                .map_err(|e| format!("seed {seed}: {e}"))?;
            let s = run.sensor_stats();
            pb.inc(1);
            Ok((seed, s.gnss_h_rms, s.gyro_err_rms))
        })
        .collect();
    pb.finish_and_clear();
    let mut ok = Vec::new();
    for r in results {
        ok.push(r?);
    }
    let n = ok.len() as f64;
    let mean_h = ok.iter().map(|x| x.1).sum::<f64>() / n;
    println!(
        "{} runs (seeds {}..{}) of '{}' in {:.2} s into {}; mean GNSS horizontal rms {:.2} m",
        ok.len(),
        args.seed,
        args.seed + args.runs - 1,
        sc.name,
        t0.elapsed().as_secs_f64(),
        args.out.display(),
        mean_h
    );
    Ok(())
}
