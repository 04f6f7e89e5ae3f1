//! A dual-frequency rover + static base station scene of raw observables
//! (issue 15, RTK/INS): GPS L1 C/A + L2C, Galileo E1 + E5b, BeiDou B1I +
//! B2I code, carrier, Doppler and C/N0 at two receivers that see the same
//! satellites and the same atmosphere, for double-differenced carrier-phase
//! processing. Deterministic from a seed (ChaCha8, one stream for the
//! common errors and one per receiver, so a rover sky mask leaves the base
//! and the common errors unchanged).
//!
//! Model (metres; `t` true GPS time; receiver `r`, satellite `s`,
//! frequency `f`; `γ_f = (f_L1/f)²` with f_L1 = 1575.42 MHz for every
//! system, so `I` is the delay a 1575.42 MHz signal would have):
//! `P = ρ + c δt_r − c (δt_s − γ_f T_GD) + T + γ_f I + e_sat + m_P + ε_P`,
//! `Φ = ρ + c δt_r − c (δt_s − γ_f T_GD) + T − γ_f I + e_sat + λ_f N + ε_Φ`,
//! `−λ_f D = ρ̇ + c δṫ_r − c δṫ_s + ε_D` (first-order ionosphere ∝ 1/f²:
//! code delayed, phase advanced by the same amount; Teunissen & Montenbruck
//! (eds.), Springer Handbook of GNSS 2017, ch. 6), with the values
//! of [`crate::raw_gnss`] (its module documentation gives their sources)
//! unless said here:
//! - **Common mode** (one realisation for both receivers): satellite
//!   orbit and clock error `e_sat` (σ 1 m, τ 3600 s); the ionosphere (broadcast
//!   Klobuchar [`crate::multi_gnss::KLOBUCHAR`] at each receiver's own pierce
//!   geometry, plus a per-satellite zenith residual σ 1 m, τ 1800 s × the
//!   obliquity at each receiver's elevation); the troposphere
//!   (Saastamoinen + Niell at each receiver's own height and elevation —
//!   the height difference of the stations enters through the model, as it
//!   does in reality — plus a per-satellite zenith wet residual σ 5 cm,
//!   τ 3600 s, × each receiver's wet mapping). The orbit error's
//!   differential part (≈ |δr| · b/ρ = 1 m × 10 km / 20,000 km = 0.5 mm) is
//!   neglected: the orbit/clock error is one scalar per satellite.
//! - **Baseline-dependent ionosphere**: a horizontal gradient per
//!   satellite (north, east components, each σ =
//!   [`RtkSceneConfig::iono_gradient_ppm`] = 1 mm/km, Gauss–Markov
//!   τ 1800 s as the residual), times the rover's horizontal offset from
//!   the base, times the obliquity: ≈ 1 ppm zenith, the order of the
//!   double-difference ionosphere of mid-latitude baselines under quiet
//!   conditions (Wanninger 1993; Odijk 2002, PhD thesis TU Delft, ch. 5;
//!   Springer Handbook of GNSS 2017 ch. 26 "Differential positioning":
//!   1–2 ppm typical, up to 5–10 ppm at solar maximum). 10 km then gives
//!   ≈ 1 cm zenith, up to 3 cm at 10° elevation on L1.
//! - **Receiver clocks**: independent TCXOs as [`crate::raw_gnss`] (the
//!   rover and the base draw their own initial bias/drift and noise).
//!   Both receivers sample at the same true times; each stamps in its own
//!   receiver time (stamps differ by < 1 ms).
//! - **C/N0 per frequency**: L1 as [`crate::raw_gnss`] (34 + 14 sin el
//!   dB-Hz + 1 dB white); the second frequency offset by the difference of
//!   the minimum received signal powers of the ICDs: GPS L2C −1.5 dB
//!   (−160.0 vs −158.5 dBW, IS-GPS-200 Tables 3-Va/3-Vb); Galileo E5b
//!   +2 dB (−155 vs −157 dBW, Galileo OS SIS ICD 2.0 §2.4.1); BeiDou B2I
//!   0 dB (−163 dBW both, BDS-SIS-ICD-B1I 3.0 §4.2.2, B2I 1.0 §4.2.2);
//!   with its own 1 dB white noise. The antenna gain pattern per band is
//!   not modelled.
//! - **Code noise** per frequency: the DLL model of [`crate::raw_gnss`]
//!   (0.5 m at 45 dB-Hz, × 10^((45 − C/N0)/20)) with the signal's C/N0 —
//!   conservative for E5b, whose 10.23 Mchip/s code would be ≈ 3× less
//!   noisy (Kaplan & Hegarty 2nd ed. eq. 5.78, noise ∝ √T_c).
//! - **Carrier noise**: 3 mm on L1 (as [`crate::raw_gnss`]), scaled on the
//!   other frequency by λ_f/λ_L1 × 10^((C/N0_L1 − C/N0_f)/20) (PLL thermal
//!   noise σ = λ/2π √(B_n/(C/N0)), Kaplan & Hegarty 2nd ed. §5.6): 4.6 mm on
//!   L2C. Carrier multipath (≤ λ/4, mm level) is not modelled.
//! - **Code multipath** independent per receiver, satellite and frequency,
//!   σ 0.6 m / sin el ≤ 3 m as [`crate::raw_gnss`]; τ 10 s at the moving
//!   rover, [`RtkSceneConfig::base_mp_tau_s`] = 120 s at the static base
//!   (the multipath period of a static antenna is λ / (2 h ω_el cos el),
//!   minutes for reflectors a few metres away, Georgiadou & Kleusberg 1988,
//!   Manuscripta Geodaetica 13).
//! - **Ambiguities**: a random integer per receiver, satellite and
//!   frequency, new on each (re)acquisition with lock time 0 and the
//!   loss-of-lock flag ([`FLAG_LOSS_OF_LOCK`]).
//! - **Cycle slips**: with probability [`RtkSceneConfig::slip_rate_per_epoch`]
//!   per tracked satellite-frequency and epoch (rover;
//!   [`RtkSceneConfig::base_slip_rate_per_epoch`] at the base; both 0 by
//!   default) the ambiguity jumps by ±1…±[`RtkSceneConfig::slip_max_cycles`]
//!   cycles (uniform). Receivers do not flag every slip (a slip the
//!   tracking loop does not notice leaves no trace but the jump), so only a
//!   fraction [`RtkSceneConfig::slip_flag_fraction`] (default 0.5, a test
//!   setting, not a measured rate) sets the loss-of-lock flag and resets
//!   the lock time.
//! - **Sky masks** ([`MaskWindow`], [`SkyMask`] of [`crate::raw_gnss`])
//!   apply to the rover only; `SkyMask::Highest(0)` is a full outage.
//!
//! Satellites are tracked above [`crate::raw_gnss::RawConfig::track_mask_rad`]
//! (10° here, below the solvers' masks, as [`crate::multi_gnss`]), at most
//! [`RtkSceneConfig::max_sats`] = 24 per epoch (the highest after the mask):
//! two records per satellite fill a [`RawEpoch`]
//! ([`navfuse_core::gnss::raw::MAX_RAW_SATS`] = 48). Records are ordered by
//! system (GPS, Galileo, BeiDou), PRN, then first and second frequency.
//! The records' [`SatState`] is computed from the broadcast (= true) orbit
//! with the measured pseudorange and stamp
//! ([`navfuse_core::gnss::raw::sat_state_from_orbit`]); its clock carries
//! the signal's group delay γ_f T_GD (IS-GPS-200 §20.3.3.3.3.2; the same
//! form is used for Galileo BGD and BeiDou TGD, a simplification), `iono_m`
//! the broadcast Klobuchar delay on the signal, and `var_m2` the σ² of the
//! ionosphere residual and the satellite error. Inter-system and
//! inter-frequency receiver biases are zero by default (they cancel in
//! double differences of one receiver type);
//! [`RtkSceneConfig::rover_signal_bias_m`] adds them at the rover for a
//! pair of different types ([`RECEIVER_TYPE_BIASES`]).

