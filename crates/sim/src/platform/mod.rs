//! Generalisation bench: randomised, physically plausible runs of platforms
//! nobody tuned navfuse for (car, wheeled robot, pedestrian, multirotor UAV).
//!
//! [`platform_scenario`] draws a trajectory from a seed (ChaCha12, its own
//! stream) inside documented per-platform limits (see `ground`, `walker`,
//! `uav`); [`platform_run`] simulates the sensors and returns what an oracle
//! or a scorer needs ([`PlatformRun`]): true initial state, turn-on biases,
//! the injected IMU time offset and the outage windows.
//!
//! Time convention: GNSS fixes and the truth are stamped in true GPS time;
//! IMU samples are stamped `imu_time_offset_s` = τ EARLIER than the truth
//! (true time = stamp + τ), so a filter with navfuse's `imu_time_offset = τ`
//! ("seconds added to IMU stamps") sees consistent times.

mod ground;
mod marine;
mod plan;
mod uav;
mod walker;

#[cfg(test)]
mod tests;

use crate::gnss_model::gnss_preset;
use crate::imu_model::imu_preset;
use crate::scenario::{GnssSection, ImuSection};
use crate::trajectory::{Start, TruthEpoch};
use crate::{simulate, Scenario, SimError, SimRun};
use core::fmt;
use core::str::FromStr;
use navfuse_core::Vec3;
use plan::Plan;
use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;

/// Platform kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Platform {
    Car,
    Robot,
    Pedestrian,
    Uav,
    /// Small craft in waves ([`marine`]); not in the generalisation matrix
    /// of issue 13 ([`Platform::MATRIX`]), run by name.
    Marine,
}

/// IMU grade → simulator preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ImuGrade {
    /// Phone-class MEMS (preset "phone").
    Consumer,
    /// Industrial MEMS (preset "adis16465").
    Industrial,
    /// Tactical grade (preset "tactical").
    Tactical,
}

/// GNSS grade → simulator preset (both output velocity).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GnssGrade {
    /// RTK fixed (preset "rtk-1hz").
    Rtk,
    /// Consumer single-point receiver (preset "consumer-1hz").
    Consumer,
}

impl Platform {
    /// Every simulated platform.
    pub const ALL: [Platform; 5] = [
        Platform::Car,
        Platform::Robot,
        Platform::Pedestrian,
        Platform::Uav,
        Platform::Marine,
    ];
    /// The platforms of issue 13's generalisation matrix.
    pub const MATRIX: [Platform; 4] = [
        Platform::Car,
        Platform::Robot,
        Platform::Pedestrian,
        Platform::Uav,
    ];
    fn name(self) -> &'static str {
        match self {
            Platform::Car => "car",
            Platform::Robot => "robot",
            Platform::Pedestrian => "pedestrian",
            Platform::Uav => "uav",
            Platform::Marine => "marine",
        }
    }
}

impl ImuGrade {
    pub const ALL: [ImuGrade; 3] = [ImuGrade::Consumer, ImuGrade::Industrial, ImuGrade::Tactical];
    fn name(self) -> &'static str {
        match self {
            ImuGrade::Consumer => "consumer",
            ImuGrade::Industrial => "industrial",
            ImuGrade::Tactical => "tactical",
        }
    }
    /// Name of the [`crate::imu_model::imu_preset`] used.
    pub fn preset(self) -> &'static str {
        match self {
            ImuGrade::Consumer => "phone",
            ImuGrade::Industrial => "adis16465",
            ImuGrade::Tactical => "tactical",
        }
    }
}

impl GnssGrade {
    pub const ALL: [GnssGrade; 2] = [GnssGrade::Rtk, GnssGrade::Consumer];
    fn name(self) -> &'static str {
        match self {
            GnssGrade::Rtk => "rtk",
            GnssGrade::Consumer => "consumer",
        }
    }
    /// Name of the [`crate::gnss_model::gnss_preset`] used.
    pub fn preset(self) -> &'static str {
        match self {
            GnssGrade::Rtk => "rtk-1hz",
            GnssGrade::Consumer => "consumer-1hz",
        }
    }
}

