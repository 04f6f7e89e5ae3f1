//! `navfuse run --estimator pf-lc | gps-acc`: the other estimators with
//! their default configurations, fed the same time-ordered events; they
//! initialise themselves from GNSS.

use crate::config::RunConfig;
use crate::error::{PipelineError, Result};
use crate::outputs::write_solutions;
use crate::run::RunOutcome;
use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig};
use navfuse_core::estimators::pf_lc::{PfLc, PfLcConfig};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use navfuse_io::trajectory::OutFormat;
use std::path::Path;
use std::time::Instant;

/// Inputs of a run of an estimator other than the ESKF.
pub(crate) struct OtherRun<'a> {
    pub cfg: &'a RunConfig,
    pub imu: &'a [ImuSample],
    pub gnss: &'a [GnssFix],
    pub n_gnss: usize,
    pub cut: usize,
    pub seconds_read: f64,
    pub out_dir: &'a Path,
    pub formats: &'a [OutFormat],
    pub inputs: &'a serde_json::Value,
    pub imu_before_start: usize,
    /// The summary's `warnings` and `resolved_input`.
    pub warnings: &'a [String],
    pub resolved: &'a serde_json::Value,
}

/// Run PF-LC (seed 002) or GPS-ACC (seed 004) with their default
/// configurations over the time-ordered events (a fix goes before the first
/// IMU sample ending at or after it); they initialise
/// themselves from GNSS. Writes the solutions and `summary.json`.
pub(crate) fn run_other(name: &str, r: &OtherRun) -> Result<RunOutcome> {
    let (mut est, config): (Box<dyn Estimator>, String) = match name {
        "pf-lc" => {
            let c = PfLcConfig::default();
            (Box::new(PfLc::new(c)), format!("{c:?}"))
        }
        "gps-acc" => {
            let c = AccelDrConfig::rate_scaled();
            (Box::new(AccelDr::new(c)), format!("{c:?}"))
        }
        other => {
            return Err(PipelineError::Estimator(format!(
                "estimator {other:?}: expected eskf, pf-lc, gps-acc or cp-att"
            )))
        }
    };
    std::fs::create_dir_all(r.out_dir).map_err(PipelineError::io(r.out_dir, ""))?;
    let t_filter = Instant::now();
    let mut sols = Vec::with_capacity(r.imu.len());
    let mut g = r.gnss.partition_point(|x| x.t < r.imu[0].t - r.imu[0].dt);
    let mut gnss_fed = 0usize;
    for s in r.imu {
        // Strict time order: a fix goes before the first IMU sample ending at
        // or after it (these estimators do not split IMU intervals).
        while g < r.gnss.len() && r.gnss[g].t <= s.t {
            if let Some(sol) = est.push(&Event::Gnss(r.gnss[g])) {
                sols.push(sol);
            }
            gnss_fed += 1;
            g += 1;
        }
        if let Some(sol) = est.push(&Event::Imu(*s)) {
            sols.push(sol);
        }
    }
    let seconds_filter = t_filter.elapsed().as_secs_f64();
    let outputs = write_solutions(r.out_dir, "solution", &sols, r.formats)?;
    let summary = serde_json::json!({
        "config": r.cfg,
        "estimator": est.name(),
        "filter": config,
        "inputs": r.inputs,
        "warnings": r.warnings,
        "resolved_input": r.resolved,
        "imu_samples_read": r.imu.len() + r.imu_before_start,
        "imu_samples_before_start": r.imu_before_start,
        "gnss_fixes_read": r.n_gnss,
        "gnss_fixes_cut_by_outage": r.cut,
        "gnss_fixes_outside_imu_span": r.n_gnss - r.cut - gnss_fed,
        "used_rejected": {"imu_fed": r.imu.len(), "gnss_fed": gnss_fed},
        "solutions": sols.len(),
        "seconds_read": r.seconds_read,
        "seconds_filter": seconds_filter,
        "outputs": &outputs,
    });
    let name_used = est.name();
    let n_imu = r.imu.len();
    finish_run(r.out_dir, outputs, summary, sols, |p, n| {
        format!(
            "navfuse run: {name_used} ({name}) {n} solutions from {n_imu} IMU samples and {gnss_fed} GNSS fixes; summary {}",
            p.display()
        )
    })
}

/// The end of a run of an estimator other than the ESKF: write `summary`
/// as `OUT/summary.json` and return the outcome; `message(summary path,
/// number of solutions)` is the one-line account.
pub(crate) fn finish_run(
    out_dir: &Path,
    outputs: Vec<String>,
    summary: serde_json::Value,
    sols: Vec<NavSolution>,
    message: impl FnOnce(&Path, usize) -> String,
) -> Result<RunOutcome> {
    let p = out_dir.join("summary.json");
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| PipelineError::Output(e.to_string()))?;
    navfuse_io::atomic::write_atomic(&p, json).map_err(PipelineError::io(&p, ""))?;
    let message = message(&p, sols.len());
    Ok(RunOutcome {
        out_dir: out_dir.to_path_buf(),
        outputs,
        summary_path: p,
        summary,
        solutions: sols.len(),
        trajectory: sols,
        smoothed: Vec::new(),
        alignment: None,
        stats: None,
        message,
    })
}