#![allow(clippy::needless_range_loop)]

use crate::multi_gnss::{light_time, KLOBUCHAR};
use crate::raw_gnss::{
    apply_mask, clock_step, gauss_markov, obliquity, window_mask, RawConfig, RawTruthEpoch,
};
pub use crate::raw_gnss::{MaskWindow, SkyMask};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic};
use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::orbit_gnss::{clock_offset, OrbitKind};
use navfuse_core::gnss::raw::{
    sat_state_from_orbit, GnssSystem, RawEpoch, RawObs, RawSat, SatState, Signal, FLAG_LOSS_OF_LOCK,
};
use navfuse_core::gnss::tropo::{day_of_year, niell_mapping, slant_delay};
use navfuse_core::gnss::{KeplerOrbit, C_LIGHT, SECONDS_PER_WEEK};
use navfuse_core::Vec3;
use navfuse_io::rinex::{GnssObs, ObsValue, SatObs};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// L1 frequency the ionosphere delay `I` refers to [Hz].
const F_L1: f64 = 1575.42e6;

/// A satellite of the scene: its system, orbit model and broadcast orbit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSat {
    pub system: GnssSystem,
    pub kind: OrbitKind,
    pub orbit: KeplerOrbit,
}

impl SceneSat {
    /// GPS satellites of `orbits`.
    pub fn gps(orbits: &[KeplerOrbit]) -> Vec<SceneSat> {
        orbits
            .iter()
            .map(|o| SceneSat {
                system: GnssSystem::Gps,
                kind: OrbitKind::Gps,
                orbit: *o,
            })
            .collect()
    }

