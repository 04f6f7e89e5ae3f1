//! A small accuracy check against a reference trajectory (the project's
//! evaluator lives in navfuse-eval; this keeps `kf-gins --truth` and the
//! tests self-contained). Positions: the antenna (IMU position + C_bn·lever,
//! lever in body FRD); errors in NED metres.

use crate::error::{PipelineError, Result};
use navfuse_core::earth;
use navfuse_core::estimators::eskf::SmoothedEpoch;
use navfuse_core::ins::mech::q_bn_from_rpy;
use navfuse_core::types::NavSolution;
use navfuse_core::Vec3;
use std::path::Path;

/// Solution of a smoothed epoch, with the 1-σ of the smoothed covariance
/// diagonal ([`crate::sigma::std_row`]).
pub fn smoothed_solution(e: &SmoothedEpoch) -> NavSolution {
    let mut s = NavSolution::unknown_at(e.t);
    s.lat = e.nav.lat;
    s.lon = e.nav.lon;
    s.h = e.nav.h;
    s.v_n = e.nav.v_n;
    s.rpy = e.nav.rpy();
    let row = crate::sigma::std_row(e.t, &e.p_diag, e.p_pos_cross, None);
    crate::sigma::set_solution_std(&mut s, &row);
    s
}

/// Read a KF-GINS `.nav` (week tow lat lon h vN vE vD roll pitch yaw; attitude may be nan).
pub fn read_nav(path: &Path) -> Result<Vec<NavSolution>> {
    let text = navfuse_io::text::read_text_capped(path, u64::MAX)
        .map_err(crate::kfgins_input::input_err)?;
    let mut v = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<f64> = line
            .split_ascii_whitespace()
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| PipelineError::Input(format!("{}:{}: {e}", path.display(), i + 1)))?;
        if f.len() < 11 {
            return Err(PipelineError::Input(format!(
                "{}:{}: expected 11 fields, got {}",
                path.display(),
                i + 1,
                f.len()
            )));
        }
        let mut s = NavSolution::unknown_at(f[1]);
        s.lat = f[2].to_radians();
        s.lon = f[3].to_radians();
        s.h = f[4];
        s.v_n = Vec3::new(f[5], f[6], f[7]);
        s.rpy = Vec3::new(f[8], f[9], f[10]).map(f64::to_radians);
        v.push(s);
    }
    Ok(v)
}

/// `START,LEN,PERIOD,COUNT` → outage intervals [start, end).
pub fn parse_outages(s: &str) -> Result<Vec<(f64, f64)>> {
    let f: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| PipelineError::Options(format!("--outages {s:?}: {e}")))?;
    if f.len() != 4 || f[1] <= 0.0 || f[2] < f[1] || f[3] < 1.0 {
        return Err(PipelineError::Options(format!(
            "--outages {s:?}: expected START,LEN,PERIOD,COUNT"
        )));
    }
    Ok((0..f[3] as usize)
        .map(|k| (f[0] + f[2] * k as f64, f[0] + f[2] * k as f64 + f[1]))
        .collect())
}

/// Antenna position of an IMU solution (lever arm in body FRD).
pub fn antenna(s: &NavSolution, lever_b: &Vec3) -> (f64, f64, f64) {
    let l_n = q_bn_from_rpy(&s.rpy) * lever_b;
    let (rm, rn) = earth::radii(s.lat);
    (
        s.lat + l_n.x / (rm + s.h),
        s.lon + l_n.y / ((rn + s.h) * s.lat.cos()),
        s.h - l_n.z,
    )
}

/// NED error [m] of the solution's antenna (interpolated to `r.t`) against `r`.
/// `None` outside the solution's time span.
pub fn error_at(sols: &[NavSolution], r: &NavSolution, lever_b: &Vec3) -> Option<Vec3> {
    let k = sols.partition_point(|s| s.t < r.t);
    if k == 0 || k >= sols.len() {
        return (k < sols.len() && (sols[k].t - r.t).abs() < 1e-6).then(|| {
            let a = antenna(&sols[k], lever_b);
            ned(r, a)
        });
    }
    let (s0, s1) = (&sols[k - 1], &sols[k]);
    let w = (r.t - s0.t) / (s1.t - s0.t);
    let a0 = antenna(s0, lever_b);
    let a1 = antenna(s1, lever_b);
    let a = (
        a0.0 + w * (a1.0 - a0.0),
        a0.1 + w * (a1.1 - a0.1),
        a0.2 + w * (a1.2 - a0.2),
    );
    Some(ned(r, a))
}

fn ned(r: &NavSolution, a: (f64, f64, f64)) -> Vec3 {
    let (rm, rn) = earth::radii(r.lat);
    Vec3::new(
        (a.0 - r.lat) * (rm + r.h),
        (a.1 - r.lon) * (rn + r.h) * r.lat.cos(),
        -(a.2 - r.h),
    )
}

/// Accuracy over the reference epochs in span [m].
pub struct Accuracy {
    /// Horizontal RMS.
    pub h_rms: f64,
    /// Vertical RMS.
    pub v_rms: f64,
    /// Largest horizontal error.
    pub h_max: f64,
    /// Epochs compared.
    pub n: usize,
}

/// Horizontal / vertical RMS of the antenna against every reference epoch in span.
pub fn accuracy(sols: &[NavSolution], truth: &[NavSolution], lever_b: &Vec3) -> Accuracy {
    let (mut h2, mut v2, mut hm, mut n) = (0.0, 0.0, 0.0f64, 0usize);
    for r in truth {
        if let Some(e) = error_at(sols, r, lever_b) {
            let h = e.x.hypot(e.y);
            h2 += h * h;
            v2 += e.z * e.z;
            hm = hm.max(h);
            n += 1;
        }
    }
    let d = n.max(1) as f64;
    Accuracy {
        h_rms: (h2 / d).sqrt(),
        v_rms: (v2 / d).sqrt(),
        h_max: hm,
        n,
    }
}

/// Per outage [s, e): max horizontal error from `s` to the first fix at or after `e`.
pub fn outage_drift(
    sols: &[NavSolution],
    truth: &[NavSolution],
    lever_b: &Vec3,
    outages: &[(f64, f64)],
    fix_times: &[f64],
) -> Vec<f64> {
    outages
        .iter()
        .map(|&(s, e)| {
            let k = fix_times.partition_point(|t| *t < e);
            let stop = fix_times.get(k).copied().unwrap_or(f64::INFINITY);
            truth
                .iter()
                .filter(|r| r.t >= s && r.t <= stop)
                .filter_map(|r| error_at(sols, r, lever_b))
                .map(|e| e.x.hypot(e.y))
                .fold(0.0, f64::max)
        })
        .collect()
}
