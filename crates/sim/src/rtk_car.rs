//! A simulated car (or another platform) with an IMU and a dual-frequency
//! rover + base pair,
//! written as the files `navfuse run` (`coupling = "rtk"`), `navfuse
//! baseline` and RTKLIB `rnx2rtkp` read: one writer for the example
//! `rtk_car_rinex` (the speed comparison of `tools/rtk_speed.sh`) and the
//! pipeline's RTK run tests, so the scene they describe is one scene.
//!
//! - `rover.obs`, `base.obs` (RINEX 3.04; the base's true position in its
//!   header), `nav.rnx` (the broadcast records that generated the scene):
//!   [`crate::rtk_scene`] at 1 Hz, default error model, GPS L1 C/A + L2C and,
//!   with [`RtkCarOptions::multi_gnss`], Galileo E1 + E5b and BeiDou
//!   B1I + B2I; the base 5 km north, 2 km east, 20 m above the car's start;
//! - `antenna_truth.csv` (`t_s,tag_s,x_m,y_m,z_m`: true time, receiver
//!   stamp, ECEF antenna position [m]);
//! - `imu.csv` and the other files of [`crate::output::write_run`]: the car
//!   of [`crate::platform`] (static start, consumer MEMS, consumer GNSS
//!   grade for its loosely coupled files);
//! - `rtk.toml`: the `navfuse run` configuration (RTK coupling, the
//!   simulated lever arm, `.nav` + `.pos` output, no smoother).

use crate::multi_gnss::constellations;
use crate::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
use crate::rtk_scene::{offset_position, simulate_rtk, RtkScene, RtkSceneConfig, SceneSat};
use crate::{SimError, SimRun};
use navfuse_core::Vec3;
use navfuse_io::rinex::NavData;
use navfuse_io::rinex_nav3::GnssEph;
use std::fmt::Write as _;
use std::path::Path;

/// What to simulate.
#[derive(Clone, Copy, Debug)]
pub struct RtkCarOptions {
    pub seed: u64,
    /// Drive length [s] (≥ 10); GNSS epochs at whole seconds 1 … ⌊length⌋ − 2.
    pub duration_s: f64,
    /// Rover cycle slips per satellite-frequency and epoch
    /// ([`RtkSceneConfig::slip_rate_per_epoch`]).
    pub slip_rate: f64,
    /// Galileo and BeiDou beside GPS.
    pub multi_gnss: bool,
    /// What moves ([`Platform::Car`] in the example and the run tests).
    pub platform: Platform,
    /// The `[filter] platform` written into `rtk.toml` (`None`: no line,
    /// `navfuse run`'s default of no motion constraints).
    pub profile: Option<Platform>,
}

/// What was written, for the caller's checks.
pub struct RtkCar {
    pub sim: SimRun,
    pub scene: RtkScene,
    /// The base's ECEF position [m].
    pub base_e: Vec3,
}

/// `rover.obs`, `base.obs`, `nav.rnx` and `antenna_truth.csv` of a scene
/// into `dir` (created).
pub fn write_scene(
    dir: &Path,
    sc: &RtkScene,
    nav_gps: &NavData,
    nav_other: &[GnssEph],
) -> Result<(), SimError> {
    let (rover_text, base_text) = sc.obs_texts();
    let mut truth = String::from("t_s,tag_s,x_m,y_m,z_m\n");
    for (ep, p) in sc.rover.iter().zip(&sc.rover_pos_e) {
        let _ = writeln!(
            truth,
            "{:.7},{:.9},{:.4},{:.4},{:.4}",
            ep.t, ep.epoch.t, p.x, p.y, p.z
        );
    }
    std::fs::create_dir_all(dir).map_err(|e| SimError::Io(format!("{}: {e}", dir.display())))?;
    for (name, text) in [
        ("rover.obs", rover_text),
        ("base.obs", base_text),
        (
            "nav.rnx",
            navfuse_io::rinex_write::nav3_text(nav_gps, nav_other),
        ),
        ("antenna_truth.csv", truth),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| SimError::Io(format!("{}: {e}", p.display())))?;
    }
    Ok(())
}

/// Simulate the car and its RTK scene and write every file of the module
/// documentation into `dir`.
pub fn write_rtk_car(dir: &Path, o: &RtkCarOptions) -> Result<RtkCar, SimError> {
    if o.duration_s.is_nan() || o.duration_s < 10.0 {
        return Err(SimError::Scenario(format!(
            "duration {} s: must be ≥ 10",
            o.duration_s
        )));
    }
    let opts = PlatformOptions {
        duration_s: o.duration_s,
        static_start: true,
        imu: ImuGrade::Consumer,
        gnss: GnssGrade::Consumer,
        ..Default::default()
    };
    let sim = platform_run(o.platform, o.seed, &opts)?.run;
    let t0 = sim.traj.truth[0].t;
    let lever = Vec3::from(sim.scenario.gnss.lever_arm_m);
    let traj = &sim.traj;
    // Antenna position and velocity (ECEF) from the true IMU trajectory.
    let antenna = |t: f64| traj.antenna_ecef(t, &lever);
    // Broadcast records with t_oe before the start, on the 960 s grid.
    let t_oe = ((t0 - 1.0) / 960.0).floor() * 960.0;
    let (nav_gps, all_other) = constellations(t_oe, o.seed);
    let nav_other = if o.multi_gnss { all_other } else { Vec::new() };
    let sats = SceneSat::from_broadcast(&nav_gps, &nav_other);
    let base_e = offset_position(&antenna(t0).0, 5000.0, 2000.0, 20.0);
    let mut cfg = RtkSceneConfig::default();
    cfg.raw.seed = o.seed * 7919 + 17;
    cfg.slip_rate_per_epoch = o.slip_rate;
    let times: Vec<f64> = (1..o.duration_s as usize - 1)
        .map(|k| t0 + k as f64)
        .collect();
    let scene = simulate_rtk(&cfg, &sats, &times, antenna, base_e);
    crate::output::write_run(&sim, dir)?;
    write_scene(dir, &scene, &nav_gps, &nav_other)?;
    let toml = format!(
        "formats = [\"nav\", \"pos\"]\n\
         [input]\nimu = \"imu.csv\"\nimu_rate = {}\ngnss = \"rover.obs\"\nnav = \"nav.rnx\"\n\
         base = \"base.obs\"\n\
         {}[filter]\n{}imu_preset = \"{}\"\nlever_arm = [{}, {}, {}]\ncoupling = \"rtk\"\nsmooth = false\n",
        sim.scenario.imu.rate_hz,
        crate::output::IMU_CSV_TOML,
        o.profile
            .map_or(String::new(), |p| format!("platform = \"{p}\"\n")),
        ImuGrade::Consumer.preset(),
        lever.x,
        lever.y,
        lever.z
    );
    let p = dir.join("rtk.toml");
    std::fs::write(&p, toml).map_err(|e| SimError::Io(format!("{}: {e}", p.display())))?;
    Ok(RtkCar { sim, scene, base_e })
}
