//! The alignment check: starts in motion with no static window and no
//! magnetometer, industrial MEMS (ADIS16465 preset), RTK and consumer GNSS,
//! run in the default configuration (`platform` + `imu_preset` only):
//! - `pedestrian`: walking 1.0–1.5 m/s with tight turns (the sim walker);
//! - `car`: already moving at 8–30 m/s, the first GNSS epoch 0.5 s before
//!   the first IMU sample (`gnss_lead_s`).
//!
//! Per run (thresholds are the issue's, fixed before any run):
//! - alignment latency: first solution − motion start (first truth epoch
//!   faster than 0.2 m/s) [s];
//! - heading: max |wrapped yaw error| over [motion + 30 s, motion + 60 s],
//!   pass when < 2°;
//! - velocity: |v − v_true| (3-D) at the first solution ≥ 2 s after the
//!   first solution, pass when < 0.2 m/s;
//! - worse than GNSS: horizontal RMS of the solutions (vs the IMU truth)
//!   above that of the fixes (vs the antenna truth), both over
//!   [first solution, last solution].
//! - the heading again for the RTS-smoothed solution of the same run
//!   (`[filter] smooth = true`; the forward solutions are unchanged by it).
//!
//! Why the walker's forward heading cannot reach 95 % (measured, not a
//! tuning): on a straight walk the GNSS sees no yaw (the step accelerations
//! average out within a stride), so the yaw drifts at the residual z-gyro
//! bias, and that bias (turn-on σ 240°/h for the ADIS16465 preset) is only
//! learnt from the yaw difference between turns. A Cramér–Rao bound of a
//! causal estimator (state: yaw at the hand-over with the bank member's 5°
//! prior, z-gyro bias, initial velocity, horizontal accelerometer bias,
//! tilt; 1 Hz velocity, plus positions for RTK; 150 walks drawn like the
//! sim walker: `python3 tools/walker_heading_crb.py 11 150`) gives at the
//! worst epoch of [30, 60] s: RTK (0.02 m/s, 2 cm) median σ 0.68°,
//! P(|e| < 2°) ≤ 0.90; with the exact initial state 0.96 (the oracle
//! measures 48/50); consumer (0.1 m/s white) median σ 2.7°, P ≤ 0.53, and
//! smoothed σ 1.0°, P ≤ 0.93. The smoother uses the later
//! turns: 100/100 RTK and 85/100 consumer seeds pass smoothed.

use super::score::{h_error_ne, motion_start};
use super::{rms, run_variant, variant_config, wrap_pi, ExperimentError, Variant};
use navfuse_sim::platform::{
    platform_run, GnssGrade, ImuGrade, Outages, Platform, PlatformOptions, PlatformRun,
};
use rayon::prelude::*;
use serde::Serialize;

/// Heading window after the motion start [s].
pub const HEADING_WINDOW_S: [f64; 2] = [30.0, 60.0];
/// Heading pass threshold [deg].
pub const HEADING_MAX_DEG: f64 = 2.0;
/// Velocity check: this long after the first solution [s] …
pub const VELOCITY_AFTER_S: f64 = 2.0;
/// … pass when |v − v_true| is below this [m/s].
pub const VELOCITY_MAX_M_S: f64 = 0.2;
/// GNSS lead of the car scenario [s] (the example).
pub const CAR_GNSS_LEAD_S: f64 = 0.5;
/// Run length [s]: the heading window ends 60 s after the (immediate)
/// motion start; 30 s more leave room for a late alignment to be seen.
pub const DURATION_S: f64 = 90.0;

/// One scenario of the check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AlignScenario {
    #[serde(serialize_with = "display")]
    pub platform: Platform,
    #[serde(serialize_with = "display")]
    pub gnss: GnssGrade,
    pub gnss_lead_s: f64,
}

fn display<T: std::fmt::Display, S: serde::Serializer>(x: &T, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(x)
}

impl AlignScenario {
    pub fn name(&self) -> String {
        format!("{}-{}", self.platform, self.gnss)
    }
    /// Platform options of seed `seed`: moving start, no outages, τ = 0, industrial IMU.
    pub fn options(&self) -> PlatformOptions {
        PlatformOptions {
            duration_s: DURATION_S,
            static_start: false,
            imu: ImuGrade::Industrial,
            gnss: self.gnss,
            outages: Outages::None,
            imu_time_offset_s: 0.0,
            gnss_lead_s: self.gnss_lead_s,
            ..Default::default()
        }
    }
}

