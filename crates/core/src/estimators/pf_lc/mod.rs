//! PF-LC: particle-filter GPS compensation + attitude KF + loosely coupled
//! position/velocity KF (seed 002, `SEEDS.md §2`).
//!
//! Pieces (each usable alone):
//! - [`compensation`]: the paper's GPS position compensation (eq. 5–13).
//! - [`sir`]: a bootstrap SIR particle filter, the principled comparator.
//! - [`attitude_kf`]: gyro + accelerometer-tilt attitude KF with HDR/HSR and
//!   SVD re-orthonormalisation (fig. 6).
//! - [`pv_kf`]: position/velocity KF in the TM plane (eq. 16–20).
//! - [`PfLc`]: the combined system as an [`Estimator`], in the "original"
//!   (raw GPS) or "proposed" (compensated GPS) configuration.
//!
//! The plane is the paper's small-area TM plane (eq. 14–15,
//! [`SmallAreaPlane`]) with its origin at the first fix. Horizontal only, as
//! in the paper: the height is the latest GPS height passed through. The
//! GPS antenna–IMU lever arm is neglected (sub-metre against 5 m CEP).

#[allow(unused_imports)]
use crate::prelude::*;

pub mod attitude_kf;
pub mod compensation;
pub mod pv_kf;
pub mod rng;
pub mod sir;

pub use attitude_kf::{AttitudeKf, AttitudeKfConfig};
pub use compensation::{CompensationConfig, Compensator};
pub use pv_kf::{PvKf, PvKfConfig};
pub use sir::{SirConfig, SirPf};

use crate::geodesy::{Geodetic, PlanePoint, SmallAreaPlane};
use crate::types::{Estimator, Event, GnssFix, ImuSample, NavSolution, Vec3};

/// Which GPS positions the position filter uses (the paper's comparison).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpsInput {
    /// "Original" loosely coupled integration: raw fixes (fig. 5).
    Raw,
    /// "Proposed": fixes after the compensation (fig. 6).
    Compensated,
}

/// Configuration of the combined PF-LC estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PfLcConfig {
    pub input: GpsInput,
    pub compensation: CompensationConfig,
    pub attitude: AttitudeKfConfig,
    pub pv: PvKfConfig,
    /// Yaw is initialised from the filter's ground course once the speed
    /// exceeds this [m/s].
    pub yaw_init_speed_m_s: f64,
    /// Course aiding of the yaw (not in the paper; the paper's yaw is gyro +
    /// HDR only): applied at GPS epochs when the speed exceeds
    /// `yaw_init_speed_m_s` and the yaw rate is below this [rad/s]. 0 = off.
    pub course_aiding_max_rate_rad_s: f64,
    /// Feed the IMU acceleration into the position filter (false: the same
    /// filter as a constant-velocity GPS smoother — a diagnostic baseline).
    pub use_imu_accel: bool,
}

impl Default for PfLcConfig {
    fn default() -> Self {
        PfLcConfig {
            input: GpsInput::Compensated,
            compensation: CompensationConfig::default(),
            attitude: AttitudeKfConfig::default(),
            pv: PvKfConfig::default(),
            yaw_init_speed_m_s: 3.0,
            course_aiding_max_rate_rad_s: 0.05,
            use_imu_accel: true,
        }
    }
}

/// The seed 002 system as a streaming estimator.
#[derive(Clone, Debug)]
pub struct PfLc {
    cfg: PfLcConfig,
    plane: Option<SmallAreaPlane>,
    comp: Compensator,
    att: AttitudeKf,
    pv: PvKf,
    t_last: f64,
    h_last: f64,
    yaw_rate: f64,
    last_input: Option<PlanePoint>,
    rejected_nonfinite: u64,
}

impl PfLc {
    pub fn new(cfg: PfLcConfig) -> Self {
        PfLc {
            cfg,
            plane: None,
            comp: Compensator::new(cfg.compensation),
            att: AttitudeKf::new(cfg.attitude),
            pv: PvKf::new(cfg.pv),
            t_last: f64::NAN,
            h_last: 0.0,
            yaw_rate: 0.0,
            last_input: None,
            rejected_nonfinite: 0,
        }
    }

    pub fn config(&self) -> &PfLcConfig {
        &self.cfg
    }
    pub fn attitude(&self) -> &AttitudeKf {
        &self.att
    }
    pub fn pv(&self) -> &PvKf {
        &self.pv
    }
    pub fn compensator(&self) -> &Compensator {
        &self.comp
    }
    /// The plane (origin = first fix), once a fix arrived.
    pub fn plane(&self) -> Option<&SmallAreaPlane> {
        self.plane.as_ref()
    }
    /// The GPS position the position filter last used (raw or compensated).
    pub fn last_input(&self) -> Option<PlanePoint> {
        self.last_input
    }
    pub fn rejected_nonfinite(&self) -> u64 {
        self.rejected_nonfinite
    }

