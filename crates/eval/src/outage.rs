//! GNSS outage schedules and the outage-drift metric.
//!
//! The metric is the one of the "drive_0708 outage" benchmark (shared data
//! README; the KF-GINS paper's): for each outage, the maximum horizontal error
//! from the outage start to the first GNSS fix after it, then the RMS of those
//! maxima.

use crate::ErrorEpoch;
use serde::{Deserialize, Serialize};

/// One outage: GNSS is absent for `start ≤ t < end` (GPS time, s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outage {
    pub start: f64,
    pub end: f64,
}

impl Outage {
    /// `start ≤ t < end`.
    pub fn contains(&self, t: f64) -> bool {
        self.start <= t && t < self.end
    }
}

/// "Cut GNSS for `length` s every `period` s, the first cut `first_after` s
/// after `t0`": outage k (k = 0, 1, …, `count` − 1 if given) is
/// `[t0 + first_after + k·period, t0 + first_after + k·period + length)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeriodicOutages {
    /// Reference time t0 [s] (GPS time, same convention as the data).
    pub t0: f64,
    /// Start of the first outage after t0 [s] (S).
    pub first_after: f64,
    /// Period [s] (P), > 0.
    pub period: f64,
    /// Outage length [s] (L), 0 < L ≤ P.
    pub length: f64,
    /// Number of outages; `None` = unbounded.
    pub count: Option<usize>,
}

impl PeriodicOutages {
    fn start_k(&self, k: usize) -> f64 {
        self.t0 + self.first_after + k as f64 * self.period
    }

    fn outage_k(&self, k: usize) -> Outage {
        let start = self.start_k(k);
        Outage {
            start,
            end: start + self.length,
        }
    }

    fn k_allowed(&self, k: usize) -> bool {
        match self.count {
            Some(n) => k < n,
            None => true,
        }
    }
}

/// A set of GNSS outages: periodic or an explicit list. Pure (no state, no
/// I/O), so runners can call [`OutageSchedule::contains`] to drop fixes and
/// the evaluator uses [`OutageSchedule::intervals`] for the metric; both use
/// the same interval bounds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutageSchedule {
    Periodic(PeriodicOutages),
    /// Explicit outages, each `[start, end)`.
    List(Vec<Outage>),
}

impl OutageSchedule {
    /// The periodic schedule, checked ([`OutageSchedule::validate`]).
    pub fn periodic(
        t0: f64,
        first_after: f64,
        period: f64,
        length: f64,
        count: Option<usize>,
    ) -> Result<Self, String> {
        let s = OutageSchedule::Periodic(PeriodicOutages {
            t0,
            first_after,
            period,
            length,
            count,
        });
        s.validate()?;
        Ok(s)
    }

    /// An explicit list, checked ([`OutageSchedule::validate`]).
    pub fn list(outages: Vec<Outage>) -> Result<Self, String> {
        let s = OutageSchedule::List(outages);
        s.validate()?;
        Ok(s)
    }

    /// Finite numbers; periodic: `period > 0`, `0 < length ≤ period`,
    /// `first_after ≥ 0`; list: each `start < end`.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            OutageSchedule::Periodic(p) => {
                if ![p.t0, p.first_after, p.period, p.length]
                    .iter()
                    .all(|x| x.is_finite())
                {
                    return Err(
                        "outage schedule: t0, start, period and length must be finite".into(),
                    );
                }
                if p.period <= 0.0 {
                    return Err(format!(
                        "outage schedule: period {} s must be > 0",
                        p.period
                    ));
                }
                if p.length <= 0.0 || p.length > p.period {
                    return Err(format!(
                        "outage schedule: length {} s must be > 0 and ≤ the period {} s",
                        p.length, p.period
                    ));
                }
                if p.first_after < 0.0 {
                    return Err(format!(
                        "outage schedule: first outage offset {} s must be ≥ 0",
                        p.first_after
                    ));
                }
                Ok(())
            }
            OutageSchedule::List(list) => {
                for (i, o) in list.iter().enumerate() {
                    if !(o.start.is_finite() && o.end.is_finite() && o.start < o.end) {
                        return Err(format!(
                            "outage {i}: [{}, {}) is not a finite interval with start < end",
                            o.start, o.end
                        ));
                    }
                }
                Ok(())
            }
        }
    }

    /// Is GNSS cut at time `t`? (`start ≤ t < end` for some outage.)
    pub fn contains(&self, t: f64) -> bool {
        match self {
            OutageSchedule::Periodic(p) => {
                let first = p.start_k(0);
                if t.is_nan() || t < first {
                    return false;
                }
                let k = ((t - first) / p.period).floor();
                if !k.is_finite() {
                    return false;
                }
                let k = k as usize;
                // The floor may be off by one at a boundary through rounding;
                // test the neighbours with the exact bounds of `intervals`.
                [k.saturating_sub(1), k, k + 1]
                    .iter()
                    .any(|&j| p.k_allowed(j) && p.outage_k(j).contains(t))
            }
            OutageSchedule::List(list) => list.iter().any(|o| o.contains(t)),
        }
    }

    /// The outages lying entirely in `[t_begin, t_end]`, in time order.
    ///
    /// Outages cut by the end of the data are left out: their maximum drift
    /// would be biased low.
    pub fn intervals(&self, t_begin: f64, t_end: f64) -> Vec<Outage> {
        let mut out: Vec<Outage> = match self {
            OutageSchedule::Periodic(p) => {
                let mut v = Vec::new();
                let mut k = 0usize;
                while p.k_allowed(k) {
                    let o = p.outage_k(k);
                    if o.end > t_end {
                        break;
                    }
                    if o.start >= t_begin {
                        v.push(o);
                    }
                    k += 1;
                }
                v
            }
            OutageSchedule::List(list) => list
                .iter()
                .copied()
                .filter(|o| o.start >= t_begin && o.end <= t_end)
                .collect(),
        };
        out.sort_by(|a, b| a.start.total_cmp(&b.start));
        out
    }
}