/// The four scenarios: pedestrian and car × RTK and consumer GNSS.
pub fn scenarios() -> Vec<AlignScenario> {
    let mut v = Vec::new();
    for (platform, gnss_lead_s) in [
        (Platform::Pedestrian, 0.0),
        (Platform::Car, CAR_GNSS_LEAD_S),
    ] {
        for gnss in GnssGrade::ALL {
            v.push(AlignScenario {
                platform,
                gnss,
                gnss_lead_s,
            });
        }
    }
    v
}

/// One run's measurements (NaN → `null`: not measurable, e.g. no solution
/// in the heading window; a failed run has `failure` set and fails every check).
#[derive(Clone, Debug, Serialize)]
pub struct AlignRow {
    pub seed: u64,
    pub failure: Option<String>,
    /// Alignment description of the run.
    pub alignment: String,
    pub motion_start_s: f64,
    pub latency_s: f64,
    /// Yaw error of the first solution [deg] and the σ the alignment gave it
    /// (diagnostics: a hand-over error beyond 3σ is the alignment's fault).
    pub yaw_err_start_deg: f64,
    /// Roll and pitch error of the first solution [deg].
    pub tilt_err_start_deg: [f64; 2],
    pub yaw_std_start_deg: f64,
    pub heading_max_err_deg: f64,
    pub heading_pass: bool,
    /// The same for the RTS-smoothed solution (`[filter] smooth = true`):
    /// what post-processing gets with hindsight. A causal filter cannot
    /// know the z-gyro bias on a walker's straights before turns reveal it
    /// (module doc); the smoother carries the bias learnt from later turns
    /// back.
    pub heading_max_err_smoothed_deg: f64,
    pub heading_pass_smoothed: bool,
    pub vel_err_m_s: f64,
    pub velocity_pass: bool,
    pub h_rms_solution_m: f64,
    pub h_rms_gnss_m: f64,
    pub worse_than_gnss: bool,
    /// Horizontal RMS of the solution at the fix epochs [m].
    pub h_rms_solution_at_fixes_m: f64,
    pub worse_than_gnss_at_fixes: bool,
    /// IMU–GNSS time offset the default applied [s] (0 when none; the
    /// truth is 0 here) and the passes' note.
    pub time_offset_applied_s: f64,
    pub time_offset_note: String,
}

/// One scenario's shares over its seeds and the per-seed rows.
#[derive(Clone, Debug, Serialize)]
pub struct ScenarioReport {
    pub name: String,
    pub scenario: AlignScenario,
    pub seeds: u64,
    pub failures: usize,
    pub heading_pass_share: f64,
    /// Heading pass share of the smoothed solution.
    pub heading_pass_smoothed_share: f64,
    pub velocity_pass_share: f64,
    pub worse_than_gnss_share: f64,
    pub worse_than_gnss_at_fixes_share: f64,
    pub latency_median_s: f64,
    pub latency_max_s: f64,
    pub rows: Vec<AlignRow>,
}

/// The check's result (`--json`).
#[derive(Clone, Debug, Serialize)]
pub struct AlignReport {
    pub scenarios: Vec<ScenarioReport>,
    pub thresholds: serde_json::Value,
}

fn failed(seed: u64, msg: String) -> AlignRow {
    AlignRow {
        seed,
        failure: Some(msg),
        alignment: String::new(),
        motion_start_s: f64::NAN,
        latency_s: f64::NAN,
        yaw_err_start_deg: f64::NAN,
        tilt_err_start_deg: [f64::NAN; 2],
        yaw_std_start_deg: f64::NAN,
        heading_max_err_deg: f64::NAN,
        heading_pass: false,
        heading_max_err_smoothed_deg: f64::NAN,
        heading_pass_smoothed: false,
        vel_err_m_s: f64::NAN,
        velocity_pass: false,
        h_rms_solution_m: f64::NAN,
        h_rms_gnss_m: f64::NAN,
        worse_than_gnss: true,
        h_rms_solution_at_fixes_m: f64::NAN,
        worse_than_gnss_at_fixes: true,
        time_offset_applied_s: f64::NAN,
        time_offset_note: String::new(),
    }
}

/// Measure one seed of `sc`.
pub fn check_seed(sc: &AlignScenario, seed: u64) -> AlignRow {
    let pr = match platform_run(sc.platform, seed, &sc.options()) {
        Ok(pr) => pr,
        Err(e) => return failed(seed, format!("simulation: {e}")),
    };
    match measure(&pr) {
        Ok(mut r) => {
            r.seed = seed;
            r
        }
        Err(m) => failed(seed, m),
    }
}

