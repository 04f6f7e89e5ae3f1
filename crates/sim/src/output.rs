//! Writers for a simulated run. The truth `.nav` goes through navfuse-io's
//! [`KfGinsNavWriter`]; navfuse-io has no IMU/GNSS *writers* yet, so the
//! KF-GINS IMU and GNSS text files are written here in the formats its
//! readers (and KF-GINS) read.
//!
//! Files in the output folder:
//! - `imu.txt` KF-GINS IMU: `tow  dθx dθy dθz [rad]  dvx dvy dvz [m/s]` (FRD)
//! - `imu_ideal.txt` the same without errors
//! - `imu.csv` time, dt, increments and average rates (Δ/dt) with a header
//! - `gnss.txt` KF-GINS GNSS: `tow lat lon [deg] h [m] σN σE σD [m]`
//! - `gnss.csv` the fixes with NED velocity and its σ
//! - `truth.nav` KF-GINS navigation result: `week tow lat lon h vN vE vD roll pitch yaw [deg]`
//! - `truth.csv` truth with instantaneous ideal rates ω_ib^b, f^b
//! - `run.toml` the scenario, seed and sensor specs (enough to reproduce the run)
//!
//! Numbers are printed with fixed formats, so output bytes depend only on
//! the values (same scenario + seed → identical files).

use crate::{SimError, SimRun};
use navfuse_core::NavSolution;
use navfuse_io::time::week_tow;
use navfuse_io::writers::{KfGinsNavWriter, TrajectoryWriter};
use std::fmt::Write as _;
use std::path::Path;

const R2D: f64 = 180.0 / core::f64::consts::PI;

fn write(dir: &Path, name: &str, text: &str) -> Result<(), SimError> {
    let p = dir.join(name);
    navfuse_io::atomic::write_atomic(&p, text)
        .map_err(|e| SimError::Io(format!("{}: {e}", p.display())))
}

fn imu_txt(s: &[navfuse_core::ImuSample]) -> String {
    let mut o = String::with_capacity(s.len() * 120);
    for x in s {
        let (_, tow) = week_tow(x.t);
        let _ = writeln!(
            o,
            "{:.6} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e}",
            tow, x.dtheta_b.x, x.dtheta_b.y, x.dtheta_b.z, x.dvel_b.x, x.dvel_b.y, x.dvel_b.z
        );
    }
    o
}

/// Write every output file of `run` into `dir` (created if missing).
/// The `[input.csv]` table of a `navfuse run` configuration that reads the
/// `imu.csv` of [`write_run`] (its column names, GPS-seconds time base,
/// increments in rad and m/s).
pub const IMU_CSV_TOML: &str = "[input.csv]\ntime = \"t_gps_s\"\ntime_base = \"gps_seconds\"\n\
     gyro = [\"dtheta_x_rad\", \"dtheta_y_rad\", \"dtheta_z_rad\"]\n\
     accel = [\"dvel_x_m_s\", \"dvel_y_m_s\", \"dvel_z_m_s\"]\n\
     gyro_unit = \"rad\"\naccel_unit = \"m/s2\"\nform = \"increment\"\n";

