//! Issue 15, must-shows 2 and 3: RTK/INS on a simulated car against a
//! static base (`navfuse experiment rtk`).
//!
//! **Scenario (the issue's, written before any run of it)**:
//! - a simulated car ([`navfuse_sim::platform`], static start, 100 Hz IMU
//!   of the grade under test: consumer MEMS "phone" — the row — and
//!   industrial "adis16465" as a second row), 20 seeds × 600 s;
//! - **dual-frequency GPS L1/L2C + Galileo E1/E5b + BeiDou B1I/B2I** at
//!   1 Hz from [`navfuse_sim::rtk_scene`] (its defaults: common satellite
//!   orbit/clock error, ionosphere and troposphere residuals ON and shared
//!   by both receivers, so they cancel in the DD up to the baseline part,
//!   the 1 ppm ionosphere gradient; each receiver's own clock, code noise,
//!   multipath and carrier noise; 10° tracking mask, ≤ 24 satellites), the
//!   synthetic constellations of [`navfuse_sim::multi_gnss::constellations`]
//!   at a reference epoch moved by 997 s per seed (the sky changes with
//!   the seed); rover cycle slips at 1e-4 per satellite-frequency and epoch
//!   (the scene's ±1…±5 cycles, half of them flagged: ≈ 2 per run, a test
//!   setting, not a measured rate), none at the base;
//! - the base at [`navfuse_sim::rtk_scene::DEFAULT_BASE_OFFSET_NEU_M`]
//!   from the car's start (5 km north, 2 km east, 20 m up: 5.4 km),
//!   position known exactly;
//! - an undetected (unflagged) 1-cycle slip injected into the rover's first
//!   signal of its third-highest satellite from 150 s on;
//! - a full outage (no satellite) for 30 s from 240 s and a 60 s window from
//!   420 s with only the 4 highest satellites (both their signals) at the
//!   rover (the urban mask); full sky otherwise. Needs ≥ 490 s.
//!
//! **Targets (the issue's)**: with the INS, consumer MEMS: first fix
//! ≤ 5 s; re-fix ≤ 2 epochs after the signals return (and the number
//! without the INS reported); horizontal RMS of the fixed epochs ≤ 2 cm;
//! 0 wrong fixes; in the 4-satellite window the fix kept or the float
//! ≤ 0.3 m horizontal, where GNSS-only RTK loses the fix. The 95 % σ
//! coverage of the fixed and float solutions is reported (target ~0.95).
//!
//! `--single-frequency` keeps the first measurements' scenario (GPS L1 only
//! from the YUMA almanac of seed 003 via two [`simulate_raw`] calls with the
//! common-mode errors off — they would be drawn independently per receiver
//! and not cancel — base 3.6 km away).
//!
//! Ambiguity capacity: dual-frequency G+E+C gives up to 2 × 24 = 48
//! records, beyond the first 32 slots; [`navfuse_core::estimators::eskf::NAMB`]
//! and [`navfuse_core::lambda::MAX_N`] are 48 = `MAX_RAW_SATS` so nothing
//! is left out (counted anyway: `capacity`).
//!
//! What makes the dual-frequency (re)fix fast, measured before adding
//! machinery: LAMBDA on both frequencies jointly (its decorrelation does
//! what a wide-lane-first Melbourne–Wübbena step would, Teunissen 1995)
//! with ~15 satellites of 3 systems × 2 signals fixes at the first or
//! second epoch without any wide-lane step, with or without the INS; so no
//! wide-lane machinery was added. Slips are caught by the INS-predicted
//! test and, where both signals of a satellite are tracked, by the
//! geometry-free and Melbourne–Wübbena tests of [`navfuse_core::gnss::slip`]
//! on the satellites the INS test left alone (the only tests of the
//! GNSS-only mode), then by the DD gates; all counted. A re-acquired satellite's new ambiguity starts from code
//! (σ 30 m/λ) with no correlation, and the same epoch's phase DD updates it
//! jointly with the position: in information form that equals starting
//! it at `(phase − INS-predicted range)/λ` with σ = the INS position σ
//! along the line of sight, so the INS prior is used whenever it is the
//! smaller one (GNSS-only mode has σ 30 m there instead).
//!
//! Choices made after the first 2-seed runs (written here as such):
//! [`RtkConfig::iono_ppm`] = 1 ppm (consumer default; the literature value
//! the scene also uses) after the fixed σ covered the truth 40–47 % of the
//! time without it; [`RtkConfig::inter_system`] on (the scene's receivers
//! are of one type, so the between-receiver inter-system bias is zero)
//! after the 4-satellite window of three systems left ≤ 1 DD per group:
//! `--intra-system-only` runs without it.
//!
//! **The differential ionosphere estimated** (issue 15's second pass,
//! [`RtkConfig::iono_estimate`]): the per-epoch budget of the ignored test
//! `rtk_fixed_error_budget_diagnostic` (scene truth of the DD errors) showed
//! the "not understood" seeds: the 1 ppm ionosphere, weighted as white
//! noise, biased the float ambiguities by up to ~1 cycle, LAMBDA then fixed
//! only a small low-variance subset (10 of 38 in seed 5) and the
//! conditional update put the fixed position 30 cm off with a 2.4 cm σ
//! while the integers were right. Estimated per satellite, with the
//! filter's own 1 ppm (not tuned here; `--iono-ppm` is a sensitivity
//! option, `--white-iono` the old model), measured
//! (`RAYON_NUM_THREADS=2 navfuse experiment rtk --seeds 20 [--seed0 21]
//! --json F`, phone / industrial, with the INS; before → after):
//! - seeds 1–20: fixed horizontal RMS full sky 3.5 / 4.4 → 0.94 / 0.40 cm;
//!   pooled 13.4 / 10.7 → 12.3 / 4.8 cm; coverage of the fixed σ
//!   76 / 72 → 97.3 / 99.4 %; first fix 0.4 → 0.0 s (the first epoch);
//!   re-fix 1.65 / 1.3 → 1.25 / 1.05 epochs; 0 → 0 wrong fixes; 4-satellite
//!   window largest error 0.62 / 0.42 → 0.59 / 0.26 m (phone: target
//!   0.3 m still not met, 4–5 phase DDs there);
//! - fresh seeds 21–40: full sky 4.2 / 3.4 → 1.5 / 0.30 cm (the phone's
//!   1.5 cm is one epoch of seed 40 right after the 4-satellite window,
//!   fixed on 5 of 38 ambiguities with σ 0.48 m and 1.46 m error; the other
//!   19 seeds 0.2–0.4 cm); coverage 74 / 68 → 98.1 / 99.7 %; wrong fixes
//!   0.55 / 0.55 per seed (11 epochs) → 0; 4-satellite window 0.51 / 0.25
//!   → 0.44 / 0.17 m.
//!
//!
//! Then the base's code multipath weighted with its own correlation time
//! ([`RtkConfig::base_mp_tau_s`] 120 s, a static antenna) instead of the
//! car's 10 s (same commands; phone / industrial): seeds 1–20 full sky
//! 0.94 / 0.40 → 0.32 / 0.30 cm, fixed coverage 97.3 / 99.4 → 98.2 / 99.4 %,
//! float coverage 80 / 86 → 95 / 99.6 %, 4-satellite window 0.59 / 0.26
//! → 0.62 / 0.28 m, re-fix unchanged (1.25 / 1.05), without the INS 1.4
//! → 2.05 epochs; seeds 21–40 full sky 1.5 / 0.30 → 0.31 / 0.30 cm, fixed
//! coverage 98.1 / 99.7 → 98.1 / 99.8 %, float 89 / 89 → 98 / 99.96 %
//! (now conservative: the white equivalent of a 120 s process), window
//! 0.44 / 0.17 → 0.42 / 0.15 m; 0 wrong fixes, first fix at the first
//! epoch throughout. Sensitivity (`--iono-ppm 2`, the filter's prior
//! twice the scene's, seeds 1–20, before the base change): first fix
//! 2.7 s, re-fix 4.0 / 3.35 epochs (target 2 missed), full sky 3.3 / 0.74
//! cm, window 0.86 / 0.29 m, 0 wrong: the ionosphere-weighted fix is only
//! as fast as the prior is tight.
//!
//! **Float links between the DD groups** ([`RtkConfig::float_links`], on
//! in [`RtkConfig::consumer`] from 2026-11-28; `--no-float-links` the
//! ablation): every group's phase against one master reference, each
//! group's link a float (its ambiguity part and the receivers' hardware
//! biases), so no zero-ISB assumption is needed and a group with one
//! satellite still adds its line of sight. Written for the 4-satellite
//! window, whose per-group DDs leave lines of sight unused; measured
//! (same commands, phone / industrial, with the INS; before → after):
//! - seeds 1–20: window largest error 0.615 / 0.276 → 0.463 / 0.218 m,
//!   hold 0.555 / 0.253 → 0.406 / 0.204 m, without the INS 1.255 →
//!   0.963 m; full sky unchanged (fixed 0.003 m, first fix at the first
//!   epoch, re-fix 1.25 / 1.05 epochs, 0 wrong fixes); float coverage
//!   95.3 → 96.3 % (phone);
//! - fresh seeds 21–40: 0.424 / 0.155 → 0.334 / 0.132 m, hold 0.389 /
//!   0.133 → 0.302 / 0.112 m, without the INS 1.89 → 1.69 m; 0 wrong
//!   fixes;
//! - without the zero-ISB assumption (`--intra-system-only`: what `navfuse
//!   run` does, receiver types unknown), seeds 1–20: 2.296 / 0.543 m
//!   without links, 0.494 / 0.271 m with them (hold 2.301 → 0.405 m;
//!   without the INS 445 → 0.98 m);
//! - `--ideal-imu gyro-misalignment` with links: 0.296 m (phone; 0.352
//!   before): what is left of the phone's 0.3 m miss is its gyro axis
//!   misalignment, the rest of the window is geometry (HDOP 11–349 of the
//!   single-reference DDs, `rtk_partial_window_geometry_diagnostic`).
//! - receivers of different types (`--receiver-biases`: the rover's
//!   hardware biases per signal, [`RECEIVER_TYPE_BIASES`], fractions of a
//!   cycle in phase and metres in code), seeds 1–20: with the links and no
//!   zero-ISB assumption (`--intra-system-only`) every number equals the
//!   bias-free run's (window 0.494 / 0.271 m, first fix 0.05 s, re-fix
//!   1.5 epochs, fixed RMS 0.003 m, 0 wrong fixes): the links absorb the
//!   biases. The default `inter_system` DDs, which assume them zero, break:
//!   phone first fix after 286 s, 5 fixed epochs of 11,380, fixed RMS
//!   1.71 m; wrong fixed epochs per seed 1.35 / 1.6 (industrial / phone;
//!   32.9 / 37.3 with fix-and-hold). So
//!   `inter_system` stays an experiment setting for one receiver type;
//!   `navfuse run` does not use it.
//!
//! The phase NIS is 0.4: the RTKLIB phase weights (a = b = 3 mm per
//! receiver) are larger than the scene's 3 mm carrier noise, which has no
//! carrier multipath; they are kept (a real antenna has it), so the
//! industrial coverage sits just above 99 %.
//!
//! **Measured before that** (`navfuse experiment rtk --seeds 20 --json F`, 20 × 600 s,
//! consumer / industrial with the INS; `--intra-system-only` in
//! brackets): first fix 0.4 / 0.4 s (0.85 / 0.9); re-fix 1.65 / 1.3
//! epochs (2.3 / 1.5), without the INS 1.9 (2.35); 0 wrong fixes; fixed
//! horizontal RMS 13.4 / 10.7 cm pooled (21.6 / 10.0), of which the full
//! sky 3.5 / 4.4 cm (10.7 / 7.3): ≤ 2.6 cm in 16 of 20 seeds, seeds 5,
//! 10, 13 at 4–15 cm with the DD integers right (not understood yet); the
//! 4-satellite window: largest error 0.62 / 0.42 m (2.24 / 0.63), fixed
//! 75–80 % of its epochs (25 %), target 0.3 m not met; the fixed σ covers
//! 72–76 % (target 95 %: the time-correlated differential ionosphere is
//! weighted as white noise). GNSS-only (industrial / consumer rows: the
//! same model, they differ only through the IMU sample grid the epochs are
//! applied on): first fix 1.0 s, re-fix 1.9 epochs, 0 wrong fixes, the
//! injected slip caught by GF / MW on 20 of 20 seeds, float horizontal RMS
//! 0.39 / 1.02 m, fixed 3.1 cm full sky; the 4-satellite window: largest
//! error 1.57 / 2.68 m (seeds 19, 20 differ between the rows: 1.6 / 22.6 m
//! and 3.4 / 4.6 m), "fixed" in 65 % of its epochs on partial fixes that
//! drift to metres (seed 11: 6.7 m with correct integers). Before its
//! constant-velocity model (`rtk/gnss_only.rs`) it diverged on 5 of 20
//! seeds (float 10⁵ m) with 20 wrong fixed epochs per seed.
//!
//! **GNSS-only restart** (`rtk/gnss_only.rs`, `Eskf::recentre_on_code`):
//! the rows "without" differed between the IMUs because the restart from
//! the code solution accepted rank-deficient geometry (seeds 19, 20: GPS +
//! BeiDou in the 4-satellite window, 4 code DDs of rank 2); on a scene
//! perturbed only in its random stream (the phone preset's misalignment
//! and g-sensitivity set to 0) seed 19 went to a false root 27 600 km off
//! and never came back (float 2.7·10⁶ m). Now the restart needs a position
//! DOP ≤ 30 (RTKLIB `maxgdop`), starts at the base, not at the filter's
//! state, and is forced when every code DD of an epoch is gated (false
//! alarm ≤ 1e-4 per epoch). Measured (`navfuse experiment rtk --seeds 20
//! --json F`; industrial / phone, "without" rows, before → after): float
//! horizontal RMS 0.375 / 1.513 → 0.375 / 0.375 m, 4-satellite window
//! 1.255 / 2.730 → 1.255 / 1.255 m (seed 19 phone alone 6.6 → 0.26 m float,
//! 29.9 → 0.42 m window), the industrial row the same to 1e-8 m; the rows
//! with the INS byte-identical. With the perturbed scene, phone "without",
//! seeds 1–20: float 3.1·10⁵ → 0.375 m, 5404 → 0 code DDs gated, 480 → 0
//! reference resets.
//!
//! Filters (both from the truth of the first IMU interval, car profile
//! with its NHC, the IMU grade's noise; [`RtkConfig::consumer`]):
//! - **with INS**: [`Eskf::with_rtk`];
//! - **with INS, fix-and-hold**: the same with [`RtkConfig::fix_and_hold`];
//! - **without INS**: the same with [`RtkConfig::gnss_only`]: position,
//!   velocity and ambiguities follow their own constant-velocity model
//!   (white acceleration 3 m/s² horizontal, 1 m/s² vertical over 1 s, from
//!   a car's dynamics; restart from the code solution with σ 30 m when the
//!   posterior σ exceeds it, RTKLIB `udpos`), decoupled from the INS
//!   states; the INS attitude only turns the lever arm and is not
//!   estimated; no INS slip test (GF / MW, LLI and the gates only).
//!   Everything else equal.
//!
//! Each rover epoch is applied at its true time estimated as the stamp
//! minus the receiver clock bias ([`receiver_clock_bias_m`] at the INS
//! antenna, a median pseudorange residual: ~10 ns), i.e. after the IMU
//! sample nearest to it.
//!
//! **Fixed means a fixed position** ([`RtkSolution::position_fixed`],
//! `.pos` Q 1): the integers validated and the fixed phase DDs alone
//! determining the position (position DOP ≤ 30, RTKLIB `maxgdop`). Until
//! then every validated epoch counted as fixed, and the 4-satellite
//! window's (one DD per system and signal: rank ≤ 2) made the pooled
//! fixed RMS 0.109 / 0.048 m (phone / industrial) against 0.003 m with
//! full sky. Measured before the change (`experiment rtk --seeds 20`, all
//! six filter rows pooled, the fixed DDs' DOP logged per epoch): 60 974
//! validated epochs with DOP ≤ 5, horizontal RMS 3 mm, largest 4.2 cm;
//! 5 099 with DOP > 100 (all in the window but 2 just after it) and 308
//! undetermined (in the window), together RMS 0.33 m, largest 1.85 m;
//! none between 5 and 100, so the threshold is not a tuning choice. Those epochs are now float with the
//! conditional solution and its σ, counted as
//! `fixed_weak_geometry_epochs` with their RMS; wrong integers are still
//! counted over every validated epoch.
//!
//! Scores:
//! - time to first fix [s] from the first epoch;
//! - horizontal RMS of the fixed epochs' IMU position against the truth
//!   (pooled over seeds; target ≤ 2 cm);
//! - wrong fixes: fixed epochs with any fixed DD integer different from the
//!   simulated one (dual frequency: the scene's record truth; single
//!   frequency: recovered exactly from the simulated carrier,
//!   `(Φ − ρ − c δt_r + c δt_s − T)/λ` with the true geometry, clock and
//!   troposphere, the 3 mm carrier noise ≪ λ/2); target 0; the fixed
//!   epochs > 5 cm (3D) from the truth are counted too;
//! - re-fix after the outage: the number of the first fixed epoch among the
//!   epochs after the signals return (1 = fixed at the first epoch back;
//!   the target ≤ 2 with the INS), with and without the INS; an
//!   epoch that never re-fixes before the 4-satellite window counts as the
//!   number of epochs to it (reported as censored);
//! - the injected slip: caught by a slip test of that satellite
//!   (INS-predicted or GF / MW; those by GF / MW counted apart), by its DD
//!   gate, or missed;
//! - partial sky: the largest horizontal error of the reported solution
//!   (fixed, else float) in the 4-satellite window (target: fix kept or
//!   ≤ 0.3 m), and the fixed share there.
//!
//! **What limits the phone in the 4-satellite window** (`--ideal-imu`,
//! diagnosis only: the simulated IMU without error terms the ESKF does not
//! model; the random draws, so the scene, are unchanged). 20 seeds, phone
//! with the INS / with fix-and-hold, window's largest error and pooled
//! fixed RMS: shipped scene 0.615 / 0.555 m, 0.109 m; without the gyro's
//! 5 mrad axis misalignment 0.352 / 0.306 m, 0.052 m; without the
//! accelerometer's misalignment 0.580 / 0.520 m; without the 36 °/h/g
//! g-sensitivity 0.618 / 0.560 m. A car's yaw rate leaks through the gyro
//! misalignment into roll and pitch, which the 21-state filter (biases and
//! diagonal scale factors) neither estimates nor counts in its noise; the
//! remedy is misalignment states, not tuning.

