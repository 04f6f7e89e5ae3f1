//! Platform profiles: one named choice (`[filter] platform`, `kf-gins
//! --platform`) that sets every vehicle-dependent default of a run from the
//! physics of the platform, never from one recording.
//!
//! | profile | NHC | standstill (ZUPT/ZARU) | course = heading | why |
//! |---|---|---|---|---|
//! | `car` | 0.5 m/s | engine-idle thresholds, ZUPT + ZARU | yes | wheels on a road: no side slip or jump beyond the terms below |
//! | `robot` | 0.2 m/s | motor-only thresholds, ZUPT + ZARU | yes | slow wheeled, skid-steer slip in turns |
//! | `pedestrian` | none | hand-held standing, ZUPT only | no | the device points anywhere relative to the walking direction |
//! | `uav` | none | none | no | flies sideways; hover is not rest |
//! | `marine` | none | none | no | leeway and current: the hull slips; a moored boat bobs |
//! | `static` | none | always, ZUPT + ZARU | no | the antenna and IMU do not move |
//!
//! NHC σ (1-σ of the lateral and vertical body velocity) is the root sum of
//! squares of the terms a ground vehicle violates the constraint by, at the
//! platform's typical speed `v` and yaw rate `ω`:
//! - an unknown IMU yaw mounting misalignment `δψ` (body x not along the
//!   wheels): `v·δψ`; a car at 20 m/s with 1° → 0.35 m/s;
//! - the IMU's unknown offset `l` from the rear (non-steered) axle: `l·ω`;
//!   1.5 m at 0.3 rad/s → 0.45 m/s;
//! - tyre side slip at lateral acceleration (slip angle ≈ 1° per 2–3 m/s² for
//!   passenger-car tyres, Gillespie, *Fundamentals of Vehicle Dynamics*, ch. 6):
//!   ≈ 0.35 m/s at 20 m/s in a 3 m/s² curve.
//!
//! These are not known per vehicle, so the value is the start of an
//! innovation-based adaptation bounded by [`NHC_ADAPT_MIN`], [`NHC_ADAPT_MAX`]
//! when adaptation is on.

use navfuse_core::estimators::adaptive::{AdaptiveConstraints, AdaptiveNoise};
use navfuse_core::estimators::eskf::NhcMountStates;
use navfuse_core::estimators::eskf::{EskfConfig, NhcConfig, ZuptConfig};
use serde::{Deserialize, Serialize};

/// A platform (vehicle type) whose physics set the constraint defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Platform {
    Car,
    Robot,
    Pedestrian,
    Uav,
    Marine,
    Static,
}

/// Every profile name, for messages and `--help`.
pub const PLATFORMS: &[&str] = &["car", "robot", "pedestrian", "uav", "marine", "static"];

impl core::str::FromStr for Platform {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "car" => Platform::Car,
            "robot" => Platform::Robot,
            "pedestrian" => Platform::Pedestrian,
            "uav" => Platform::Uav,
            "marine" => Platform::Marine,
            "static" => Platform::Static,
            _ => {
                return Err(format!(
                    "platform {s:?}: expected one of {}",
                    PLATFORMS.join(", ")
                ))
            }
        })
    }
}

impl core::fmt::Display for Platform {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let i = *self as usize;
        f.write_str(PLATFORMS[i])
    }
}

/// Lower bound of the adapted NHC σ [m/s]: below the velocity noise an
/// industrial MEMS integrates between two 10 Hz constraint updates the
/// constraint would be over-trusted.
pub const NHC_ADAPT_MIN: f64 = 0.05;
/// Upper bound of the adapted NHC σ [m/s]: beyond ~2 m/s lateral velocity a
/// wheeled vehicle is skidding, and the constraint carries no information.
pub const NHC_ADAPT_MAX: f64 = 2.0;

