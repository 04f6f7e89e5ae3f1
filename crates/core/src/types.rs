//! Plain data that flows between readers, estimators and writers.
//!
//! Time: every `t` is GPS time in seconds, counted from the GPS epoch
//! (1980-01-06 00:00 GPST), i.e. `week · 604800 + tow`. Readers of formats
//! that carry only the time of week (KF-GINS text files) take the GPS week as
//! a parameter; with week 0 (unknown) `t` is simply the time of week, which is
//! consistent as long as every input of a run uses the same convention.

#[allow(unused_imports)]
use crate::prelude::*;
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

impl GnssFix {
    /// NED offset [m] of `other` from this fix, linearised with the WGS-84
    /// radii at this fix's latitude (`δN = δφ (R_M + h)`,
    /// `δE = δλ (R_N + h) cos φ`, `δD = −δh`; Groves 2nd ed. §2.4):
    /// for fixes metres to kilometres apart.
    pub fn ned_to(&self, other: &GnssFix) -> Vec3 {
        let (rm, rn) = crate::earth::radii(self.lat);
        Vec3::new(
            (other.lat - self.lat) * (rm + self.h),
            (other.lon - self.lon) * (rn + self.h) * self.lat.cos(),
            -(other.h - self.h),
        )
    }
}

/// Wheel speed / odometer measurement (issue 17).
///
/// The mean forward speed over `(t − dt, t]` along the body x axis (FRD) of
/// the wheel `wheel`, signed (negative when reversing). A source that gives a
/// distance increment `Δs` over `dt` reports `speed_mps = Δs / dt`; an
/// instantaneous speed has `dt = 0`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct OdometerSample {
    /// GPS time at the end of the interval [s].
    pub t: f64,
    /// Interval the speed is averaged over [s] (0: instantaneous).
    pub dt: f64,
    /// Signed forward speed [m/s] (before any scale-factor correction).
    pub speed_mps: f64,
    /// 1-σ of `speed_mps` [m/s] as the source knows it (0: unknown, the
    /// estimator's configured σ applies).
    pub std_mps: f64,
    /// Which wheel: 0 = the vehicle reference (e.g. rear-axle centre or a
    /// CAN vehicle speed), 1.. = individual wheels mapped to lever arms by
    /// the configuration.
    pub wheel: u8,
}

/// Where a [`HeadingFix`] comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HeadingSource {
    /// Two-antenna GNSS baseline (UBX NAV-RELPOSNED, NMEA HDT/THS, a simulator).
    #[default]
    DualAntenna,
    /// Multi-antenna carrier-phase attitude (CP-ATT, seed 003).
    CpAtt,
    /// Magnetometer heading (after declination).
    Magnetometer,
}

/// Heading (and optionally pitch) of a known body-fixed direction, usually an
/// antenna baseline master → slave (issue 17).
///
/// Angles in NED: `heading_rad` clockwise from true north, `pitch_rad`
/// positive when the baseline points up. The baseline's mounting (its body
/// frame direction) is configuration, not part of the measurement.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct HeadingFix {
    /// GPS time [s].
    pub t: f64,
    /// Heading, clockwise from true north [rad], in (−π, π].
    pub heading_rad: f64,
    /// Pitch of the baseline [rad]; NaN when the source gives none.
    pub pitch_rad: f64,
    /// 1-σ heading [rad] (> 0).
    pub std_heading_rad: f64,
    /// 1-σ pitch [rad]; NaN when there is no pitch.
    pub std_pitch_rad: f64,
    /// Baseline length [m]; NaN when unknown.
    pub baseline_m: f64,
    /// Producer of the measurement.
    pub source: HeadingSource,
}

/// Three-axis magnetometer sample, body frame FRD [T] (issue 17).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct MagSample {
    /// GPS time [s].
    pub t: f64,
    /// Measured field in the body frame [T] (1 µT = 1e-6 T).
    pub m_b: Vec3,
}

/// Largest number of antenna baselines in a [`CarrierPhaseSat`] record.
pub const MAX_CP_BASELINES: usize = 4;

/// One satellite's carrier phases on every antenna baseline at one epoch,
/// for multi-antenna attitude (CP-ATT, seed 003; issue 17).
///
/// An epoch streams as one record per satellite, ordered by decreasing
/// elevation, the last one flagged `last_in_epoch`; this keeps [`Event`]
/// small and copyable (the estimator assembles the epoch in a fixed buffer).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CarrierPhaseSat {
    /// GPS time of the epoch [s].
    pub t: f64,
    /// Satellite PRN.
    pub prn: u8,
    /// Number of baselines with data (≤ [`MAX_CP_BASELINES`]).
    pub n_baselines: u8,
    /// True on the epoch's last satellite.
    pub last_in_epoch: bool,
    /// ENU unit line of sight master → satellite.
    pub los_enu: Vec3,
    /// Undifferenced phase σ [m].
    pub sigma_m: f64,
    /// Single differences `φ_master − φ_slave` [m] per baseline.
    pub sd_phase_m: [f64; MAX_CP_BASELINES],
}

/// Time-ordered input to an estimator.
///
/// An estimator ignores the variants it has no model for (and counts them if
/// it reports statistics); adding a measurement type adds one variant here.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    Imu(ImuSample),
    Gnss(GnssFix),
    /// Wheel speed / odometer.
    Odometer(OdometerSample),
    /// GNSS heading from an antenna baseline (or CP-ATT, or a magnetometer).
    Heading(HeadingFix),
    /// Magnetometer.
    Mag(MagSample),
    /// One satellite of a multi-antenna carrier-phase epoch.
    CarrierPhase(CarrierPhaseSat),
    /// One satellite/signal of a raw GNSS epoch (issue 14; the tightly
    /// coupled ESKF's input, [`crate::gnss::raw`]).
    RawGnss(crate::gnss::raw::RawSat),
}

impl Event {
    /// GPS time of the event [s].
    pub fn t(&self) -> f64 {
        match self {
            Event::Imu(s) => s.t,
            Event::Gnss(g) => g.t,
            Event::Odometer(o) => o.t,
            Event::Heading(h) => h.t,
            Event::Mag(m) => m.t,
            Event::CarrierPhase(c) => c.t,
            Event::RawGnss(r) => r.obs.t,
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

#[cfg(test)]
mod event_size_tests {
    use super::*;

    /// The aiding variants must not make every IMU sample's event bigger:
    /// `GnssFix` stays the largest variant (multi-antenna carrier phase
    /// streams per satellite for this reason).
    #[test]
    fn aiding_variants_do_not_grow_the_event() {
        let largest = core::mem::size_of::<GnssFix>();
        for s in [
            core::mem::size_of::<OdometerSample>(),
            core::mem::size_of::<HeadingFix>(),
            core::mem::size_of::<MagSample>(),
            core::mem::size_of::<CarrierPhaseSat>(),
        ] {
            assert!(s <= largest, "{s} > {largest}");
        }
        assert!(core::mem::size_of::<Event>() <= largest + 8);
    }
}