use super::ExperimentError;
use crate::ToolError;
use navfuse_core::estimators::eskf::{
    receiver_clock_bias_m, Eskf, RtkConfig, RtkSolution, RtkStats,
};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic, geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::raw::{GnssSystem, Signal};
use navfuse_core::gnss::tropo::{day_of_year, slant_delay};
use navfuse_core::gnss::{sat_at_receive, KeplerOrbit, C_LIGHT};
use navfuse_core::{Estimator, Event, Vec3};
use navfuse_sim::imu_model::ImuIdeal;
use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
use navfuse_sim::raw_gnss::{simulate_raw, MaskWindow, RawConfig, RawTruthEpoch, SkyMask};
use navfuse_sim::rtk_scene::{
    offset_position, simulate_rtk, RtkSceneConfig, SceneSat, DEFAULT_BASE_OFFSET_NEU_M,
    RECEIVER_TYPE_BIASES,
};
use navfuse_sim::trajectory::Trajectory;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

/// Outage start and length, 4-satellite window start and length [s from t₀].
pub const OUTAGE_START_S: f64 = 240.0;
pub const OUTAGE_S: f64 = 30.0;
pub const PARTIAL_START_S: f64 = 420.0;
pub const PARTIAL_S: f64 = 60.0;
/// Satellites left in the partial-sky window.
pub const PARTIAL_SATS: usize = 4;
/// An undetected 1-cycle slip is injected into the rover's carrier of its
/// third-highest satellite from this time on [s from t₀] (no loss-of-lock
/// flag: what the INS-predicted test has to catch).
pub const SLIP_AT_S: f64 = 150.0;
/// Base offset from the car's start, north and east [m] (single frequency).
pub const BASE_NE_M: (f64, f64) = (3000.0, 2000.0);
/// Rover cycle-slip probability per satellite-frequency and epoch of the
/// dual-frequency scene (module documentation: a test setting).
pub const SLIP_RATE: f64 = 1e-4;
/// Reference epoch of the dual-frequency scene (GPS week 2034, day 2, as
/// the scene's tests), moved by 997 s per seed.
const T_REF: f64 = 2034.0 * 604_800.0 + 2.0 * 86_400.0;

