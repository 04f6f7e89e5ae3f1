//! navfuse-eval: a sink that aligns solutions with a reference by time and
//! produces error series and summary statistics (`ARCHITECTURE.md`, "The
//! evaluator is a sink too").
//!
//! Alignment ([`Align`]): by default at each solution epoch, the reference
//! interpolated linearly in time between its bracketing epochs; or at each
//! reference epoch, the solution interpolated. Epochs outside the span of the
//! interpolated series, inside one of its gaps longer than
//! [`EvalConfig::max_gap`], or with non-finite solution values are excluded
//! and counted ([`Counts`]).
//!
//! Errors are *solution − reference*, position in local NED metres at the
//! reference point, velocity NED [m/s], attitude roll/pitch/yaw [rad] wrapped
//! to (−π, π]. With a lever arm `l_b` (body FRD, from the solution's reference
//! point to the reference's point, e.g. IMU → antenna) the solution position
//! is moved first: `p_ant = p_imu + c_bn · l_b` (Groves 2nd ed. eq. 14.103,
//! `c_bn` from the solution attitude by `navfuse_core::attitude::dcm_from_euler`).
//! NED offsets are exact (through ECEF, `navfuse_core::geodesy::ned_from_geodetic`).

pub mod consistency;
pub mod files;
pub mod outage;
#[cfg(feature = "parquet")]
pub mod parquet;
pub mod stats;

pub use consistency::{consistency, consistency_of, Consistency, NeesStats};
pub use outage::{outage_metric, Outage, OutageReport, OutageResult, OutageSchedule};
pub use stats::Stats;

use navfuse_core::attitude::{dcm_from_euler, wrap_pi};
use navfuse_core::geodesy::{ned_from_geodetic, Geodetic};
use navfuse_core::{NavSolution, Vec3};
use serde::{Deserialize, Serialize};

/// Where the two series are compared.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Align {
    /// At each solution epoch, the reference interpolated (default).
    #[default]
    AtSolution,
    /// At each reference epoch, the solution interpolated (position,
    /// velocity, attitude). Useful when the solution is much denser than the
    /// reference (e.g. a 100 Hz INS vs 4 Hz RTK truth) or when results are
    /// to be compared with figures computed at the truth epochs.
    AtReference,
}

/// Evaluator settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalConfig {
    /// Largest spacing [s] of the interpolated series (the reference, or the
    /// solution with [`Align::AtReference`]) across which it is
    /// interpolated; epochs inside a longer gap are excluded.
    pub max_gap: f64,
    /// Lever arm [m], body FRD, from the solution's point to the reference's
    /// point (e.g. IMU → GNSS antenna). `None`: compare the points as they are.
    pub lever_arm_b: Option<[f64; 3]>,
    /// Where the series are compared.
    pub align: Align,
}

impl Default for EvalConfig {
    /// `max_gap` 1.0 s (four missed epochs of a 4 Hz reference), no lever
    /// arm, errors at the solution epochs.
    fn default() -> Self {
        EvalConfig {
            max_gap: 1.0,
            lever_arm_b: None,
            align: Align::AtSolution,
        }
    }
}

/// Errors at one epoch (solution − reference).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorEpoch {
    /// GPS time [s].
    pub t: f64,
    /// Position error north, east, down [m] in the NED frame at the reference point.
    pub pos_ned: [f64; 3],
    /// √(north² + east²) [m].
    pub horizontal: f64,
    /// |down| [m].
    pub vertical: f64,
    /// Velocity error NED [m/s]; `None` when either velocity is unknown (NaN).
    /// At the solution's point (no lever-arm velocity term ω × l).
    pub vel_ned: Option<[f64; 3]>,
    /// Roll, pitch, yaw error [rad], each wrapped to (−π, π]; `None` when
    /// either attitude is unknown (NaN).
    pub att_rpy: Option<[f64; 3]>,
}

/// How the epochs were used. The epochs are the solution's
/// ([`Align::AtSolution`]) or the reference's ([`Align::AtReference`]); the
/// span and gaps are those of the other, interpolated, series.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counts {
    /// Epochs seen.
    pub epochs: usize,
    /// Epochs with errors computed.
    pub evaluated: usize,
    /// Excluded: before the first epoch of the interpolated series.
    pub before_span: usize,
    /// Excluded: after its last epoch.
    pub after_span: usize,
    /// Excluded: inside one of its gaps longer than `max_gap`.
    pub in_gap: usize,
    /// Excluded: non-finite solution time or position, or (with a lever arm)
    /// non-finite solution attitude.
    pub invalid: usize,
}

