//! A simulated car drive with raw GNSS written as the files `navfuse run`
//! reads with `[filter] coupling = "tight"` (issue 14): the IMU as
//! `imu.csv` (and the other [`navfuse_sim::output`] files: `truth.nav`, …),
//! the raw observables and ephemerides as a u-blox log `raw.ubx`
//! (RXM-RAWX + RXM-SFRBX, [`navfuse_io::ubx_gnss::write_ubx_gnss`]) and a
//! ready `tight.toml`. Used by the tight-coupling tests of the pipeline and
//! the CLI.
//!
//! Scenario: [`platform_run`] car, static start, consumer MEMS ("phone"),
//! the scenario's antenna lever arm; raw GNSS at 1 Hz from
//! [`synthetic_constellation`] (24 GPS satellites, t_oe on the 16 s LNAV
//! grid at the middle of the drive, angles in the LNAV fields' ±π) with the
//! simulator's documented consumer-receiver error model
//! ([`navfuse_sim::raw_gnss`], seed `7919 · seed + 17` as the experiment's).
//! The simulator's ionosphere is the residual after the broadcast model; the
//! log carries a Klobuchar model ([`KLOBUCHAR`]) whose delay is added to the
//! code and taken from the phase, so a reader that applies it sees the
//! simulated residual. Observables are rounded to the RINEX resolution
//! (1 mm, 0.001 cycle, 0.001 Hz) and C/N0 to UBX's whole dB-Hz, so a RINEX
//! copy of [`RawDrive::obs`] carries the same numbers as the log.