/// Options of `navfuse experiment rtk`.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct Options {
    /// Number of seeds.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 5))]
    pub seeds: u64,
    /// First seed.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub seed0: u64,
    /// Drive length [s] (≥ 490: the outage and the 4-satellite window).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 600.0))]
    pub duration: f64,
    /// YUMA almanac (default: gnss/almanac/yuma_week1011.alm under the data
    /// root; a synthetic 24-satellite constellation when absent).
    #[cfg_attr(feature = "clap", arg(long))]
    pub almanac: Option<PathBuf>,
    /// Write the report as JSON to FILE.
    #[cfg_attr(feature = "clap", arg(long))]
    pub json: Option<PathBuf>,
    /// The first measurements' scenario: GPS L1 only, common-mode errors
    /// off (module documentation).
    #[cfg_attr(feature = "clap", arg(long))]
    pub single_frequency: bool,
    /// Ablation: DDs within each system only (dual frequency; default:
    /// [`RtkConfig::inter_system`] on, the scene's receivers are of one type).
    #[cfg_attr(feature = "clap", arg(long))]
    pub intra_system_only: bool,
    /// Ablation: no float links between the DD groups
    /// ([`RtkConfig::float_links`], on in [`RtkConfig::consumer`]).
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_float_links: bool,
    /// Robustness check: rover and base of different receiver types, their
    /// between-receiver hardware biases per signal
    /// ([`navfuse_sim::rtk_scene::RECEIVER_TYPE_BIASES`]) at the rover.
    /// `inter_system` (on unless `--intra-system-only`) assumes them zero.
    #[cfg_attr(feature = "clap", arg(long))]
    pub receiver_biases: bool,
    /// Ablation only: the bootstrapped success-rate threshold (default
    /// [`RtkConfig::rtklib`]'s 0.999; 0 turns the check off, ratio only).
    #[cfg_attr(feature = "clap", arg(long))]
    pub success_min: Option<f64>,
    /// Ablation only: the differential ionosphere weighted as white noise
    /// ([`RtkConfig::iono_estimate`] off, the earlier model).
    #[cfg_attr(feature = "clap", arg(long))]
    pub white_iono: bool,
    /// Sensitivity only: the filter's differential-ionosphere σ [ppm]
    /// (default [`RtkConfig::consumer`]'s 1 ppm; the scene keeps its own).
    #[cfg_attr(feature = "clap", arg(long))]
    pub iono_ppm: Option<f64>,
    /// Diagnosis only: remove error terms the filter does not model from
    /// the simulated IMUs (comma-separated; the scene's random draws are
    /// unchanged, so everything else stays the same).
    #[cfg_attr(feature = "clap", arg(long, value_enum, value_delimiter = ','))]
    pub ideal_imu: Vec<IdealImuTerm>,
}

