//! Plain data that flows between readers, estimators and writers.
//!
//! Time: every `t` is GPS time in seconds, counted from the GPS epoch
//! (1980-01-06 00:00 GPST), i.e. `week · 604800 + tow`. Readers of formats
//! that carry only the time of week (KF-GINS text files) take the GPS week as
//! a parameter; with week 0 (unknown) `t` is simply the time of week, which is
//! consistent as long as every input of a run uses the same convention.

use nalgebra::{Matrix3, Vector3};

/// 3-vector of `f64`. Name variables with their frame: `v_n`, `f_b`, `omega_ib_b`.
pub type Vec3 = Vector3<f64>;
/// 3×3 matrix of `f64`, e.g. a DCM `c_bn` (body → navigation).
pub type Mat3 = Matrix3<f64>;

/// One IMU interval in increment form (the form every estimator consumes).
///
/// Covers the interval `(t - dt, t]`. Body frame FRD. Rate-form inputs are
/// integrated by the reader. A level IMU at rest reads
/// `dvel_b ≈ (0, 0, −9.8)·dt` (specific force, not acceleration).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ImuSample {
    /// GPS time at the end of the interval [s].
    pub t: f64,
    /// Interval length [s], > 0.
    pub dt: f64,
    /// Angle increment ∫ω_ib^b dt over the interval [rad].
    pub dtheta_b: Vec3,
    /// Velocity increment ∫f^b dt over the interval [m/s].
    pub dvel_b: Vec3,
}

/// A GNSS position (and optionally velocity) fix at the antenna phase centre.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct GnssFix {
    /// GPS time of the fix [s].
    pub t: f64,
    /// Geodetic latitude [rad], WGS84.
    pub lat: f64,
    /// Longitude [rad], WGS84, east positive.
    pub lon: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// 1-σ position error, north/east/down [m].
    pub std_ned: Vec3,
    /// Velocity in NED [m/s], when the source has it.
    pub v_n: Option<Vec3>,
    /// 1-σ velocity error, NED [m/s].
    pub std_v_n: Option<Vec3>,
    /// Solution quality as the source reports it (RTKLIB: 1 fix, 2 float, …; 0 unknown).
    pub quality: u8,
    /// Number of satellites used (0 unknown).
    pub num_sats: u8,
}

/// Time-ordered input to an estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    Imu(ImuSample),
    Gnss(GnssFix),
}

impl Event {
    /// GPS time of the event [s].
    pub fn t(&self) -> f64 {
        match self {
            Event::Imu(s) => s.t,
            Event::Gnss(g) => g.t,
        }
    }
}

/// One navigation solution epoch (the output of every estimator).
///
/// Position is of the estimator's reference point (the IMU for inertial
/// estimators, the antenna for GNSS-only ones) unless documented otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NavSolution {
    /// GPS time [s].
    pub t: f64,
    /// Latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// Velocity, NED [m/s].
    pub v_n: Vec3,
    /// Roll, pitch, yaw (ZYX) of body FRD w.r.t. NED [rad]; NaN when unknown.
    pub rpy: Vec3,
    /// 1-σ position, NED [m]; NaN when the estimator has no covariance.
    pub std_pos_ned: Vec3,
    /// 1-σ velocity, NED [m/s]; NaN when unknown.
    pub std_v_n: Vec3,
    /// 1-σ attitude error (roll, pitch, yaw) [rad]; NaN when unknown.
    pub std_rpy: Vec3,
}

impl NavSolution {
    /// A solution with every uncertainty and the attitude set to NaN ("unknown").
    pub fn unknown_at(t: f64) -> Self {
        let nan = Vec3::repeat(f64::NAN);
        NavSolution {
            t,
            rpy: nan,
            std_pos_ned: nan,
            std_v_n: nan,
            std_rpy: nan,
            ..Default::default()
        }
    }
}

/// The streaming interface shared by the four estimators.
///
/// Events must arrive in non-decreasing time order. `push` must not allocate
/// or do I/O; it returns a solution when the estimator has one for this event
/// (inertial estimators: every IMU sample once initialised).
pub trait Estimator {
    /// Short, stable name ("eskf", "pf-lc", "gps-acc", "cp-att").
    fn name(&self) -> &'static str;
    /// Feed one event; maybe get a solution for its epoch.
    fn push(&mut self, ev: &Event) -> Option<NavSolution>;
}