/// Statistics per error quantity; `None` where there were no values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub north: Option<Stats>,
    pub east: Option<Stats>,
    pub down: Option<Stats>,
    pub horizontal: Option<Stats>,
    pub vertical: Option<Stats>,
    pub vel_north: Option<Stats>,
    pub vel_east: Option<Stats>,
    pub vel_down: Option<Stats>,
    /// √(vn² + ve²) of the velocity error [m/s].
    pub vel_horizontal: Option<Stats>,
    pub roll: Option<Stats>,
    pub pitch: Option<Stats>,
    pub yaw: Option<Stats>,
}

impl Summary {
    /// Statistics of an error series.
    pub fn of(errors: &[ErrorEpoch]) -> Summary {
        let col = |f: &dyn Fn(&ErrorEpoch) -> Option<f64>| -> Option<Stats> {
            let v: Vec<f64> = errors.iter().filter_map(f).collect();
            Stats::of(&v)
        };
        Summary {
            north: col(&|e| Some(e.pos_ned[0])),
            east: col(&|e| Some(e.pos_ned[1])),
            down: col(&|e| Some(e.pos_ned[2])),
            horizontal: col(&|e| Some(e.horizontal)),
            vertical: col(&|e| Some(e.vertical)),
            vel_north: col(&|e| e.vel_ned.map(|v| v[0])),
            vel_east: col(&|e| e.vel_ned.map(|v| v[1])),
            vel_down: col(&|e| e.vel_ned.map(|v| v[2])),
            vel_horizontal: col(&|e| e.vel_ned.map(|v| v[0].hypot(v[1]))),
            roll: col(&|e| e.att_rpy.map(|a| a[0])),
            pitch: col(&|e| e.att_rpy.map(|a| a[1])),
            yaw: col(&|e| e.att_rpy.map(|a| a[2])),
        }
    }
}

/// The result of an evaluation (serialisable to JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    pub config: EvalConfig,
    pub counts: Counts,
    pub summary: Summary,
    /// Outage metric, when outages were given.
    pub outages: Option<OutageReport>,
    pub errors: Vec<ErrorEpoch>,
}

/// Which input series an error refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Series {
    Solution,
    Reference,
}

impl std::fmt::Display for Series {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Series::Solution => "solution",
            Series::Reference => "reference",
        })
    }
}

/// Bad input to the evaluator.
#[derive(Clone, Debug, PartialEq)]
pub enum EvalError {
    /// The series is empty.
    Empty(Series),
    /// Epoch `index` (0-based) has a non-finite time (or, for the
    /// reference, position).
    NonFinite { series: Series, index: usize },
    /// Epoch `index` is not later than the one before it (the interpolated
    /// series must be strictly increasing in time).
    NotIncreasing {
        series: Series,
        index: usize,
        t_prev: f64,
        t: f64,
    },
    /// `max_gap` not > 0, a non-finite lever arm, or an alignment the
    /// streaming [`Evaluator`] does not do.
    BadConfig(String),
}

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EvalError::Empty(s) => write!(f, "{s} series is empty"),
            EvalError::NonFinite { series, index } => write!(
                f,
                "{series} epoch {index} (0-based): time or position is not finite"
            ),
            EvalError::NotIncreasing {
                series,
                index,
                t_prev,
                t,
            } => write!(
                f,
                "{series} epoch {index} (0-based): time {t} s is not after the previous epoch's {t_prev} s"
            ),
            EvalError::BadConfig(s) => write!(f, "evaluator configuration: {s}"),
        }
    }
}

impl std::error::Error for EvalError {}

fn check_config(cfg: &EvalConfig) -> Result<(), EvalError> {
    if cfg.max_gap.is_nan() || cfg.max_gap <= 0.0 {
        return Err(EvalError::BadConfig(format!(
            "max_gap {} s must be > 0",
            cfg.max_gap
        )));
    }
    if let Some(l) = cfg.lever_arm_b {
        if !l.iter().all(|x| x.is_finite()) {
            return Err(EvalError::BadConfig(format!(
                "lever arm {l:?} is not finite"
            )));
        }
    }
    Ok(())
}

/// A series to interpolate in: non-empty, finite strictly increasing times;
/// with `positions` also finite positions.
fn check_series(s: &[NavSolution], series: Series, positions: bool) -> Result<(), EvalError> {
    if s.is_empty() {
        return Err(EvalError::Empty(series));
    }
    for (i, x) in s.iter().enumerate() {
        let pos_ok = x.lat.is_finite() && x.lon.is_finite() && x.h.is_finite();
        if !x.t.is_finite() || (positions && !pos_ok) {
            return Err(EvalError::NonFinite { series, index: i });
        }
        if i > 0 && x.t <= s[i - 1].t {
            return Err(EvalError::NotIncreasing {
                series,
                index: i,
                t_prev: s[i - 1].t,
                t: x.t,
            });
        }
    }
    Ok(())
}

