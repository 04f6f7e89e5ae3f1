//! `navfuse run` as a library call: load the inputs named by a
//! [`RunConfig`], run the ESKF ([`crate::eskf_run::run_eskf`]) or another
//! estimator, write `solution.nav` (+ extra formats, innovations, smoothed)
//! and `summary.json`.

use crate::config::{resolve_path, RunConfig};
use crate::error::{PipelineError, Result};
use crate::eskf_run::{run_eskf_span, select_span};
use crate::input::{self, InputSpec};
use crate::other::{run_other, OtherRun};
use crate::outputs::{out_formats, write_innovations, write_journal_parquet, write_solutions};
use crate::run_checks::time_keys_json;
use crate::sigma::write_std;
use crate::summary::Summary;
use crate::time_offset::TimeOffsetCfg;
use navfuse_core::estimators::eskf::EskfStats;
use navfuse_core::types::NavSolution;
use navfuse_io::trajectory::OutFormat;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Caller's overrides of a run (the CLI's flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Output folder (default: `output` of the config, relative to its
    /// folder, else `./navfuse-out`).
    pub output: Option<PathBuf>,
    /// Estimator overriding `[filter] estimator`: `eskf`, `pf-lc`, `gps-acc`, `cp-att`.
    pub estimator: Option<String>,
    /// Do not write the σ files (`solution.std`, `solution_smoothed.std`);
    /// for measuring what they cost.
    pub no_std: bool,
}

/// What [`run`] wrote.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    /// The output folder.
    pub out_dir: PathBuf,
    /// Every file written except `summary.json`, as listed in it.
    pub outputs: Vec<String>,
    /// The `summary.json` written.
    pub summary_path: PathBuf,
    /// Its content.
    pub summary: serde_json::Value,
    /// Number of (forward) solutions.
    pub solutions: usize,
    /// The forward solutions written to `solution.nav` (IMU point; lat/lon
    /// [rad], NED velocity, rpy of body FRD w.r.t. NED), for in-memory callers.
    pub trajectory: Vec<NavSolution>,
    /// The smoothed solutions (empty unless `[filter] smooth`).
    pub smoothed: Vec<NavSolution>,
    /// How the ESKF was aligned (`None` for the other estimators).
    pub alignment: Option<String>,
    /// The ESKF's update counters (`None` for the other estimators).
    pub stats: Option<EskfStats>,
    /// The one-line account `navfuse run` prints to stderr.
    pub message: String,
}