    /// The GPS, Galileo and BeiDou satellites of
    /// [`crate::multi_gnss::constellations`] (as broadcast).
    pub fn multi(t_oe: f64, seed: u64) -> Vec<SceneSat> {
        let (gps, other) = crate::multi_gnss::constellations(t_oe, seed);
        SceneSat::from_broadcast(&gps, &other)
    }

    /// The satellites of broadcast records: GPS `gps`, Galileo and BeiDou
    /// of `other` (other systems skipped).
    pub fn from_broadcast(
        gps: &navfuse_io::rinex::NavData,
        other: &[navfuse_io::rinex_nav3::GnssEph],
    ) -> Vec<SceneSat> {
        let mut v = SceneSat::gps(&gps.orbits);
        for e in other {
            let system = match e.sys {
                'E' => GnssSystem::Galileo,
                'C' => GnssSystem::BeiDou,
                _ => continue,
            };
            v.push(SceneSat {
                system,
                kind: e.kind,
                orbit: e.orbit,
            });
        }
        v
    }
}

/// Scene configuration (defaults: the module documentation's values).
#[derive(Clone, Debug, PartialEq)]
pub struct RtkSceneConfig {
    /// The single-receiver error model (clock, code, multipath, Doppler,
    /// ionosphere and troposphere residuals, satellite error, carrier
    /// noise, tracking mask, orbit time offset, the rover's sky-mask
    /// windows, seed) of [`crate::raw_gnss`].
    pub raw: RawConfig,
    /// Simulate the second frequency (false: first signals only).
    pub dual_frequency: bool,
    /// Horizontal ionosphere gradient, σ per component [mm/km] (1 ppm).
    pub iono_gradient_ppm: f64,
    /// Code multipath correlation time at the static base [s].
    pub base_mp_tau_s: f64,
    /// C/N0 of the second frequency minus the first [dB], per system
    /// (GPS, Galileo, BeiDou).
    pub cn0_offset_f2_db: [f64; 3],
    /// Cycle-slip probability per satellite-frequency and epoch, rover.
    pub slip_rate_per_epoch: f64,
    /// The same at the base.
    pub base_slip_rate_per_epoch: f64,
    /// Largest slip [cycles]; sizes uniform in ±1…±max.
    pub slip_max_cycles: i64,
    /// Fraction of slips the receiver flags (loss of lock).
    pub slip_flag_fraction: f64,
    /// Satellites per epoch (two records each).
    pub max_sats: usize,
    /// Broadcast ionosphere model (the deterministic part of `I`); None:
    /// only the residual.
    pub klobuchar: Option<Klobuchar>,
    /// Between-receiver hardware biases at the rover, per signal
    /// ([`signal_slot`]: GPS L1, L2C, Galileo E1, E5b, BeiDou B1I, B2I):
    /// (phase [m], code [m]), added to every satellite's record of that
    /// signal. Zero by default (receivers of one type: they cancel in the
    /// DDs of one signal and between systems sharing a frequency); see
    /// [`RECEIVER_TYPE_BIASES`] for receivers of different types.
    pub rover_signal_bias_m: [[f64; 2]; 6],
}