fn measure(pr: &PlatformRun) -> Result<AlignRow, String> {
    let traj = &pr.run.traj;
    let t_move = motion_start(traj).ok_or("the platform never moves")?;
    // The default configuration plus `[filter] smooth = true`: the
    // smoother only records along the forward pass (the forward solutions
    // are the default run's), and its output is scored as a second column.
    let mut cfg = variant_config(Variant::Default, pr);
    cfg.filter.smooth = true;
    let r = run_variant(&cfg, pr).map_err(|e| e.to_string())?;
    let sols = &r.solutions;
    let (first, last) = match (sols.first(), sols.last()) {
        (Some(a), Some(b)) => (a.t, b.t),
        _ => return Err("no solutions".into()),
    };
    let [w0, w1] = HEADING_WINDOW_S.map(|d| t_move + d);
    let heading_max = |sols: &[navfuse_core::types::NavSolution]| -> f64 {
        let head: Vec<f64> = sols
            .iter()
            .filter(|s| s.t >= w0 && s.t <= w1)
            .map(|s| wrap_pi(s.rpy.z - traj.at(s.t).rpy.z).to_degrees().abs())
            .collect();
        // NaN (any NaN yaw, or no solution in the window) fails.
        if head.is_empty() {
            f64::NAN
        } else {
            head.iter().fold(0.0f64, |m, &x| {
                if x.is_nan() || m.is_nan() {
                    f64::NAN
                } else {
                    m.max(x)
                }
            })
        }
    };
    let heading_max_err_deg = heading_max(sols);
    let heading_max_err_smoothed_deg = heading_max(&r.smoothed);
    let vel_err_m_s = sols
        .iter()
        .find(|s| s.t >= first + VELOCITY_AFTER_S - 1e-9)
        .map_or(f64::NAN, |s| (s.v_n - traj.at(s.t).v_n).norm());
    let e_sol: Vec<f64> = sols
        .iter()
        .map(|s| {
            let (n, e) = h_error_ne(s.lat, s.lon, &traj.at(s.t));
            n.hypot(e)
        })
        .collect();
    let e_gnss: Vec<f64> = pr
        .run
        .gnss
        .iter()
        .zip(&pr.run.gnss_truth)
        .filter(|(g, _)| g.t >= first && g.t <= last)
        .map(|(g, &(lat, lon, h))| {
            let tr = navfuse_sim::trajectory::TruthEpoch {
                lat,
                lon,
                h,
                ..traj.truth[0]
            };
            let (n, e) = h_error_ne(g.lat, g.lon, &tr);
            n.hypot(e)
        })
        .collect();
    let e_at_fixes: Vec<f64> = pr
        .run
        .gnss
        .iter()
        .filter(|g| g.t >= first && g.t <= last)
        .filter_map(|g| {
            let k = sols.partition_point(|s| s.t < g.t);
            let near = [k.checked_sub(1), Some(k)]
                .into_iter()
                .flatten()
                .filter_map(|i| sols.get(i))
                .min_by(|a, b| (a.t - g.t).abs().total_cmp(&(b.t - g.t).abs()))?;
            let (n, e) = h_error_ne(near.lat, near.lon, &traj.at(near.t));
            Some(n.hypot(e))
        })
        .collect();
    let (h_sol, h_gnss) = (rms(&e_sol), rms(&e_gnss));
    let h_sol_fix = rms(&e_at_fixes);
    let not_better = |a: f64, b: f64| {
        !matches!(
            a.partial_cmp(&b),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        )
    };
    Ok(AlignRow {
        seed: 0,
        failure: None,
        alignment: r.alignment,
        motion_start_s: t_move,
        latency_s: first - t_move,
        yaw_err_start_deg: sols.first().map_or(f64::NAN, |s| {
            wrap_pi(s.rpy.z - traj.at(s.t).rpy.z).to_degrees()
        }),
        tilt_err_start_deg: sols.first().map_or([f64::NAN; 2], |s| {
            let tr = traj.at(s.t).rpy;
            [
                wrap_pi(s.rpy.x - tr.x).to_degrees(),
                wrap_pi(s.rpy.y - tr.y).to_degrees(),
            ]
        }),
        yaw_std_start_deg: r.align_yaw_std_deg,
        heading_max_err_deg,
        heading_pass: heading_max_err_deg < HEADING_MAX_DEG,
        heading_max_err_smoothed_deg,
        heading_pass_smoothed: heading_max_err_smoothed_deg < HEADING_MAX_DEG,
        vel_err_m_s,
        velocity_pass: vel_err_m_s < VELOCITY_MAX_M_S,
        h_rms_solution_m: h_sol,
        h_rms_gnss_m: h_gnss,
        // NaN on either side (nothing to compare) counts as worse.
        worse_than_gnss: not_better(h_sol, h_gnss),
        h_rms_solution_at_fixes_m: h_sol_fix,
        worse_than_gnss_at_fixes: not_better(h_sol_fix, h_gnss),
        time_offset_applied_s: r.time_offset_applied.as_ref().map_or(0.0, |a| a.0),
        time_offset_note: r.time_offset_passes.clone().unwrap_or_default(),
    })
}

