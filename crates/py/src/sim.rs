//! `navfuse.simulate`: navfuse-sim's platform generator (car, robot,
//! pedestrian, uav drawn from a seed) or a scenario TOML file, returned as
//! tables: measured IMU (body FRD increments), GNSS fixes (antenna) and the
//! truth (IMU point, lat/lon [deg], NED velocity, roll/pitch/yaw [deg]).

use crate::err;
use crate::tables::{gnss_bytes, imu_bytes, solutions_bytes};
use navfuse_core::{NavSolution, Vec3};
use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
use navfuse_sim::trajectory::TruthEpoch;
use navfuse_sim::{simulate as sim_run, Scenario};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::Path;

fn truth_solution(e: &TruthEpoch) -> NavSolution {
    NavSolution {
        t: e.t,
        lat: e.lat,
        lon: e.lon,
        h: e.h,
        v_n: e.v_n,
        rpy: e.rpy,
        std_pos_ned: Vec3::zeros(),
        std_v_n: Vec3::zeros(),
        std_rpy: Vec3::zeros(),
    }
}

/// Simulate `scenario` (a platform name — `car`, `robot`, `pedestrian`,
/// `uav` — or a scenario TOML path) with `seed`. Platform options: duration
/// [s], IMU grade (`consumer`, `industrial`, `tactical`), GNSS grade
/// (`rtk`, `consumer`), static start, IMU time offset τ [s]. Returns a dict:
/// `imu`, `gnss`, `truth` (table bytes), `outages` (`[start, end)` GPS s),
/// `description`, `imu_rate_hz`, `imu_time_offset_s`, `lever_arm_m` (GNSS
/// antenna, body FRD [m]), `imu_preset`.
#[pyfunction]
#[pyo3(signature = (scenario, seed, duration_s = 600.0, imu_grade = None, gnss_grade = None, static_start = true, imu_time_offset_s = 0.0))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    scenario: &str,
    seed: u64,
    duration_s: f64,
    imu_grade: Option<&str>,
    gnss_grade: Option<&str>,
    static_start: bool,
    imu_time_offset_s: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (run, outages, rate, tau) = match scenario.parse::<Platform>() {
        Ok(p) => {
            let mut opt = PlatformOptions {
                duration_s,
                static_start,
                imu_time_offset_s,
                ..Default::default()
            };
            if let Some(g) = imu_grade {
                opt.imu = g.parse::<ImuGrade>().map_err(err)?;
            }
            if let Some(g) = gnss_grade {
                opt.gnss = g.parse::<GnssGrade>().map_err(err)?;
            }
            let r = py
                .allow_threads(|| platform_run(p, seed, &opt))
                .map_err(err)?;
            (r.run, r.outages, opt.imu_rate_hz, r.imu_time_offset_s)
        }
        Err(_) if scenario.ends_with(".toml") => {
            let sc = Scenario::from_file(Path::new(scenario)).map_err(err)?;
            let r = py
                .allow_threads(|| sim_run(&sc, seed, None, None))
                .map_err(err)?;
            let t0 = r.traj.truth[0].t;
            let o = sc
                .gnss
                .outages
                .iter()
                .map(|w| [t0 + w[0], t0 + w[1]])
                .collect();
            (r, o, sc.imu.rate_hz, 0.0)
        }
        Err(e) => {
            return Err(err(format!(
                "scenario {scenario:?}: {e}, and not a scenario .toml file"
            )))
        }
    };
    let truth: Vec<NavSolution> = run.traj.truth.iter().map(truth_solution).collect();
    d.set_item("imu", PyBytes::new(py, &imu_bytes(&run.imu)))?;
    d.set_item("gnss", PyBytes::new(py, &gnss_bytes(&run.gnss)))?;
    d.set_item("truth", PyBytes::new(py, &solutions_bytes(&truth)))?;
    d.set_item(
        "outages",
        outages.iter().map(|w| (w[0], w[1])).collect::<Vec<_>>(),
    )?;
    d.set_item("description", run.scenario.description.clone())?;
    d.set_item("imu_rate_hz", rate)?;
    d.set_item("imu_time_offset_s", tau)?;
    d.set_item("lever_arm_m", run.scenario.gnss.lever_arm_m)?;
    d.set_item("imu_preset", run.scenario.imu.preset.clone())?;
    Ok(d)
}