/// An IMU error term `--ideal-imu` removes ([`navfuse_sim::imu_model::ImuIdeal`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum IdealImuTerm {
    GyroMisalignment,
    AccelMisalignment,
    GSensitivity,
}

impl core::str::FromStr for IdealImuTerm {
    type Err = String;
    /// `--ideal-imu`'s spellings, for callers without clap.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "gyro-misalignment" => Ok(IdealImuTerm::GyroMisalignment),
            "accel-misalignment" => Ok(IdealImuTerm::AccelMisalignment),
            "g-sensitivity" => Ok(IdealImuTerm::GSensitivity),
            _ => Err(format!(
                "{s:?}: expected gyro-misalignment, accel-misalignment or g-sensitivity"
            )),
        }
    }
}

impl Default for Options {
    /// The command's defaults (5 seeds from 1, 600 s, dual frequency, the
    /// shipped filter configuration, no ablation).
    fn default() -> Self {
        Options {
            seeds: 5,
            seed0: 1,
            duration: 600.0,
            almanac: None,
            json: None,
            single_frequency: false,
            intra_system_only: false,
            no_float_links: false,
            receiver_biases: false,
            success_min: None,
            white_iono: false,
            iono_ppm: None,
            ideal_imu: Vec::new(),
        }
    }
}

impl Options {
    /// The IMU error terms removed by `--ideal-imu`.
    pub fn imu_ideal(&self) -> ImuIdeal {
        let has = |t| self.ideal_imu.contains(&t);
        ImuIdeal {
            gyro_misalignment: has(IdealImuTerm::GyroMisalignment),
            accel_misalignment: has(IdealImuTerm::AccelMisalignment),
            g_sensitivity: has(IdealImuTerm::GSensitivity),
        }
    }
}

/// Scores of one filter (means over seeds unless said).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Scores {
    /// Mean time to first fix [s] (seeds that fixed) and seeds never fixed.
    pub first_fix_s: Option<f64>,
    pub never_fixed: usize,
    /// Pooled horizontal RMS of the fixed epochs [m], and of all epochs'
    /// float solution outside the outage [m].
    pub fixed_h_rms_m: Option<f64>,
    pub float_h_rms_m: Option<f64>,
    /// Pooled horizontal RMS of the fixed epochs outside the 4-satellite
    /// window [m] (full sky).
    pub fixed_h_rms_full_sky_m: Option<f64>,
    /// Fixed epochs / epochs with satellites (pooled). Fixed = reported
    /// as fixed (`.pos` Q 1, [`RtkSolution::position_fixed`]): integers
    /// validated and the fixed DDs alone determining the position.
    pub fixed_epochs: usize,
    pub epochs: usize,
    /// Epochs with validated integers whose fixed DDs do not determine the
    /// position (reported as float), pooled, and their horizontal RMS [m].
    pub fixed_weak_geometry_epochs: usize,
    pub fixed_weak_geometry_h_rms_m: Option<f64>,
    /// Mean per seed: epochs with validated integers (whatever the
    /// geometry) with a wrong DD integer; fixed epochs > 5 cm (3D) from
    /// the truth.
    pub wrong_fixes: f64,
    pub fixed_over_5cm: f64,
    /// Mean epochs to re-fix after the outage; seeds censored.
    pub refix_epochs: Option<f64>,
    pub refix_censored: usize,
    /// Mean over seeds of the largest horizontal error in the 4-satellite
    /// window [m], and the fixed share of its epochs.
    pub partial_sky_h_m: Option<f64>,
    pub partial_sky_fixed_share: f64,
    /// Share of epochs whose horizontal error is inside the 95 % ellipse
    /// of the reported σ (χ²₂ = 5.991): fixed solutions, float solutions.
    pub coverage95_fixed: f64,
    pub coverage95_float: f64,
    /// Mean phase DDs used per epoch with satellites.
    pub mean_phase_dd: f64,
    /// Injected slips caught by a slip test (INS-predicted or dual-frequency
    /// GF/MW) / by the DD gate / missed; of the caught ones, those the
    /// GF/MW test caught (it runs first).
    pub injected_slip_detected: usize,
    pub injected_slip_dual: usize,
    pub injected_slip_gated: usize,
    pub injected_slip_missed: usize,
    /// Filter counters summed over seeds.
    pub slips: u64,
    pub dual_slips: u64,
    pub lli_resets: u64,
    pub phase_gated: u64,
    pub code_gated: u64,
    pub ref_resets: u64,
    pub fix_attempts: u64,
    pub fixed: u64,
    pub fixed_partial: u64,
    pub fixed_weak_geometry: u64,
    pub rejected_success_rate: u64,
    pub rejected_ratio: u64,
    pub rejected_too_few: u64,
    pub mean_nis_code: f64,
    pub mean_nis_phase: f64,
    /// Largest |filter time − estimated true epoch time| [s].
    pub max_time_error_s: f64,
}

/// One IMU grade: with and without the INS.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GradeReport {
    pub with_ins: Scores,
    pub without_ins: Scores,
    /// With the INS and fix-and-hold ([`RtkConfig::fix_and_hold`]).
    pub with_ins_hold: Scores,
}

/// The report (`--json`): the keys (consumer MEMS, means over
/// seeds) first, then everything per grade.
#[derive(Clone, Debug, Serialize)]
pub struct RtkReport {
    pub first_fix_s: Option<f64>,
    pub refix_epochs: Option<f64>,
    pub refix_epochs_without_ins: Option<f64>,
    pub fixed_h_rms_m: Option<f64>,
    pub wrong_fixes: f64,
    pub partial_sky_h_m: Option<f64>,
    pub by_imu: BTreeMap<String, GradeReport>,
    pub seeds: Vec<u64>,
    pub duration_s: f64,
    pub orbits: String,
    pub scenario: String,
    pub failed: Vec<(u64, String)>,
}

/// What one run of one filter gave.
#[derive(Clone, Debug, Default)]
struct RunOut {
    first_fix: Option<f64>,
    fixed_h2: Vec<f64>,
    /// Fixed epochs outside the 4-satellite window.
    fixed_h2_full: Vec<f64>,
    /// Integers validated, but the fixed DDs do not determine the position
    /// (reported as float, [`RtkSolution::position_fixed`]).
    weak_h2: Vec<f64>,
    float_h2: Vec<f64>,
    epochs: usize,
    wrong: usize,
    over5: usize,
    refix: Option<usize>,
    refix_censored: bool,
    partial_max: f64,
    partial_fixed: (usize, usize),
    stats: Option<RtkStats>,
    max_dt: f64,
    n_phase: usize,
    /// (inside, scored) of the 95 % coverage: fixed, float.
    cover: [(usize, usize); 2],
    /// The injected slip: 0 detected, 1 gated, 2 missed; caught by GF/MW.
    slip_outcome: Option<u8>,
    slip_dual: bool,
}

/// One seed and grade's outcome: with and without the INS.
type Job = (u64, ImuGrade, Result<[RunOut; 3], String>);

