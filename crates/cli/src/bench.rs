//! `navfuse bench`: ESKF throughput in IMU samples per second, single thread,
//! covariance propagated every sample (21 states, the KF-GINS model), GNSS
//! position updates at their real epochs.
//!
//! Input: the drive_0708 KF-GINS configuration (IMU + 1 Hz GNSS) repeated —
//! the filter restarts each lap — until at least `--hours` of IMU data have
//! been processed. Without the data, a synthetic static 100 Hz stream with
//! 1 Hz fixes is used. Reports wall-clock and on-CPU time (Linux
//! `/proc/thread-self/schedstat`, so other processes on a busy machine do
//! not count against the filter).

use clap::Args as ClapArgs;
use navfuse_core::earth;
use navfuse_core::estimators::eskf::Eskf;
use navfuse_core::ins::mech::NavState;
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use navfuse_pipeline::kfgins_input::RunInput;
use std::path::PathBuf;
use std::time::Instant;

/// Measure estimator throughput (IMU samples per second).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// KF-GINS YAML giving the data (default: drive_0708 full, from $NAVFUSE_DATA).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Hours of IMU data to process (the input is repeated).
    #[arg(long, default_value_t = 1.0)]
    pub hours: f64,
    /// Use the synthetic static stream even if the data is present.
    #[arg(long)]
    pub synthetic: bool,
}

/// On-CPU time of this thread [s] (Linux schedstat), if available.
pub fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn synthetic() -> (KfGinsConfig, RunInput) {
    let yaml = r#"
imupath: "-"
gnsspath: "-"
outputpath: "-"
starttime: 0
endtime: -1
initpos: [ 40.0, -105.0, 1600.0 ]
initvel: [ 0, 0, 0 ]
initatt: [ 0, 0, 30 ]
initposstd: [ 0.05, 0.05, 0.05 ]
initvelstd: [ 0.05, 0.05, 0.05 ]
initattstd: [ 1.0, 1.0, 5.0 ]
imunoise:
  arw: [ 8.0, 8.0, 8.0 ]
  vrw: [ 1.0, 1.0, 1.0 ]
  gbstd: [ 5.8, 5.8, 5.8 ]
  abstd: [ 291.0, 291.0, 291.0 ]
  gsstd: [ 1000.0, 1000.0, 1000.0 ]
  asstd: [ 1000.0, 1000.0, 1000.0 ]
  corrtime: 1.0
antlever: [ 0, -0.05, 0 ]
"#;
    let cfg = KfGinsConfig::parse(yaml, "<synthetic>").expect("built-in config");
    let nav: NavState = cfg.init_nav();
    let c_nb = nav.c_bn().transpose();
    let dt = 0.01;
    let w = c_nb * earth::omega_ie_n(nav.lat) * dt;
    let f = c_nb * (-earth::gravity_n(nav.lat, nav.h)) * dt;
    let n = 60_000;
    let imu = (0..n)
        .map(|k| {
            // A small deterministic wobble so the numbers are not all equal.
            let s = ((k as f64) * 0.37).sin() * 1e-6;
            ImuSample {
                t: (k + 1) as f64 * dt,
                dt,
                dtheta_b: w + Vec3::new(s, -s, s),
                dvel_b: f + Vec3::new(-s, s, s),
            }
        })
        .collect();
    let gnss = (1..(n / 100))
        .map(|k| GnssFix {
            t: k as f64 + 0.005,
            lat: nav.lat,
            lon: nav.lon,
            h: nav.h,
            std_ned: Vec3::repeat(0.02),
            ..Default::default()
        })
        .collect();
    (cfg, RunInput { imu, gnss })
}

pub fn run(args: Args) -> Result<(), String> {
    let (cfg, input, what) = if args.synthetic {
        let (c, i) = synthetic();
        (c, i, "synthetic static stream".to_string())
    } else {
        let path = match &args.config {
            Some(p) => Some(p.clone()),
            None => {
                let p = navfuse_io::data::data_dir().join("drive_0708/kfgins/kf-gins_full.yaml");
                p.exists().then_some(p)
            }
        };
        match path {
            Some(p) => {
                let c = KfGinsConfig::load(&p)?;
                let i =
                    navfuse_pipeline::kfgins_input::read_kfgins(&c).map_err(|e| e.to_string())?;
                (c, i, p.display().to_string())
            }
            None => {
                let (c, i) = synthetic();
                (
                    c,
                    i,
                    "synthetic static stream (drive_0708 not found)".to_string(),
                )
            }
        }
    };
    let i0 = input.imu.partition_point(|s| s.t < cfg.starttime);
    let imu = &input.imu[i0..];
    let lap_seconds: f64 = imu.iter().map(|s| s.dt).sum();
    if imu.is_empty() || lap_seconds <= 0.0 {
        return Err("no IMU samples after the start time".into());
    }
    let laps = ((args.hours * 3600.0) / lap_seconds).ceil().max(1.0) as usize;
    let ecfg = cfg.eskf_config();
    let (nav, err, std) = (cfg.init_nav(), cfg.init_errors(), cfg.init_std());
    let mut samples = 0u64;
    let mut sink = 0.0;
    let cpu0 = thread_cpu_seconds();
    let wall0 = Instant::now();
    for _ in 0..laps {
        let mut f = Eskf::new(ecfg, nav, err, &std);
        let mut g = input.gnss.partition_point(|x| x.t <= cfg.starttime);
        for s in imu {
            while g < input.gnss.len() && input.gnss[g].t <= s.t + 1e-3 {
                f.push(&Event::Gnss(input.gnss[g]));
                g += 1;
            }
            if let Some(sol) = f.push(&Event::Imu(*s)) {
                sink += sol.h;
            }
            samples += 1;
        }
    }
    let wall = wall0.elapsed().as_secs_f64();
    let cpu = match (cpu0, thread_cpu_seconds()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    println!("input: {what}");
    println!(
        "ESKF (21 states, covariance propagated every sample, GNSS position updates): {samples} IMU samples = {:.2} h of data in {laps} laps",
        samples as f64 * lap_seconds / imu.len() as f64 / 3600.0
    );
    println!(
        "wall: {wall:.3} s -> {:.0} samples/s",
        samples as f64 / wall
    );
    if let Some(c) = cpu {
        println!(
            "on-CPU: {c:.3} s -> {:.0} samples/s ({:.3} µs/sample)",
            samples as f64 / c,
            c / samples as f64 * 1e6
        );
    }
    if !sink.is_finite() {
        return Err("filter produced a non-finite height".into());
    }
    Ok(())
}