/// Index of `signal` in [`RtkSceneConfig::rover_signal_bias_m`].
pub fn signal_slot(signal: Signal) -> Option<usize> {
    match signal {
        Signal::GpsL1Ca => Some(0),
        Signal::GpsL2C => Some(1),
        Signal::GalE1 => Some(2),
        Signal::GalE5b => Some(3),
        Signal::BdsB1I => Some(4),
        Signal::BdsB2I => Some(5),
        _ => None,
    }
}

/// Rover − base hardware biases of two receivers of different types, per
/// signal of [`signal_slot`] (phase m, code m), GPS L1 the zero: phase
/// biases fractions of a cycle different per signal, code biases of metres.
/// Representative magnitudes, not measurements of one pair: Odijk &
/// Teunissen 2013 (GPS Solutions 17:521) report between-receiver L1–E1
/// phase ISBs of a fraction of a cycle and code ISBs of metres for mixed
/// receiver types, stable over days. A test input for DD models that must
/// not assume them zero.
pub const RECEIVER_TYPE_BIASES: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [0.071, 0.8],
    [0.052, 2.3],
    [-0.094, -1.4],
    [0.113, 4.1],
    [-0.031, 3.2],
];

impl Default for RtkSceneConfig {
    fn default() -> Self {
        RtkSceneConfig {
            raw: RawConfig {
                track_mask_rad: 10f64.to_radians(),
                ..Default::default()
            },
            dual_frequency: true,
            iono_gradient_ppm: 1.0,
            base_mp_tau_s: 120.0,
            cn0_offset_f2_db: [-1.5, 2.0, 0.0],
            slip_rate_per_epoch: 0.0,
            base_slip_rate_per_epoch: 0.0,
            slip_max_cycles: 5,
            slip_flag_fraction: 0.5,
            max_sats: navfuse_core::gnss::raw::MAX_RAW_SATS / 2,
            klobuchar: Some(KLOBUCHAR),
            rover_signal_bias_m: [[0.0; 2]; 6],
        }
    }
}

/// A base `north_m`, `east_m`, `up_m` [m] from `p_e` (ECEF [m]), e.g. the
/// rover's start: [`DEFAULT_BASE_OFFSET_NEU_M`] places it ≈ 5.4 km away.
pub fn offset_position(p_e: &Vec3, north_m: f64, east_m: f64, up_m: f64) -> Vec3 {
    let g = ecef_to_geodetic(p_e);
    p_e + c_en(g.lat, g.lon).transpose() * Vec3::new(north_m, east_m, -up_m)
}

/// Default base offset from the rover's start (north, east, up) [m]: a
/// 5.4 km baseline, inside the 2–10 km of the short-baseline RTK,
/// 20 m higher (a roof).
pub const DEFAULT_BASE_OFFSET_NEU_M: [f64; 3] = [5000.0, 2000.0, 20.0];

/// Truth of one record (parallel to the epoch's records).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct RecordTruth {
    /// Carrier ambiguity in effect [cycles] (phase = … + λ N).
    pub ambiguity_cyc: i64,
    /// Cycle slip injected at this epoch [cycles] (0: none).
    pub slip_cyc: i64,
    /// Slant ionosphere delay at 1575.42 MHz [m] (the signal's is γ_f ×).
    pub iono_l1_m: f64,
    /// Slant troposphere delay [m].
    pub tropo_m: f64,
    /// Geometric range with earth rotation at the true time [m].
    pub range_m: f64,
}

/// The simulated pair.
#[derive(Clone, Debug)]
pub struct RtkScene {
    pub rover: Vec<RawTruthEpoch>,
    pub base: Vec<RawTruthEpoch>,
    /// Per epoch, parallel to `rover[k].epoch.sats()`.
    pub rover_truth: Vec<Vec<RecordTruth>>,
    pub base_truth: Vec<Vec<RecordTruth>>,
    /// True rover antenna position and velocity (ECEF) per epoch.
    pub rover_pos_e: Vec<Vec3>,
    pub rover_vel_e: Vec<Vec3>,
    pub base_pos_e: Vec3,
}