/// The car filter of `grade` at the truth of the first IMU interval
/// ([`super::aiding::car_filter_at_truth`] with the grade's noise).
fn car_filter(traj: &Trajectory, lever: Vec3, grade: ImuGrade) -> Result<Eskf, String> {
    super::aiding::car_filter_at_truth(traj, lever, grade, Default::default())
}

/// The simulated integer ambiguity of each PRN in one receiver's epoch
/// (module documentation; common-mode errors off).
fn truth_integers(
    e: &RawTruthEpoch,
    rx: &Vec3,
    orbits: &[KeplerOrbit],
    orbit_offset: f64,
) -> HashMap<u8, i64> {
    let g = ecef_to_geodetic(rx);
    let cen = c_en(g.lat, g.lon);
    let t_orb = e.t + orbit_offset;
    let doy = day_of_year(t_orb);
    let mut out = HashMap::new();
    for s in e.epoch.sats() {
        let Some(o) = orbits.iter().find(|o| o.prn == s.obs.prn) else {
            continue;
        };
        let sr = sat_at_receive(o, rx, t_orb);
        let u_n = cen * ((sr.pos_e - rx) / sr.range);
        let el = (-u_n.z).clamp(-1.0, 1.0).asin();
        let dts = (o.clock_offset(sr.t_tx) - o.tgd) * C_LIGHT;
        let trop = slant_delay(el, g.lat, g.h, doy, 0.7);
        let model = sr.range + e.clock_bias_s * C_LIGHT - dts + trop;
        let lam = s.obs.wavelength_m();
        out.insert(s.obs.prn, ((s.obs.carrier_m - model) / lam).round() as i64);
    }
    out
}

/// Truth key of a satellite-signal (system index, PRN, signal as u8:
/// [`Signal`] is not `Hash`).
type TKey = (usize, u8, u8);

fn tkey(sys: GnssSystem, prn: u8, sig: Signal) -> TKey {
    (sys.index(), prn, sig as u8)
}

/// Everything of one seed and IMU grade that both filters share.
struct Drive<'a> {
    traj: &'a Trajectory,
    imu: &'a [navfuse_core::ImuSample],
    lever: Vec3,
    rover: Vec<RawTruthEpoch>,
    base: Vec<RawTruthEpoch>,
    base_e: Vec3,
    /// Truth SD integers per epoch (rover − base) by satellite-signal.
    sd_truth: Vec<HashMap<TKey, i64>>,
    t0: f64,
    /// Satellite of the injected slip.
    slip_prn: Option<(GnssSystem, u8)>,
}

fn run_filter(d: &Drive, f: Eskf) -> Result<RunOut, String> {
    run_filter_observed(d, f, |_, _, _, _| {})
}

/// [`run_filter`] calling `on_epoch(k, solution, filter, (north, east)
/// horizontal error [m])` after each rover epoch `k`'s update
/// (diagnostics).
fn run_filter_observed(
    d: &Drive,
    mut f: Eskf,
    mut on_epoch: impl FnMut(usize, &RtkSolution, &Eskf, (f64, f64)),
) -> Result<RunOut, String> {
    let mut out = RunOut::default();
    let mut i = 0usize;
    let dt_imu = d.imu.get(1).map_or(0.01, |s| s.t - d.imu[0].t);
    let mut bias_m = 0.0;
    let t_first = d.rover.first().map_or(d.t0, |e| e.t);
    let out_end = d.t0 + OUTAGE_START_S + OUTAGE_S;
    let (p0, p1) = (d.t0 + PARTIAL_START_S, d.t0 + PARTIAL_START_S + PARTIAL_S);
    let mut back = 0usize;
    for (k, (re, be)) in d.rover.iter().zip(&d.base).enumerate() {
        let nav = *f.nav();
        let r_ins = geodetic_to_ecef(&Geodetic {
            lat: nav.lat,
            lon: nav.lon,
            h: nav.h,
        });
        if let Some(b) = receiver_clock_bias_m(&re.epoch, &r_ins) {
            bias_m = b;
        }
        let te = re.epoch.t - bias_m / C_LIGHT;
        while i < d.imu.len() && d.imu[i].t <= te + 0.5 * dt_imu {
            f.push(&Event::Imu(d.imu[i]));
            i += 1;
        }
        if i >= d.imu.len() {
            break;
        }
        out.max_dt = out.max_dt.max((f.time() - te).abs());
        let sol: RtkSolution = f
            .rtk_update(&re.epoch, &be.epoch, &d.base_e)
            .map_err(|e| e.to_string())?;
        let tr = d.traj.at(sol.t);
        let (n, e) = super::h_error_ne(sol.pos.lat, sol.pos.lon, &tr);
        let h_err = n.hypot(e);
        on_epoch(k, &sol, &f, (n, e));
        let (fnn, fe) = super::h_error_ne(sol.float_pos.lat, sol.float_pos.lon, &tr);
        let inside = |n: f64, e: f64, s: &Vec3| (n / s.x).powi(2) + (e / s.y).powi(2) <= 5.991;
        if re.epoch.n > 0 {
            out.epochs += 1;
            out.n_phase += sol.n_phase;
            out.cover[1].1 += 1;
            if inside(fnn, fe, &sol.float_std_ned) {
                out.cover[1].0 += 1;
            }
            out.float_h2.push(fnn * fnn + fe * fe);
        }
        // Fixed = reported as fixed (Q 1): the integers validated and the
        // fixed DDs alone determining the position.
        let pos_fixed = sol.position_fixed();
        if pos_fixed {
            out.cover[0].1 += 1;
            if inside(n, e, &sol.std_ned) {
                out.cover[0].0 += 1;
            }
            out.first_fix.get_or_insert(sol.t - t_first);
            out.fixed_h2.push(h_err * h_err);
            if !(re.t >= p0 && re.t < p1) {
                out.fixed_h2_full.push(h_err * h_err);
            }
            let up = sol.pos.h - tr.h;
            if (h_err * h_err + up * up).sqrt() > 0.05 {
                out.over5 += 1;
            }
        } else if sol.fixed {
            out.weak_h2.push(h_err * h_err);
        }
        // Wrong integers count whatever the geometry.
        if sol.fixed {
            let sd = &d.sd_truth[k];
            let wrong = sol.fixed_dd[..sol.n_fixed].iter().any(|x| {
                match (
                    sd.get(&tkey(x.system, x.prn, x.signal)),
                    sd.get(&tkey(x.ref_system, x.ref_prn, x.ref_signal)),
                ) {
                    (Some(a), Some(b)) => a - b != x.n,
                    _ => true,
                }
            });
            if wrong {
                out.wrong += 1;
            }
        }
        // Re-fix after the outage (epochs after the signals return).
        if re.t >= out_end && re.t < p0 && out.refix.is_none() {
            back += 1;
            if pos_fixed {
                out.refix = Some(back);
            }
        }
        if re.t >= p0 && out.refix.is_none() && back > 0 {
            out.refix = Some(back);
            out.refix_censored = true;
        }
        if re.t >= p0 && re.t < p1 {
            out.partial_max = out.partial_max.max(h_err);
            out.partial_fixed.1 += 1;
            if pos_fixed {
                out.partial_fixed.0 += 1;
            }
        }
    }
    out.stats = f.rtk_stats().copied();
    if let (Some((sys, prn)), Some(st)) = (d.slip_prn, &out.stats) {
        let c = st.sat(sys, prn);
        // Before the outage the satellite had no other reason to reset.
        out.slip_dual = c.dual_slips > 0;
        out.slip_outcome = Some(if c.slips > 0 || c.dual_slips > 0 {
            0
        } else if c.phase_gated > 0 {
            1
        } else {
            2
        });
    }
    Ok(out)
}

