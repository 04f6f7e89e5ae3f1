//! Scenario edge of the trajectory generator: the start state and the
//! motion segments as written in TOML (see the parent module for the motion
//! model they compile into).

use serde::{Deserialize, Serialize};

/// Start of a trajectory.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Start {
    /// Latitude [deg].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height [m].
    #[serde(default)]
    pub h_m: f64,
    /// Roll, pitch, yaw [deg] (ZYX, body FRD w.r.t. NED).
    #[serde(default)]
    pub rpy_deg: [f64; 3],
    /// Initial velocity in the body frame [m/s] (a car: `[speed, 0, 0]`).
    #[serde(default)]
    pub v_b: [f64; 3],
    /// GPS week of the start (times are `week·604800 + tow`).
    #[serde(default = "default_week")]
    pub gps_week: u32,
    /// GPS time of week at the start [s].
    #[serde(default = "default_tow")]
    pub tow_s: f64,
}

fn default_week() -> u32 {
    2300
}
fn default_tow() -> f64 {
    345_600.0
}

fn default_accel() -> f64 {
    1.5
}
fn default_transition() -> f64 {
    3.0
}
fn default_uturn_rate() -> f64 {
    18.0
}

/// One motion segment of a scenario (`type = "…"` in TOML).
///
/// Angles in degrees and speeds in m/s (or km/h where the name says so) at
/// this edge; positive turn = clockwise seen from above (yaw increases, NED).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// Keep the current attitude and body velocity for `duration_s`.
    Hold { duration_s: f64 },
    /// Change forward speed to `speed_mps` / `speed_kmh` at `accel` m/s².
    Accelerate {
        speed_mps: Option<f64>,
        speed_kmh: Option<f64>,
        #[serde(default = "default_accel")]
        accel: f64,
    },
    /// Decelerate to rest at `decel` m/s².
    Stop {
        #[serde(default = "default_accel")]
        decel: f64,
    },
    /// Keep the current speed for a time or a distance.
    Cruise {
        duration_s: Option<f64>,
        distance_m: Option<f64>,
    },
    /// Turn at `rate_deg_s` for `angle_deg` or `duration_s` (sign of rate = direction).
    Turn {
        rate_deg_s: f64,
        angle_deg: Option<f64>,
        duration_s: Option<f64>,
    },
    /// 180° turn at `rate_deg_s` (negative: to the left).
    Uturn {
        #[serde(default = "default_uturn_rate")]
        rate_deg_s: f64,
    },
    /// Pitch to a road grade (percent; negative descends) over `transition_s`, driving on.
    Grade {
        grade_pct: f64,
        #[serde(default = "default_transition")]
        transition_s: f64,
    },
    /// Sinusoidal attitude oscillation about the current attitude:
    /// `rpy(τ) = rpy₀ + amplitude·sin(ω τ)`.
    Oscillate {
        amplitude_deg: [f64; 3],
        omega_rad_s: f64,
        duration_s: f64,
    },
    /// Raw phase: Euler-angle rates [deg/s] and body acceleration [m/s²] for `duration_s`
    /// (gnss-ins-sim command type 1).
    Rates {
        rpy_rate_deg_s: [f64; 3],
        #[serde(default)]
        accel_b: [f64; 3],
        duration_s: f64,
    },
    /// Reach a target attitude [deg] / body velocity [m/s] (absolute or relative),
    /// limited by `max_rate_deg_s` and `max_accel`, then hold for the rest of
    /// `duration_s` (gnss-ins-sim command types 2–5).
    Target {
        rpy_deg: [f64; 3],
        v_b: [f64; 3],
        #[serde(default)]
        rpy_relative: bool,
        #[serde(default)]
        v_relative: bool,
        duration_s: f64,
        #[serde(default = "default_max_rate")]
        max_rate_deg_s: f64,
        #[serde(default = "default_max_accel")]
        max_accel: f64,
    },
    /// Raw phase in the navigation frame: Euler-angle rates [deg/s] and NED
    /// acceleration `a_n` [m/s²] for `duration_s` — velocity independent of the
    /// attitude (a multirotor flying sideways while yawing).
    RatesNed {
        #[serde(default)]
        rpy_rate_deg_s: [f64; 3],
        #[serde(default)]
        accel_n: [f64; 3],
        duration_s: f64,
    },
    /// Walking with a step-periodic body velocity and attitude sway (see
    /// [`super::walk`]); the duration is rounded to whole strides (two steps).
    Walk {
        duration_s: f64,
        /// Mean walking speed at the end [m/s] (linear ramp); default: keep.
        speed_mps: Option<f64>,
        /// Heading change over the segment [deg] (positive: to the right).
        #[serde(default)]
        turn_deg: f64,
        /// Steps per second.
        #[serde(default = "super::walk::default_cadence")]
        cadence_hz: f64,
        /// Step-induced acceleration amplitudes [m/s²]: forward and vertical
        /// at the cadence, lateral at half the cadence.
        #[serde(default = "super::walk::default_step_accel")]
        step_accel_mps2: [f64; 3],
        /// Attitude sway amplitudes [deg]: roll and yaw at half the cadence,
        /// pitch at the cadence.
        #[serde(default = "super::walk::default_sway")]
        sway_deg: [f64; 3],
        /// Device yaw minus walking course [deg]; default: the direction of
        /// the current horizontal body velocity (body x at rest).
        yaw_offset_deg: Option<f64>,
    },
    /// A closed rectangular loop (seed 002 campus drive): from rest, accelerate,
    /// `laps` times around a `length_m × width_m` rectangle with right-hand
    /// 90° corners at `corner_rate_deg_s`, then stop on the first side.
    Loop {
        speed_kmh: f64,
        length_m: f64,
        width_m: f64,
        #[serde(default = "one")]
        laps: u32,
        #[serde(default = "default_corner")]
        corner_rate_deg_s: f64,
    },
}

fn default_max_rate() -> f64 {
    30.0
}
fn default_max_accel() -> f64 {
    2.0
}
fn one() -> u32 {
    1
}
fn default_corner() -> f64 {
    15.0
}

pub(super) fn seg_name(s: &Segment) -> &'static str {
    match s {
        Segment::Hold { .. } => "hold",
        Segment::Accelerate { .. } => "accelerate",
        Segment::Stop { .. } => "stop",
        Segment::Cruise { .. } => "cruise",
        Segment::Turn { .. } => "turn",
        Segment::Uturn { .. } => "uturn",
        Segment::Grade { .. } => "grade",
        Segment::Oscillate { .. } => "oscillate",
        Segment::Rates { .. } => "rates",
        Segment::Target { .. } => "target",
        Segment::Loop { .. } => "loop",
        Segment::RatesNed { .. } => "rates_ned",
        Segment::Walk { .. } => "walk",
    }
}