impl RtkScene {
    /// One receiver's epochs as RINEX 3 observations: the receiver time tags
    /// and, per system G, E, C, the codes of [`Signal::rinex3_codes`] of
    /// the first then the second signal (pseudorange [m], phase [cycles],
    /// Doppler [Hz], C/N0 [dB-Hz]); the phase carries LLI bit 0 when the
    /// record has the loss-of-lock flag.
    pub fn gnss_obs(eps: &[RawTruthEpoch]) -> (Vec<f64>, GnssObs) {
        let systems = [GnssSystem::Gps, GnssSystem::Galileo, GnssSystem::BeiDou];
        let sys_codes = systems
            .iter()
            .map(|&sys| {
                let mut c: Vec<String> = Vec::new();
                for sig in [Some(Signal::first_of(sys)), Signal::second_of(sys)]
                    .into_iter()
                    .flatten()
                {
                    c.extend(sig.rinex3_codes().iter().map(|x| x.to_string()));
                }
                (sys.letter(), c)
            })
            .collect();
        let mut tags = Vec::with_capacity(eps.len());
        let mut epochs = Vec::with_capacity(eps.len());
        for e in eps {
            tags.push(e.epoch.t);
            let mut sats: Vec<SatObs> = Vec::new();
            for r in e.epoch.sats() {
                let o = &r.obs;
                let col = if o.signal.is_first() { 0 } else { 4 };
                let letter = o.system.letter();
                let i = match sats.iter().position(|x| x.0 == letter && x.1 == o.prn) {
                    Some(i) => i,
                    None => {
                        sats.push((letter, o.prn, vec![None; 8]));
                        sats.len() - 1
                    }
                };
                let v = |x: f64, lli: u8| x.is_finite().then_some(ObsValue { value: x, lli });
                let lli = u8::from(o.flags & FLAG_LOSS_OF_LOCK != 0);
                let vals = &mut sats[i].2;
                vals[col] = v(o.pseudorange_m, 0);
                vals[col + 1] = v(o.carrier_m / o.wavelength_m(), lli);
                vals[col + 2] = v(o.doppler_hz, 0);
                vals[col + 3] = v(o.cn0_dbhz as f64, 0);
            }
            epochs.push(sats);
        }
        (tags, GnssObs { sys_codes, epochs })
    }

    /// RINEX 3.04 observation texts of the rover (header position: its
    /// first true position) and the base (header position: its true
    /// position, as a surveyed base's file carries it).
    pub fn obs_texts(&self) -> (String, String) {
        let (tr, gr) = RtkScene::gnss_obs(&self.rover);
        let (tb, gb) = RtkScene::gnss_obs(&self.base);
        let p = self.rover_pos_e.first().copied().unwrap_or_default();
        let b = self.base_pos_e;
        (
            navfuse_io::rinex_write::obs3_text("SIMROVER", [p.x, p.y, p.z], &tr, &gr),
            navfuse_io::rinex_write::obs3_text("SIMBASE", [b.x, b.y, b.z], &tb, &gb),
        )
    }
}

/// One receiver's state.
struct Receiver {
    rng: ChaCha8Rng,
    b: f64,
    d: f64,
    /// Per satellite and frequency: multipath (unit), ambiguity, lock time.
    mp: Vec<[f64; 2]>,
    amb: Vec<[i64; 2]>,
    lock: Vec<[f64; 2]>,
    mp_tau: f64,
    slip_rate: f64,
    masked: bool,
    /// Hardware biases per signal of [`signal_slot`] (phase m, code m).
    hw_bias: [[f64; 2]; 6],
    /// Time since the previous epoch [s] (0 at the first).
    dt: f64,
}

/// The satellite errors both receivers see.
struct Common {
    rng: ChaCha8Rng,
    sat_e: Vec<f64>,
    iono: Vec<f64>,
    grad: Vec<[f64; 2]>,
    trop: Vec<f64>,
}

fn n01(r: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(r)
}

impl Receiver {
    fn new(
        cfg: &RawConfig,
        seed: u64,
        n: usize,
        mp_tau: f64,
        slip_rate: f64,
        masked: bool,
        hw_bias: [[f64; 2]; 6],
    ) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let b = rng.gen_range(-1.0..1.0) * cfg.clock_bias0_max_s;
        let d = rng.gen_range(-1.0..1.0) * cfg.clock_drift0_max;
        let mp = (0..n).map(|_| [n01(&mut rng), n01(&mut rng)]).collect();
        Receiver {
            rng,
            b,
            d,
            mp,
            amb: vec![[0; 2]; n],
            lock: vec![[-1.0; 2]; n],
            mp_tau,
            slip_rate,
            masked,
            hw_bias,
            dt: 0.0,
        }
    }

    fn step(&mut self, cfg: &RawConfig, dt: f64) {
        self.dt = dt;
        let (w1, w2) = (n01(&mut self.rng), n01(&mut self.rng));
        clock_step(cfg, &mut self.b, &mut self.d, dt, w1, w2);
        for m in self.mp.iter_mut() {
            for x in m.iter_mut() {
                *x = gauss_markov(*x, 1.0, self.mp_tau, dt, n01(&mut self.rng));
            }
        }
    }
}

