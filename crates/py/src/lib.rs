//! `navfuse._navfuse`: the compiled half of the `navfuse` Python package
//! (python/navfuse wraps it: numpy arrays, pandas DataFrames, docstrings,
//! stubs). Tables cross as row-major float64 bytes with named, unit-suffixed
//! columns ([`tables`]); summaries as JSON text. Every Rust run releases the
//! GIL; every error is raised as `navfuse.NavfuseError` carrying the text the
//! CLI prints (`file:line: field …`).

mod eskf;
mod sim;
mod tables;

use navfuse_core::estimators::eskf::EskfStats;
use navfuse_eval::{evaluate as eval_run, EvalConfig, Outage, OutageSchedule};
use navfuse_pipeline::kf_gins::{check, run_kf_gins, KfGinsOptions};
use navfuse_pipeline::{run as run_pipeline, run_eskf, RunConfig, RunOptions};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict};
use std::path::{Path, PathBuf};
use tables::Table;

create_exception!(
    navfuse,
    NavfuseError,
    PyException,
    "A navfuse error: bad input (naming file, line and field), configuration, alignment or estimator failure."
);

/// Any displayable error as a `NavfuseError` with its text.
pub(crate) fn err(e: impl std::fmt::Display) -> PyErr {
    NavfuseError::new_err(e.to_string())
}

/// The ESKF's update counters as JSON.
pub(crate) fn stats_json(s: &EskfStats) -> serde_json::Value {
    serde_json::json!({
        "imu_samples": s.imu_samples,
        "imu_rejected_bad": s.imu_rejected_bad,
        "gnss_pos_used": s.gnss_pos_used,
        "gnss_pos_rejected_gate": s.gnss_pos_rejected_gate,
        "deweighted": s.deweighted,
        "gnss_pos_forced": s.gnss_pos_forced,
        "gnss_rejected_bad": s.gnss_rejected_bad,
        "gnss_vel_used": s.gnss_vel_used,
        "gnss_vel_rejected_gate": s.gnss_vel_rejected_gate,
        "height_used": s.height_used,
        "height_rejected_gate": s.height_rejected_gate,
        "nhc_used": s.nhc_used,
        "nhc_rejected_gate": s.nhc_rejected_gate,
        "zupt_used": s.zupt_used,
        "zupt_rejected_gate": s.zupt_rejected_gate,
        "zaru_used": s.zaru_used,
        "singular": s.singular,
    })
}

/// Solutions as bytes in a new Python `bytearray`: mutable, so the
/// DataFrame can own the buffer without a second copy (`_tables.frame`).
fn sol_bytes<'py>(py: Python<'py>, s: &[navfuse_core::NavSolution]) -> Bound<'py, PyByteArray> {
    PyByteArray::new(py, &tables::solutions_bytes(s))
}

/// `navfuse kf-gins YAML` in-process: returns a dict with `solution` and
/// `smoothed` (solution-table bytes), `output_dir`, `stats` (JSON) and
/// `time_offset_s` (None when none applied).
#[pyfunction]
#[pyo3(signature = (yaml, enhanced = false, smooth = false, output = None, platform = None, time_offset = None))]
fn kf_gins<'py>(
    py: Python<'py>,
    yaml: PathBuf,
    enhanced: bool,
    smooth: bool,
    output: Option<PathBuf>,
    platform: Option<String>,
    time_offset: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let platform = platform
        .map(|p| p.parse::<navfuse_pipeline::profile::Platform>())
        .transpose()
        .map_err(err)?;
    let opts = KfGinsOptions {
        enhanced,
        platform,
        smooth,
        output,
        time_offset,
        ..Default::default()
    };
    let r = py
        .allow_threads(|| run_kf_gins(&yaml, &opts))
        .map_err(err)?;
    let smoothed: Vec<_> = r.smoothed.iter().map(check::smoothed_solution).collect();
    let d = PyDict::new(py);
    d.set_item("solution", sol_bytes(py, &r.solutions))?;
    d.set_item("smoothed", sol_bytes(py, &smoothed))?;
    d.set_item("output_dir", r.output_dir)?;
    d.set_item("stats", stats_json(&r.stats).to_string())?;
    d.set_item("time_offset_s", r.time_offset.map(|o| o.0))?;
    Ok(d)
}

/// `navfuse run CONFIG.toml` in-process; returns `solution`, `smoothed`,
/// `summary` (JSON), `output_dir`, `outputs`, `message`.
#[pyfunction]
#[pyo3(signature = (path, output = None, estimator = None))]
fn run_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    output: Option<PathBuf>,
    estimator: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg = RunConfig::from_toml_file(&path).map_err(err)?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    run_cfg(
        py,
        &cfg,
        &base,
        RunOptions {
            output,
            estimator,
            no_std: false,
        },
    )
}

fn run_cfg<'py>(
    py: Python<'py>,
    cfg: &RunConfig,
    base: &Path,
    opts: RunOptions,
) -> PyResult<Bound<'py, PyDict>> {
    let r = py
        .allow_threads(|| run_pipeline(cfg, base, &opts))
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("solution", sol_bytes(py, &r.trajectory))?;
    d.set_item("smoothed", sol_bytes(py, &r.smoothed))?;
    d.set_item("summary", r.summary.to_string())?;
    d.set_item("output_dir", r.out_dir)?;
    d.set_item("outputs", r.outputs)?;
    d.set_item("message", r.message)?;
    Ok(d)
}

