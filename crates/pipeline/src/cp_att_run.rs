//! CP-ATT (seed 003) in `navfuse run` (issue 17): `estimator = "cp-att"`
//! runs the carrier-phase attitude alone on `[input] carrier_phase`
//! (`navfuse_io::carrier_phase` CSV); `[filter] heading_source = "cp-att"`
//! runs it beside the ESKF and feeds its attitude to the ESKF as
//! [`Event::Heading`] events (source [`HeadingSource::CpAtt`], the heading
//! and pitch of the IMU body x axis, see `cp_att_stream::heading_fix`) at
//! the epoch times, merged in time order with the GNSS fixes.
//!
//! `[cp_att]` keys (docs/config.md): `baselines_m` (slave − master in the
//! antenna frame), `antenna_axes_b` (the IMU-body FRD directions of the
//! antenna frame's x, y, z axes; default x right, y forward, z up, the
//! paper's frame), `output`, `fallback_float`, `wavelength_m` and the
//! attitude-dynamics bounds of the fixed-solution attitude filter.

use crate::config::{resolve_path, RunConfig};
use crate::error::{PipelineError, Result};
use crate::outputs::write_solutions;
use crate::run::RunOutcome;
use navfuse_core::estimators::cp_att_stream::{
    heading_fix, CpAttStream, CpAttStreamConfig, CpAttStreamStats,
};
use navfuse_core::estimators::cp_attitude::{AttFilterConfig, CpAttOutput, FixConfig};
use navfuse_core::types::{CarrierPhaseSat, Estimator, Event, HeadingFix, NavSolution};
use navfuse_core::{Mat3, Vec3};
use navfuse_io::carrier_phase::CpCsvReader;
use navfuse_io::trajectory::OutFormat;
use navfuse_io::RecordStats;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `[filter] heading_source`: what aids the ESKF's heading.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum HeadingSourceCfg {
    /// No heading aiding (the default).
    #[default]
    None,
    /// CP-ATT on `[input] carrier_phase` with `[cp_att]`.
    CpAtt,
}

/// `[cp_att]`: CP-ATT's antenna geometry and solution.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CpAttCfg {
    /// Baselines slave − master in the antenna frame [m], in the order of
    /// the file's `sdK_m` columns (2 to 4; the float solution needs 3).
    pub baselines_m: Vec<[f64; 3]>,
    /// The IMU-body (FRD) directions of the antenna frame's x, y, z axes
    /// (rows); default `[[0,1,0],[1,0,0],[0,0,-1]]`: x right, y forward,
    /// z up (the paper's frame on a level-mounted antenna platform).
    pub antenna_axes_b: Option<[[f64; 3]; 3]>,
    /// "fixed" (default), "fixed-joint", "fixed-wahba", "float", "float-wahba".
    pub output: Option<String>,
    /// Report the float solution until the first fix (default true).
    pub fallback_float: Option<bool>,
    /// Carrier wavelength [m] (default GPS L1, 0.190293673).
    pub wavelength_m: Option<f64>,
    /// Bounds (horizontal, vertical) of the body's angular rate [deg/s],
    /// angular acceleration [deg/s²] and jerk [deg/s³] for the attitude
    /// filter (Bar-Shalom's rule, `AttFilterConfig::from_bounds`).
    pub max_rate_dps: Option<[f64; 2]>,
    pub max_accel_dps2: Option<[f64; 2]>,
    pub max_jerk_dps3: Option<[f64; 2]>,
}

/// Default dynamics bounds of a road vehicle [deg/s, deg/s², deg/s³],
/// (horizontal = roll/pitch axes, vertical = yaw). Yaw rate: a car at the
/// lateral-acceleration limit (~8 m/s²) at 5 m/s turns 90°/s, on a parking
/// manoeuvre ~30°/s: 60°/s; roll/pitch rate of a sprung body ~10–20°/s:
/// 20°/s. Accelerations and jerks: the rate bound reached within ~0.5 s
/// (steering step response, suspension frequency 1–2 Hz).
const CAR_RATE_DPS: [f64; 2] = [20.0, 60.0];
const CAR_ACCEL_DPS2: [f64; 2] = [40.0, 120.0];
const CAR_JERK_DPS3: [f64; 2] = [80.0, 240.0];