/// The rover's sky-mask windows: the outage and the 4-satellite window.
fn rover_windows(t0: f64) -> Vec<MaskWindow> {
    vec![
        MaskWindow {
            start: t0 + OUTAGE_START_S,
            end: t0 + OUTAGE_START_S + OUTAGE_S,
            mask: SkyMask::Highest(0),
        },
        MaskWindow {
            start: t0 + PARTIAL_START_S,
            end: t0 + PARTIAL_START_S + PARTIAL_S,
            mask: SkyMask::Highest(PARTIAL_SATS),
        },
    ]
}

/// Satellite of the third-highest record at the rover at `SLIP_AT_S`.
fn slip_satellite(
    rover: &[RawTruthEpoch],
    traj: &Trajectory,
    lever: &Vec3,
    t0: f64,
) -> Option<(GnssSystem, u8)> {
    rover.iter().find(|e| e.t >= t0 + SLIP_AT_S).and_then(|e| {
        let (ra, _) = traj.antenna_ecef(e.t, lever);
        let g = ecef_to_geodetic(&ra);
        let cen = c_en(g.lat, g.lon);
        let mut v: Vec<(f64, (GnssSystem, u8))> = e
            .epoch
            .sats()
            .iter()
            .filter(|s| s.obs.signal.is_first())
            .map(|s| {
                let u = cen * (s.sat.pos_e - ra).normalize();
                (-u.z, (s.obs.system, s.obs.prn))
            })
            .collect();
        v.sort_by(|a, b| b.0.total_cmp(&a.0));
        v.get(2).map(|x| x.1)
    })
}

/// The dual-frequency G+E+C drive (module documentation).
#[cfg(test)]
fn drive_dual(seed: u64, run: &navfuse_sim::SimRun) -> Result<Drive<'_>, String> {
    drive_dual_with(seed, run, |_| {}).map(|(d, _)| d)
}

/// Per epoch, the scene's record truth of the rover and of the base.
type SceneTruth = (
    Vec<Vec<navfuse_sim::rtk_scene::RecordTruth>>,
    Vec<Vec<navfuse_sim::rtk_scene::RecordTruth>>,
);

/// [`drive_dual`] with the scene configuration passed through `tweak`
/// (diagnostic ablations only) and the scene's record truth.
fn drive_dual_with(
    seed: u64,
    run: &navfuse_sim::SimRun,
    tweak: impl Fn(&mut RtkSceneConfig),
) -> Result<(Drive<'_>, SceneTruth), String> {
    let traj = &run.traj;
    let lever = Vec3::from(run.scenario.gnss.lever_arm_m);
    let t0 = traj.truth[0].t;
    let t_ref = T_REF + 997.0 * seed as f64;
    let sats = SceneSat::multi((t_ref / 960.0).floor() * 960.0, seed);
    let mut cfg = RtkSceneConfig::default();
    cfg.raw.orbit_time_offset_s = t_ref - t0;
    cfg.raw.windows = rover_windows(t0);
    cfg.raw.seed = seed.wrapping_mul(7919).wrapping_add(17);
    cfg.slip_rate_per_epoch = SLIP_RATE;
    tweak(&mut cfg);
    let (a0, _) = traj.antenna_ecef(t0, &lever);
    let [bn, be, bu] = DEFAULT_BASE_OFFSET_NEU_M;
    let base_e = offset_position(&a0, bn, be, bu);
    let t_end = traj.truth.last().map_or(t0, |s| s.t);
    let times: Vec<f64> = (1..)
        .map(|k| t0 + k as f64)
        .take_while(|t| *t <= t_end - 1.0)
        .collect();
    let mut sc = simulate_rtk(
        &cfg,
        &sats,
        &times,
        |t| traj.antenna_ecef(t, &lever),
        base_e,
    );
    let slip_prn = slip_satellite(&sc.rover, traj, &lever, t0);
    if let Some((sys, prn)) = slip_prn {
        for (e, tr) in sc.rover.iter_mut().zip(sc.rover_truth.iter_mut()) {
            if e.t < t0 + SLIP_AT_S {
                continue;
            }
            let n = e.epoch.n;
            for (s, x) in e.epoch.sats[..n].iter_mut().zip(tr.iter_mut()) {
                if s.obs.system == sys && s.obs.prn == prn && s.obs.signal.is_first() {
                    s.obs.carrier_m += s.obs.wavelength_m();
                    x.ambiguity_cyc += 1;
                }
            }
        }
    }
    let key = |s: &navfuse_core::gnss::raw::RawSat| tkey(s.obs.system, s.obs.prn, s.obs.signal);
    let sd_truth = (0..sc.rover.len())
        .map(|k| {
            let b: HashMap<TKey, i64> = sc.base[k]
                .epoch
                .sats()
                .iter()
                .zip(&sc.base_truth[k])
                .map(|(s, x)| (key(s), x.ambiguity_cyc))
                .collect();
            sc.rover[k]
                .epoch
                .sats()
                .iter()
                .zip(&sc.rover_truth[k])
                .filter_map(|(s, x)| b.get(&key(s)).map(|nb| (key(s), x.ambiguity_cyc - nb)))
                .collect()
        })
        .collect();
    Ok((
        Drive {
            traj,
            imu: &run.imu,
            lever,
            rover: sc.rover,
            base: sc.base,
            base_e,
            sd_truth,
            t0,
            slip_prn,
        },
        (sc.rover_truth, sc.base_truth),
    ))
}

/// One seed and grade: the drive, both receivers, both filters.
fn run_seed(
    seed: u64,
    grade: ImuGrade,
    o: &Options,
    orbits: &[KeplerOrbit],
    rc: RtkConfig,
) -> Result<[RunOut; 3], String> {
    let opt = platform_options(grade, o.duration, o.imu_ideal());
    let pr = platform_run(Platform::Car, seed, &opt).map_err(|e| e.to_string())?;
    let run = &pr.run;
    let d = if o.single_frequency {
        drive_l1(seed, run, orbits)?
    } else {
        drive_dual_with(seed, run, |c| {
            if o.receiver_biases {
                c.rover_signal_bias_m = RECEIVER_TYPE_BIASES;
            }
        })
        .map(|(d, _)| d)?
    };
    let [with, without, hold] = seed_filters(&d, grade, rc)?;
    Ok([
        run_filter(&d, with)?,
        run_filter(&d, without)?,
        run_filter(&d, hold)?,
    ])
}

/// The car drive of one seed: static start, `grade`'s IMU less the
/// `ideal` terms.
fn platform_options(grade: ImuGrade, duration: f64, ideal: ImuIdeal) -> PlatformOptions {
    PlatformOptions {
        duration_s: duration,
        static_start: true,
        imu: grade,
        gnss: GnssGrade::Consumer,
        imu_ideal: ideal,
        ..Default::default()
    }
}

/// The three filters of a drive: with the INS, without (GNSS-only), with
/// the INS and fix-and-hold (module documentation).
fn seed_filters(d: &Drive, grade: ImuGrade, rc: RtkConfig) -> Result<[Eskf; 3], String> {
    let with = car_filter(d.traj, d.lever, grade)?
        .with_rtk(rc)
        .map_err(|e| e.to_string())?;
    let without = car_filter(d.traj, d.lever, grade)?
        .with_rtk(RtkConfig {
            gnss_only: true,
            ..rc
        })
        .map_err(|e| e.to_string())?;
    let hold = car_filter(d.traj, d.lever, grade)?
        .with_rtk(RtkConfig {
            fix_and_hold: true,
            ..rc
        })
        .map_err(|e| e.to_string())?;
    Ok([with, without, hold])
}

