//! `navfuse kf-gins CONFIG.yaml`: run an unmodified KF-GINS YAML configuration
//! with navfuse's ESKF in the KF-GINS model (21 states, GNSS position, same
//! timing of updates), writing KF-GINS's three output files.
//!
//! `--enhanced` adds navfuse's land-vehicle aiding (NHC, ZUPT/ZARU, χ² gating);
//! `--smooth` adds an RTS smoother pass (`KF_GINS_Navresult_smoothed.nav`).
//! The run is [`navfuse_pipeline::kf_gins::run_kf_gins`]; this adds the
//! `--truth` / `--compare` accuracy lines and the `--verbose` summary.

use crate::fail::Fail;
use clap::Args as ClapArgs;
use navfuse_core::types::NavSolution;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use navfuse_pipeline::kf_gins::{check, run_kf_gins, KfGinsOptions, KfGinsRun};
use navfuse_pipeline::kf_gins_align::AlignSource;
use navfuse_pipeline::PipelineError;
use std::path::PathBuf;
use std::time::Instant;

/// Run a KF-GINS YAML configuration (drop-in replacement for KF-GINS).
#[derive(ClapArgs, Debug, Clone)]
pub struct Args {
    /// KF-GINS YAML configuration (paths inside are relative to it).
    pub config: PathBuf,
    /// navfuse's land-vehicle configuration: NHC, ZUPT/ZARU, χ² gating
    /// (the same as `--platform car`).
    #[arg(long)]
    pub enhanced: bool,
    /// Platform profile: car, robot, pedestrian, uav, marine, static (its
    /// constraints and gating; see docs/config.md).
    #[arg(long)]
    pub platform: Option<navfuse_pipeline::profile::Platform>,
    /// Also run the RTS smoother and write `KF_GINS_Navresult_smoothed.nav`.
    #[arg(long)]
    pub smooth: bool,
    /// Also write the solutions as Parquet (`KF_GINS_Navresult.parquet`).
    #[arg(long)]
    pub parquet: bool,
    /// χ² innovation gate probability for the KF-GINS model (e.g. 0.9999);
    /// `--enhanced` always gates at 0.9999.
    #[arg(long)]
    pub gate: Option<f64>,
    /// Use GNSS positions only until this many seconds after `starttime`; after
    /// that only GNSS velocity (needs `gnssvelpath`) and height aid the INS
    /// (seed 001's after-370-s mode).
    #[arg(long)]
    pub position_until: Option<f64>,
    /// Write the outputs here instead of the YAML's `outputpath`.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Print a one-line summary with timing and update counts to stderr.
    #[arg(long, short)]
    pub verbose: bool,
    /// IMU–GNSS time offset added to the IMU stamps: seconds, `auto`
    /// (estimated with its σ from the GNSS course and the z gyro, applied
    /// only when significant) or `none`. Default: `auto` with `--enhanced` or
    /// `--platform`, else `none` (KF-GINS applies none).
    #[arg(long)]
    pub time_offset: Option<String>,
    /// Print accuracy against this reference (KF-GINS .nav layout of the
    /// antenna, e.g. `truth.nav`): horizontal/vertical RMS and, with
    /// `--outages`, the per-outage maximum horizontal drift and its RMS.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Print the horizontal/vertical RMS difference to another KF-GINS result
    /// (IMU positions, e.g. KF-GINS's own `KF_GINS_Navresult.nav`), at its epochs.
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Outage schedule for `--truth`: `START,LEN,PERIOD,COUNT` [s] (e.g. 243382,30,90,5).
    #[arg(long)]
    pub outages: Option<String>,
    /// Initial state: `yaml` (the YAML's, as KF-GINS), `data` (navfuse's
    /// alignment: levelling, GNSS course or the yaw Gaussian-sum filter) or
    /// `auto` (the YAML's unless its attitude fails a χ² test against the
    /// data's alignment; then the data's, with a warning). Default: `auto`
    /// with `--enhanced` or `--platform`, else `yaml`.
    #[arg(long, value_parser = AlignSource::parse)]
    pub align: Option<AlignSource>,
}

pub fn run(args: Args) -> Result<(), Fail> {
    let t0 = Instant::now();
    let r = run_config(&args)?;
    if let Some(cp) = &args.compare {
        let other = check::read_nav(cp)?;
        let a = check::accuracy(&r.solutions, &other, &navfuse_core::Vec3::zeros());
        eprintln!(
            "vs {}: horizontal RMS {:.4} m, vertical RMS {:.4} m, max horizontal {:.4} m ({} epochs)",
            cp.display(), a.h_rms, a.v_rms, a.h_max, a.n
        );
    }
    if let Some(tp) = &args.truth {
        let truth = check::read_nav(tp)?;
        let lever = r.config.lever_arm_b;
        let outages = match &args.outages {
            Some(s) => Some(check::parse_outages(s).map_err(|e| Fail::usage(e.to_string()))?),
            None => None,
        };
        let fixes = run_fix_times(&args).map_err(Fail::input)?;
        let print = |name: &str, sols: &[NavSolution]| {
            let a = check::accuracy(sols, &truth, &lever);
            eprintln!("{name}: horizontal RMS {:.4} m, vertical RMS {:.4} m, max horizontal {:.3} m ({} epochs)", a.h_rms, a.v_rms, a.h_max, a.n);
            if let Some(o) = &outages {
                let m = check::outage_drift(sols, &truth, &lever, o, &fixes);
                let rms = (m.iter().map(|x| x * x).sum::<f64>() / m.len().max(1) as f64).sqrt();
                eprintln!("{name}: per-outage max horizontal drift {m:.2?} m, RMS {rms:.2} m");
            }
        };
        print("forward", &r.solutions);
        if !r.smoothed.is_empty() {
            let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
            print("smoothed", &sm);
        }
    }
    if args.verbose {
        let s = &r.stats;
        eprintln!(
            "navfuse kf-gins: {} IMU samples, GNSS pos used {} (gated {}, forced {}), vel used {} (gated {}), height used {} (gated {}), NHC {}, ZUPT {}, ZARU {}, {:.3} s -> {}",
            s.imu_samples,
            s.gnss_pos_used,
            s.gnss_pos_rejected_gate,
            s.gnss_pos_forced,
            s.gnss_vel_used,
            s.gnss_vel_rejected_gate,
            s.height_used,
            s.height_rejected_gate,
            s.nhc_used,
            s.zupt_used,
            s.zaru_used,
            t0.elapsed().as_secs_f64(),
            r.output_dir.display()
        );
    }
    Ok(())
}

/// The library run of these arguments.
pub fn run_config(args: &Args) -> Result<KfGinsRun, PipelineError> {
    let opts = KfGinsOptions {
        enhanced: args.enhanced,
        platform: args.platform,
        smooth: args.smooth,
        gate: args.gate,
        position_until: args.position_until,
        output: args.output.clone(),
        time_offset: args.time_offset.clone(),
        verbose: args.verbose,
        align: args.align,
        parquet: args.parquet,
        white_sigma: false,
    };
    run_kf_gins(&args.config, &opts)
}

fn run_fix_times(args: &Args) -> Result<Vec<f64>, String> {
    let cfg = KfGinsConfig::load(&args.config)?;
    Ok(
        navfuse_pipeline::kfgins_input::read_kfgins_gnss(&cfg.resolve(&cfg.gnsspath))
            .map_err(|e| e.to_string())?
            .iter()
            .map(|g| g.t)
            .collect(),
    )
}