fn parse_output(s: &str) -> Option<CpAttOutput> {
    Some(match s {
        "fixed" => CpAttOutput::Fixed,
        "fixed-joint" => CpAttOutput::FixedJoint,
        "fixed-wahba" => CpAttOutput::FixedWahba,
        "float" => CpAttOutput::Float,
        "float-wahba" => CpAttOutput::FloatWahba,
        _ => return None,
    })
}

impl CpAttCfg {
    /// The estimator configuration for epochs `epoch_dt` [s] apart.
    /// Errors name the key.
    pub fn stream_config(&self, epoch_dt: f64) -> std::result::Result<CpAttStreamConfig, String> {
        let b: Vec<Vec3> = self.baselines_m.iter().map(|b| Vec3::from(*b)).collect();
        let mut c = CpAttStreamConfig::new(&b);
        if b.len() > c.b_a.len() {
            return Err(format!("baselines_m: at most {} baselines", c.b_a.len()));
        }
        if let Some(ax) = self.antenna_axes_b {
            // Rows: antenna axes in the body; c_ba has them as columns.
            c.c_ba = Mat3::from_rows(&ax.map(|r| Vec3::from(r).transpose())).transpose();
        }
        if let Some(o) = &self.output {
            c.output = parse_output(o).ok_or_else(|| {
                format!(
                    "output: {o:?} is not fixed, fixed-joint, fixed-wahba, float or float-wahba"
                )
            })?;
        }
        c.fallback_float = self.fallback_float.unwrap_or(true);
        let deg = |v: [f64; 2]| [v[0].to_radians(), v[1].to_radians()];
        let bounds = [
            deg(self.max_rate_dps.unwrap_or(CAR_RATE_DPS)),
            deg(self.max_accel_dps2.unwrap_or(CAR_ACCEL_DPS2)),
            deg(self.max_jerk_dps3.unwrap_or(CAR_JERK_DPS3)),
        ];
        if bounds
            .iter()
            .flatten()
            .any(|x| !(x.is_finite() && *x > 0.0))
        {
            return Err("max_rate_dps / max_accel_dps2 / max_jerk_dps3: must be > 0".into());
        }
        let lambda = self.wavelength_m.unwrap_or(FixConfig::default().lambda);
        if !(0.01..=1.0).contains(&lambda) {
            return Err(format!("wavelength_m: {lambda} outside [0.01, 1] m"));
        }
        c.fix = Some(FixConfig {
            lambda,
            att_filter: Some(AttFilterConfig::from_bounds(&bounds, 2, epoch_dt)),
            ..Default::default()
        });
        CpAttStream::new(c).map_err(|e| e.to_string())?;
        Ok(c)
    }
}

/// The records of `[input] carrier_phase` (all of them; the first bad line
/// is an error naming file, line and field).
pub fn load_records(
    cfg: &RunConfig,
    base_dir: &Path,
) -> Result<(Vec<CarrierPhaseSat>, RecordStats)> {
    let name = cfg
        .input
        .carrier_phase
        .as_deref()
        .ok_or_else(|| cfg.err("[input] carrier_phase: required by CP-ATT"))?;
    let path = resolve_path(base_dir, name);
    let f = std::fs::File::open(&path).map_err(PipelineError::io(&path, "cannot open: "))?;
    let mut rdr = CpCsvReader::new(std::io::BufReader::new(f), &path.display().to_string());
    let recs = rdr
        .by_ref()
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| PipelineError::Input(e.to_string()))?;
    if recs.is_empty() {
        return Err(PipelineError::Input(format!(
            "{}: no carrier-phase records",
            path.display()
        )));
    }
    Ok((recs, rdr.stats().clone()))
}

