//! The run's uncertainty outputs: σ rows from the covariance
//! (`solution.std`, `solution_smoothed.std`, [`navfuse_io::stdfile`]), the
//! coasting account and the NIS self-check of `summary.json`.

use crate::error::{PipelineError, Result};
use navfuse_core::estimators::consistency::{EpochStatus, NisMonitor, KINDS};
use navfuse_core::estimators::eskf::{StateVec, I_ATT, I_BA, I_BG, I_POS, I_SA, I_SG, I_VEL};
use navfuse_core::types::{GnssFix, NavSolution, Vec3};
use navfuse_io::stdfile::{write_std_row, StdRow};
use std::path::Path;

/// The σ row at `t` from the diagonal of the error-state covariance
/// (states indexed by the ESKF's named offsets).
pub fn std_row(t: f64, p_diag: &StateVec, status: Option<EpochStatus>) -> StdRow {
    let sd = |i: usize| {
        Vec3::new(
            p_diag[i].max(0.0).sqrt(),
            p_diag[i + 1].max(0.0).sqrt(),
            p_diag[i + 2].max(0.0).sqrt(),
        )
    };
    StdRow {
        t,
        pos_ned: sd(I_POS),
        vel_ned: sd(I_VEL),
        att_rpy: sd(I_ATT),
        bg: sd(I_BG),
        ba: sd(I_BA),
        sg: sd(I_SG),
        sa: sd(I_SA),
        status,
    }
}

/// Copy the position, velocity and attitude σ of `r` into `s` (so every
/// trajectory format carries them).
pub fn set_solution_std(s: &mut NavSolution, r: &StdRow) {
    s.std_pos_ned = r.pos_ned;
    s.std_v_n = r.vel_ned;
    s.std_rpy = r.att_rpy;
}

/// Seconds without any accepted update after which an epoch counts as
/// coasting: 2.5 nominal GNSS intervals (the median spacing of the fixes
/// fed), i.e. two fixes missed; 2.5 s when there are fewer than two fixes.
pub fn coast_after_s(gnss: &[GnssFix]) -> f64 {
    let mut d: Vec<f64> = gnss
        .windows(2)
        .map(|w| w[1].t - w[0].t)
        .filter(|x| *x > 0.0)
        .collect();
    if d.is_empty() {
        return 2.5;
    }
    let m = d.len() / 2;
    let med = *d.select_nth_unstable_by(m, f64::total_cmp).1;
    2.5 * med
}

/// Write `rows` as a σ file at `path`; returns the path written.
pub fn write_std(path: &Path, rows: &[StdRow]) -> Result<String> {
    use std::io::Write as _;
    let write = || -> std::io::Result<()> {
        let f = std::fs::File::create(path)?;
        let mut w = std::io::BufWriter::with_capacity(1 << 16, f);
        for r in rows {
            write_std_row(&mut w, r)?;
        }
        w.flush()
    };
    write().map_err(PipelineError::io(path, ""))?;
    Ok(path.display().to_string())
}

/// `summary.json` `coasting`: share of the epochs more than `coast_after_s`
/// after the last position update, and the longest time without one.
pub fn coasting_json(rows: &[StdRow], coast_after_s: f64) -> serde_json::Value {
    let since: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.status.map(|s| s.since_pos_s))
        .collect();
    let n = since.len().max(1) as f64;
    let coasting = since.iter().filter(|s| **s > coast_after_s).count();
    let longest = since.iter().copied().fold(0.0, f64::max);
    serde_json::json!({
        "definition": "epochs more than coast_after_s after the last accepted GNSS position/height update",
        "coast_after_s": coast_after_s,
        "share_of_epochs": coasting as f64 / n,
        "longest_s": longest,
    })
}

/// `summary.json` `nis_check` and the warnings of overconfident types
/// ([`navfuse_core::estimators::consistency`] defines the test).
pub fn nis_json(m: &NisMonitor) -> (serde_json::Value, Vec<String>) {
    let mut per = serde_json::Map::new();
    let mut warnings = Vec::new();
    for k in KINDS {
        let Some(s) = m.stats(k) else { continue };
        if s.overconfident {
            warnings.push(format!(
                "{}: the filter is overconfident: mean NIS per degree of freedom {:.2} \
                 (consistent: 1, 95 % interval {:.2}–{:.2}); its σ is too small",
                k.name(),
                s.mean_per_dof,
                s.ci95.0,
                s.ci95.1
            ));
        }
        per.insert(
            k.name().into(),
            serde_json::json!({
                "updates": s.updates,
                "gated": s.gated,
                "mean_nis_per_dof": s.mean_per_dof,
                "ci95": [s.ci95.0, s.ci95.1],
                "share_above_chi2_95": s.share_above95,
                "windows": s.windows,
                "windows_above_chi2_99": s.windows_above,
                "windows_below_chi2_99": s.windows_below,
                "overconfident": s.overconfident,
            }),
        );
    }
    (
        serde_json::json!({
            "test": "mean NIS per degree of freedom over the run (every update tried) against 1 \
                     with its χ² 95 % interval (Bar-Shalom, Li & Kirubarajan §5.4.2); overconfident \
                     when above the interval and above 2; windows of 10 s against the χ² 99 % interval",
            "types": per,
        }),
        warnings,
    )
}