/// Errors of `sol` against `r` at the same epoch (`None`: invalid solution).
fn compare(sol: &NavSolution, r: &NavSolution, lever_b: Option<Vec3>) -> Option<ErrorEpoch> {
    let finite3 = |v: &Vec3| v.iter().all(|x| x.is_finite());
    if !(sol.t.is_finite() && sol.lat.is_finite() && sol.lon.is_finite() && sol.h.is_finite())
        || (lever_b.is_some() && !finite3(&sol.rpy))
    {
        return None;
    }
    let mut d_n = ned_offset(r, sol);
    if let Some(l_b) = lever_b {
        d_n += dcm_from_euler(&sol.rpy) * l_b;
    }
    let vel_ned = (finite3(&r.v_n) && finite3(&sol.v_n)).then(|| {
        let dv = sol.v_n - r.v_n;
        [dv.x, dv.y, dv.z]
    });
    let att_rpy = (finite3(&r.rpy) && finite3(&sol.rpy)).then(|| {
        [
            wrap_pi(sol.rpy.x - r.rpy.x),
            wrap_pi(sol.rpy.y - r.rpy.y),
            wrap_pi(sol.rpy.z - r.rpy.z),
        ]
    });
    Some(ErrorEpoch {
        t: r.t,
        pos_ned: [d_n.x, d_n.y, d_n.z],
        horizontal: d_n.x.hypot(d_n.y),
        vertical: d_n.z.abs(),
        vel_ned,
        att_rpy,
    })
}

impl Counts {
    fn exclude(&mut self, why: Excluded) {
        match why {
            Excluded::Before => self.before_span += 1,
            Excluded::After => self.after_span += 1,
            Excluded::Gap => self.in_gap += 1,
        }
    }
}

/// Streaming evaluator at the solution epochs ([`Align::AtSolution`]):
/// holds the reference, takes solutions one by one.
pub struct Evaluator<'r> {
    reference: &'r [NavSolution],
    cfg: EvalConfig,
    lever_b: Option<Vec3>,
    counts: Counts,
    errors: Vec<ErrorEpoch>,
}

impl<'r> Evaluator<'r> {
    /// Checks the reference (non-empty, finite, strictly increasing time) and
    /// the config (`align` must be [`Align::AtSolution`]).
    pub fn new(reference: &'r [NavSolution], cfg: EvalConfig) -> Result<Self, EvalError> {
        check_config(&cfg)?;
        if cfg.align != Align::AtSolution {
            return Err(EvalError::BadConfig(
                "the streaming evaluator compares at the solution epochs; use `evaluate` for AtReference".into(),
            ));
        }
        check_series(reference, Series::Reference, true)?;
        Ok(Evaluator {
            reference,
            cfg,
            lever_b: cfg.lever_arm_b.map(Vec3::from),
            counts: Counts::default(),
            errors: Vec::new(),
        })
    }

    /// Evaluate one solution epoch; returns its errors when it was evaluated.
    pub fn push(&mut self, sol: &NavSolution) -> Option<ErrorEpoch> {
        self.counts.epochs += 1;
        if !sol.t.is_finite() {
            self.counts.invalid += 1;
            return None;
        }
        let r = match interpolate(self.reference, sol.t, self.cfg.max_gap) {
            Ok(r) => r,
            Err(why) => {
                self.counts.exclude(why);
                return None;
            }
        };
        let Some(e) = compare(sol, &r, self.lever_b) else {
            self.counts.invalid += 1;
            return None;
        };
        self.counts.evaluated += 1;
        self.errors.push(e);
        Some(e)
    }

    /// Counts so far.
    pub fn counts(&self) -> Counts {
        self.counts
    }

    /// Errors so far.
    pub fn errors(&self) -> &[ErrorEpoch] {
        &self.errors
    }

    /// Summary statistics and (with `outages`) the outage metric; see
    /// [`outage_metric`] for `fix_times`.
    pub fn finish(self, outages: Option<&[Outage]>, fix_times: Option<&[f64]>) -> Evaluation {
        finish(self.cfg, self.counts, self.errors, outages, fix_times)
    }
}

fn finish(
    config: EvalConfig,
    counts: Counts,
    errors: Vec<ErrorEpoch>,
    outages: Option<&[Outage]>,
    fix_times: Option<&[f64]>,
) -> Evaluation {
    Evaluation {
        config,
        counts,
        summary: Summary::of(&errors),
        outages: outages.map(|o| outage_metric(&errors, o, fix_times)),
        errors,
    }
}