    fn solution(&self, t: f64) -> Option<NavSolution> {
        let plane = self.plane.as_ref()?;
        if !self.pv.is_init() {
            return None;
        }
        let [n, e] = self.pv.pos();
        let [vn, ve] = self.pv.vel();
        let g = plane.inverse(&PlanePoint { north: n, east: e }, self.h_last);
        let s = self.pv.std();
        let mut sol = NavSolution::unknown_at(t);
        sol.lat = g.lat;
        sol.lon = g.lon;
        sol.h = g.h;
        sol.v_n = Vec3::new(vn, ve, 0.0);
        sol.std_pos_ned = Vec3::new(s[0], s[1], f64::NAN);
        sol.std_v_n = Vec3::new(s[2], s[3], f64::NAN);
        if self.att.is_aligned() {
            let mut rpy = self.att.rpy();
            let sp = self.att.std_phi();
            if !self.att.yaw_valid() {
                rpy.z = f64::NAN;
            }
            sol.rpy = rpy;
            sol.std_rpy = sp;
        }
        Some(sol)
    }

    fn push_imu(&mut self, s: &ImuSample) -> Option<NavSolution> {
        let v = if self.pv.is_init() {
            let [vn, ve] = self.pv.vel();
            Some(Vec3::new(vn, ve, 0.0))
        } else {
            None
        };
        self.att.set_velocity(v);
        let dv_n = self.att.push(s);
        if s.dt > 0.0 {
            self.yaw_rate =
                0.9 * self.yaw_rate + 0.1 * ((s.dtheta_b.z / s.dt) - self.att.gyro_bias().z);
        }
        let g = crate::earth::gravity(self.plane.map_or(0.0, |p| p.origin.lat), self.h_last);
        let dv_ne = match dv_n {
            Some(dv) if self.att.yaw_valid() && self.cfg.use_imu_accel => {
                // Δv^n = ĉ_bn Δv_b + g^n Δt; only N and E enter the plane filter.
                let _ = g;
                Some([dv.x, dv.y])
            }
            _ => None,
        };
        if s.dt.is_finite() {
            self.pv.predict(s.dt, dv_ne);
        }
        self.t_last = s.t;
        if self.att.yaw_valid() {
            self.solution(s.t)
        } else {
            None
        }
    }

    fn push_gnss(&mut self, f: &GnssFix) -> Option<NavSolution> {
        if !(f.lat.is_finite() && f.lon.is_finite() && f.h.is_finite() && f.t.is_finite()) {
            self.rejected_nonfinite += 1;
            return None;
        }
        let geo = Geodetic {
            lat: f.lat,
            lon: f.lon,
            h: f.h,
        };
        let plane = *self.plane.get_or_insert_with(|| SmallAreaPlane::new(geo));
        let p = plane.forward(&geo);
        self.h_last = f.h;
        let (n, e) = match self.cfg.input {
            GpsInput::Raw => (p.north, p.east),
            GpsInput::Compensated => match self.comp.push(f.t, p.north, p.east) {
                Some(c) => (c.north, c.east),
                None => return None,
            },
        };
        self.last_input = Some(PlanePoint { north: n, east: e });
        self.pv.update(n, e);
        let [vn, ve] = self.pv.vel();
        let speed = (vn * vn + ve * ve).sqrt();
        if self.att.is_aligned() && speed > self.cfg.yaw_init_speed_m_s {
            let course = ve.atan2(vn);
            if !self.att.yaw_valid() {
                self.att.set_yaw(course);
            } else if self.yaw_rate.abs() < self.cfg.course_aiding_max_rate_rad_s {
                self.att.update_course(course);
            }
        }
        self.t_last = f.t;
        self.solution(f.t)
    }
}

impl Estimator for PfLc {
    fn name(&self) -> &'static str {
        "pf-lc"
    }

    /// IMU: attitude propagation + position/velocity prediction; a solution
    /// once the yaw is known. GNSS: (compensation +) position update; the
    /// posterior solution at the fix epoch.
    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        match ev {
            Event::Imu(s) => self.push_imu(s),
            Event::Gnss(f) => self.push_gnss(f),
            // Seed 002 fuses IMU + GNSS only.
            _ => None,
        }
    }
}