use crate::experiments::tight::simulate_drive_raw;
use navfuse_core::geodesy::{c_en, geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::{LAMBDA_L1, SECONDS_PER_WEEK};
use navfuse_io::rinex::{NavData, ObsEpoch, ObsFile, ObsValue};
use navfuse_sim::carrier_phase::synthetic_constellation;
use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
use navfuse_sim::raw_gnss::RawConfig;
use std::path::Path;

/// The broadcast ionosphere of the log: GEONET 0759, 2005-04-02
/// (`gnss/rinex/07590920.05n` of the shared data), ION ALPHA / BETA, a
/// mid-latitude spring day.
pub const KLOBUCHAR: Klobuchar = Klobuchar {
    alpha: [1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08],
    beta: [8.8060e+04, 1.6380e+04, -1.9660e+05, -1.3110e+05],
};

/// The constellation and the raw-observable configuration of the drive
/// of `seed` (module documentation): what [`write_raw_drive`] simulates,
/// exposed so a diagnostic can re-simulate the same draws.
pub fn drive_sky(
    sim: &navfuse_sim::SimRun,
    seed: u64,
    duration_s: f64,
) -> (Vec<navfuse_core::gnss::KeplerOrbit>, RawConfig) {
    let t0 = sim.traj.truth[0].t;
    let t_ref = ((t0 + 0.5 * duration_s) / 16.0).round() * 16.0;
    // Angles into the LNAV fields' ±π range (the same orbits).
    let orbits: Vec<_> = synthetic_constellation(t_ref)
        .into_iter()
        .map(|mut o| {
            let w = |a: f64| {
                (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
            };
            o.m0 = w(o.m0);
            o.omega0 = w(o.omega0);
            o
        })
        .collect();
    let cfg = RawConfig {
        seed: seed * 7919 + 17,
        ..Default::default()
    };
    (orbits, cfg)
}

/// What [`write_raw_drive`] simulated and wrote.
pub struct RawDrive {
    pub sim: navfuse_sim::SimRun,
    /// The observations of `raw.ubx` (`C1 L1 D1 S1`) and its ephemerides.
    pub obs: ObsFile,
    pub nav: NavData,
}

/// Simulate the drive (`seed`, `duration_s`) and write its files into `dir`
/// (module documentation).
pub fn write_raw_drive(dir: &Path, seed: u64, duration_s: f64) -> Result<RawDrive, String> {
    write_raw_drive_imu(dir, seed, duration_s, ImuGrade::Consumer)
}

/// [`write_raw_drive`] with another IMU grade (diagnostics: the same GNSS
/// draws under a better IMU, its preset in `tight.toml`).
pub fn write_raw_drive_imu(
    dir: &Path,
    seed: u64,
    duration_s: f64,
    imu: ImuGrade,
) -> Result<RawDrive, String> {
    write_raw_drive_on(dir, seed, duration_s, imu, Platform::Car, false)
}

/// [`write_raw_drive_imu`] on another platform of the simulator; with
/// `profile`, `tight.toml` also names it (`[filter] platform`), so the run
/// uses that platform's motion constraints and alignment.
pub fn write_raw_drive_on(
    dir: &Path,
    seed: u64,
    duration_s: f64,
    imu: ImuGrade,
    platform: Platform,
    profile: bool,
) -> Result<RawDrive, String> {
    let opts = PlatformOptions {
        duration_s,
        static_start: true,
        imu,
        gnss: GnssGrade::Consumer,
        ..Default::default()
    };
    let sim = platform_run(platform, seed, &opts)
        .map_err(|e| e.to_string())?
        .run;
    let (orbits, cfg) = drive_sky(&sim, seed, duration_s);
    let eps = simulate_drive_raw(&sim, &orbits, &cfg);
    let r3 = |x: f64| (x * 1e3).round() / 1e3;
    let mut obs = ObsFile {
        version: 3.04,
        marker: "SIM".into(),
        types: vec!["C1".into(), "L1".into(), "D1".into(), "S1".into()],
        codes: vec!["C1C".into(), "L1C".into(), "D1C".into(), "S1C".into()],
        ..Default::default()
    };
    for e in &eps {
        let tr = sim.traj.at(e.t);
        let rx = geodetic_to_ecef(&Geodetic {
            lat: tr.lat,
            lon: tr.lon,
            h: tr.h,
        });
        let cen = c_en(tr.lat, tr.lon);
        let tow = e.epoch.t - (e.epoch.t / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
        let sats = e
            .epoch
            .sats()
            .iter()
            .map(|s| {
                let u = cen * (s.sat.pos_e - rx).normalize();
                let el = (-u.z).asin();
                let i = KLOBUCHAR.delay_l1(tr.lat, tr.lon, u.y.atan2(u.x), el, tow);
                let lli = s.obs.flags & 1;
                let v = |value: f64, lli: u8| Some(ObsValue { value, lli });
                (
                    s.obs.prn,
                    vec![
                        v(r3(s.obs.pseudorange_m + i), 0),
                        v(r3((s.obs.carrier_m - i) / LAMBDA_L1), lli),
                        v(r3(s.obs.doppler_hz), 0),
                        // UBX carries whole dB-Hz.
                        v((s.obs.cn0_dbhz as f64).round(), 0),
                    ],
                )
            })
            .collect();
        obs.epochs.push(ObsEpoch {
            t: e.epoch.t,
            flag: 0,
            sats,
        });
    }
    let nav = NavData {
        ura_m: vec![cfg.sat_sigma_m; orbits.len()],
        orbits,
        iono: Some(KLOBUCHAR),
    };
    let bytes = navfuse_io::ubx_gnss::write_ubx_gnss(&obs, &nav)?;
    navfuse_io::atomic::write_atomic(&dir.join("raw.ubx"), bytes).map_err(|e| e.to_string())?;
    navfuse_sim::output::write_run(&sim, dir).map_err(|e| e.to_string())?;
    let l = sim.scenario.gnss.lever_arm_m;
    let toml = format!(
        "# A simulated car drive ({duration_s} s, seed {seed}): consumer MEMS IMU\n\
         # (imu.csv) and raw GNSS (raw.ubx: RXM-RAWX + RXM-SFRBX), tightly coupled.\n\
         [input]\nimu = \"imu.csv\"\nimu_rate = {}\ngnss = \"raw.ubx\"\n\
         {}[filter]\n{}imu_preset = \"{}\"\nlever_arm = [{}, {}, {}]\ncoupling = \"tight\"\n",
        sim.scenario.imu.rate_hz,
        navfuse_sim::output::IMU_CSV_TOML,
        if profile {
            format!("platform = \"{platform}\"\n")
        } else {
            String::new()
        },
        imu.preset(),
        l[0],
        l[1],
        l[2]
    );
    navfuse_io::atomic::write_atomic(&dir.join("tight.toml"), toml).map_err(|e| e.to_string())?;
    Ok(RawDrive { sim, obs, nav })
}