/// The outages of `sched` lying completely inside the time span of `solution`.
pub fn outages_in_span(solution: &[NavSolution], sched: &OutageSchedule) -> Vec<Outage> {
    let (lo, hi) = solution
        .iter()
        .map(|s| s.t)
        .filter(|t| t.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
    sched.intervals(lo, hi)
}

/// Evaluate a solution series against a reference series (see the crate doc
/// and [`Align`]).
///
/// `outages`: when given, the schedule's outages lying completely inside the
/// solution's time span are scored with [`outage_metric`].
pub fn evaluate(
    solution: &[NavSolution],
    reference: &[NavSolution],
    cfg: &EvalConfig,
    outages: Option<&OutageSchedule>,
    fix_times: Option<&[f64]>,
) -> Result<Evaluation, EvalError> {
    let list = outages.map(|sched| outages_in_span(solution, sched));
    match cfg.align {
        Align::AtSolution => {
            let mut ev = Evaluator::new(reference, *cfg)?;
            for s in solution {
                ev.push(s);
            }
            Ok(ev.finish(list.as_deref(), fix_times))
        }
        Align::AtReference => {
            check_config(cfg)?;
            check_series(reference, Series::Reference, true)?;
            check_series(solution, Series::Solution, false)?;
            let lever_b = cfg.lever_arm_b.map(Vec3::from);
            let mut counts = Counts::default();
            let mut errors = Vec::with_capacity(reference.len());
            for r in reference {
                counts.epochs += 1;
                match interpolate(solution, r.t, cfg.max_gap) {
                    Err(why) => counts.exclude(why),
                    Ok(s) => match compare(&s, r, lever_b) {
                        Some(e) => {
                            counts.evaluated += 1;
                            errors.push(e);
                        }
                        None => counts.invalid += 1,
                    },
                }
            }
            Ok(finish(*cfg, counts, errors, list.as_deref(), fix_times))
        }
    }
}

enum Excluded {
    Before,
    After,
    Gap,
}

/// The time-ordered series `r` at time `t` ([`interpolate`] without a gap
/// limit), held at its first or last epoch outside its span; `None` when
/// `r` is empty.
pub fn interpolate_held(r: &[NavSolution], t: f64) -> Option<NavSolution> {
    match interpolate(r, t, f64::INFINITY) {
        Ok(s) => Some(s),
        Err(Excluded::Before) => r.first().copied(),
        Err(_) => r.last().copied(),
    }
}

/// The series `r` at time `t`: linear in time between the bracketing epochs
/// (latitude, longitude, height, velocity; attitude angles along the shorter
/// arc). An exact epoch match is used as is, even beside a long gap.
fn interpolate(r: &[NavSolution], t: f64, max_gap: f64) -> Result<NavSolution, Excluded> {
    let idx = r.partition_point(|x| x.t <= t); // epochs with r.t ≤ t
    if idx == 0 {
        return Err(Excluded::Before);
    }
    let a = &r[idx - 1];
    if a.t == t {
        return Ok(*a);
    }
    if idx == r.len() {
        return Err(Excluded::After);
    }
    let b = &r[idx];
    if b.t - a.t > max_gap {
        return Err(Excluded::Gap);
    }
    let w = (t - a.t) / (b.t - a.t);
    let lin = |x: f64, y: f64| x + w * (y - x);
    let ang = |x: f64, y: f64| wrap_pi(x + w * wrap_pi(y - x));
    Ok(NavSolution {
        t,
        lat: lin(a.lat, b.lat),
        lon: ang(a.lon, b.lon),
        h: lin(a.h, b.h),
        v_n: a.v_n + (b.v_n - a.v_n) * w,
        rpy: Vec3::new(
            ang(a.rpy.x, b.rpy.x),
            ang(a.rpy.y, b.rpy.y),
            ang(a.rpy.z, b.rpy.z),
        ),
        std_pos_ned: a.std_pos_ned + (b.std_pos_ned - a.std_pos_ned) * w,
        std_v_n: a.std_v_n + (b.std_v_n - a.std_v_n) * w,
        std_rpy: a.std_rpy + (b.std_rpy - a.std_rpy) * w,
    })
}

/// NED offset [m] of `p` from `origin`: exact, through ECEF, in the local
/// tangent frame at `origin` (Groves 2nd ed. §2.4).
fn ned_offset(origin: &NavSolution, p: &NavSolution) -> Vec3 {
    let g = |x: &NavSolution| Geodetic {
        lat: x.lat,
        lon: x.lon,
        h: x.h,
    };
    ned_from_geodetic(&g(origin), &g(p))
}

#[cfg(test)]
mod tests;
