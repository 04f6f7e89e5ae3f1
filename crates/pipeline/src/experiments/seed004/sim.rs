//! Table 3: the simulated runs, their scoring and the rows.

use super::*;

/// A simulated run: time-ordered events and the truth at each fix.
pub struct SimRun {
    pub events: Vec<Event>,
    /// (t, lat, lon) of the truth at every GNSS epoch.
    pub truth: Vec<(f64, f64, f64)>,
}

/// Run navfuse-sim on `sc` with `seed`; `accel_noise` [G²] (if given)
/// replaces the accelerometer's white noise (variance per sample at the
/// scenario's IMU rate).
pub fn simulate(
    sc: &navfuse_sim::Scenario,
    seed: u64,
    accel_noise: Option<f64>,
) -> Result<SimRun, ToolError> {
    let mut imu = sc.imu_spec().map_err(|e| e.to_string())?;
    if let Some(var) = accel_noise {
        // variance per sample σ² [G²] at rate f → density σ·G0/√f [m/s/√s], in m/s/√h.
        let g0 = navfuse_core::earth::STANDARD_GRAVITY;
        imu.accel.vrw_m_s_sqrt_h = var.sqrt() * g0 / sc.imu.rate_hz.sqrt() * 60.0;
    }
    let run = navfuse_sim::simulate(sc, seed, Some(imu), None).map_err(|e| e.to_string())?;
    let truth = run
        .gnss
        .iter()
        .zip(&run.gnss_truth)
        .map(|(f, t)| (f.t, t.0, t.1))
        .collect();
    Ok(SimRun {
        events: run.events(),
        truth,
    })
}

/// Feed `events` to `est`, passing only the fixes at t0 + m·`every` s
/// (whole seconds, within 0.01 s); returns every solution.
pub fn run_with_interval<E: Estimator>(
    est: &mut E,
    events: &[Event],
    every: u32,
) -> Vec<NavSolution> {
    let t0 = first_fix_t(events);
    let mut out = Vec::with_capacity(events.len());
    for ev in events {
        if let Event::Gnss(f) = ev {
            if !fix_used(t0, f.t, every) {
                continue;
            }
        }
        if let Some(s) = est.push(ev) {
            // A solution at the same time replaces the previous one (the fix
            // after the IMU sample of its epoch).
            if out.last().is_some_and(|p: &NavSolution| p.t == s.t) {
                out.pop();
            }
            out.push(s);
        }
    }
    out
}

/// Time of the first fix of `events` (0 without one).
pub(super) fn first_fix_t(events: &[Event]) -> f64 {
    events
        .iter()
        .find_map(|e| match e {
            Event::Gnss(f) => Some(f.t),
            _ => None,
        })
        .unwrap_or(0.0)
}

/// Whether the fix at `t` is used at interval `every` s: t0 + m·`every`
/// whole seconds, within 0.01 s.
pub(super) fn fix_used(t0: f64, t: f64, every: u32) -> bool {
    let s = (t - t0).round();
    (t - t0 - s).abs() <= 0.01 && (s as i64) % every as i64 == 0
}

/// Position of `sols` at `t`, linearly interpolated (None outside).
pub(super) fn interp(sols: &[NavSolution], t: f64) -> Option<(f64, f64)> {
    let i = sols.partition_point(|s| s.t <= t);
    if i == 0 {
        return None;
    }
    let a = &sols[i - 1];
    if (a.t - t).abs() < 1e-6 || i == sols.len() {
        return ((t - a.t).abs() < 0.05).then_some((a.lat, a.lon));
    }
    let b = &sols[i];
    let w = (t - a.t) / (b.t - a.t);
    Some((a.lat + w * (b.lat - a.lat), a.lon + w * (b.lon - a.lon)))
}

/// Mean |longitude| and |latitude| error [m] of `sols` against `truth`
/// (t, lat, lon) at the truth epochs the solutions cover.
pub fn mean_errors(sols: &[NavSolution], truth: &[(f64, f64, f64)]) -> (f64, f64) {
    let (mut e_lon, mut e_lat, mut n) = (0.0, 0.0, 0usize);
    for &(t, lat, lon) in truth {
        let Some((la, lo)) = interp(sols, t) else {
            continue;
        };
        let (rm, rn) = earth::radii(lat);
        e_lat += ((la - lat) * rm).abs();
        e_lon += ((lo - lon) * rn * lat.cos()).abs();
        n += 1;
    }
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    (e_lon / n as f64, e_lat / n as f64)
}

