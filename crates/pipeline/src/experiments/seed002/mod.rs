//! `navfuse experiment seed002`: the seed 002 experiment (`SEEDS.md §2`,
//! issue 6) in simulation over many seeds and on the real drive_0708, beside
//! the paper's numbers.
//!
//! Methods, all on the same GNSS fixes (4 Hz, 5 m CEP, time-correlated):
//! raw GPS · compensated GPS (the paper's "particle filter", eq. 5–13) ·
//! SIR particle filter GPS (comparator) · original LC (PV KF on raw GPS) ·
//! proposed LC (PV KF on compensated GPS) · ESKF (column left `null` until
//! `navfuse_core::estimators::eskf` lands on this branch).
//! Metric: mean horizontal error at the fix epochs against the truth, after
//! a warm-up, averaged over the seeds; cornering table: the mean error inside
//! each corner (turn start to turn end + `CORNER_TAIL_S`).
//!
//! Simulation (`--sim`): by default navfuse-sim with
//! `scenarios/seed002_campus_loop.toml` (hold, two laps of a 400 m × 250 m
//! loop at 20 km/h = 8 corners, ADIS16365 preset, "lowcost-4hz" GNSS: 5 m
//! CEP, 80 % of the variance first-order Gauss–Markov with τ = 60 s, 20 %
//! white, rare multipath jumps). `--sim builtin` uses this module's own loop
//! (written before navfuse-sim landed): exact kinematics of a level car, nine
//! corners (as many as the paper's Table 2) with a smooth yaw-rate bump, and
//! the same error models. `--gm-fraction` changes the time-correlated share
//! of the GNSS error (a sensitivity study: 0 = white jitter only).
//! Corners are found from the truth course (> 8°/s for ≥ 1.5 s at > 2 m/s)
//! in every data set, simulated or real.
//!
//! Real: drive_0708 KF-GINS `imu.txt` (vehicle FRD, time offset applied) and
//! `truth.nav` (4 Hz RTK-fixed antenna positions) — the truth positions
//! degraded by the same seeded GNSS error model are the fixes.

use crate::ToolError;
use navfuse_core::estimators::eskf::{Eskf, EskfConfig, ImuErrors, InitStd, NhcConfig};
use navfuse_core::estimators::pf_lc::compensation::Compensator;
use navfuse_core::estimators::pf_lc::rng::SplitMix64;
use navfuse_core::estimators::pf_lc::{GpsInput, PfLc, PfLcConfig, SirConfig, SirPf};
use navfuse_core::geodesy::{Geodetic, LocalFrame, PlanePoint, SmallAreaPlane};
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::{Estimator, Event, GnssFix, ImuSample, NavSolution, Vec3};
use navfuse_io::kfgins::{KfGinsImuOptions, KfGinsImuReader, KfGinsNavReader};
use serde_json::{json, Value};
use std::path::PathBuf;

mod data;
mod methods;
mod run;
#[cfg(test)]
mod tests;

use data::*;
use methods::*;
pub use run::run;

/// The ESKF starts once the attitude KF has had this many course updates
/// (its yaw then comes from a settled course, not the first one at 3 m/s).
const ESKF_START_COURSES: u64 = 20;
/// Particles of the SIR comparator.
const N_PARTICLES: usize = 1000;
/// Fix epochs in the first `WARMUP_S` seconds after the first fix are not scored.
const WARMUP_S: f64 = 5.0;
/// A corner's scoring window runs this long after the turn ends [s].
const CORNER_TAIL_S: f64 = 2.0;
const G: f64 = navfuse_core::earth::STANDARD_GRAVITY;
const DEG: f64 = std::f64::consts::PI / 180.0;

/// The paper's numbers (mean errors in metres; Table 2 columns A, B, C).
const PAPER_RAW: f64 = 12.23;
const PAPER_COMP: f64 = 7.34;
const PAPER_LC_ORIG: f64 = 6.68;
const PAPER_LC_PROP: f64 = 5.88;
const PAPER_A: [f64; 9] = [
    8.3286, 7.6414, 10.5169, 12.5851, 6.3420, 7.1529, 7.708, 1.3384, 7.7719,
];
const PAPER_B: [f64; 9] = [
    2.2168, 2.8558, 1.7433, 2.6282, 3.6215, 2.4760, 0.7752, 0.7048, 0.6787,
];
const PAPER_C: [f64; 9] = [
    2.2115, 2.8203, 1.7245, 2.5871, 3.4795, 2.3525, 0.3542, 0.6923, 0.6546,
];

