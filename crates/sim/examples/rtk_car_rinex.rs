//! A simulated car with an IMU and a dual-frequency multi-GNSS rover + base
//! pair, written as the files `navfuse run` (`coupling = "rtk"`), `navfuse
//! baseline` and RTKLIB `rnx2rtkp` read (issue 15, must-show 4, the speed
//! comparison of `tools/rtk_speed.sh`):
//! - `OUT/rover.obs`, `OUT/base.obs` (RINEX 3.04; the base's true position
//!   in its header), `OUT/nav.rnx` (the broadcast GPS, Galileo, BeiDou
//!   records that generated the scene): [`navfuse_sim::rtk_scene`] at 1 Hz,
//!   GPS L1 C/A + L2C, Galileo E1 + E5b, BeiDou B1I + B2I, default error
//!   model, no cycle slips, the base 5 km north, 2 km east, 20 m above the
//!   car's start;
//! - `OUT/imu.csv` (+ `imu.txt`, `gnss.*`, `truth.*` of
//!   [`navfuse_sim::output::write_run`]): the car of
//!   [`navfuse_sim::platform`] (static start, consumer MEMS, 100 Hz);
//! - `OUT/rtk.toml`: the `navfuse run` configuration (RTK coupling, its
//!   lever arm, `.pos` output, no smoother).
//!
//! The scene is the one of the pipeline test
//! `simulated_car_rtk_run_fixes_and_writes_quality` with Galileo and BeiDou
//! added and the length chosen here (nothing tuned on results).
//! Usage: cargo run --release -p navfuse-sim --example rtk_car_rinex -- OUT [SEED] [SECONDS]

use navfuse_core::Vec3;
use navfuse_sim::multi_gnss::constellations;
use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
use navfuse_sim::rtk_scene::{offset_position, simulate_rtk, RtkSceneConfig, SceneSat};
use std::fmt::Write as _;

fn arg<T: std::str::FromStr>(a: Option<String>, default: T, name: &str) -> T
where
    T::Err: std::fmt::Display,
{
    match a.map(|s| s.parse::<T>()) {
        None => default,
        Some(Ok(v)) => v,
        Some(Err(e)) => {
            eprintln!("{name}: {e}");
            std::process::exit(2);
        }
    }
}

fn fail(what: &str, e: impl std::fmt::Display) -> ! {
    eprintln!("{what}: {e}");
    std::process::exit(1);
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else {
        eprintln!("usage: rtk_car_rinex OUT_DIR [SEED] [SECONDS]");
        std::process::exit(2);
    };
    let seed: u64 = arg(args.next(), 1, "SEED");
    let duration: f64 = arg(args.next(), 3600.0, "SECONDS");
    if duration.is_nan() || duration < 10.0 {
        fail("SECONDS", "must be ≥ 10");
    }
    let dir = std::path::Path::new(&out);
    let opts = PlatformOptions {
        duration_s: duration,
        static_start: true,
        imu: ImuGrade::Consumer,
        gnss: GnssGrade::Consumer,
        ..Default::default()
    };
    let sim = platform_run(Platform::Car, seed, &opts)
        .unwrap_or_else(|e| fail("platform", e))
        .run;
    let t0 = sim.traj.truth[0].t;
    let lever = Vec3::from(sim.scenario.gnss.lever_arm_m);
    let traj = &sim.traj;
    // Antenna position and velocity (ECEF) from the true IMU trajectory.
    let antenna = |t: f64| traj.antenna_ecef(t, &lever);
    let t_oe = ((t0 - 1.0) / 960.0).floor() * 960.0;
    let (nav_gps, nav_other) = constellations(t_oe, seed);
    let sats = SceneSat::from_broadcast(&nav_gps, &nav_other);
    let base = offset_position(&antenna(t0).0, 5000.0, 2000.0, 20.0);
    let mut cfg = RtkSceneConfig::default();
    cfg.raw.seed = seed * 7919 + 17;
    let times: Vec<f64> = (1..duration as usize - 1).map(|k| t0 + k as f64).collect();
    let sc = simulate_rtk(&cfg, &sats, &times, antenna, base);
    let (rover_text, base_text) = sc.obs_texts();
    let mut truth = String::from("t_s,tag_s,x_m,y_m,z_m\n");
    for (ep, p) in sc.rover.iter().zip(&sc.rover_pos_e) {
        let _ = writeln!(
            truth,
            "{:.7},{:.9},{:.4},{:.4},{:.4}",
            ep.t, ep.epoch.t, p.x, p.y, p.z
        );
    }
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        if let Err(e) = std::fs::create_dir_all(dir).and_then(|_| std::fs::write(&p, text)) {
            fail(&p.display().to_string(), e);
        }
    };
    navfuse_sim::output::write_run(&sim, dir).unwrap_or_else(|e| fail("write_run", e));
    write("rover.obs", rover_text);
    write("base.obs", base_text);
    write(
        "nav.rnx",
        navfuse_io::rinex_write::nav3_text(&nav_gps, &nav_other),
    );
    write("antenna_truth.csv", truth);
    write(
        "rtk.toml",
        format!(
            "formats = [\"nav\", \"pos\"]\n\
             [input]\nimu = \"imu.csv\"\nimu_rate = {}\ngnss = \"rover.obs\"\nnav = \"nav.rnx\"\n\
             base = \"base.obs\"\n\
             [input.csv]\ntime = \"t_gps_s\"\ntime_base = \"gps_seconds\"\n\
             gyro = [\"dtheta_x_rad\", \"dtheta_y_rad\", \"dtheta_z_rad\"]\n\
             accel = [\"dvel_x_m_s\", \"dvel_y_m_s\", \"dvel_z_m_s\"]\n\
             gyro_unit = \"rad\"\naccel_unit = \"m/s2\"\nform = \"increment\"\n\
             [filter]\nimu_preset = \"{}\"\nlever_arm = [{}, {}, {}]\ncoupling = \"rtk\"\nsmooth = false\n",
            sim.scenario.imu.rate_hz,
            ImuGrade::Consumer.preset(),
            lever.x,
            lever.y,
            lever.z
        ),
    );
    let recs = |v: &[navfuse_sim::raw_gnss::RawTruthEpoch]| {
        v.iter().map(|e| e.epoch.n).sum::<usize>() as f64 / v.len().max(1) as f64
    };
    println!(
        "{}: {} epochs, {:.1} rover and {:.1} base records per epoch, {} IMU samples, base {:.4} {:.4} {:.4}",
        dir.display(),
        sc.rover.len(),
        recs(&sc.rover),
        recs(&sc.base),
        sim.imu.len(),
        base.x,
        base.y,
        base.z
    );
}
