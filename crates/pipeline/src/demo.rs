//! The demo (`navfuse demo`): simulate a drive, run every estimator on it,
//! write the outputs and score them.
//!
//! Needs no files: the default scenario (`scenarios/demo_drive.toml`, a
//! ~10-minute car drive with an industrial MEMS IMU at 100 Hz and 1 Hz GNSS
//! with two outages) is embedded. Every estimator in [`estimators`] is fed
//! the same time-ordered events; each one's solutions are written
//! (`<name>.nav`, `<name>.csv`) beside the truth and sensor files and scored
//! against the exact truth: horizontal RMS and max over the run, and the
//! largest horizontal error inside each GNSS outage (the drift while coasting).

use crate::ToolError;
use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig, GpsHold};
use navfuse_core::estimators::eskf::{Eskf, EskfConfig, ImuErrors, ImuNoise, InitStd, NhcConfig};
use navfuse_core::estimators::pf_lc::{PfLc, PfLcConfig};
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::Estimator;
use navfuse_core::{earth, Event, NavSolution, Vec3};
use navfuse_io::trajectory::{create_writer, OutFormat};
use navfuse_io::writers::TrajectoryWriter;
use navfuse_sim::{output, simulate, Scenario, SimRun};
use std::path::Path;
use std::time::Instant;

/// The embedded default scenario.
pub const DEMO_SCENARIO: &str = include_str!("../../../scenarios/demo_drive.toml");

/// Every estimator the demo runs, fed the same events. Add one line per
/// estimator as they land.
fn estimators(run: &SimRun) -> Vec<Box<dyn Estimator>> {
    let mut v: Vec<Box<dyn Estimator>> = vec![Box::new(GpsHold::new())];
    if let Some(e) = eskf_for(run) {
        v.push(Box::new(e));
    }
    v.push(Box::new(PfLc::new(PfLcConfig::default())));
    v.push(Box::new(AccelDr::new(AccelDrConfig::rate_scaled())));
    v
}

/// Attitude error injected into the ESKF's initial state [rad] (roll, pitch,
/// yaw): what a levelling + magnetometer start would give (seed 001 starts
/// from an AHRS average).
pub const ESKF_INIT_ATT_ERR: [f64; 3] = [0.005, -0.005, 0.035];

/// The seed 001 ESKF configured from the simulated IMU's own error model
/// (ARW/VRW, Gauss–Markov bias instability; the turn-on bias and scale-factor
/// spread as initial σ), GNSS lever arm from the scenario, χ² gate, NHC.
/// Started at the true position and velocity with [`ESKF_INIT_ATT_ERR`].
/// `None` for an accelerometer-only IMU.
fn eskf_for(run: &SimRun) -> Option<Eskf> {
    let g = run.imu_spec.gyro.as_ref()?.to_si();
    let a = run.imu_spec.accel.to_si();
    let tau = if g.gm_tau > 0.0 { g.gm_tau } else { 1000.0 };
    let floor = |x: f64, min: f64| Vec3::repeat(x.max(min));
    let cfg = EskfConfig {
        noise: ImuNoise {
            arw: floor(g.white, 1e-5),
            vrw: floor(a.white, 1e-4),
            bg_std: floor(g.gm_sigma, 1e-6),
            ba_std: floor(a.gm_sigma, 1e-5),
            sg_std: floor(g.scale_sigma * 0.1, 1e-5),
            sa_std: floor(a.scale_sigma * 0.1, 1e-5),
            corr_time: tau,
        },
        lever_arm_b: Vec3::from(run.scenario.gnss.lever_arm_m),
        scale_factors: true,
        gate_probability: Some(0.9999),
        use_gnss_velocity: true,
        position_until: None,
        nhc: Some(NhcConfig {
            std: 0.1,
            interval: 0.1,
            min_speed: 2.0,
        }),
        zupt: None,
        smoother_every: 0,
        aiding: Default::default(),
        ..EskfConfig::seed001()
    };
    let t = &run.traj.truth[0];
    let nav = NavState {
        lat: t.lat,
        lon: t.lon,
        h: t.h,
        v_n: t.v_n,
        q_bn: q_bn_from_rpy(&(t.rpy + Vec3::from(ESKF_INIT_ATT_ERR))),
    };
    let std = InitStd {
        pos: Vec3::repeat(3.0),
        vel: Vec3::repeat(0.1),
        att: Vec3::new(0.01, 0.01, 0.05),
        bg: floor(g.bias_sigma + g.gm_sigma, 1e-5),
        ba: floor(a.bias_sigma + a.gm_sigma, 1e-4),
        sg: floor(g.scale_sigma, 1e-4),
        sa: floor(a.scale_sigma, 1e-4),
    };
    Some(Eskf::new(cfg, nav, ImuErrors::default(), &std))
}

/// Scores of one estimator against truth.
pub struct Score {
    pub name: &'static str,
    /// Solutions written and scored.
    pub epochs: usize,
    /// Horizontal RMS and max, vertical RMS [m] over the run.
    pub h_rms: f64,
    pub h_max: f64,
    pub v_rms: f64,
    /// Yaw error RMS [deg] (NaN without attitude).
    pub yaw_rms: f64,
    /// Largest horizontal error inside each outage [m] (NaN: no solution there).
    pub outage_max: Vec<f64>,
    /// Wall time of the estimator loop [s].
    pub secs: f64,
}