/// Run `seeds` seeds (0…) of every scenario (rayon over (scenario, seed);
/// deterministic order).
pub fn run_align_check(
    scenarios: &[AlignScenario],
    seeds: u64,
) -> Result<AlignReport, ExperimentError> {
    if seeds == 0 {
        return Err(ExperimentError::Options("--seeds must be ≥ 1".into()));
    }
    let jobs: Vec<(usize, u64)> = (0..scenarios.len())
        .flat_map(|c| (0..seeds).map(move |s| (c, s)))
        .collect();
    let rows: Vec<AlignRow> = super::on_worker_pool(|| {
        jobs.par_iter()
            .map(|&(c, s)| check_seed(&scenarios[c], s))
            .collect()
    });
    let per = seeds as usize;
    let reports = scenarios
        .iter()
        .zip(rows.chunks(per))
        .map(|(sc, rows)| {
            let share = |f: &dyn Fn(&AlignRow) -> bool| {
                rows.iter().filter(|r| f(r)).count() as f64 / rows.len() as f64
            };
            let mut lat: Vec<f64> = rows
                .iter()
                .map(|r| r.latency_s)
                .filter(|x| x.is_finite())
                .collect();
            lat.sort_by(f64::total_cmp);
            ScenarioReport {
                name: sc.name(),
                scenario: *sc,
                seeds,
                failures: rows.iter().filter(|r| r.failure.is_some()).count(),
                heading_pass_share: share(&|r| r.heading_pass),
                heading_pass_smoothed_share: share(&|r| r.heading_pass_smoothed),
                velocity_pass_share: share(&|r| r.velocity_pass),
                worse_than_gnss_share: share(&|r| r.worse_than_gnss),
                worse_than_gnss_at_fixes_share: share(&|r| r.worse_than_gnss_at_fixes),
                latency_median_s: lat.get(lat.len() / 2).copied().unwrap_or(f64::NAN),
                latency_max_s: lat.last().copied().unwrap_or(f64::NAN),
                rows: rows.to_vec(),
            }
        })
        .collect();
    Ok(AlignReport {
        scenarios: reports,
        thresholds: serde_json::json!({
            "heading_window_after_motion_s": HEADING_WINDOW_S,
            "heading_max_deg": HEADING_MAX_DEG,
            "velocity_after_first_solution_s": VELOCITY_AFTER_S,
            "velocity_max_m_s": VELOCITY_MAX_M_S,
            "car_gnss_lead_s": CAR_GNSS_LEAD_S,
            "duration_s": DURATION_S,
            "imu": "industrial (adis16465)",
            "configuration": "default: [filter] platform + imu_preset only",
        }),
    })
}