macro_rules! named_enum {
    ($t:ty, $what:literal) => {
        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
        impl FromStr for $t {
            type Err = SimError;
            /// Lowercase name (case-insensitive).
            fn from_str(s: &str) -> Result<Self, SimError> {
                let l = s.trim().to_ascii_lowercase();
                <$t>::ALL
                    .into_iter()
                    .find(|x| x.name() == l)
                    .ok_or_else(|| {
                        let known: Vec<&str> = <$t>::ALL.iter().map(|x| x.name()).collect();
                        SimError::Scenario(format!(
                            "unknown {} '{s}' (known: {})",
                            $what,
                            known.join(", ")
                        ))
                    })
            }
        }
    };
}
named_enum!(Platform, "platform");
named_enum!(ImuGrade, "IMU grade");
named_enum!(GnssGrade, "GNSS grade");

/// GNSS outage schedule, in seconds after the trajectory start.
#[derive(Clone, Debug, PartialEq)]
pub enum Outages {
    None,
    /// `length_s` outages every `every_s` from `first_s`, each followed by at
    /// least `length_s` of GNSS before the end of the run.
    Periodic {
        first_s: f64,
        every_s: f64,
        length_s: f64,
    },
    /// Explicit `[start, end)` windows.
    Windows(Vec<[f64; 2]>),
}

impl Default for Outages {
    /// 30 s outages every 120 s from 120 s. 30 s is the common short-outage
    /// length of GNSS/INS benchmarks; the first 120 s leave time for heading
    /// to become observable (MEMS headings need some manoeuvring), and the
    /// 90 s of GNSS between outages let a filter re-converge before the next.
    fn default() -> Self {
        Outages::Periodic {
            first_s: 120.0,
            every_s: 120.0,
            length_s: 30.0,
        }
    }
}

impl Outages {
    /// Windows `[start, end)` [s after the start] inside a run of `duration_s`.
    pub fn windows(&self, duration_s: f64) -> Vec<[f64; 2]> {
        match self {
            Outages::None => Vec::new(),
            Outages::Windows(w) => w.clone(),
            &Outages::Periodic {
                first_s,
                every_s,
                length_s,
            } => {
                let mut v = Vec::new();
                if !(every_s > 0.0 && length_s > 0.0) {
                    return v;
                }
                let mut a = first_s;
                while a + 2.0 * length_s <= duration_s + 1e-9 {
                    v.push([a, a + length_s]);
                    a += every_s;
                }
                v
            }
        }
    }
}

/// Options of a platform run.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatformOptions {
    /// Length of the trajectory [s] (600).
    pub duration_s: f64,
    /// true: start with a 10–20 s hold at rest; false: already moving at t₀
    /// at a platform-typical speed, no stop/pause/hover in the first 60 s.
    pub static_start: bool,
    /// Start position: latitude, longitude [deg], ellipsoidal height [m].
    pub start_lat_deg: f64,
    pub start_lon_deg: f64,
    pub start_h_m: f64,
    pub imu: ImuGrade,
    pub gnss: GnssGrade,
    /// IMU output rate [Hz] (100).
    pub imu_rate_hz: f64,
    /// Internal integration steps per IMU interval (10; fewer = faster, still exact to O(h⁴)).
    pub substeps: u32,
    pub outages: Outages,
    /// τ: IMU samples are stamped τ earlier than the truth (true = stamp + τ) [s].
    pub imu_time_offset_s: f64,
    /// The IMU output starts this long after the first GNSS epoch [s] (≥ 0;
    /// with `static_start = false` the run then starts in motion with GNSS first).
    pub gnss_lead_s: f64,
    /// Diagnosis only: error terms removed from the IMU grade's
    /// specification ([`crate::imu_model::ImuIdeal`]; default: none).
    pub imu_ideal: crate::imu_model::ImuIdeal,
    /// GNSS output rate [Hz] instead of the grade's preset (1 Hz); the
    /// per-fix error model (σ, Gauss–Markov share and τ) is unchanged, so a
    /// faster receiver's fixes are more correlated, as real ones are.
    pub gnss_rate_hz: Option<f64>,
}