fn horizontal_vertical(run: &SimRun, s: &NavSolution) -> (f64, f64) {
    let t = run.traj.at(s.t);
    let (rm, rn) = earth::radii(t.lat);
    let dn = (s.lat - t.lat) * (rm + t.h);
    let de = (s.lon - t.lon) * (rn + t.h) * t.lat.cos();
    (dn.hypot(de), s.h - t.h)
}

fn run_estimator(
    est: &mut dyn Estimator,
    events: &[Event],
    run: &SimRun,
    out: &Path,
) -> Result<Score, String> {
    let t0 = Instant::now();
    let name = est.name();
    let mut sols = Vec::with_capacity(run.imu.len());
    for ev in events {
        if let Some(s) = est.push(ev) {
            sols.push(s);
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let open = |fmt: OutFormat| -> Result<Box<dyn TrajectoryWriter>, String> {
        let p = out.join(format!("{name}.{}", fmt.extension()));
        create_writer(&p, fmt).map_err(|e| format!("{}: {e}", p.display()))
    };
    let mut nav = open(OutFormat::Nav)?;
    let mut csv = open(OutFormat::Csv)?;
    let start = run.traj.truth[0].t;
    let outages = &run.scenario.gnss.outages;
    let mut outage_max = vec![f64::NAN; outages.len()];
    let (mut h2, mut v2, mut hmax) = (0.0, 0.0, 0.0f64);
    let (mut y2, mut ny) = (0.0, 0usize);
    let mut n = 0usize;
    for s in &sols {
        nav.write(s).map_err(|e| format!("{name}.nav: {e}"))?;
        csv.write(s).map_err(|e| format!("{name}.csv: {e}"))?;
        let (h, v) = horizontal_vertical(run, s);
        if !(h.is_finite() && v.is_finite()) {
            return Err(format!("{name}: non-finite solution at t = {}", s.t));
        }
        h2 += h * h;
        v2 += v * v;
        if s.rpy.z.is_finite() {
            let dy = navfuse_core::attitude::wrap_pi(s.rpy.z - run.traj.at(s.t).rpy.z);
            y2 += dy * dy;
            ny += 1;
        }
        hmax = hmax.max(h);
        n += 1;
        let rel = s.t - start;
        for (k, o) in outages.iter().enumerate() {
            if rel >= o[0] && rel < o[1] {
                outage_max[k] = if outage_max[k].is_nan() {
                    h
                } else {
                    outage_max[k].max(h)
                };
            }
        }
    }
    nav.finish().map_err(|e| format!("{name}.nav: {e}"))?;
    csv.finish().map_err(|e| format!("{name}.csv: {e}"))?;
    let nf = n.max(1) as f64;
    Ok(Score {
        name,
        epochs: n,
        h_rms: (h2 / nf).sqrt(),
        h_max: hmax,
        v_rms: (v2 / nf).sqrt(),
        yaw_rms: if ny > 0 {
            (y2 / ny as f64).sqrt().to_degrees()
        } else {
            f64::NAN
        },
        outage_max,
        secs,
    })
}

/// Simulate, write the sensor files, run and score every estimator into
/// `out`; also returns the simulation's wall time [s].
pub fn simulate_and_score(
    sc: &Scenario,
    seed: u64,
    out: &Path,
) -> Result<(SimRun, Vec<Score>, f64), ToolError> {
    let t0 = Instant::now();
    let run = simulate(sc, seed, None, None).map_err(|e| e.to_string())?;
    let t_sim = t0.elapsed().as_secs_f64();
    output::write_run(&run, out).map_err(|e| e.to_string())?;
    let events = run.events();
    let mut scores = Vec::new();
    for mut est in estimators(&run) {
        scores.push(run_estimator(est.as_mut(), &events, &run, out)?);
    }
    Ok((run, scores, t_sim))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_scenario_parses_and_is_a_ten_minute_drive_with_outages() {
        let sc = Scenario::from_toml(DEMO_SCENARIO, "demo").unwrap();
        assert_eq!(sc.gnss.outages.len(), 2);
        let spec = sc.imu_spec().unwrap();
        assert!(spec.gyro.is_some());
        let tr = navfuse_sim::trajectory::generate(&sc.start, &sc.segment, 10.0, 1).unwrap();
        assert!((540.0..660.0).contains(&tr.duration()), "{}", tr.duration());
    }

    #[test]
    fn short_drive_runs_every_estimator_and_scores_them() {
        // The embedded drive cut to its first ~290 s (first outage 210–240 s).
        let mut sc = Scenario::from_toml(DEMO_SCENARIO, "demo").unwrap();
        sc.segment.truncate(13);
        let out = std::env::temp_dir().join(format!("navfuse-demo-{}", std::process::id()));
        let (run, scores, _) = simulate_and_score(&sc, 2, &out).unwrap();
        assert!(run.traj.duration() > 240.0, "{}", run.traj.duration());
        let names: Vec<&str> = scores.iter().map(|s| s.name).collect();
        assert_eq!(names, ["gps-hold", "eskf", "pf-lc", "gps-acc"]);
        for s in &scores {
            assert!(s.epochs > 20_000 && s.h_rms.is_finite(), "{}", s.name);
            assert!(out.join(format!("{}.nav", s.name)).exists());
        }
        // The fused solution must beat holding the last fix through an outage.
        let (hold, eskf) = (&scores[0], &scores[1]);
        assert!(
            eskf.outage_max[0] < 0.2 * hold.outage_max[0],
            "{:?} vs {:?}",
            eskf.outage_max,
            hold.outage_max
        );
        assert!(eskf.h_rms < 5.0, "eskf h rms {}", eskf.h_rms);
        let _ = std::fs::remove_dir_all(&out);
    }
}