/// Do what `navfuse run` does: read the inputs of `cfg` (paths relative to
/// `base_dir`, the configuration's folder), run the estimator, write the
/// solutions and `summary.json` into the output folder.
pub fn run(cfg: &RunConfig, base_dir: &Path, opts: &RunOptions) -> Result<RunOutcome> {
    let rel = |p: &str| resolve_path(base_dir, p);
    let out_dir = opts
        .output
        .clone()
        .or(cfg.output.as_deref().map(rel))
        .unwrap_or_else(|| PathBuf::from("navfuse-out"));
    let formats = out_formats(&cfg.formats).map_err(|e| cfg.err(format!("formats: {e}")))?;
    let estimator = opts
        .estimator
        .clone()
        .or(cfg.filter.estimator.clone())
        .unwrap_or_else(|| "eskf".into());
    let coupling = cfg.coupling()?;
    let tight = coupling == crate::config::Coupling::Tight;
    let rtk = coupling == crate::config::Coupling::Rtk;
    crate::rtk_run::check_keys(cfg, rtk)?;
    if rtk && estimator != "eskf" {
        return Err(cfg.err(format!(
            "[filter] coupling = \"rtk\" is an ESKF model; estimator {estimator:?} takes fixes \
             (use estimator = \"eskf\" or coupling = \"loose\")"
        )));
    }
    if rtk && cfg.filter.smooth {
        return Err(cfg.err(
            "[filter] smooth = true: the RTS smoother does not handle the RTK filter's \
             ambiguity states (they are outside its 21-state records); use smooth = false \
             with coupling = \"rtk\"",
        ));
    }
    if rtk && cfg.input.ubx.is_some() {
        return Err(cfg.err(
            "[filter] coupling = \"rtk\" reads the rover's raw observations from [input] gnss \
             (a .ubx log with RXM-RAWX + RXM-SFRBX, or RINEX observations + nav); \
             [input] ubx is an ESF/NAV-PVT log",
        ));
    }
    if tight && estimator != "eskf" {
        return Err(cfg.err(format!(
            "[filter] coupling = \"tight\" is an ESKF model; estimator {estimator:?} takes fixes \
             (use estimator = \"eskf\" or coupling = \"loose\")"
        )));
    }
    if tight && cfg.filter.smooth {
        // The smoother's records hold the 21 INS states; the tight filter's
        // receiver clock and satellite-error consider states live beside
        // them, so an RTS pass would ignore their correlation with the INS
        // states (and on the simulated test drive it gained nothing:
        // 1.945 m smoothed against 1.938 m forward).
        return Err(cfg.err(
            "[filter] smooth = true: the RTS smoother does not handle the tight filter's \
             receiver clock and satellite-error states (they are outside its 21-state records); \
             use smooth = false with coupling = \"tight\"",
        ));
    }
    if tight && cfg.input.ubx.is_some() {
        return Err(cfg.err(
            "[filter] coupling = \"tight\" reads raw observations from [input] gnss \
             (a .ubx log with RXM-RAWX + RXM-SFRBX, or RINEX observations + nav); \
             [input] ubx is an ESF/NAV-PVT log",
        ));
    }
    let nav: Vec<PathBuf> = cfg.input.nav.iter().map(|p| rel(p)).collect();
    // The base first: its errors (no nav, bad position) need no other file.
    let base = if rtk {
        Some(crate::rtk_run::load_base_cfg(cfg, &rel, &nav)?)
    } else {
        None
    };
    if estimator == "cp-att" {
        // Carrier phase only: the IMU and GNSS files are not read.
        return crate::cp_att_run::run_cp_att(cfg, base_dir, &out_dir, &formats);
    }
    let t_read = Instant::now();
    // Empty (not given, e.g. with `[input] ubx`) stays empty.
    let rel_given = |p: &str| if p.is_empty() { PathBuf::new() } else { rel(p) };
    let (imu_path, gnss_path) = (rel_given(&cfg.input.imu), rel_given(&cfg.input.gnss));
    let imu_tag = cfg.input.imu_tag.as_deref().map(rel);
    let none = TimeOffsetCfg::Named("none".into());
    // Unset or `auto`: loaded without an offset, decided below on the
    // loaded inputs (filter passes when the fixes carry velocities).
    // Not with tight coupling: the passes rerun the loosely coupled filter.
    let passes = crate::offset_passes::wants_passes(cfg) && !tight && !rtk;
    let offset = if passes {
        Some(&none)
    } else {
        cfg.input.imu_time_offset.as_ref()
    };
    let mut loaded = input::load(&InputSpec {
        imu: &imu_path,
        imu_format: cfg.input.imu_format.as_deref(),
        imu_rate: cfg.input.imu_rate,
        csv: cfg.input.csv.as_ref(),
        gnss: &gnss_path,
        gnss_format: cfg.input.gnss_format.as_deref(),
        imu_time_offset: offset,
        imu_time_base: cfg.input.imu_time_base,
        gnss_time_base: cfg.input.gnss_time_base,
        imu_tag: imu_tag.as_deref(),
        ubx: cfg.input.ubx.as_deref().map(rel).as_deref(),
        ubx_cfg: crate::ubx_input::events_config(
            cfg.input.ubx_metres_per_tick,
            cfg.input.ubx_esf_tick_s,
            cfg.input.imu_rate,
        )
        .map_err(|e| cfg.err(e))?,
        nav: &nav,
        raw: tight || rtk,
        raw_second: rtk,
    })
    .map_err(|e| match e {
        // The data's fault (exit code 3), named after the configuration.
        PipelineError::Input(m) => PipelineError::Input(format!("{}: {m}", cfg.name())),
        e => cfg.err(e.to_string()),
    })?;
    let mut kept = if passes {
        crate::offset_passes::decide_on_loaded(cfg, base_dir, &mut loaded, !opts.no_std)?
    } else {
        None
    };
    let ubx_aiding = crate::ubx_input::aiding_counts(&loaded.aiding);
    // `[input] odometer`: after the offset is decided (its samples take it).
    let odometer = match &cfg.input.odometer {
        Some(p) => Some(
            crate::odo_input::load_odometer(
                &rel(p),
                &cfg.input.odometer_csv.clone().unwrap_or_default(),
                &mut loaded,
            )
            .map_err(|m| PipelineError::Input(format!("{}: {m}", cfg.name())))?,
        ),
        None => None,
    };
    let heading = match &cfg.input.heading {
        Some(p) => Some(
            crate::heading_input::load_heading(&rel(p), cfg.input.heading_sigma_deg, &mut loaded)
                .map_err(|m| PipelineError::Input(format!("{}: {m}", cfg.name())))?,
        ),
        None => None,
    };
    let inputs = serde_json::json!({
        "imu": loaded.imu_report,
        "gnss": loaded.gnss_report,
        "odometer": odometer,
        "heading": heading,
        "time_base": loaded.time_base,
        "ubx_aiding_events": ubx_aiding,
        "imu_time_offset_applied_s": loaded.imu_time_offset.as_ref().map(|o| o.0),
        "imu_time_offset_source": loaded.imu_time_offset.as_ref().map(|o| o.1.clone()),
    });
    let seconds_read = t_read.elapsed().as_secs_f64();
    let mut span = select_span(cfg, &loaded.imu, &loaded.gnss)?;
    span.aiding = &loaded.aiding;
    if tight {
        let raw = loaded
            .raw
            .as_ref()
            .ok_or_else(|| PipelineError::Estimator("tight coupling without raw records".into()))?;
        span.tight = Some(crate::eskf_run::cut_raw(cfg, span.imu[0].t, raw));
    }
    let rtk_span = match (base, loaded.raw.as_ref()) {
        (Some(b), Some(raw)) => {
            let mut b = b;
            crate::rtk_run::base_on_rover_time(&mut b, loaded.imu.first().map_or(0.0, |s| s.t));
            Some(crate::rtk_run::rtk_span(
                cfg,
                span.imu[0].t,
                raw,
                b,
                cfg.input.base.as_deref().unwrap_or(""),
            )?)
        }
        (Some(_), None) => return Err(PipelineError::Estimator("rtk without raw records".into())),
        _ => None,
    };
    span.rtk = rtk_span.as_ref();
    let mut resolved = loaded.resolved.clone();
    resolved["time_keys"] = time_keys_json(cfg, &loaded.imu);
    let warnings = &loaded.warnings;
    if estimator != "eskf" {
        return run_other(
            &estimator,
            &OtherRun {
                cfg,
                imu: span.imu,
                gnss: &span.gnss,
                n_gnss: span.gnss_all.len(),
                cut: span.cut(),
                seconds_read,
                out_dir: &out_dir,
                formats: &formats,
                inputs: &inputs,
                imu_before_start: span.imu_before_start,
                warnings,
                resolved: &resolved,
            },
        );
    }
    let r = match kept.take() {
        Some(r) => r,
        None => run_eskf_span(cfg, base_dir, &span, loaded.aux.as_ref(), !opts.no_std)?,
    };
    std::fs::create_dir_all(&out_dir).map_err(PipelineError::io(&out_dir, ""))?;
    let mut outputs = Vec::new();
    // `.pos` carries the covariance's cross terms and the aiding status:
    // written from the σ rows (crate::pos_out), not by write_solutions.
    let pos = formats.contains(&OutFormat::Pos);
    let formats: Vec<OutFormat> = formats
        .into_iter()
        .filter(|f| *f != OutFormat::Pos)
        .collect();
    let write_pos = |stem: &str, sols: &[_], std: &[_]| {
        crate::pos_out::write_pos(
            &out_dir.join(format!("{stem}.pos")),
            sols,
            std,
            &r.std,
            &span.gnss,
            r.coast_after_s,
            r.rtk.as_ref().map(|_| &r.rtk_epochs[..]),
        )
    };
    outputs.extend(write_solutions(
        &out_dir,
        "solution",
        &r.solutions,
        &formats,
    )?);
    if pos {
        outputs.push(write_pos("solution", &r.solutions, &r.std)?);
    }
    if !opts.no_std {
        outputs.push(write_std(&out_dir.join("solution.std"), &r.std)?);
    }
    let journal = out_dir.join("solution.innovations.csv");
    outputs.push(match &r.rtk {
        // RTK: the fix decisions are rows of the journal too.
        Some(_) => crate::outputs::write_innovations_rtk(&journal, &r.updates, &r.rtk_epochs)?,
        None => write_innovations(&journal, &r.updates)?,
    });
    if formats.contains(&OutFormat::Parquet) {
        let p = out_dir.join("journal.parquet");
        outputs.push(write_journal_parquet(&p, &r.updates)?);
    }
    if cfg.filter.smooth {
        outputs.extend(write_solutions(
            &out_dir,
            "solution_smoothed",
            &r.smoothed,
            &formats,
        )?);
        if pos {
            outputs.push(write_pos(
                "solution_smoothed",
                &r.smoothed,
                &r.smoothed_std,
            )?);
        }
        if !opts.no_std {
            outputs.push(write_std(
                &out_dir.join("solution_smoothed.std"),
                &r.smoothed_std,
            )?);
        }
    }
    let time_offset = r.time_offset_text(loaded.imu_time_offset.as_ref());
    let mut summary = Summary::new(cfg, &r, inputs, time_offset, seconds_read, outputs.clone());
    // The inputs' warnings first, then the run's (alignment, …).
    summary.warnings = warnings.iter().cloned().chain(summary.warnings).collect();
    summary.resolved_input = &resolved;
    let p = out_dir.join("summary.json");
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| PipelineError::Output(e.to_string()))?;
    navfuse_io::atomic::write_atomic(&p, json).map_err(PipelineError::io(&p, ""))?;
    let st = &r.stats;
    let gnss_used = match &r.tight {
        Some(t) => format!(
            "tight: pseudoranges used {} / gated {}, Dopplers used {} / gated {} of {} observations",
            t.total.pseudorange_used,
            t.total.pseudorange_gated_chi2,
            t.total.doppler_used,
            t.total.doppler_gated_chi2,
            t.observations
        ),
        None => format!(
            "GNSS used {} / gated {}",
            st.gnss_pos_used, st.gnss_pos_rejected_gate
        ),
    };
    let message = format!(
        "navfuse run: {} solutions, {gnss_used}; {}; summary {}",
        r.solutions.len(),
        summary.alignment,
        p.display()
    );
    Ok(RunOutcome {
        out_dir,
        outputs,
        summary: serde_json::to_value(&summary)
            .map_err(|e| PipelineError::Output(e.to_string()))?,
        summary_path: p,
        solutions: r.solutions.len(),
        trajectory: r.solutions,
        smoothed: r.smoothed,
        alignment: Some(r.alignment),
        stats: Some(r.stats),
        message,
    })
}