impl Default for PlatformOptions {
    fn default() -> Self {
        PlatformOptions {
            duration_s: 600.0,
            static_start: true,
            // Mid-latitude default (Wuhan, as the demo drive): nothing is tuned to it.
            start_lat_deg: 30.528,
            start_lon_deg: 114.356,
            start_h_m: 25.0,
            imu: ImuGrade::Industrial,
            gnss: GnssGrade::Consumer,
            imu_rate_hz: 100.0,
            substeps: 10,
            outages: Outages::default(),
            imu_time_offset_s: 0.0,
            gnss_lead_s: 0.0,
            imu_ideal: Default::default(),
            gnss_rate_hz: None,
        }
    }
}

/// ChaCha12 stream of the trajectory draws (the sensor streams are 1–3).
const STREAM_PLATFORM: u64 = 10;

/// What the planner knows beyond the scenario.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PlanInfo {
    /// Pedestrian: device yaw − walking course [rad].
    pub yaw_offset: Option<f64>,
}

fn plan(p: Platform, seed: u64, opt: &PlatformOptions) -> Result<(Scenario, PlanInfo), SimError> {
    if !(opt.duration_s.is_finite() && opt.duration_s > 0.0) {
        return Err(SimError::Scenario(format!(
            "platform: duration_s = {} must be > 0",
            opt.duration_s
        )));
    }
    if !(opt.imu_rate_hz.is_finite() && opt.imu_rate_hz > 0.0) || opt.substeps == 0 {
        return Err(SimError::Scenario(format!(
            "platform: imu_rate_hz = {} must be > 0 and substeps ≥ 1",
            opt.imu_rate_hz
        )));
    }
    for (n, x) in [
        ("start_lat_deg", opt.start_lat_deg),
        ("start_lon_deg", opt.start_lon_deg),
        ("start_h_m", opt.start_h_m),
        ("imu_time_offset_s", opt.imu_time_offset_s),
        ("gnss_lead_s", opt.gnss_lead_s),
    ] {
        if !x.is_finite() {
            return Err(SimError::Scenario(format!(
                "platform: {n} = {x} is not finite"
            )));
        }
    }
    if let Some(r) = opt.gnss_rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(SimError::Scenario(format!(
                "platform: gnss_rate_hz = {r} must be > 0"
            )));
        }
    }
    if opt.gnss_lead_s < 0.0 || opt.gnss_lead_s >= opt.duration_s {
        return Err(SimError::Scenario(format!(
            "platform: gnss_lead_s = {} must be in [0, duration_s)",
            opt.gnss_lead_s
        )));
    }
    let mut rng = ChaCha12Rng::seed_from_u64(seed);
    rng.set_stream(STREAM_PLATFORM);
    let h = 1.0 / (opt.imu_rate_hz * opt.substeps as f64);
    let mut pl = Plan::new(h, opt.duration_s);
    let (start_rpy, start_v_b, info) = match p {
        Platform::Car => ground::car(&mut pl, &mut rng, opt.static_start),
        Platform::Robot => ground::robot(&mut pl, &mut rng, opt.static_start),
        Platform::Pedestrian => walker::pedestrian(&mut pl, &mut rng, opt.static_start),
        Platform::Uav => uav::multirotor(&mut pl, &mut rng, opt.static_start),
        Platform::Marine => marine::small_craft(&mut pl, &mut rng, opt.static_start),
    };
    let sc = Scenario {
        name: format!("platform-{p}-{seed}"),
        description: format!(
            "{p}, seed {seed}, {} s, {} start, IMU {}, GNSS {}",
            opt.duration_s,
            if opt.static_start { "static" } else { "moving" },
            opt.imu.preset(),
            opt.gnss.preset()
        ),
        start: Start {
            lat_deg: opt.start_lat_deg,
            lon_deg: opt.start_lon_deg,
            h_m: opt.start_h_m,
            rpy_deg: start_rpy.map(f64::to_degrees),
            v_b: start_v_b,
            gps_week: 2300,
            tow_s: 345_600.0,
        },
        imu: ImuSection {
            rate_hz: opt.imu_rate_hz,
            substeps: opt.substeps,
            preset: opt.imu.preset().into(),
            model: None,
        },
        gnss: GnssSection {
            preset: opt.gnss.preset().into(),
            outages: opt.outages.windows(opt.duration_s),
            ..Default::default()
        },
        segment: pl.segs,
    };
    Ok((sc, info))
}

