//! The IMU–GNSS time offset: how a run applies one ([`TimeOffset`],
//! [`TimeOffsetCfg`]) and its estimate from the data ([`estimate_time_offset`]).
//! Convention: true time = IMU stamp + τ.

use crate::error::{PipelineError, Result};
use navfuse_core::ins::time_offset::{TimeOffsetConfig, TimeOffsetEstimate};
use navfuse_core::types::{GnssFix, ImuSample};
use serde::{Deserialize, Serialize};

/// `imu_time_offset`: a number of seconds or `"auto"`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum TimeOffsetCfg {
    Seconds(f64),
    Named(String),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeOffset {
    /// No offset applied.
    None,
    /// Estimated with its σ ([`auto_estimate`]), applied when significant.
    Auto,
    /// Given [s].
    Seconds(f64),
}

impl TimeOffset {
    /// `none`, `auto` or a number of seconds (finite, |τ| < 10 s).
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "none" => Ok(TimeOffset::None),
            "auto" => Ok(TimeOffset::Auto),
            _ => s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() < 10.0)
                .map(TimeOffset::Seconds)
                .ok_or_else(|| {
                    PipelineError::Options(format!(
                        "time offset {s:?}: expected seconds (|τ| < 10), auto or none"
                    ))
                }),
        }
    }

    /// The offset [s] to apply and how it was found. `Auto` estimates τ with
    /// its σ ([`auto_estimate`]) and applies it only when it is significantly
    /// non-zero (|τ| > 3.29 σ, a 0.1 % two-sided false alarm, and σ ≤ 20 ms);
    /// otherwise nothing is applied (`Ok(None)`): a default must never make a
    /// data set worse, and an unsignificant τ can only add error.
    pub fn resolve(self, imu: &[ImuSample], gnss: &[GnssFix]) -> Result<Option<(f64, String)>> {
        match self {
            TimeOffset::None => Ok(None),
            TimeOffset::Seconds(s) => Ok(Some((s, "given".into()))),
            TimeOffset::Auto => {
                let e = auto_estimate(imu, gnss);
                Ok(match (e.apply, e.tau_s) {
                    (true, Some(tau)) => Some((tau, format!("estimated, {}", describe(&e)))),
                    _ => None,
                })
            }
        }
    }
}

/// The IMU–GNSS time offset τ with its σ and significance test
/// ([`navfuse_core::ins::time_offset::estimate`]: GNSS course against the
/// integrated z-gyro, gyro bias/scale and antenna lever fitted, gross errors
/// rejected; course σ from the GNSS velocity σ and speed, so no fixed speed
/// threshold). Convention: true time = IMU stamp + τ.
pub fn auto_estimate(imu: &[ImuSample], gnss: &[GnssFix]) -> TimeOffsetEstimate {
    navfuse_core::ins::time_offset::estimate(imu, gnss, &TimeOffsetConfig::default())
}

/// One line: `τ = +0.100 ± 0.004 s (412 course epochs): significant …`.
pub fn describe(e: &TimeOffsetEstimate) -> String {
    match e.tau_s {
        Some(tau) => format!(
            "τ = {tau:+.4} ± {:.4} s ({} GNSS course epochs, {} rejected): {}",
            e.std_s,
            e.pairs_used,
            e.outliers,
            e.reason.describe()
        ),
        None => format!(
            "no estimate ({} GNSS course epochs): {}",
            e.pairs_used,
            e.reason.describe()
        ),
    }
}