/// Reproduce the seed 002 experiment (simulation + real drive_0708).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct Options {
    /// Number of simulation seeds (≥ 20 for the reported table).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 20))]
    pub seeds: u32,
    /// First seed; seeds are first..first+seeds.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub first_seed: u64,
    /// Noise realisations on the real drive (default: same as --seeds).
    #[cfg_attr(feature = "clap", arg(long))]
    pub real_seeds: Option<u32>,
    /// Write the results as JSON to this file.
    #[cfg_attr(feature = "clap", arg(long))]
    pub json: Option<PathBuf>,
    /// Skip the real-data part (otherwise missing data is an error).
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_real: bool,
    /// Share of the GNSS error variance that is time-correlated (Gauss–Markov);
    /// 0.8 is the sim preset. A sensitivity study, e.g. 0 = white jitter only.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0.8))]
    pub gm_fraction: f64,
    /// Simulator: the navfuse-sim campus-loop scenario (default) or the
    /// built-in nine-corner loop of this module.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "navfuse-sim"))]
    pub sim: SimSource,
    /// Scenario for `--sim navfuse-sim`.
    #[cfg_attr(feature = "clap", arg(long))]
    pub scenario: Option<PathBuf>,
    /// Diagnostic: position filter without the IMU acceleration input.
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_imu_accel: bool,
    /// Override the compensation history span (parameter study).
    #[cfg_attr(feature = "clap", arg(long))]
    pub span: Option<usize>,
    /// Override the compensation w_min (parameter study).
    #[cfg_attr(feature = "clap", arg(long))]
    pub w_min: Option<f64>,
    /// Override the compensation w_max (parameter study).
    #[cfg_attr(feature = "clap", arg(long))]
    pub w_max: Option<f64>,
    /// Write an HTML report (DIR/index.html, DIR/plots/*.svg) of the first
    /// seed's run on drive_0708 (with `--no-real`: of the simulation): raw
    /// GPS, compensated GPS, original LC, proposed LC and ESKF against the truth.
    #[cfg_attr(feature = "clap", arg(long, value_name = "DIR"))]
    pub report: Option<PathBuf>,
}

/// Where the simulated runs come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SimSource {
    /// `navfuse-sim` with `scenarios/seed002_campus_loop.toml` (or --scenario).
    NavfuseSim,
    /// This module's own nine-corner loop (exact kinematics, same error models).
    Builtin,
}

/// GNSS error model (per horizontal axis; see the module doc).
#[derive(Clone, Copy, Debug)]
struct GnssErrModel {
    rate_hz: f64,
    sigma_h: f64,
    gm_fraction: f64,
    gm_tau_s: f64,
    jump_prob: f64,
    jump_sigma: f64,
    jump_dur_s: f64,
}

impl GnssErrModel {
    /// sim preset "lowcost-4hz" (seed 002: 5 m CEP at 4 Hz).
    #[cfg(test)]
    fn lowcost_4hz() -> Self {
        Self::lowcost_4hz_gm(0.8)
    }
    /// The same with another time-correlated share of the variance.
    fn lowcost_4hz_gm(gm_fraction: f64) -> Self {
        GnssErrModel {
            rate_hz: 4.0,
            sigma_h: 5.0 / 1.177_410_022_515_474_5,
            gm_fraction,
            gm_tau_s: 60.0,
            jump_prob: 0.002,
            jump_sigma: 8.0,
            jump_dur_s: 3.0,
        }
    }
}

/// Stateful generator of the horizontal error (north, east) [m].
struct GnssErrGen {
    m: GnssErrModel,
    rng: SplitMix64,
    gm: [f64; 2],
    jump: [f64; 2],
    jump_left: f64,
    init: bool,
}

impl GnssErrGen {
    fn new(m: GnssErrModel, seed: u64) -> Self {
        GnssErrGen {
            m,
            rng: SplitMix64::new(seed),
            gm: [0.0; 2],
            jump: [0.0; 2],
            jump_left: 0.0,
            init: false,
        }
    }

    /// Error for the next epoch, `dt` after the previous one.
    fn next(&mut self, dt: f64) -> [f64; 2] {
        let s_gm = self.m.sigma_h * self.m.gm_fraction.sqrt();
        let s_w = self.m.sigma_h * (1.0 - self.m.gm_fraction).sqrt();
        if !self.init {
            // Start the Gauss–Markov process in its steady state.
            self.gm = [s_gm * self.rng.normal(), s_gm * self.rng.normal()];
            self.init = true;
        } else {
            // Exact discretisation of the first-order GM process.
            let phi = (-dt / self.m.gm_tau_s).exp();
            let q = s_gm * (1.0 - phi * phi).sqrt();
            for g in self.gm.iter_mut() {
                *g = phi * *g + q * self.rng.normal();
            }
        }
        self.jump_left -= dt;
        if self.jump_left <= 0.0 {
            self.jump = [0.0; 2];
            if self.rng.uniform() < self.m.jump_prob {
                self.jump = [
                    self.m.jump_sigma * self.rng.normal(),
                    self.m.jump_sigma * self.rng.normal(),
                ];
                self.jump_left = self.m.jump_dur_s;
            }
        }
        [
            self.gm[0] + s_w * self.rng.normal() + self.jump[0],
            self.gm[1] + s_w * self.rng.normal() + self.jump[1],
        ]
    }
}

/// One data set: time-ordered events (IMU + degraded fixes), the truth at
/// each fix (same order as the fixes), the corners (t_start, t_end).
struct DataSet {
    events: Vec<Event>,
    truth: Vec<Geodetic>,
    corners: Vec<(f64, f64)>,
}

/// Per-run scores.
#[derive(Clone, Debug, Default)]
struct Scores {
    raw: f64,
    comp: f64,
    sir: f64,
    lc_orig: f64,
    lc_prop: f64,
    eskf: f64,
    /// Scored epochs.
    epochs: usize,
    /// Per corner: (A raw, B original LC, C proposed LC).
    corners: Vec<[f64; 3]>,
    /// Rejections and restarts seen (for the run summary).
    pv_gated: u64,
    comp_reanchored: u64,
    course_resets: u64,
    sir_reinits: u64,
}