/// Median interval between distinct epoch times [s] (1 s with one epoch).
pub fn epoch_interval(recs: &[CarrierPhaseSat]) -> f64 {
    let mut d: Vec<f64> = recs
        .windows(2)
        .map(|w| w[1].t - w[0].t)
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 1.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// CP-ATT over the records of `cfg`: its solutions and counters.
pub fn run_records(
    cfg: &RunConfig,
    recs: &[CarrierPhaseSat],
) -> Result<(Vec<NavSolution>, CpAttStreamStats)> {
    let c = cfg
        .cp_att
        .as_ref()
        .ok_or_else(|| cfg.err("[cp_att]: required by CP-ATT (baselines_m)"))?;
    let sc = c
        .stream_config(epoch_interval(recs))
        .map_err(|m| cfg.err(format!("[cp_att] {m}")))?;
    let mut est = CpAttStream::new(sc).map_err(|e| cfg.err(format!("[cp_att] {e}")))?;
    let mut sols = Vec::new();
    for r in recs {
        sols.extend(est.push(&Event::CarrierPhase(*r)));
    }
    sols.extend(est.flush());
    Ok((sols, *est.stats()))
}

/// The heading aids of `[filter] heading_source` (empty for "none").
pub fn heading_aids(cfg: &RunConfig, base_dir: &Path) -> Result<Vec<HeadingFix>> {
    match cfg.filter.heading_source.unwrap_or_default() {
        HeadingSourceCfg::None => Ok(Vec::new()),
        HeadingSourceCfg::CpAtt => {
            let (recs, _) = load_records(cfg, base_dir)?;
            let (sols, _) = run_records(cfg, &recs)?;
            Ok(sols.iter().filter_map(heading_fix).collect())
        }
    }
}

/// `navfuse run --estimator cp-att`: solutions (`solution.nav`,
/// `solution.csv` with the attitude σ, extra formats) and `summary.json`.
pub(crate) fn run_cp_att(
    cfg: &RunConfig,
    base_dir: &Path,
    out_dir: &Path,
    formats: &[OutFormat],
) -> Result<RunOutcome> {
    let t0 = std::time::Instant::now();
    let (recs, read_stats) = load_records(cfg, base_dir)?;
    let seconds_read = t0.elapsed().as_secs_f64();
    let (sols, st) = run_records(cfg, &recs)?;
    std::fs::create_dir_all(out_dir).map_err(PipelineError::io(out_dir, ""))?;
    let mut fmts = formats.to_vec();
    if !fmts.contains(&OutFormat::Csv) {
        fmts.push(OutFormat::Csv);
    }
    let outputs = write_solutions(out_dir, "solution", &sols, &fmts)?;
    let summary = serde_json::json!({
        "config": cfg,
        "estimator": "cp-att",
        "inputs": {"carrier_phase": read_stats.to_string()},
        "epoch_interval_s": epoch_interval(&recs),
        "records_used": st.records,
        "records_rejected": {
            "out_of_order": st.rejected_out_of_order,
            "duplicate_prn": st.rejected_duplicate,
            "invalid": st.rejected_invalid,
        },
        "epochs": st.epochs,
        "solutions": sols.len(),
        "seconds_read": seconds_read,
        "seconds_filter": t0.elapsed().as_secs_f64() - seconds_read,
        "outputs": &outputs,
        "note": "attitude only: position and velocity are NaN (carrier-phase records carry no position)",
    });
    let (epochs, records) = (st.epochs, st.records);
    crate::other::finish_run(out_dir, outputs, summary, sols, |p, n| {
        format!(
            "navfuse run: cp-att {n} attitude solutions from {epochs} epochs ({records} records); summary {}",
            p.display()
        )
    })
}

#[cfg(test)]
#[path = "cp_att_run_tests.rs"]
mod tests;