/// IMU–GNSS time offset by cross-correlation of the GNSS course rate with the
/// IMU yaw rate (body z gyro, FRD: both positive turning right), over
/// intervals between consecutive fixes (thinned to ~1 s) with speed ≥ 3 m/s;
/// robust to GNSS outliers (velocity changes beyond 1 g skipped, then pairs
/// beyond 5 robust σ of the gyro agreement dropped and the scan repeated). Returns the
/// offset `τ` [s] to add to the IMU stamps (best in ±`max_lag`, 5 ms steps)
/// and the correlation coefficient there. `None` without enough turning data.
pub fn estimate_time_offset(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    max_lag: f64,
) -> Option<(f64, f64)> {
    // Cumulative z-angle for O(1) interval means.
    let mut cum = Vec::with_capacity(imu.len() + 1);
    cum.push(0.0);
    for s in imu {
        cum.push(cum.last().copied().unwrap_or(0.0) + s.dtheta_b.z);
    }
    let angle_at = |t: f64| -> Option<f64> {
        let k = imu.partition_point(|s| s.t < t);
        if k == 0 || k >= imu.len() {
            return None;
        }
        let s = &imu[k];
        let frac = 1.0 - (s.t - t) / s.dt;
        Some(cum[k] + frac.clamp(0.0, 1.0) * s.dtheta_b.z)
    };
    // Fixes about 1 s apart (faster GNSS is thinned: the course from fixes a
    // quarter second apart is mostly noise).
    let mut thinned: Vec<GnssFix> = Vec::with_capacity(gnss.len());
    for g in gnss {
        if thinned.last().is_none_or(|l| g.t - l.t >= 0.95) {
            thinned.push(*g);
        }
    }
    // Course at each fix from the neighbouring fixes, then course rate.
    // A triple whose velocity change needs more than 1 g is skipped: no car
    // does that, a GNSS outlier does.
    let mut pairs = Vec::new();
    for w in thinned.windows(3) {
        let vel = |a: &GnssFix, b: &GnssFix| {
            let (rm, rn) = navfuse_core::earth::radii(a.lat);
            let dt = b.t - a.t;
            let dn = (b.lat - a.lat) * (rm + a.h);
            let de = (b.lon - a.lon) * (rn + a.h) * a.lat.cos();
            (dn / dt, de / dt, dt)
        };
        let (n0, e0, dt0) = vel(&w[0], &w[1]);
        let (n1, e1, dt1) = vel(&w[1], &w[2]);
        let (v0, v1) = (n0.hypot(e0), n1.hypot(e1));
        if v0 < 3.0 || v1 < 3.0 || !(0.5..2.0).contains(&dt0) || !(0.5..2.0).contains(&dt1) {
            continue;
        }
        if (n1 - n0).hypot(e1 - e0) > 9.81 * 0.5 * (dt0 + dt1) {
            continue;
        }
        let mut d = e1.atan2(n1) - e0.atan2(n0);
        d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
        // Course change between the interval midpoints.
        let (ta, tb) = (0.5 * (w[0].t + w[1].t), 0.5 * (w[1].t + w[2].t));
        pairs.push((ta, tb, d));
    }
    // IMU stamp + τ = true time  ⇒  IMU angle over [ta − τ, tb − τ].
    let imu_angle = |ta: f64, tb: f64, tau: f64| -> Option<f64> {
        Some(angle_at(tb - tau)? - angle_at(ta - tau)?)
    };
    let scan = |pairs: &[(f64, f64, f64)]| -> Option<(f64, f64)> {
        if pairs.len() < 30 {
            return None;
        }
        let mut best: Option<(f64, f64)> = None;
        let steps = (max_lag / 0.005).round() as i64;
        for i in -steps..=steps {
            let tau = i as f64 * 0.005;
            let (mut sx, mut sy, mut sxx, mut syy, mut sxy, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for &(ta, tb, d) in pairs {
                let Some(g) = imu_angle(ta, tb, tau) else {
                    continue;
                };
                sx += d;
                sy += g;
                sxx += d * d;
                syy += g * g;
                sxy += d * g;
                n += 1.0;
            }
            if n < 30.0 {
                continue;
            }
            let cov = sxy / n - sx * sy / (n * n);
            let r = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
            if best.is_none_or(|(_, br)| r > br) {
                best = Some((tau, r));
            }
        }
        best
    };
    let (tau, _) = scan(&pairs)?;
    // Second pass without the pairs whose course change disagrees with the
    // gyro by more than 5 robust σ (median absolute deviation) at that τ.
    let resid: Vec<f64> = pairs
        .iter()
        .map(|&(ta, tb, d)| imu_angle(ta, tb, tau).map_or(f64::INFINITY, |g| d - g))
        .collect();
    let mut sorted: Vec<f64> = resid.iter().copied().filter(|e| e.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let med = *sorted.get(sorted.len() / 2)?;
    let mut dev: Vec<f64> = sorted.iter().map(|e| (e - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let limit = (5.0 * 1.4826 * dev[dev.len() / 2]).max(1e-3);
    let kept: Vec<(f64, f64, f64)> = pairs
        .iter()
        .zip(&resid)
        .filter(|(_, e)| (*e - med).abs() <= limit)
        .map(|(p, _)| *p)
        .collect();
    scan(&kept)
}

/// The summary's `time_offset` text: the offset the input loading applied
/// (`applied`: τ [s] and how) and the estimate on the run's inputs after it
/// (`residual`, reported, never applied twice).
pub fn time_offset_note(residual: &TimeOffsetEstimate, applied: Option<&(f64, String)>) -> String {
    let applied = match applied {
        Some((tau, how)) => format!("{tau:+.4} s, {how}"),
        None => "none".into(),
    };
    format!(
        "applied to the IMU stamps: {applied}; estimate on the inputs after it: {}",
        describe(residual)
    )
}