/// Simulate both receivers at the true times `times`: the rover antenna
/// at `rover(t)` (ECEF position, velocity), the static base at
/// `base_pos_e`, tracking the satellites `sats`.
pub fn simulate_rtk(
    cfg: &RtkSceneConfig,
    sats: &[SceneSat],
    times: &[f64],
    rover: impl Fn(f64) -> (Vec3, Vec3),
    base_pos_e: Vec3,
) -> RtkScene {
    let raw = &cfg.raw;
    let ns = sats.len();
    let mut com = {
        let mut rng = ChaCha8Rng::seed_from_u64(raw.seed);
        let sat_e = (0..ns).map(|_| raw.sat_sigma_m * n01(&mut rng)).collect();
        let iono = (0..ns).map(|_| raw.iono_zenith_m * n01(&mut rng)).collect();
        let g = cfg.iono_gradient_ppm * 1e-6;
        let grad = (0..ns)
            .map(|_| [g * n01(&mut rng), g * n01(&mut rng)])
            .collect();
        let trop = (0..ns)
            .map(|_| raw.tropo_zenith_m * n01(&mut rng))
            .collect();
        Common {
            rng,
            sat_e,
            iono,
            grad,
            trop,
        }
    };
    // Sub-seeds (odd constants, so rover ≠ base ≠ common for every seed).
    let mut rx = [
        Receiver::new(
            raw,
            raw.seed ^ 0x726f_7665_7200_0001,
            ns,
            raw.mp_tau_s,
            cfg.slip_rate_per_epoch,
            true,
            cfg.rover_signal_bias_m,
        ),
        Receiver::new(
            raw,
            raw.seed ^ 0x6261_7365_0000_0003,
            ns,
            cfg.base_mp_tau_s,
            cfg.base_slip_rate_per_epoch,
            false,
            [[0.0; 2]; 6],
        ),
    ];
    let g_base = ecef_to_geodetic(&base_pos_e);
    let c_base = c_en(g_base.lat, g_base.lon);
    let mut scene = RtkScene {
        rover: Vec::with_capacity(times.len()),
        base: Vec::with_capacity(times.len()),
        rover_truth: Vec::with_capacity(times.len()),
        base_truth: Vec::with_capacity(times.len()),
        rover_pos_e: Vec::with_capacity(times.len()),
        rover_vel_e: Vec::with_capacity(times.len()),
        base_pos_e,
    };
    let mut t_prev = f64::NAN;
    for &t in times {
        let dt = if t_prev.is_finite() { t - t_prev } else { 0.0 };
        t_prev = t;
        if dt > 0.0 {
            let g = cfg.iono_gradient_ppm * 1e-6;
            for k in 0..ns {
                let r = &mut com.rng;
                com.sat_e[k] =
                    gauss_markov(com.sat_e[k], raw.sat_sigma_m, raw.sat_tau_s, dt, n01(r));
                com.iono[k] =
                    gauss_markov(com.iono[k], raw.iono_zenith_m, raw.iono_tau_s, dt, n01(r));
                for c in 0..2 {
                    com.grad[k][c] = gauss_markov(com.grad[k][c], g, raw.iono_tau_s, dt, n01(r));
                }
                com.trop[k] =
                    gauss_markov(com.trop[k], raw.tropo_zenith_m, raw.tropo_tau_s, dt, n01(r));
            }
            for r in rx.iter_mut() {
                r.step(raw, dt);
            }
        }
        let (r_rover, v_rover) = rover(t);
        for (j, r) in rx.iter_mut().enumerate() {
            let (p, v) = if j == 0 {
                (r_rover, v_rover)
            } else {
                (base_pos_e, Vec3::zeros())
            };
            let (ep, truth) = receiver_epoch(cfg, sats, &com, r, t, &p, &v, &base_pos_e, &c_base);
            if j == 0 {
                scene.rover.push(ep);
                scene.rover_truth.push(truth);
            } else {
                scene.base.push(ep);
                scene.base_truth.push(truth);
            }
        }
        scene.rover_pos_e.push(r_rover);
        scene.rover_vel_e.push(v_rover);
    }
    scene
}