/// The drift of one outage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutageResult {
    pub start: f64,
    pub end: f64,
    /// End of the scored window: the first GNSS fix at or after `end`, or
    /// `end` when no fix times were given (or none follows).
    pub window_end: f64,
    /// Evaluated epochs in `[start, window_end)`.
    pub count: usize,
    /// Maximum horizontal error in the window [m]; `None` when `count` is 0.
    pub max_horizontal: Option<f64>,
    /// Time of that maximum [s].
    pub t_max: Option<f64>,
}

/// The outage metric over all outages.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutageReport {
    pub outages: Vec<OutageResult>,
    /// RMS of the per-outage maxima [m] over the outages with epochs.
    pub rms_of_max: Option<f64>,
    /// Largest per-outage maximum [m].
    pub max_of_max: Option<f64>,
    /// Outages with no evaluated epoch in their window (not in the RMS).
    pub empty_outages: usize,
}

/// Per outage, the maximum horizontal error over the evaluated epochs with
/// `start ≤ t < window_end`, where `window_end` is the first of `fix_times`
/// at or after the outage end (the first fix after the outage; the solution
/// at that instant has absorbed it, so it is excluded), or the outage end
/// when `fix_times` is `None` or no fix follows. Then the RMS of the maxima.
///
/// `errors` need not be sorted; `fix_times` need not be sorted.
pub fn outage_metric(
    errors: &[ErrorEpoch],
    outages: &[Outage],
    fix_times: Option<&[f64]>,
) -> OutageReport {
    let mut results = Vec::with_capacity(outages.len());
    for o in outages {
        let window_end = fix_times
            .and_then(|f| {
                f.iter()
                    .copied()
                    .filter(|&t| t >= o.end)
                    .min_by(f64::total_cmp)
            })
            .unwrap_or(o.end);
        let mut count = 0;
        let mut best: Option<(f64, f64)> = None;
        for e in errors {
            if e.t >= o.start && e.t < window_end {
                count += 1;
                let better = match best {
                    Some((m, _)) => e.horizontal > m,
                    None => true,
                };
                if better {
                    best = Some((e.horizontal, e.t));
                }
            }
        }
        results.push(OutageResult {
            start: o.start,
            end: o.end,
            window_end,
            count,
            max_horizontal: best.map(|b| b.0),
            t_max: best.map(|b| b.1),
        });
    }
    let maxima: Vec<f64> = results.iter().filter_map(|r| r.max_horizontal).collect();
    let rms_of_max = if maxima.is_empty() {
        None
    } else {
        Some((maxima.iter().map(|m| m * m).sum::<f64>() / maxima.len() as f64).sqrt())
    };
    OutageReport {
        empty_outages: results.len() - maxima.len(),
        max_of_max: maxima.iter().copied().max_by(f64::total_cmp),
        rms_of_max,
        outages: results,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn protocol() -> OutageSchedule {
        OutageSchedule::periodic(243262.0, 120.0, 90.0, 30.0, None).unwrap()
    }

    #[test]
    fn drive_0708_protocol_gives_five_outages() {
        // Data span of the drive: 243262 … 243811 (549 s).
        let iv = protocol().intervals(243262.0, 243811.0);
        assert_eq!(iv.len(), 5);
        for (k, o) in iv.iter().enumerate() {
            assert_eq!(o.start, 243262.0 + 120.0 + 90.0 * k as f64);
            assert_eq!(o.end, o.start + 30.0);
        }
    }

    #[test]
    fn contains_half_open() {
        let s = protocol();
        assert!(!s.contains(243381.999));
        assert!(s.contains(243382.0));
        assert!(s.contains(243411.999));
        assert!(!s.contains(243412.0));
        assert!(s.contains(243472.0));
        assert!(!s.contains(f64::NAN));
        let capped = OutageSchedule::periodic(0.0, 10.0, 20.0, 5.0, Some(2)).unwrap();
        assert!(capped.contains(31.0));
        assert!(!capped.contains(51.0));
        assert_eq!(capped.intervals(0.0, 1e9).len(), 2);
    }

    #[test]
    fn list_schedule() {
        let s = OutageSchedule::list(vec![
            Outage {
                start: 5.0,
                end: 6.0,
            },
            Outage {
                start: 1.0,
                end: 2.0,
            },
        ])
        .unwrap();
        assert!(s.contains(1.5) && s.contains(5.0) && !s.contains(6.0));
        let iv = s.intervals(0.0, 10.0);
        assert_eq!(iv[0].start, 1.0);
        assert_eq!(iv.len(), 2);
        assert!(OutageSchedule::list(vec![Outage {
            start: 2.0,
            end: 1.0
        }])
        .is_err());
    }

    #[test]
    fn invalid_periodic_rejected() {
        assert!(OutageSchedule::periodic(0.0, 1.0, 0.0, 1.0, None).is_err());
        assert!(OutageSchedule::periodic(0.0, 1.0, 10.0, 11.0, None).is_err());
        assert!(OutageSchedule::periodic(0.0, -1.0, 10.0, 1.0, None).is_err());
        assert!(OutageSchedule::periodic(f64::NAN, 1.0, 10.0, 1.0, None).is_err());
    }

    fn err_at(t: f64, h: f64) -> ErrorEpoch {
        ErrorEpoch {
            t,
            pos_ned: [h, 0.0, 0.0],
            horizontal: h,
            vertical: 0.0,
            vel_ned: None,
            att_rpy: None,
        }
    }

    #[test]
    fn quadratic_drift_gives_analytic_max() {
        // Error grows as a·(t − start)² inside each outage (a quadratic drift
        // like an accelerometer bias), zero outside. Epochs every 0.1 s;
        // fixes every 1 s at x.5. The first fix after an outage [s, s+30) is
        // s+30.5, so the max is at the last epoch before it, t = s+30.4.
        let starts = [100.0, 190.0];
        let a = [0.01, 0.04];
        let drift = |t: f64| -> f64 {
            for (s, a) in starts.iter().zip(a) {
                if t >= *s && t < s + 30.5 {
                    return a * (t - s) * (t - s);
                }
            }
            0.0
        };
        let errors: Vec<ErrorEpoch> = (0..3000)
            .map(|i| {
                let t = i as f64 * 0.1;
                err_at(t, drift(t))
            })
            .collect();
        let fixes: Vec<f64> = (0..300).map(|i| i as f64 + 0.5).collect();
        let outages: Vec<Outage> = starts
            .iter()
            .map(|&s| Outage {
                start: s,
                end: s + 30.0,
            })
            .collect();
        let with_fixes = outage_metric(&errors, &outages, Some(&fixes));
        for (r, a) in with_fixes.outages.iter().zip(a) {
            let expect = a * 30.4f64.powi(2);
            assert!((r.max_horizontal.unwrap() - expect).abs() < 1e-9, "{r:?}");
            assert!((r.window_end - (r.end + 0.5)).abs() < 1e-12);
            assert!((r.t_max.unwrap() - (r.start + 30.4)).abs() < 1e-9);
        }
        let m: Vec<f64> = a.iter().map(|a| a * 30.4f64.powi(2)).collect();
        let rms = ((m[0] * m[0] + m[1] * m[1]) / 2.0).sqrt();
        assert!((with_fixes.rms_of_max.unwrap() - rms).abs() < 1e-9);
        assert!((with_fixes.max_of_max.unwrap() - m[1]).abs() < 1e-9);

        // Without fix times the window ends at the outage end: last epoch s+29.9.
        let no_fixes = outage_metric(&errors, &outages, None);
        for (r, a) in no_fixes.outages.iter().zip(a) {
            assert!((r.max_horizontal.unwrap() - a * 29.9f64.powi(2)).abs() < 1e-9);
            assert_eq!(r.count, 300);
        }
    }

    #[test]
    fn empty_window_is_reported_not_scored() {
        let errors = vec![err_at(0.0, 1.0), err_at(50.0, 2.0)];
        let outages = [
            Outage {
                start: 10.0,
                end: 20.0,
            },
            Outage {
                start: 45.0,
                end: 55.0,
            },
        ];
        let r = outage_metric(&errors, &outages, None);
        assert_eq!(r.empty_outages, 1);
        assert_eq!(r.outages[0].max_horizontal, None);
        assert_eq!(r.rms_of_max, Some(2.0));
    }

    proptest! {
        #[test]
        fn contains_matches_intervals(
            t0 in -1e3f64..1e6, s in 0f64..200.0, p in 1f64..100.0, frac in 0.01f64..1.0,
            n in 1usize..8, dt in -50f64..1000.0,
        ) {
            let l = p * frac;
            let sched = OutageSchedule::periodic(t0, s, p, l, Some(n)).unwrap();
            let t = t0 + dt;
            let iv = sched.intervals(f64::NEG_INFINITY, f64::INFINITY);
            prop_assert_eq!(iv.len(), n);
            prop_assert_eq!(sched.contains(t), iv.iter().any(|o| o.contains(t)));
            // Every interval start is inside, every end outside.
            for o in &iv {
                prop_assert!(sched.contains(o.start));
                prop_assert!(l == p || !sched.contains(o.end));
            }
        }
    }
}