pub fn write_run(run: &SimRun, dir: &Path) -> Result<(), SimError> {
    std::fs::create_dir_all(dir).map_err(|e| SimError::Io(format!("{}: {e}", dir.display())))?;
    write(dir, "imu.txt", &imu_txt(&run.imu))?;
    write(dir, "imu_ideal.txt", &imu_txt(&run.traj.imu))?;

    let mut o = String::from(
        "t_gps_s,dt_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dvel_x_m_s,dvel_y_m_s,dvel_z_m_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,accel_x_m_s2,accel_y_m_s2,accel_z_m_s2\n",
    );
    for x in &run.imu {
        let w = x.dtheta_b / x.dt;
        let f = x.dvel_b / x.dt;
        let _ = writeln!(
            o,
            "{:.6},{:.6},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e}",
            x.t, x.dt, x.dtheta_b.x, x.dtheta_b.y, x.dtheta_b.z, x.dvel_b.x, x.dvel_b.y, x.dvel_b.z,
            w.x, w.y, w.z, f.x, f.y, f.z
        );
    }
    write(dir, "imu.csv", &o)?;

    let mut txt = String::new();
    let mut csv = String::from(
        "t_gps_s,lat_deg,lon_deg,h_m,std_n_m,std_e_m,std_d_m,vn_m_s,ve_m_s,vd_m_s,std_vn_m_s,std_ve_m_s,std_vd_m_s\n",
    );
    for g in &run.gnss {
        let (_, tow) = week_tow(g.t);
        let _ = writeln!(
            txt,
            "{:.6} {:.11} {:.11} {:.4} {:.4} {:.4} {:.4}",
            tow,
            g.lat * R2D,
            g.lon * R2D,
            g.h,
            g.std_ned.x,
            g.std_ned.y,
            g.std_ned.z
        );
        let (v, sv) = match (g.v_n, g.std_v_n) {
            (Some(v), Some(s)) => (
                format!("{:.5},{:.5},{:.5}", v.x, v.y, v.z),
                format!("{:.5},{:.5},{:.5}", s.x, s.y, s.z),
            ),
            _ => (",,".into(), ",,".into()),
        };
        let _ = writeln!(
            csv,
            "{:.6},{:.11},{:.11},{:.4},{:.4},{:.4},{:.4},{v},{sv}",
            g.t,
            g.lat * R2D,
            g.lon * R2D,
            g.h,
            g.std_ned.x,
            g.std_ned.y,
            g.std_ned.z
        );
    }
    write(dir, "gnss.txt", &txt)?;
    write(dir, "gnss.csv", &csv)?;

    let nav_path = dir.join("truth.nav");
    let nav_err = |e: std::io::Error| SimError::Io(format!("{}: {e}", nav_path.display()));
    let mut nav_file = navfuse_io::atomic::AtomicFile::create(&nav_path).map_err(nav_err)?;
    let mut nav = KfGinsNavWriter::new(&mut nav_file);
    let mut csv = String::from(
        "t_gps_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg,w_ib_x_rad_s,w_ib_y_rad_s,w_ib_z_rad_s,f_x_m_s2,f_y_m_s2,f_z_m_s2\n",
    );
    for x in &run.traj.truth {
        nav.write(&NavSolution {
            t: x.t,
            lat: x.lat,
            lon: x.lon,
            h: x.h,
            v_n: x.v_n,
            rpy: x.rpy,
            ..NavSolution::unknown_at(x.t)
        })
        .map_err(nav_err)?;
        let _ = writeln!(
            csv,
            "{:.6},{:.11},{:.11},{:.5},{:.6},{:.6},{:.6},{:.8},{:.8},{:.8},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e},{:.12e}",
            x.t, x.lat * R2D, x.lon * R2D, x.h, x.v_n.x, x.v_n.y, x.v_n.z,
            x.rpy.x * R2D, x.rpy.y * R2D, x.rpy.z * R2D,
            x.w_ib_b.x, x.w_ib_b.y, x.w_ib_b.z, x.f_b.x, x.f_b.y, x.f_b.z
        );
    }
    nav.finish().map_err(nav_err)?;
    nav_file.commit().map_err(nav_err)?;
    write(dir, "truth.csv", &csv)?;

    #[derive(serde::Serialize)]
    struct Meta<'a> {
        seed: u64,
        imu_spec: &'a crate::imu_model::ImuSpec,
        gnss_spec: &'a crate::gnss_model::GnssSpec,
        scenario: &'a crate::Scenario,
    }
    let meta = toml::to_string(&Meta {
        seed: run.seed,
        imu_spec: &run.imu_spec,
        gnss_spec: &run.gnss_spec,
        scenario: &run.scenario,
    })
    .map_err(|e| SimError::Io(format!("run.toml: {e}")))?;
    write(
        dir,
        "run.toml",
        &format!("# navfuse sim: scenario, seed and sensor specs of this run\n{meta}"),
    )
}
