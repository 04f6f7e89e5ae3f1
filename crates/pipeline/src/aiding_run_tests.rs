//! Issue 17 plumbing: a simulated UBX log (ESF-RAW IMU + wheel ticks,
//! NAV-PVT, NAV-RELPOSNED from `navfuse_sim::ubx_out`) through
//! [`crate::run::run`] with a GNSS outage: the odometer and baseline
//! heading reach the ESKF (counters > 0) and bound the outage drift better
//! than the same run with both turned off. The same for a wheel-speed CSV
//! (`[input] odometer`, [`crate::odo_input`]).

use crate::config::RunConfig;
use crate::run::{run, RunOptions};
use navfuse_sim::{simulate, Scenario};

const SCENARIO: &str = r#"
name = "ubx_aiding"
description = "car: static, accelerate, cruise, two turns"
[start]
lat_deg = 40.0
lon_deg = -105.0
h_m = 1600.0
rpy_deg = [0.0, 0.0, 30.0]
[imu]
preset = "3dm-gx3-35"
rate_hz = 100
substeps = 4
[gnss]
preset = "consumer-1hz"
[[segment]]
type = "hold"
duration_s = 20
[[segment]]
type = "accelerate"
speed_kmh = 40
[[segment]]
type = "cruise"
duration_s = 30
[[segment]]
type = "turn"
rate_deg_s = 10
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 20
[[segment]]
type = "turn"
rate_deg_s = -10
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 40
"#;

/// The scenario simulated with seed 7 and written to `dir/log.ubx`.
fn ubx_drive(dir: &std::path::Path) -> navfuse_sim::SimRun {
    let sc = Scenario::from_toml(SCENARIO, "ubx_aiding").unwrap();
    let sim = simulate(&sc, 7, None, None).unwrap();
    navfuse_sim::ubx_out::write_ubx(&sim, &dir.join("log.ubx"), 0.02).unwrap();
    sim
}