/// The summary: one line per scenario.
pub fn format_summary(r: &AlignReport) -> String {
    let mut s = format!(
        "{:<22} {:>6} {:>6} {:>9} {:>9} {:>9} {:>10} {:>10} {:>10} {:>10}\n",
        "scenario",
        "seeds",
        "fails",
        "head<2°",
        "smoothed",
        "|dv|<0.2",
        "worse>GNSS",
        "@fixes",
        "lat med s",
        "lat max s"
    );
    for c in &r.scenarios {
        s += &format!(
            "{:<22} {:>6} {:>6} {:>8.0}% {:>8.0}% {:>8.0}% {:>9.0}% {:>9.0}% {:>10.2} {:>10.2}\n",
            c.name,
            c.seeds,
            c.failures,
            100.0 * c.heading_pass_share,
            100.0 * c.heading_pass_smoothed_share,
            100.0 * c.velocity_pass_share,
            100.0 * c.worse_than_gnss_share,
            100.0 * c.worse_than_gnss_at_fixes_share,
            c.latency_median_s,
            c.latency_max_s
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CI-sized: 3 seeds of every scenario complete (a failure is a row with
    /// its message, not a panic), shares are shares, and the JSON has the
    /// fields the report promises.
    #[test]
    fn three_seeds_complete_with_the_promised_fields() {
        let r = run_align_check(&scenarios(), 3).unwrap();
        assert_eq!(r.scenarios.len(), 4);
        for c in &r.scenarios {
            assert_eq!(c.rows.len(), 3);
            for x in [
                c.heading_pass_share,
                c.velocity_pass_share,
                c.worse_than_gnss_share,
            ] {
                assert!((0.0..=1.0).contains(&x), "{}: {x}", c.name);
            }
            for row in &c.rows {
                assert!(
                    row.failure.is_some() || row.latency_s.is_finite(),
                    "{}: {row:?}",
                    c.name
                );
            }
        }
        let j = serde_json::to_value(&r).unwrap();
        for k in [
            "heading_pass_share",
            "velocity_pass_share",
            "worse_than_gnss_share",
            "rows",
        ] {
            assert!(!j["scenarios"][0][k].is_null(), "{k}");
        }
        for k in [
            "latency_s",
            "heading_max_err_deg",
            "vel_err_m_s",
            "h_rms_gnss_m",
            "worse_than_gnss",
        ] {
            assert!(j["scenarios"][3]["rows"][2].get(k).is_some(), "{k}");
        }
        println!("{}", format_summary(&r));
    }

    /// The walker with RTK on seeds not used for the 50-seed check
    /// (100…109): every run starts with the ESKF bank over yaw hypotheses,
    /// the bank resolves to one heading, and that heading is the right one:
    /// the max error over [30, 60] s after the motion start stays below the
    /// bank's grid spacing (10°; a wrong member or a divergence would be
    /// ≥ 10° off). The 2° pass count is printed (measured 5/10 before the
    /// bank's merge rule, 4/10 after; the oracle's exact initial state gets
    /// 8/10 on these seeds: the rest is the gyro bias on straight
    /// stretches, not the alignment; smoothed: 10/10).
    #[test]
    fn walker_rtk_bank_resolves_on_unseen_seeds() {
        let sc = AlignScenario {
            platform: Platform::Pedestrian,
            gnss: GnssGrade::Rtk,
            gnss_lead_s: 0.0,
        };
        let rows: Vec<AlignRow> = super::super::on_worker_pool(|| {
            (100..110)
                .into_par_iter()
                .map(|s| check_seed(&sc, s))
                .collect()
        });
        for r in &rows {
            assert!(r.failure.is_none(), "{r:?}");
            assert!(
                r.alignment.contains("resolved"),
                "seed {}: {}",
                r.seed,
                r.alignment
            );
        }
        let pass = rows.iter().filter(|r| r.heading_pass).count();
        let errs: Vec<f64> = rows.iter().map(|r| r.heading_max_err_deg).collect();
        println!("{pass}/10 within 2°: {errs:?}");
        assert!(errs.iter().all(|e| *e < 10.0), "{errs:?}");
    }

    /// The walker with RTK on seeds never run during this work (130…149;
    /// 0…129 were): (1) the member that goes on started within 3σ of the
    /// member prior (3 × 5° = 15°) of the true yaw — the hypothesis
    /// nearest the truth is at most 5° off, so a winner beyond 15° got there
    /// by a large-angle transient (seed 11 of the 50-seed check: 27°
    /// before the merge rule); (2) the forward heading never leaves the
    /// bank's grid spacing (10°); (3) the smoothed heading meets the issue's
    /// target, < 2° over [30, 60] s in ≥ 95 % of the seeds (19 of 20). The
    /// forward 2° count is printed, not asserted: a causal filter's
    /// ceiling there is ≈ 91 % (module doc).
    #[test]
    fn walker_rtk_on_unseen_seeds_winner_near_truth_and_smoothed_heading() {
        let sc = AlignScenario {
            platform: Platform::Pedestrian,
            gnss: GnssGrade::Rtk,
            gnss_lead_s: 0.0,
        };
        let rows: Vec<AlignRow> = super::super::on_worker_pool(|| {
            (130..150)
                .into_par_iter()
                .map(|s| check_seed(&sc, s))
                .collect()
        });
        let y0: Vec<f64> = rows.iter().map(|r| r.yaw_err_start_deg).collect();
        let errs: Vec<f64> = rows.iter().map(|r| r.heading_max_err_deg).collect();
        let pass = rows.iter().filter(|r| r.heading_pass).count();
        let smoothed = rows.iter().filter(|r| r.heading_pass_smoothed).count();
        println!(
            "forward {pass}/20, smoothed {smoothed}/20 within 2°; start yaw errors {y0:?}; \
             forward max errors {errs:?}"
        );
        for r in &rows {
            assert!(r.failure.is_none(), "{r:?}");
        }
        assert!(y0.iter().all(|e| e.abs() < 15.0), "{y0:?}");
        assert!(errs.iter().all(|e| *e < 10.0), "{errs:?}");
        assert!(smoothed >= 19, "smoothed {smoothed}/20");
    }
}