/// One table row: mean and spread over runs (seeds).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cell {
    pub lon_m: f64,
    pub lat_m: f64,
    pub lon_sd_m: f64,
    pub lat_sd_m: f64,
}

pub(super) fn cell(v: &[(f64, f64)]) -> Cell {
    let n = v.len() as f64;
    let (ml, mt) = (
        v.iter().map(|x| x.0).sum::<f64>() / n,
        v.iter().map(|x| x.1).sum::<f64>() / n,
    );
    let sd = |m: f64, f: &dyn Fn(&(f64, f64)) -> f64| {
        if v.len() < 2 {
            0.0
        } else {
            (v.iter().map(|x| (f(x) - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
        }
    };
    Cell {
        lon_m: ml,
        lat_m: mt,
        lon_sd_m: sd(ml, &|x| x.0),
        lat_sd_m: sd(mt, &|x| x.1),
    }
}

/// One row of Table 3/4.
#[derive(Clone, Debug)]
pub struct Row {
    pub interval_s: u32,
    /// The headline configuration ([`AccelDrConfig::rate_scaled`] unless overridden).
    pub gps_acc: Cell,
    /// [`AccelDrConfig::default`]: navfuse corrections, the paper's per-sample Q.
    pub gps_acc_default: Cell,
    /// The paper's literal method ([`AccelDrConfig::paper_literal`]).
    pub gps_acc_literal: Cell,
    pub gps_only: Cell,
    /// navfuse's ESKF (gyro + accelerometer) on the same fixes: the KF-GINS
    /// configuration of drive_0708, and with NHC/ZUPT (`kf_gins::enhanced`).
    pub eskf: Option<Cell>,
    pub eskf_nhc: Option<Cell>,
}

/// The three GPS+accel configurations of a table: headline, default, literal.
#[derive(Clone, Copy, Debug)]
pub struct Configs {
    pub main: AccelDrConfig,
    pub default: AccelDrConfig,
    pub literal: AccelDrConfig,
}

impl Configs {
    pub(super) fn all(&self) -> [AccelDrConfig; 3] {
        [self.main, self.default, self.literal]
    }
}

/// Table 3: the simulation over `seeds` seeds starting at `seed0`.
pub fn table3(
    cfgs: &Configs,
    sc: &navfuse_sim::Scenario,
    seed0: u64,
    seeds: u64,
    noise: Option<f64>,
    mut keep: Option<&mut Kept>,
) -> Result<Vec<Row>, ToolError> {
    let mut acc: Vec<[Vec<(f64, f64)>; 3]> = vec![Default::default(); INTERVALS.len()];
    let mut hold: Vec<Vec<(f64, f64)>> = vec![Vec::new(); INTERVALS.len()];
    for seed in seed0..seed0 + seeds {
        let run = simulate(sc, seed, noise)?;
        let truth = &run.truth[1..];
        for (i, &every) in INTERVALS.iter().enumerate() {
            let mut kept = Vec::new();
            for (c, cfg) in cfgs.all().iter().enumerate() {
                let sols = run_with_interval(&mut AccelDr::new(*cfg), &run.events, every);
                acc[i][c].push(mean_errors(&sols, truth));
                kept.push(sols);
            }
            let sols = run_with_interval(&mut GpsHold::new(), &run.events, every);
            hold[i].push(mean_errors(&sols, truth));
            if seed == seed0 && every == REPORT_EVERY {
                if let Some(k) = keep.as_deref_mut() {
                    keep_row(k, kept, sols, &run.events, every, truth);
                }
            }
        }
    }
    Ok(INTERVALS
        .iter()
        .enumerate()
        .map(|(i, &interval_s)| Row {
            interval_s,
            gps_acc: cell(&acc[i][0]),
            gps_acc_default: cell(&acc[i][1]),
            gps_acc_literal: cell(&acc[i][2]),
            gps_only: cell(&hold[i]),
            eskf: None,
            eskf_nhc: None,
        })
        .collect())
}
