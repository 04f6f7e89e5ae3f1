//! `navfuse demo`: simulate a drive, run every estimator on it, write outputs and a report.
//!
//! Needs no files: the default scenario (`scenarios/demo_drive.toml`, a
//! ~10-minute car drive with an industrial MEMS IMU at 100 Hz and 1 Hz GNSS
//! with two outages) is embedded. Simulation, estimators and scores:
//! [`navfuse_pipeline::demo`].

use clap::Args as ClapArgs;
use navfuse_core::Vec3;
use navfuse_pipeline::demo::{simulate_and_score, DEMO_SCENARIO, ESKF_INIT_ATT_ERR};
use navfuse_sim::Scenario;
use std::path::PathBuf;
use std::time::Instant;

/// Simulate a drive, run every estimator on it, write outputs and a report.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Seed of the simulated sensor errors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use this scenario instead of the embedded drive.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Skip the HTML report (written by default to OUT/report/index.html,
    /// plots/*.svg: people would rather look than read).
    #[arg(long)]
    pub no_report: bool,
    /// The report is the default now; accepted so that older scripts run.
    #[arg(long, hide = true, conflicts_with = "no_report")]
    pub report: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let t0 = Instant::now();
    let sc = match &args.scenario {
        Some(p) => Scenario::from_file(p).map_err(|e| e.to_string())?,
        None => Scenario::from_toml(DEMO_SCENARIO, "embedded demo_drive.toml")
            .map_err(|e| e.to_string())?,
    };
    let (run, scores, t_sim) = simulate_and_score(&sc, args.seed, &args.out)?;

    println!("navfuse demo — simulated drive (seed {})", args.seed);
    println!("{}", run.summary());
    let outs: Vec<String> = sc
        .gnss
        .outages
        .iter()
        .map(|o| format!("{:.0}–{:.0} s", o[0], o[1]))
        .collect();
    println!(
        "GNSS outages: {}",
        if outs.is_empty() {
            "none".into()
        } else {
            outs.join(", ")
        }
    );
    println!();
    println!(
        "estimators run: {}",
        scores.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
    );
    println!(
        "{:<12} {:>8} {:>10} {:>10} {:>10} {:>12}  max h error in each outage [m]",
        "estimator", "epochs", "h rms [m]", "h max [m]", "v rms [m]", "yaw rms [°]",
    );
    for s in &scores {
        let o: Vec<String> = s.outage_max.iter().map(|x| format!("{x:.2}")).collect();
        println!(
            "{:<12} {:>8} {:>10.2} {:>10.2} {:>10.2} {:>12}  {}   ({:.3} s)",
            s.name,
            s.epochs,
            s.h_rms,
            s.h_max,
            s.v_rms,
            if s.yaw_rms.is_nan() {
                "–".to_string()
            } else {
                format!("{:.3}", s.yaw_rms)
            },
            o.join(" / "),
            s.secs
        );
    }
    println!(
        "(errors of the IMU point vs exact truth; gps-hold reports the antenna, {} m lever arm; \
         eskf starts at the true position/velocity with a {:.1}°/{:.1}°/{:.1}° roll/pitch/yaw error; \
         in brackets: wall time of the estimator loop)",
        Vec3::from(sc.gnss.lever_arm_m).norm(),
        ESKF_INIT_ATT_ERR[0].to_degrees(),
        ESKF_INIT_ATT_ERR[1].to_degrees(),
        ESKF_INIT_ATT_ERR[2].to_degrees()
    );
    println!(
        "wrote {} (truth.nav/csv, imu*.txt/csv, gnss.txt/csv, <estimator>.nav/csv); simulation {:.2} s, total {:.2} s",
        args.out.display(),
        t_sim,
        t0.elapsed().as_secs_f64()
    );
    if !args.no_report {
        let start = run.traj.truth[0].t;
        let outages = sc.gnss.outages.iter().map(|o| (start + o[0], start + o[1]));
        navfuse_report::build::from_demo(&args.out, outages.collect())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The report is written by default and skipped with `--no-report`.
    #[test]
    fn demo_writes_its_report_unless_told_not_to() {
        let base = std::env::temp_dir().join(format!("navfuse-demo-cli-{}", std::process::id()));
        for no_report in [false, true] {
            let out = base.join(if no_report { "without" } else { "with" });
            let _ = std::fs::remove_dir_all(&out);
            let args = Args {
                out: out.clone(),
                seed: 1,
                scenario: None,
                no_report,
                report: false,
            };
            run(args).unwrap();
            assert!(out.join("eskf.nav").exists());
            let html = out.join("report/index.html");
            assert_eq!(html.exists(), !no_report, "{}", html.display());
        }
        let _ = std::fs::remove_dir_all(&base);
    }
}