/// The vehicle-dependent part of a run's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    pub platform: Platform,
    /// Non-holonomic constraint, if the platform obeys one.
    pub nhc: Option<NhcConfig>,
    /// Prior σ of the NHC's systematic terms (mounting pitch and yaw,
    /// forward offset from the non-holonomic point) when they are
    /// estimated as states ([`NhcMountStates`]; opt-in, `[filter.nhc]
    /// mount_states = true`). Not the default, measured: a simulated drive
    /// with the IMU yawed 3° drifts 6–10 m in a 30 s outage without them
    /// and 0.5–3 m with them (core test
    /// `nhc_mount_states_learn_a_yawed_imu_and_keep_the_outage_straight`),
    /// but drive_0708 (mounting yaw 0.44 ± 0.18°, lever 0.02 ± 0.04 m as
    /// estimated) drifts more with them (RMS of outage maxima 7.8 → 12.2 m;
    /// its first outage, 120 s after the start, comes before the states
    /// have converged, and the NHC then holds the heading only to their σ).
    /// `None`: no prior for this platform (a car's is used when asked).
    /// A run's resolved profile keeps it only when asked for.
    pub nhc_mount: Option<NhcMountStates>,
    /// Standstill detection and zero-velocity/-rate updates.
    pub zupt: Option<ZuptConfig>,
    /// The GNSS course over ground is the body heading when moving (NHC holds).
    pub course_is_heading: bool,
    /// The course follows the heading up to a slowly varying offset (a
    /// walker's device), so the course-vs-gyro time-offset estimate is valid;
    /// false where the course is free of the heading (a multirotor flies
    /// sideways, a boat crabs with the current).
    pub course_follows_heading: bool,
    /// Largest plausible horizontal acceleration [m/s²]: GNSS velocity
    /// changes beyond it are outliers (alignment, time offset).
    pub max_accel: f64,
}

/// Prior 1-σ of the IMU's mounting pitch and yaw in a wheeled vehicle:
/// a sensor box set by eye against the body edges is square to 1–2°, and
/// brackets, seats and body flex add about 1°; 3° keeps a 9° mistake within
/// 3σ and the small-angle model (first order in the angles) within 0.4 %.
pub const MOUNT_ANGLE_STD_RAD: f64 = 3.0 * core::f64::consts::PI / 180.0;

/// χ² gate probability of every update of a profiled run: a 1-in-10⁴ false
/// rejection per update, so over a 1 h, 10 Hz constraint stream ≈ 4 honest
/// innovations are de-weighted or rejected; innovations up to
/// [`GATE_DEWEIGHT_FACTOR`]× the gate are de-weighted (R·NIS/gate) rather
/// than rejected, and after [`GNSS_FORCE_AFTER`] consecutive rejected GNSS
/// positions the next is applied ungated (no lock-out after a divergence).
pub const GATE_PROBABILITY: f64 = 0.9999;
/// See [`GATE_PROBABILITY`]: a Mahalanobis distance ≈ 46 for 3 dof.
pub const GATE_DEWEIGHT_FACTOR: f64 = 100.0;
/// See [`GATE_PROBABILITY`]: 5 s of 1 Hz fixes.
pub const GNSS_FORCE_AFTER: u32 = 5;

impl Profile {
    /// `c` with this profile's gating and constraints (the IMU noise, lever
    /// arm and everything else of `c` kept).
    pub fn apply(&self, mut c: EskfConfig) -> EskfConfig {
        c.gate_probability = Some(GATE_PROBABILITY);
        c.gate_deweight_factor = GATE_DEWEIGHT_FACTOR;
        c.gnss_force_after = GNSS_FORCE_AFTER;
        c.nhc = self.nhc;
        c.zupt = self.zupt;
        c
    }

    /// Innovation-based adaptation of this profile's constraint noise
    /// ([`navfuse_core::estimators::adaptive`]): NHC within
    /// [[`NHC_ADAPT_MIN`], [`NHC_ADAPT_MAX`]] started from the profile's σ,
    /// ZUPT and ZARU within their physical bounds.
    pub fn adaptive(&self) -> AdaptiveConstraints {
        AdaptiveConstraints {
            nhc: self.nhc.map(|_| AdaptiveNoise {
                min_std: NHC_ADAPT_MIN,
                max_std: NHC_ADAPT_MAX,
                ..AdaptiveNoise::nhc_ground_vehicle()
            }),
            zupt: self.zupt.map(|_| AdaptiveNoise::zupt()),
            zaru: self
                .zupt
                .and_then(|z| z.zaru_std)
                .map(|_| AdaptiveNoise::zaru()),
        }
    }
}