/// One receiver's epoch at true time `t`, antenna at `p` moving with `v`.
#[allow(clippy::too_many_arguments)]
fn receiver_epoch(
    cfg: &RtkSceneConfig,
    sats: &[SceneSat],
    com: &Common,
    r: &mut Receiver,
    t: f64,
    p: &Vec3,
    v: &Vec3,
    base: &Vec3,
    c_base: &navfuse_core::Mat3,
) -> (RawTruthEpoch, Vec<RecordTruth>) {
    let raw = &cfg.raw;
    let g = ecef_to_geodetic(p);
    let cen = c_en(g.lat, g.lon);
    let t_orb = t + raw.orbit_time_offset_s;
    let doy = day_of_year(t_orb);
    let tow = t_orb.rem_euclid(SECONDS_PER_WEEK);
    let course = {
        let v_n = cen * v;
        v_n.y.atan2(v_n.x)
    };
    // Tracked: (el, az, sat index, range, transmit time).
    let mut vis: Vec<(f64, f64, usize, f64, f64)> = Vec::new();
    for (i, s) in sats.iter().enumerate() {
        if s.orbit.health != 0 {
            continue;
        }
        let (ps, range, t_tx) = light_time(&s.orbit, s.kind, p, t_orb);
        let u_n = cen * ((ps - p) / range);
        let el = (-u_n.z).clamp(-1.0, 1.0).asin();
        if el >= raw.track_mask_rad {
            vis.push((el, u_n.y.atan2(u_n.x), i, range, t_tx));
        }
    }
    let n_tracked = vis.len();
    vis.sort_by(|a, b| b.0.total_cmp(&a.0));
    if r.masked {
        apply_mask(window_mask(&raw.windows, t), &mut vis, course, |x| {
            (x.0, x.1)
        });
    }
    vis.truncate(cfg.max_sats);
    vis.sort_by_key(|x| (sats[x.2].system.index(), sats[x.2].orbit.prn));
    let mut present = vec![false; sats.len()];
    for x in &vis {
        present[x.2] = true;
    }
    for i in 0..sats.len() {
        if !present[i] {
            r.lock[i] = [-1.0; 2];
        }
    }
    let stamp = t + r.b;
    let mut ep = RawEpoch::new(stamp);
    let mut truth = Vec::with_capacity(2 * vis.len());
    // Rover offset from the base, north/east [m] (ionosphere gradient).
    let d_n = c_base * (p - base);
    let nf = if cfg.dual_frequency { 2 } else { 1 };
    for &(el, az, i, range, t_tx) in &vis {
        let s = &sats[i];
        let o = &s.orbit;
        let hh = 0.05;
        let rr = (light_time(o, s.kind, &(p + v * hh), t_orb + hh).1
            - light_time(o, s.kind, &(p - v * hh), t_orb - hh).1)
            / (2.0 * hh);
        let clk = clock_offset(o, s.kind, t_tx);
        let dts_rate =
            (clock_offset(o, s.kind, t_tx + 0.5) - clock_offset(o, s.kind, t_tx - 0.5)) * C_LIGHT;
        let se = el.sin().max(0.05);
        let cn0_1 = 34.0 + 14.0 * se;
        let mp_sigma = (raw.mp_zenith_m / se).min(raw.mp_cap_m);
        let of = obliquity(el);
        let (_, m_w) = niell_mapping(el, g.lat, g.h, doy);
        let t_delay = slant_delay(el, g.lat, g.h, doy, 0.7) + com.trop[i] * m_w;
        let klob = cfg
            .klobuchar
            .map_or(0.0, |k| k.delay_l1(g.lat, g.lon, az, el, tow));
        let grad = com.grad[i][0] * d_n.x + com.grad[i][1] * d_n.y;
        let i_l1 = klob + of * (com.iono[i] + grad);
        for f in 0..nf {
            let (signal, cn0_off) = if f == 0 {
                (Signal::first_of(s.system), 0.0)
            } else {
                match Signal::second_of(s.system) {
                    Some(sig) => (sig, cfg.cn0_offset_f2_db[s.system.index().min(2)]),
                    None => continue,
                }
            };
            let lam = signal.wavelength_m(0);
            let gamma = (F_L1 / signal.frequency_hz(0)).powi(2);
            let gamma1 = (F_L1 / Signal::first_of(s.system).frequency_hz(0)).powi(2);
            // Group delay: T_GD refers to the first signal (scaled by the
            // ratio of the two frequencies' γ, IS-GPS-200 §20.3.3.3.3.2).
            let tgd_f = o.tgd * gamma / gamma1;
            let dts = (clk - tgd_f) * C_LIGHT;
            let cn0 = cn0_1 + cn0_off + n01(&mut r.rng);
            let kf = 10f64.powf(((raw.cn0_ref_dbhz - cn0) / 20.0).max(0.0));
            let i_f = gamma * i_l1;
            let common = range + r.b * C_LIGHT - dts + t_delay + com.sat_e[i];
            let pr =
                common + i_f + mp_sigma * r.mp[i][f] + raw.code_sigma_ref_m * kf * n01(&mut r.rng);
            let rr_meas = rr + r.d * C_LIGHT - dts_rate
                + raw.doppler_sigma_ref_mps * kf / se.sqrt() * n01(&mut r.rng);
            let mut flags = 0;
            let mut slip = 0;
            if r.lock[i][f] < 0.0 {
                r.amb[i][f] = r.rng.gen_range(-1_000_000..1_000_000);
                r.lock[i][f] = 0.0;
                flags |= FLAG_LOSS_OF_LOCK;
            } else {
                r.lock[i][f] += r.dt;
                if r.slip_rate > 0.0 && r.rng.gen_bool(r.slip_rate.min(1.0)) {
                    let m = r.rng.gen_range(1..=cfg.slip_max_cycles.max(1));
                    slip = if r.rng.gen_bool(0.5) { m } else { -m };
                    r.amb[i][f] += slip;
                    if r.rng.gen_bool(cfg.slip_flag_fraction.clamp(0.0, 1.0)) {
                        flags |= FLAG_LOSS_OF_LOCK;
                        r.lock[i][f] = 0.0;
                    }
                }
            }
            // Carrier noise: PLL thermal noise ∝ λ / √(C/N0) (module doc).
            let sig_cp = raw.carrier_sigma_m * lam / Signal::first_of(s.system).wavelength_m(0)
                * 10f64.powf(-cn0_off / 20.0);
            let cp = common - i_f + lam * r.amb[i][f] as f64 + sig_cp * n01(&mut r.rng);
            // The receiver's hardware biases (after every random draw: the
            // draws do not depend on them).
            let hw = signal_slot(signal).map_or([0.0, 0.0], |k| r.hw_bias[k]);
            let (pr, cp) = (pr + hw[1], cp + hw[0]);
            let mut sat: SatState =
                sat_state_from_orbit(o, s.kind, stamp + raw.orbit_time_offset_s, pr);
            sat.clock_m -= (tgd_f - o.tgd) * C_LIGHT;
            sat.iono_m = (gamma * klob) as f32;
            sat.var_m2 =
                ((raw.iono_zenith_m * of * gamma).powi(2) + raw.sat_sigma_m.powi(2)) as f32;
            ep.push(RawSat {
                obs: RawObs {
                    t: stamp,
                    pseudorange_m: pr,
                    carrier_m: cp,
                    doppler_hz: -rr_meas / lam,
                    cn0_dbhz: cn0 as f32,
                    lock_time_s: r.lock[i][f] as f32,
                    system: s.system,
                    prn: o.prn,
                    signal,
                    glo_fcn: 0,
                    flags,
                    last_in_epoch: false,
                },
                sat,
            });
            truth.push(RecordTruth {
                ambiguity_cyc: r.amb[i][f],
                slip_cyc: slip,
                iono_l1_m: i_l1,
                tropo_m: t_delay,
                range_m: range,
            });
        }
    }
    (
        RawTruthEpoch {
            t,
            epoch: ep,
            clock_bias_s: r.b,
            clock_drift: r.d,
            n_tracked,
        },
        truth,
    )
}

#[cfg(test)]
#[path = "rtk_scene_tests.rs"]
mod tests;