/// A randomised, physically plausible scenario of platform `p` drawn from
/// `seed` (same seed and options → identical scenario). Start frame: body
/// FRD w.r.t. NED, `start.v_b` body frame; outages in s after the start.
pub fn platform_scenario(
    p: Platform,
    seed: u64,
    opt: &PlatformOptions,
) -> Result<Scenario, SimError> {
    plan(p, seed, opt).map(|(s, _)| s)
}

/// One platform run with everything an oracle or a scorer needs.
#[derive(Clone, Debug)]
pub struct PlatformRun {
    pub platform: Platform,
    pub options: PlatformOptions,
    /// The simulation. `run.imu[i].t` = true time − τ; `run.traj` (truth and
    /// ideal increments, use `traj.at(t)` to score) and `run.gnss` are in true
    /// time. With `gnss_lead_s > 0` the IMU and the truth start that much
    /// after the first GNSS epoch.
    pub run: SimRun,
    /// True state at the first IMU sample, i.e. at true time
    /// `run.imu[0].t + τ` (lat/lon [rad], h [m], v_n NED [m/s], rpy of the IMU body [rad]).
    pub init: TruthEpoch,
    /// Stamp of the first IMU sample [s] (IMU clock).
    pub init_stamp_s: f64,
    /// Turn-on biases drawn for this run: gyro [rad/s], accel [m/s²] (sensor frame).
    pub gyro_turn_on_bias: Vec3,
    pub accel_turn_on_bias: Vec3,
    /// τ: true time = IMU stamp + τ [s].
    pub imu_time_offset_s: f64,
    /// GNSS outage windows `[start, end)` in true GPS time [s].
    pub outages: Vec<[f64; 2]>,
    /// Pedestrian: device yaw − walking course [rad] (constant over the run).
    pub yaw_offset_rad: Option<f64>,
}

/// Draw and simulate one platform run (see [`PlatformRun`] for the time
/// convention). Deterministic in (`p`, `seed`, `opt`).
pub fn platform_run(
    p: Platform,
    seed: u64,
    opt: &PlatformOptions,
) -> Result<PlatformRun, SimError> {
    let (sc, info) = plan(p, seed, opt)?;
    let imu = opt.imu_ideal.apply(imu_preset(opt.imu.preset())?);
    let mut gnss = gnss_preset(opt.gnss.preset())?;
    if let Some(r) = opt.gnss_rate_hz {
        gnss.rate_hz = r;
    }
    let mut run = simulate(&sc, seed, Some(imu), Some(gnss))?;
    let t0 = run.traj.truth[0].t;
    // GNSS lead: drop the first IMU intervals (and their truth) so the first
    // fix, at t₀, comes `gnss_lead_s` before the IMU starts.
    let k = (opt.gnss_lead_s / run.traj.imu_dt).round() as usize;
    if k >= run.imu.len() {
        return Err(SimError::Scenario(
            "platform: gnss_lead_s leaves no IMU data".into(),
        ));
    }
    run.imu.drain(..k);
    run.traj.imu.drain(..k);
    run.traj.truth.drain(..k);
    let tau = opt.imu_time_offset_s;
    for s in &mut run.imu {
        s.t -= tau;
    }
    let outages = sc
        .gnss
        .outages
        .iter()
        .map(|o| [t0 + o[0], t0 + o[1]])
        .collect();
    Ok(PlatformRun {
        platform: p,
        options: opt.clone(),
        init: run.traj.truth[1],
        init_stamp_s: run.imu[0].t,
        gyro_turn_on_bias: run.turn_on_bias.0,
        accel_turn_on_bias: run.turn_on_bias.1,
        imu_time_offset_s: tau,
        outages,
        yaw_offset_rad: info.yaw_offset,
        run,
    })
}