#[test]
fn ubx_odometer_and_heading_reach_the_eskf_and_bound_the_outage_drift() {
    let dir = crate::test_dir("ubx-aiding");
    let sim = ubx_drive(&dir);
    let truth = &sim.traj.truth;
    // A 40 s outage from 60 s on (through the first turn).
    let base = "[input]\nubx = \"log.ubx\"\nubx_metres_per_tick = 0.02\n[filter]\n\
                platform = \"car\"\nimu_preset = \"3dm-gx3-35\"\n\
                [outage]\nstart = 60.0\nlength = 40.0\nperiod = 1000.0\n";
    let go = |extra: &str, name: &str| {
        let cfg: RunConfig = toml::from_str(&format!("{base}{extra}")).unwrap();
        let opts = RunOptions {
            output: Some(dir.join(name)),
            ..Default::default()
        };
        let out = run(&cfg, &dir, &opts).unwrap();
        let t0 = out.trajectory[0].t;
        let (rm, rn) = navfuse_core::earth::radii(truth[0].lat);
        let worst = out
            .trajectory
            .iter()
            .filter(|s| s.t >= t0 + 60.0 && s.t < t0 + 100.0)
            .map(|s| {
                let k = truth
                    .partition_point(|e| e.t < s.t - 1e-6)
                    .min(truth.len() - 1);
                let dn = (s.lat - truth[k].lat) * rm;
                let de = (s.lon - truth[k].lon) * rn * truth[k].lat.cos();
                dn.hypot(de)
            })
            .fold(0.0f64, f64::max);
        (out, worst)
    };
    let (on, e_on) = go("", "on");
    let (off, e_off) = go(
        "[filter.odometer]\nenabled = false\n[filter.heading]\nenabled = false\n",
        "off",
    );
    let a = on.stats.unwrap().aiding;
    eprintln!("aided {a:?}: worst outage error {e_on:.2} m; unaided {e_off:.2} m");
    assert!(a.odometer_used > 1000, "{a:?}");
    assert!(a.heading_used > 50, "{a:?}");
    let b = off.stats.unwrap().aiding;
    assert_eq!(b.odometer_used + b.heading_used, 0, "{b:?}");
    assert!(on.summary["filter"]["aiding"]["odometer"].is_object());
    assert!(off.summary["filter"]["aiding"]["odometer"].is_null());
    assert!(
        e_on < 0.5 * e_off,
        "aided {e_on:.2} m, unaided {e_off:.2} m"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Written before the result was seen: the drive's wheel odometer (1 %
/// scale error, 2 cm ticks, 10 Hz, from `navfuse_sim::aiding::wheel_speed`)
/// as a CSV of two rear-wheel cumulative distances, read by column map,
/// reaches the ESKF (counted in summary.json) and halves the worst error of
/// a 40-s outage against the same run without it (baseline heading off in
/// both; the UBX log's wheel ticks rejected for want of a tick scale).
#[test]
fn odometer_csv_reaches_the_eskf_and_bounds_the_outage_drift() {
    use navfuse_sim::aiding::{wheel_speed, WheelSpec};
    let dir = crate::test_dir("odo-csv");
    let sim = ubx_drive(&dir);
    let spec = WheelSpec {
        lever_arm_b: navfuse_core::Vec3::new(-1.0, 0.0, 0.3),
        scale_error: 0.01,
        tick_m: 0.02,
        rate_hz: 10.0,
        noise_mps: 0.0,
        slip_rate_hz: 0.0,
        slip_duration_s: (0.5, 1.0),
        slip_max: 0.0,
    };
    let w = wheel_speed(&sim.traj, &spec, 7);
    // Left and right wheels ±0.4 m apart in their counts: the mean is the axle's.
    let mut csv = String::from("# rear wheels, cumulative metres\nt,odo_rl,odo_rr\n");
    let mut d = 0.0;
    for o in &w {
        d += o.speed_mps * o.dt;
        csv += &format!("{:.4},{:.4},{:.4}\n", o.t, d - 0.4, d + 0.4);
    }
    std::fs::write(dir.join("wheels.csv"), csv).unwrap();
    let truth = &sim.traj.truth;
    let base = "[input]\nubx = \"log.ubx\"\n[filter]\nplatform = \"car\"\n\
                imu_preset = \"3dm-gx3-35\"\n[filter.heading]\nenabled = false\n\
                [outage]\nstart = 60.0\nlength = 40.0\nperiod = 1000.0\n";
    let odo = "[input.odometer_csv]\ntime = \"t\"\nquantity = \"distance\"\n\
               columns = [\"odo_rl\", \"odo_rr\"]\n\
               [filter.odometer]\nlever_arm_m = [-1.0, 0.0, 0.3]\n";
    let go = |extra: &str, name: &str| {
        let text = format!("{base}{extra}");
        // `odometer` belongs in [input]: put it after its header line.
        let text = text.replacen(
            "[input]\n",
            &format!(
                "[input]\n{}",
                if extra.is_empty() {
                    ""
                } else {
                    "odometer = \"wheels.csv\"\n"
                }
            ),
            1,
        );
        let cfg: RunConfig = toml::from_str(&text).unwrap();
        let opts = RunOptions {
            output: Some(dir.join(name)),
            ..Default::default()
        };
        let out = run(&cfg, &dir, &opts).unwrap();
        let t0 = out.trajectory[0].t;
        let (rm, rn) = navfuse_core::earth::radii(truth[0].lat);
        let worst = out
            .trajectory
            .iter()
            .filter(|s| s.t >= t0 + 60.0 && s.t < t0 + 100.0)
            .map(|s| {
                let k = truth
                    .partition_point(|e| e.t < s.t - 1e-6)
                    .min(truth.len() - 1);
                let dn = (s.lat - truth[k].lat) * rm;
                let de = (s.lon - truth[k].lon) * rn * truth[k].lat.cos();
                dn.hypot(de)
            })
            .fold(0.0f64, f64::max);
        (out, worst)
    };
    let (on, e_on) = go(odo, "on");
    let (off, e_off) = go("", "off");
    let a = on.stats.unwrap().aiding;
    let rep = &on.summary["inputs"]["odometer"];
    eprintln!(
        "odometer CSV {a:?}, input {rep}: worst outage error {e_on:.2} m; without {e_off:.2} m"
    );
    assert_eq!(
        rep["records"].as_u64().unwrap() as usize,
        w.len() - 1,
        "{rep}"
    );
    assert!(a.odometer_used > 1000, "{a:?}");
    assert_eq!(off.stats.unwrap().aiding.odometer_used, 0);
    assert!(on.summary["filter"]["aiding"]["odometer"].is_object());
    assert!(e_on < 0.5 * e_off, "with {e_on:.2} m, without {e_off:.2} m");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The drive's dual-antenna heading (1 m fore–aft baseline, 3 mm carrier
/// noise, 1 Hz, from `navfuse_sim::aiding::dual_antenna`) as NMEA HDT after
/// each epoch's GGA/RMC, read by `[input] heading` with the configured σ,
/// reaches the ESKF (counted in summary.json; none without it), and over a
/// 40-s outage the filter's yaw σ stays at the heading's level (below its
/// σ_ψ = 0.24°) while it grows without the heading, with the RMS yaw error
/// inside 2 σ_ψ. The UBX log carries only IMU and NAV-PVT here (the sim's
/// NAV-RELPOSNED would be a second heading source).
///
/// History: the first version compared the yaw error at one instant (the
/// outage end) and used the full UBX log: it failed (0.036° with, 0.008°
/// without, the RELPOSNED headings fused in both); a single instant of a
/// single seed's unaided error can be small by chance, so the σ (which the
/// heading bounds by construction) and the RMS error are asserted instead.
#[test]
fn nmea_heading_reaches_the_eskf_and_holds_yaw_in_an_outage() {
    use navfuse_sim::aiding::{dual_antenna, DualAntennaSpec};
    let dir = crate::test_dir("hdt-input");
    let sc = Scenario::from_toml(SCENARIO, "ubx_aiding").unwrap();
    let sim = simulate(&sc, 11, None, None).unwrap();
    let mut w = navfuse_io::ubx_write::UbxStreamWriter::new(Vec::new(), 0.02);
    for e in sim.events() {
        w.write(&e).unwrap();
    }
    std::fs::write(dir.join("log.ubx"), w.into_inner()).unwrap();
    let spec = DualAntennaSpec {
        baseline_m: 1.0,
        mount_yaw_rad: 0.0,
        mount_pitch_rad: 0.0,
        phase_std_m: 0.003,
        rate_hz: 1.0,
    };
    let heads = dual_antenna(&sim.traj, &spec, 11);
    let sigma_deg = spec.heading_std().to_degrees();
    let mut nmea = Vec::new();
    {
        let mut w = navfuse_io::nmea::NmeaWriter::new(&mut nmea);
        for h in &heads {
            let fix = navfuse_core::types::GnssFix {
                t: h.t,
                lat: 0.7,
                lon: -1.8,
                h: 1600.0,
                std_ned: navfuse_core::Vec3::repeat(1.0),
                quality: 1,
                ..Default::default()
            };
            w.write_fix(&fix).unwrap();
        }
    }
    // Each epoch's HDT right after its sentences (the fix writer ends an epoch with GST).
    let text = String::from_utf8(nmea).unwrap();
    let mut out = String::new();
    let mut k = 0;
    for line in text.lines() {
        out += line;
        out += "\r\n";
        if line.contains("GST") && k < heads.len() {
            let body = format!(
                "GPHDT,{:.3},T",
                heads[k].heading_rad.to_degrees().rem_euclid(360.0)
            );
            out += &format!(
                "${body}*{:02X}\r\n",
                navfuse_io::nmea::checksum(body.as_bytes())
            );
            k += 1;
        }
    }
    assert_eq!(k, heads.len(), "one HDT per epoch");
    std::fs::write(dir.join("hdt.nmea"), out).unwrap();
    let truth = &sim.traj.truth;
    let base = "[filter]\nplatform = \"car\"\nimu_preset = \"3dm-gx3-35\"\n\
                [outage]\nstart = 60.0\nlength = 40.0\nperiod = 1000.0\n";
    let go = |input: &str, name: &str| {
        let cfg: RunConfig =
            toml::from_str(&format!("[input]\nubx = \"log.ubx\"\n{input}{base}")).unwrap();
        let opts = RunOptions {
            output: Some(dir.join(name)),
            ..Default::default()
        };
        let out = run(&cfg, &dir, &opts).unwrap();
        let t0 = out.trajectory[0].t;
        let outage = |t: f64| t >= t0 + 60.0 && t < t0 + 100.0;
        let (mut se, mut n, mut sig_end) = (0.0, 0usize, 0.0);
        for s in out.trajectory.iter().filter(|s| outage(s.t)) {
            let k = truth
                .partition_point(|e| e.t < s.t - 1e-6)
                .min(truth.len() - 1);
            let d = (s.rpy.z - truth[k].rpy.z + std::f64::consts::PI)
                .rem_euclid(2.0 * std::f64::consts::PI)
                - std::f64::consts::PI;
            se += d * d;
            n += 1;
            sig_end = s.std_rpy.z;
        }
        (
            out,
            (se / n as f64).sqrt().to_degrees(),
            sig_end.to_degrees(),
        )
    };
    let (on, e_on, s_on) = go(
        &format!("heading = \"hdt.nmea\"\nheading_sigma_deg = {sigma_deg}\n"),
        "on",
    );
    let (off, e_off, s_off) = go("", "off");
    let a = on.stats.unwrap().aiding;
    let rep = &on.summary["inputs"]["heading"];
    eprintln!(
        "NMEA heading {a:?}, input {rep}: outage yaw RMS error {e_on:.3}° (σ at its end {s_on:.3}°) \
         with, {e_off:.3}° ({s_off:.3}°) without; heading σ {sigma_deg:.3}°"
    );
    assert_eq!(
        rep["records"].as_u64().unwrap() as usize,
        heads.len(),
        "{rep}"
    );
    assert!(a.heading_used > 50, "{a:?}");
    assert_eq!(off.stats.unwrap().aiding.heading_used, 0);
    assert!(
        s_on < sigma_deg && s_on < s_off,
        "σ with {s_on}°, without {s_off}°"
    );
    assert!(
        e_on < 2.0 * sigma_deg,
        "RMS yaw error {e_on}° with the heading"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// An odometer CSV without a usable row (here: only its header) is an error
/// naming the file and the rejections, not a run without odometer.
#[test]
fn odometer_csv_without_usable_rows_is_an_error() {
    let dir = crate::test_dir("odo-csv-empty");
    ubx_drive(&dir);
    std::fs::write(dir.join("wheels.csv"), "t,speed\n").unwrap();
    let text = "[input]\nubx = \"log.ubx\"\nodometer = \"wheels.csv\"\n\
                [filter]\nplatform = \"car\"\nimu_preset = \"3dm-gx3-35\"\n\
                [input.odometer_csv]\ntime = \"t\"\ncolumns = [\"speed\"]\n";
    let cfg: RunConfig = toml::from_str(text).unwrap();
    let Err(err) = run(&cfg, &dir, &RunOptions::default()) else {
        panic!("an odometer file without rows must not run");
    };
    let err = err.to_string();
    assert!(
        err.contains("wheels.csv") && err.contains("no usable odometer rows"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