/// The single-frequency GPS L1 drive (module documentation).
fn drive_l1<'a>(
    seed: u64,
    run: &'a navfuse_sim::SimRun,
    orbits: &[KeplerOrbit],
) -> Result<Drive<'a>, String> {
    let traj = &run.traj;
    let lever = Vec3::from(run.scenario.gnss.lever_arm_m);
    let t0 = traj.truth[0].t;
    let t_oa = orbits.first().map_or(0.0, |o| o.t_oe);
    let orbit_offset = t_oa - t0 + 997.0 * seed as f64;
    let short_baseline = RawConfig {
        iono_zenith_m: 0.0,
        tropo_zenith_m: 0.0,
        sat_sigma_m: 0.0,
        orbit_time_offset_s: orbit_offset,
        ..Default::default()
    };
    let rover_cfg = RawConfig {
        windows: rover_windows(t0),
        seed: seed.wrapping_mul(7919).wrapping_add(17),
        ..short_baseline.clone()
    };
    let mut rover = super::tight::simulate_drive_raw(run, orbits, &rover_cfg);
    // The injected slip: the third-highest satellite at SLIP_AT_S.
    let slip_prn = slip_satellite(&rover, traj, &lever, t0);
    if let Some((_, prn)) = slip_prn {
        for e in rover.iter_mut().filter(|e| e.t >= t0 + SLIP_AT_S) {
            let n = e.epoch.n;
            for s in e.epoch.sats[..n].iter_mut() {
                if s.obs.prn == prn {
                    s.obs.carrier_m += s.obs.wavelength_m();
                }
            }
        }
    }
    let s0 = &traj.truth[0];
    let (rm, rn) = navfuse_core::earth::radii(s0.lat);
    let base_geo = Geodetic {
        lat: s0.lat + BASE_NE_M.0 / (rm + s0.h),
        lon: s0.lon + BASE_NE_M.1 / ((rn + s0.h) * s0.lat.cos()),
        h: s0.h,
    };
    let base_e = geodetic_to_ecef(&base_geo);
    let base_cfg = RawConfig {
        seed: seed.wrapping_mul(104_729).wrapping_add(3),
        ..short_baseline
    };
    let times: Vec<f64> = rover.iter().map(|e| e.t).collect();
    let base = simulate_raw(&base_cfg, orbits, &times, |_| (base_e, Vec3::zeros()));
    let l1 = |p: &u8| tkey(GnssSystem::Gps, *p, Signal::GpsL1Ca);
    let sd_truth: Vec<HashMap<TKey, i64>> = rover
        .iter()
        .zip(&base)
        .map(|(r, b)| {
            let (ra, _) = traj.antenna_ecef(r.t, &lever);
            let nr = truth_integers(r, &ra, orbits, orbit_offset);
            let nb = truth_integers(b, &base_e, orbits, orbit_offset);
            nr.iter()
                .filter_map(|(p, a)| nb.get(p).map(|b| (l1(p), a - b)))
                .collect()
        })
        .collect();
    Ok(Drive {
        traj,
        imu: &run.imu,
        lever,
        rover,
        base,
        base_e,
        sd_truth,
        t0,
        slip_prn,
    })
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn scores(v: &[RunOut]) -> Scores {
    let n = v.len().max(1) as f64;
    let ff: Vec<f64> = v.iter().filter_map(|r| r.first_fix).collect();
    let fixed: Vec<f64> = v.iter().flat_map(|r| r.fixed_h2.iter().copied()).collect();
    let float: Vec<f64> = v.iter().flat_map(|r| r.float_h2.iter().copied()).collect();
    let full: Vec<f64> = v
        .iter()
        .flat_map(|r| r.fixed_h2_full.iter().copied())
        .collect();
    let weak: Vec<f64> = v.iter().flat_map(|r| r.weak_h2.iter().copied()).collect();
    let refix: Vec<f64> = v.iter().filter_map(|r| r.refix.map(|x| x as f64)).collect();
    let partial: Vec<f64> = v.iter().map(|r| r.partial_max).collect();
    let pf = v.iter().fold((0, 0), |a, r| {
        (a.0 + r.partial_fixed.0, a.1 + r.partial_fixed.1)
    });
    let mut s = Scores {
        first_fix_s: mean(&ff),
        never_fixed: v.len() - ff.len(),
        fixed_h_rms_m: mean(&fixed).map(f64::sqrt),
        float_h_rms_m: mean(&float).map(f64::sqrt),
        fixed_h_rms_full_sky_m: mean(&full).map(f64::sqrt),
        fixed_epochs: fixed.len(),
        epochs: v.iter().map(|r| r.epochs).sum(),
        fixed_weak_geometry_epochs: weak.len(),
        fixed_weak_geometry_h_rms_m: mean(&weak).map(f64::sqrt),
        wrong_fixes: v.iter().map(|r| r.wrong as f64).sum::<f64>() / n,
        fixed_over_5cm: v.iter().map(|r| r.over5 as f64).sum::<f64>() / n,
        refix_epochs: mean(&refix),
        refix_censored: v.iter().filter(|r| r.refix_censored).count(),
        partial_sky_h_m: mean(&partial),
        partial_sky_fixed_share: pf.0 as f64 / pf.1.max(1) as f64,
        coverage95_fixed: {
            let c = v
                .iter()
                .fold((0, 0), |a, r| (a.0 + r.cover[0].0, a.1 + r.cover[0].1));
            c.0 as f64 / c.1.max(1) as f64
        },
        coverage95_float: {
            let c = v
                .iter()
                .fold((0, 0), |a, r| (a.0 + r.cover[1].0, a.1 + r.cover[1].1));
            c.0 as f64 / c.1.max(1) as f64
        },
        mean_phase_dd: v.iter().map(|r| r.n_phase).sum::<usize>() as f64
            / v.iter().map(|r| r.epochs).sum::<usize>().max(1) as f64,
        injected_slip_detected: v.iter().filter(|r| r.slip_outcome == Some(0)).count(),
        injected_slip_dual: v.iter().filter(|r| r.slip_dual).count(),
        injected_slip_gated: v.iter().filter(|r| r.slip_outcome == Some(1)).count(),
        injected_slip_missed: v.iter().filter(|r| r.slip_outcome == Some(2)).count(),
        max_time_error_s: v.iter().map(|r| r.max_dt).fold(0.0, f64::max),
        ..Default::default()
    };
    let (mut nc, mut np) = ((0.0, 0u64), (0.0, 0u64));
    for st in v.iter().filter_map(|r| r.stats.as_ref()) {
        let t = st.total();
        s.slips += t.slips as u64;
        s.dual_slips += t.dual_slips as u64;
        s.lli_resets += t.lli_resets as u64;
        s.phase_gated += t.phase_gated as u64;
        s.code_gated += t.code_gated as u64;
        s.ref_resets += t.ref_resets as u64;
        s.fix_attempts += st.fix_attempts;
        s.fixed += st.fixed;
        s.fixed_partial += st.fixed_partial;
        s.fixed_weak_geometry += st.fixed_weak_geometry;
        s.rejected_success_rate += st.rejected_success_rate;
        s.rejected_ratio += st.rejected_ratio;
        s.rejected_too_few += st.rejected_too_few;
        nc = (nc.0 + st.nis_code.0, nc.1 + st.nis_code.1);
        np = (np.0 + st.nis_phase.0, np.1 + st.nis_phase.1);
    }
    s.mean_nis_code = nc.0 / nc.1.max(1) as f64;
    s.mean_nis_phase = np.0 / np.1.max(1) as f64;
    s
}

/// The filters' RTK configuration for the options `o`.
fn filter_config(o: &Options) -> RtkConfig {
    let mut rc = RtkConfig::consumer();
    rc.inter_system = !(o.single_frequency || o.intra_system_only);
    rc.float_links = !o.no_float_links;
    if o.single_frequency {
        // That scenario has no differential ionosphere by construction
        // (common-mode errors off, module documentation).
        rc.iono_ppm = 0.0;
    }
    if o.white_iono {
        rc.iono_estimate = false;
    }
    if let (Some(p), false) = (o.iono_ppm, o.single_frequency) {
        rc.iono_ppm = p.max(0.0);
    }
    if let Some(p) = o.success_min {
        // 0 = off: any success rate passes.
        rc.success_min = p.max(f64::MIN_POSITIVE);
    }
    rc
}