impl Platform {
    /// The profile of this platform (see the module table).
    pub fn profile(self) -> Profile {
        // Standstill detector of a car (`kf-gins --enhanced`): 0.5 s window;
        // std |f| < 0.1 m/s² and gyro std < 2 °/s cover an idling engine's
        // vibration (idle at 600–900 rpm shakes the body at 10–30 Hz with
        // 0.05–0.2 m/s² rms, ISO 2631 seat-vibration surveys); the window-mean
        // f within 0.2 m/s² of gravity catches smooth acceleration; the filter
        // speed < 1 m/s. ZUPT σ 0.02 m/s (a parked car rocks by centimetres per
        // second), ZARU σ 0.1 °/s.
        let car_zupt = ZuptConfig {
            window: 50,
            max_accel_std: 0.1,
            max_gyro_std: 2.0f64.to_radians(),
            max_accel_dev: 0.2,
            max_speed: 1.0,
            vel_std: 0.02,
            zaru_std: Some(0.1f64.to_radians()),
            interval: 0.1,
        };
        match self {
            Platform::Car => Profile {
                platform: self,
                // RSS of the three terms of the module doc ≈ 0.66 m/s at
                // 20 m/s; 0.5 m/s at the urban speeds where most time is spent.
                nhc: Some(NhcConfig {
                    std: 0.5,
                    interval: 0.1,
                    min_speed: 0.5,
                }),
                // Lever σ: the IMU anywhere between the bumpers, −1 m
                // (behind the rear axle, in the boot) to +3.5 m (engine
                // bay) from the rear axle of a 4.5 m car.
                nhc_mount: Some(NhcMountStates::prior(MOUNT_ANGLE_STD_RAD, 1.5)),
                zupt: Some(car_zupt),
                course_is_heading: true,
                course_follows_heading: true,
                // Tyre friction limit ≈ 1 g.
                max_accel: 9.81,
            },
            Platform::Robot => Profile {
                platform: self,
                // v ≤ 1.5 m/s: misalignment 2° → 0.05 m/s; IMU 0.3 m off the
                // turning centre at 1 rad/s → 0.3 m/s; skid-steer slip in turns
                // of the same order. RSS ≈ 0.3; 0.2 m/s is the straight-line
                // value, the adaptation widens it in turns.
                nhc: Some(NhcConfig {
                    std: 0.2,
                    interval: 0.1,
                    min_speed: 0.1,
                }),
                // Lever σ: within a ≤ 1 m chassis.
                nhc_mount: Some(NhcMountStates::prior(MOUNT_ANGLE_STD_RAD, 0.3)),
                // No combustion engine: the vibration at rest is sensor noise
                // plus fans/motors, an order below a car's.
                zupt: Some(ZuptConfig {
                    max_accel_std: 0.05,
                    max_gyro_std: 0.5f64.to_radians(),
                    // A third of the slowest cruising speed (0.3 m/s): an
                    // IMU cannot tell rest from smooth slow motion, so the
                    // filter's speed must say rest with margin.
                    max_speed: 0.1,
                    vel_std: 0.01,
                    ..car_zupt
                }),
                course_is_heading: true,
                course_follows_heading: true,
                max_accel: 4.0,
            },
            Platform::Pedestrian => Profile {
                platform: self,
                nhc: None,
                nhc_mount: None,
                // Standing with a hand-held device: hand tremor 0.05–0.1 m/s²
                // and a few °/s of wrist motion; walking shakes it with
                // 1–3 m/s² at the step frequency, far above. The hand sways
                // the device by cm/s: ZUPT σ 0.05 m/s, no ZARU (the hand turns).
                zupt: Some(ZuptConfig {
                    max_accel_std: 0.3,
                    max_gyro_std: 10.0f64.to_radians(),
                    max_accel_dev: 0.5,
                    // A third of a slow walk (0.8 m/s), as for the robot.
                    max_speed: 0.3,
                    vel_std: 0.05,
                    zaru_std: None,
                    ..car_zupt
                }),
                course_is_heading: false,
                course_follows_heading: true,
                max_accel: 9.81,
            },
            Platform::Uav => Profile {
                platform: self,
                nhc: None,
                nhc_mount: None,
                zupt: None,
                course_is_heading: false,
                course_follows_heading: false,
                max_accel: 20.0,
            },
            Platform::Marine => Profile {
                platform: self,
                nhc: None,
                nhc_mount: None,
                zupt: None,
                course_is_heading: false,
                course_follows_heading: false,
                max_accel: 5.0,
            },
            Platform::Static => Profile {
                platform: self,
                nhc: None,
                nhc_mount: None,
                // Always at rest: the detector is switched wide open.
                zupt: Some(ZuptConfig {
                    max_accel_std: f64::INFINITY,
                    max_gyro_std: f64::INFINITY,
                    max_accel_dev: f64::INFINITY,
                    max_speed: f64::INFINITY,
                    vel_std: 0.005,
                    zaru_std: Some(0.01f64.to_radians()),
                    ..car_zupt
                }),
                course_is_heading: false,
                course_follows_heading: false,
                max_accel: 0.5,
            },
        }
    }
}