/// A run configuration given as JSON (the TOML schema: `navfuse.run(dict)`),
/// paths relative to `base_dir`. With `imu`/`gnss` tables (bytes, columns)
/// the ESKF runs in memory on them and writes nothing.
#[pyfunction]
#[pyo3(signature = (json, base_dir, output = None, estimator = None, imu = None, gnss = None))]
fn run_json<'py>(
    py: Python<'py>,
    json: &str,
    base_dir: PathBuf,
    output: Option<PathBuf>,
    estimator: Option<String>,
    imu: Option<(Vec<u8>, usize)>,
    gnss: Option<(Vec<u8>, usize)>,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg: RunConfig = serde_json::from_str(json).map_err(|e| err(format!("run config: {e}")))?;
    let (imu, gnss) = match (imu, gnss) {
        (None, None) => {
            return run_cfg(
                py,
                &cfg,
                &base_dir,
                RunOptions {
                    output,
                    estimator,
                    no_std: false,
                },
            )
        }
        (Some(i), Some(g)) => (i, g),
        _ => return Err(err("run config: give both imu and gnss arrays, or neither")),
    };
    let imu_t = Table {
        name: &cfg.input.imu,
        data: &imu.0,
        ncols: imu.1,
    };
    let imu = tables::imu_from(&imu_t, cfg.input.imu_rate).map_err(err)?;
    let gnss = tables::gnss_from(&Table {
        name: &cfg.input.gnss,
        data: &gnss.0,
        ncols: gnss.1,
    })
    .map_err(err)?;
    let r = py
        .allow_threads(|| run_eskf(&cfg, &base_dir, &imu, &gnss, None))
        .map_err(err)?;
    let summary = serde_json::json!({
        "config": cfg,
        "alignment": r.alignment,
        "align_method": r.align_method,
        "align_wait_s": r.align_wait_s,
        "align_yaw_std_deg": r.align_yaw_std_deg,
        "warnings": r.warnings,
        "noise_source": r.noise_source,
        "platform": r.platform.map(|p| p.to_string()),
        "stats": stats_json(&r.stats),
        "imu_samples_read": r.imu_samples_read,
        "imu_samples_before_start": r.imu_samples_before_start,
        "gnss_fixes_read": r.gnss_fixes_read,
        "gnss_fixes_cut_by_outage": r.gnss_fixes_cut_by_outage,
        "gnss_fixes_fed": r.gnss_fixes_fed,
        "solutions": r.solutions.len(),
        "seconds_filter": r.seconds_filter,
        "imu_time_offset_applied_s": r.time_offset_applied.as_ref().map(|o| o.0),
    });
    let d = PyDict::new(py);
    d.set_item("solution", sol_bytes(py, &r.solutions))?;
    d.set_item("smoothed", sol_bytes(py, &r.smoothed))?;
    d.set_item("summary", summary.to_string())?;
    Ok(d)
}

/// Errors of `solution` against `truth` (solution-table bytes, 19 columns),
/// optional outage windows `[start, end)` [s]: returns (summary JSON, error
/// table bytes in [`EVAL_COLUMNS`] order).
#[pyfunction]
#[pyo3(signature = (solution, truth, outages = None))]
fn evaluate<'py>(
    py: Python<'py>,
    solution: &[u8],
    truth: &[u8],
    outages: Option<Vec<(f64, f64)>>,
) -> PyResult<(String, Bound<'py, PyBytes>)> {
    let t = |name, data| Table {
        name,
        data,
        ncols: 19,
    };
    let sol = tables::solutions_from(&t("solution", solution)).map_err(err)?;
    let tru = tables::solutions_from(&t("truth", truth)).map_err(err)?;
    let sched = outages
        .map(|o| {
            OutageSchedule::list(
                o.into_iter()
                    .map(|(start, end)| Outage { start, end })
                    .collect(),
            )
        })
        .transpose()
        .map_err(|e| err(format!("outages: {e}")))?;
    let ev = py
        .allow_threads(|| eval_run(&sol, &tru, &EvalConfig::default(), sched.as_ref(), None))
        .map_err(err)?;
    let mut rows = Vec::with_capacity(ev.errors.len() * EVAL_COLUMNS.len() * 8);
    let nan3 = [f64::NAN; 3];
    for e in &ev.errors {
        let a = e.att_rpy.unwrap_or(nan3).map(f64::to_degrees);
        let v = e.vel_ned.unwrap_or(nan3);
        let p = e.pos_ned;
        for x in [
            e.t,
            p[0],
            p[1],
            p[2],
            e.horizontal,
            e.vertical,
            v[0],
            v[1],
            v[2],
            a[0],
            a[1],
            a[2],
        ] {
            rows.extend_from_slice(&x.to_le_bytes());
        }
    }
    let summary = serde_json::json!({
        "counts": ev.counts,
        "summary": ev.summary,
        "outages": ev.outages,
    });
    Ok((summary.to_string(), PyBytes::new(py, &rows)))
}

/// Columns of the error table of `evaluate` (solution − reference).
const EVAL_COLUMNS: [&str; 12] = [
    "t_s",
    "north_m",
    "east_m",
    "down_m",
    "horizontal_m",
    "vertical_m",
    "vel_n_mps",
    "vel_e_mps",
    "vel_d_mps",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
];

#[pymodule]
fn _navfuse(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("NavfuseError", m.py().get_type::<NavfuseError>())?;
    m.add("SOLUTION_COLUMNS", tables::SOLUTION_COLUMNS.to_vec())?;
    m.add("IMU_COLUMNS", tables::IMU_COLUMNS.to_vec())?;
    m.add("GNSS_COLUMNS", tables::GNSS_COLUMNS.to_vec())?;
    m.add("EVAL_COLUMNS", EVAL_COLUMNS.to_vec())?;
    m.add_class::<eskf::Eskf>()?;
    m.add_function(wrap_pyfunction!(kf_gins, m)?)?;
    m.add_function(wrap_pyfunction!(run_file, m)?)?;
    m.add_function(wrap_pyfunction!(run_json, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    Ok(())
}
