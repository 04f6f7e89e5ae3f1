//! `navfuse.Eskf`: the 21-state ESKF of navfuse-core driven from Python,
//! one sample at a time (`push_imu`, `push_gnss`) or a whole recording at
//! once (`process`, the GIL released), configured from a KF-GINS YAML
//! (model, noise, initial state and its σ, start/end time).
//!
//! Frames: IMU increments body FRD; fixes at the antenna, lat/lon [deg] in
//! and out (radians inside); velocities NED; GPS time (or TOW) in seconds.

use crate::tables::{self, gnss_from, imu_from, Table};
use crate::{err, stats_json};
use navfuse_core::estimators::eskf::Eskf as CoreEskf;
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::PathBuf;

/// Streaming ESKF (KF-GINS model, navfuse-core) — see the Python docstring.
#[pyclass(module = "navfuse._navfuse")]
pub struct Eskf {
    eskf: CoreEskf,
    /// First IMU stamp processed by `process` [s] (KF-GINS `starttime`).
    start: f64,
    /// Last IMU stamp processed by `process` [s] (`endtime`, ∞ when −1).
    end: f64,
    /// Nominal IMU rate [Hz]: the first sample's `dt` when none is given.
    rate_hz: f64,
    /// Stamp of the last IMU sample pushed (for `dt` when none is given).
    last_imu_t: Option<f64>,
}

impl Eskf {
    fn push_sample(&mut self, s: ImuSample) -> Option<NavSolution> {
        self.last_imu_t = Some(s.t);
        self.eskf.push(&Event::Imu(s))
    }
}

#[pymethods]
impl Eskf {
    /// `Eskf(yaml, enhanced=False)`: the model, noise, initial state and
    /// start/end time of a KF-GINS YAML; `enhanced` adds the `car` profile
    /// (NHC, ZUPT/ZARU, χ² gating) as `navfuse kf-gins --enhanced` does.
    #[new]
    #[pyo3(signature = (yaml, enhanced = false))]
    fn new(yaml: PathBuf, enhanced: bool) -> PyResult<Self> {
        let cfg = KfGinsConfig::load(&yaml).map_err(err)?;
        let mut ecfg = cfg.eskf_config();
        if enhanced {
            ecfg = navfuse_pipeline::kf_gins::enhanced(ecfg);
        }
        let eskf = CoreEskf::new(ecfg, cfg.init_nav(), cfg.init_errors(), &cfg.init_std());
        Ok(Eskf {
            eskf,
            start: cfg.starttime,
            end: if cfg.endtime < 0.0 {
                f64::INFINITY
            } else {
                cfg.endtime
            },
            rate_hz: cfg.imudatarate,
            last_imu_t: None,
        })
    }

    /// One IMU sample: stamp `t` [s], angle increment `dtheta_b` [rad] and
    /// velocity increment `dvel_b` [m/s] over `(t − dt, t]`, body FRD. `dt`
    /// defaults to the time since the last sample (the first: 1/rate).
    /// Returns the solution row (`SOLUTION_COLUMNS`) or None.
    #[pyo3(signature = (t, dtheta_b, dvel_b, dt = None))]
    fn push_imu(
        &mut self,
        t: f64,
        dtheta_b: [f64; 3],
        dvel_b: [f64; 3],
        dt: Option<f64>,
    ) -> Option<[f64; 19]> {
        let dt = dt.unwrap_or_else(|| match self.last_imu_t {
            Some(p) => t - p,
            None => 1.0 / self.rate_hz,
        });
        let s = ImuSample {
            t,
            dt,
            dtheta_b: Vec3::from(dtheta_b),
            dvel_b: Vec3::from(dvel_b),
        };
        self.push_sample(s).map(|s| tables::solution_row(&s))
    }

    /// One GNSS fix at the antenna: `t` [s], `lat_deg`, `lon_deg`, `h_m`,
    /// 1-σ NED `std_ned_m` [m]; optional NED velocity [m/s] and its 1-σ.
    #[pyo3(signature = (t, lat_deg, lon_deg, h_m, std_ned_m, v_n_mps = None, std_v_n_mps = None))]
    #[allow(clippy::too_many_arguments)]
    fn push_gnss(
        &mut self,
        t: f64,
        lat_deg: f64,
        lon_deg: f64,
        h_m: f64,
        std_ned_m: [f64; 3],
        v_n_mps: Option<[f64; 3]>,
        std_v_n_mps: Option<[f64; 3]>,
    ) {
        let f = GnssFix {
            t,
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
            h: h_m,
            std_ned: Vec3::from(std_ned_m),
            v_n: v_n_mps.map(Vec3::from),
            std_v_n: std_v_n_mps.map(Vec3::from),
            quality: 0,
            num_sats: 0,
        };
        self.eskf.push(&Event::Gnss(f));
    }

    /// Batch run on tables (row-major float64 bytes, `ncols` columns): IMU
    /// rows from the first at/after the start time to the end time, each fix
    /// after the start handed over before the first IMU sample with
    /// `t_imu + 1 ms ≥ t_fix` (KF-GINS's order, as `navfuse kf-gins`).
    /// Returns the solution table bytes. The GIL is released meanwhile.
    fn _process<'py>(
        &mut self,
        py: Python<'py>,
        imu: &[u8],
        imu_cols: usize,
        gnss: &[u8],
        gnss_cols: usize,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let imu = imu_from(
            &Table {
                name: "imu",
                data: imu,
                ncols: imu_cols,
            },
            self.rate_hz,
        )
        .map_err(err)?;
        let gnss = gnss_from(&Table {
            name: "gnss",
            data: gnss,
            ncols: gnss_cols,
        })
        .map_err(err)?;
        let sols = py.allow_threads(|| {
            let i0 = imu.partition_point(|s| s.t < self.start);
            let mut g = gnss.partition_point(|f| f.t <= self.start);
            let mut sols = Vec::with_capacity(imu.len() - i0);
            for s in &imu[i0..] {
                if s.t > self.end {
                    break;
                }
                while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
                    self.eskf.push(&Event::Gnss(gnss[g]));
                    g += 1;
                }
                if let Some(sol) = self.push_sample(*s) {
                    sols.push(sol);
                }
            }
            tables::solutions_bytes(&sols)
        });
        Ok(PyBytes::new(py, &sols))
    }

    /// The update counters as a JSON object text.
    fn _stats(&self) -> String {
        stats_json(self.eskf.stats()).to_string()
    }
}