/// Run the experiment over seeds `seed0 …` for both IMU grades.
pub fn run_rtk(o: &Options) -> Result<RtkReport, ExperimentError> {
    let min = PARTIAL_START_S + PARTIAL_S + 10.0;
    if o.seeds == 0 || !(o.duration.is_finite() && o.duration >= min) {
        return Err(ExperimentError::Options(format!(
            "rtk: need --seeds >= 1 and --duration >= {min} s"
        )));
    }
    let (orbits, orbit_name) = super::tight::load_orbits(o.almanac.as_ref());
    let rc = filter_config(o);
    let ids: Vec<u64> = (o.seed0..o.seed0 + o.seeds).collect();
    let grades = [ImuGrade::Industrial, ImuGrade::Consumer];
    let jobs: Vec<(u64, ImuGrade)> = ids
        .iter()
        .flat_map(|&s| grades.iter().map(move |&g| (s, g)))
        .collect();
    let res: Vec<Job> = super::on_worker_pool(|| {
        jobs.par_iter()
            .map(|&(s, g)| (s, g, run_seed(s, g, o, &orbits, rc)))
            .collect()
    });
    let mut failed = Vec::new();
    let mut by_imu = BTreeMap::new();
    for g in grades {
        let (mut w, mut wo, mut wh) = (Vec::new(), Vec::new(), Vec::new());
        for (s, gg, r) in &res {
            if *gg != g {
                continue;
            }
            match r {
                Ok([a, b, c]) => {
                    w.push(a.clone());
                    wo.push(b.clone());
                    wh.push(c.clone());
                }
                Err(e) => failed.push((*s, format!("{}: {e}", g.preset()))),
            }
        }
        by_imu.insert(
            g.preset().to_string(),
            GradeReport {
                with_ins: scores(&w),
                without_ins: scores(&wo),
                with_ins_hold: scores(&wh),
            },
        );
    }
    let c = &by_imu[ImuGrade::Consumer.preset()];
    Ok(RtkReport {
        first_fix_s: c.with_ins.first_fix_s,
        refix_epochs: c.with_ins.refix_epochs,
        refix_epochs_without_ins: c.without_ins.refix_epochs,
        fixed_h_rms_m: c.with_ins.fixed_h_rms_m,
        wrong_fixes: c.with_ins.wrong_fixes,
        partial_sky_h_m: c.with_ins.partial_sky_h_m,
        by_imu: by_imu.clone(),
        seeds: ids,
        duration_s: o.duration,
        orbits: orbit_name,
        scenario: if o.single_frequency {
            format!(
                "car, GPS L1 1 Hz rover + static base {:.1} km away, common-mode errors off \
                 (short-baseline approximation); full outage {OUTAGE_START_S}-{} s, \
                 {PARTIAL_SATS} satellites {PARTIAL_START_S}-{} s",
                BASE_NE_M.0.hypot(BASE_NE_M.1) / 1000.0,
                OUTAGE_START_S + OUTAGE_S,
                PARTIAL_START_S + PARTIAL_S
            )
        } else {
            let [n, e, u] = DEFAULT_BASE_OFFSET_NEU_M;
            format!(
                "car, dual-frequency GPS L1/L2C + Galileo E1/E5b + BeiDou B1I/B2I 1 Hz rover + \
                 static base {:.1} km away (rtk_scene, common-mode errors on, slips {SLIP_RATE}); \
                 full outage {OUTAGE_START_S}-{} s, {PARTIAL_SATS} satellites {PARTIAL_START_S}-{} s",
                (n * n + e * e + u * u).sqrt() / 1000.0,
                OUTAGE_START_S + OUTAGE_S,
                PARTIAL_START_S + PARTIAL_S
            )
        } + &ideal_note(&o.ideal_imu),
        failed,
    })
}

/// The scenario's note on `--ideal-imu` (empty without it).
fn ideal_note(terms: &[IdealImuTerm]) -> String {
    if terms.is_empty() {
        return String::new();
    }
    let names: Vec<&str> = terms
        .iter()
        .map(|t| match t {
            IdealImuTerm::GyroMisalignment => "gyro misalignment",
            IdealImuTerm::AccelMisalignment => "accel misalignment",
            IdealImuTerm::GSensitivity => "g-sensitivity",
        })
        .collect();
    format!("; DIAGNOSIS: simulated IMU without {}", names.join(", "))
}

/// `navfuse experiment rtk`: print the table, optionally write JSON.
pub fn run(o: Options) -> Result<(), ToolError> {
    let r = run_rtk(&o).map_err(|e| e.to_string())?;
    println!(
        "RTK/INS: {} ({}), {} seeds x {} s",
        r.scenario,
        r.orbits,
        r.seeds.len(),
        r.duration_s
    );
    let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.3}"));
    println!(
        "{:<12} {:<8} {:>9} {:>10} {:>10} {:>8} {:>8} {:>9} {:>11} {:>9}",
        "imu",
        "ins",
        "TTFF s",
        "fixed h m",
        "float h m",
        "fixed %",
        "wrong",
        "refix ep",
        "4-sat max m",
        "4-sat fix"
    );
    for (g, gr) in &r.by_imu {
        for (name, s) in [
            ("with", &gr.with_ins),
            ("without", &gr.without_ins),
            ("hold", &gr.with_ins_hold),
        ] {
            println!(
                "{:<12} {:<8} {:>9} {:>10} {:>10} {:>8.1} {:>8.2} {:>9} {:>11} {:>9.2}",
                g,
                name,
                f(s.first_fix_s),
                f(s.fixed_h_rms_m),
                f(s.float_h_rms_m),
                100.0 * s.fixed_epochs as f64 / s.epochs.max(1) as f64,
                s.wrong_fixes,
                f(s.refix_epochs),
                f(s.partial_sky_h_m),
                s.partial_sky_fixed_share
            );
            println!(
                "{:<21} fixed h RMS full sky {}; cov95 fixed {:.3} float {:.3}; phase DD/epoch {:.1}; injected slip caught by test {} (GF/MW {}) / gate {} / missed {}; slips INS {} GF/MW {} lli {} phase gated {} code gated {} ref resets {}; fix: {} attempts, {} fixed ({} partial, {} weak geometry: h RMS {}), rejected {} success rate / {} ratio / {} too few; NIS code {:.2} phase {:.2}; >5 cm fixed {:.2}; refix censored {}; never fixed {}",
                "", f(s.fixed_h_rms_full_sky_m), s.coverage95_fixed, s.coverage95_float, s.mean_phase_dd, s.injected_slip_detected, s.injected_slip_dual, s.injected_slip_gated, s.injected_slip_missed, s.slips, s.dual_slips, s.lli_resets, s.phase_gated, s.code_gated, s.ref_resets, s.fix_attempts, s.fixed, s.fixed_partial, s.fixed_weak_geometry, f(s.fixed_weak_geometry_h_rms_m),
                s.rejected_success_rate, s.rejected_ratio, s.rejected_too_few, s.mean_nis_code, s.mean_nis_phase,
                s.fixed_over_5cm, s.refix_censored, s.never_fixed
            );
        }
    }
    for (seed, e) in &r.failed {
        println!("seed {seed} failed: {e}");
    }
    if let Some(p) = &o.json {
        let text = serde_json::to_string_pretty(&r).map_err(|e| e.to_string())?;
        navfuse_io::atomic::write_atomic_named(p, text)?;
    }
    Ok(())
}

#[cfg(test)]
#[path = "rtk_tests.rs"]
mod tests;
