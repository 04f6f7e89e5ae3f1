//! RTK/INS (issue 15): carrier-phase and code double differences (DD)
//! between the rover and a static base station, in the ESKF, with float
//! ambiguities, INS-predicted cycle-slip detection and LAMBDA fixing.
//! Off by default; the plain filter and the tight path do not run any of
//! this and stay bit-identical ([`Eskf::with_rtk`]).
//!
//! **Ambiguity states** ([`NAMB`] slots, kept outside the 21×21 covariance
//! as the clock block of [`super::tight`]: `P = [[P_xx, P_xa], [P_xaᵀ,
//! P_aa]]`): one *single-difference* (rover − base) ambiguity [cycles] per
//! (system, PRN, signal). Single-difference states rather than DD states
//! (RTKLIB `rtkpos.c` does the same): the DD ambiguity of satellite `i`
//! against reference `r` is `a_i − a_r` for whatever reference the epoch
//! picks, so a reference change needs no re-keying and no covariance
//! transformation; the common part of all SD ambiguities of one system and
//! signal (receiver clock and phase-bias difference) is unobservable from
//! DDs and just stays at its prior. The ambiguities are constants (no process
//! noise): propagation is `P_xa ← Φ_x P_xa` only (`Φ_x = I + F dt`, the
//! filter's first-order transition), `P_aa` unchanged.
//!
//! Capacity [`NAMB`] = 48 = [`MAX_RAW_SATS`] = [`crate::lambda::MAX_N`]:
//! every record an epoch can hold gets a slot and all its DD ambiguities
//! can go into one LAMBDA search. It was 32, but dual-frequency GPS +
//! Galileo + BeiDou above a 15° mask is ~15–20 satellites × 2 signals
//! (the `experiment rtk` scene: up to 24 × 2); selecting satellites by
//! elevation instead would throw away the redundancy that makes
//! instantaneous fixing possible. The joint covariance is then 72 × 72
//! (on the stack, 41 kB). A record beyond the capacity (only possible when
//! freed slots lag, not from one epoch) is not used and counted
//! ([`RtkSatCounts::capacity`]).
//!
//! **Measurements** (Teunissen & Montenbruck, *Springer Handbook of GNSS*
//! 2017, ch. 26; RTKLIB `ddres`), per system and signal against its
//! highest-elevation satellite `r`:
//! `DDP_i = (ρ_r,i − ρ_b,i) − (ρ_r,r − ρ_b,r)` and
//! `DDΦ_i = DDP_i + λ (a_i − a_r)`, with `ρ_r` predicted at the rover
//! *antenna* `r + C_bn l` (lever arm `l`), `ρ_b` at the base, each from its
//! own receiver's satellite state, earth rotation during travel
//! ([`geometric_range`]), satellite clocks, and the troposphere modelled at
//! both sites (Saastamoinen + Niell, [`crate::gnss::tropo`], as `navfuse
//! baseline`). Receiver clocks and inter-system biases cancel, so there are
//! no clock states. GLONASS (FDMA: DD ambiguities not integer without
//! inter-frequency bias calibration) is not used ([`RtkSatCounts::bad`]).
//! `H = [−Δuᵀ, 0, −Δuᵀ[l_n×], 0…, +λ (a_i), −λ (a_r)]`, `Δu = u_i − u_r`
//! (NED lines of sight from the rover antenna).
//! With [`RtkConfig::float_links`] (on in [`RtkConfig::consumer`]) the
//! phase DDs of all groups are formed against one master reference
//! (`+λ_i a_i − λ_m a_m`): each group's own reference then adds a DD whose
//! ambiguity part, with the receivers' hardware phase biases, is a float
//! the SD states carry (the group's common part, otherwise unobserved);
//! the integer DDs LAMBDA fixes stay within groups.
//!
//! **Differential ionosphere** ([`RtkConfig::iono_estimate`], on in
//! [`RtkConfig::consumer`]): [`NION`] more states in the block, one per
//! satellite, the SD slant delay `I` on 1575.42 MHz beyond the broadcast
//! model; the DD code gets `+γ_i I_i − γ_r I_r`, the DD phase the negative
//! (`γ_f = (λ_f/λ_L1)²`), so two frequencies separate it from the range.
//! Gauss–Markov, σ = `iono_ppm` × |baseline| × single-layer obliquity. Off,
//! it is white noise of that σ in every SD variance: measured on the
//! `experiment rtk` scene (1 ppm, 5.4 km) that made the fixed epochs
//! 3.5–4.4 cm RMS with 72–76 % coverage, up to 30 cm on seeds whose
//! time-correlated ionosphere biased the float ambiguities by ~1 cycle
//! (right integers, biased conditional update), and 11 wrong fixed epochs
//! in seeds 21–40; estimated, 0.3–0.9 cm and 97–99 %.
//!
//! **Weights**: undifferenced phase `σ² = a² + b²/sin²el`, a = b = 3 mm
//! (RTKLIB defaults `stats-errphase`, `stats-errphaseel`, manual 2.4.3
//! Table F.4-1), code either the same × `stats-eratio1` = 100 (RTKLIB) or
//! the receiver's code model ([`RtkConfig::code_model`]). SD variance
//! `v_i = σ²_rover,i + σ²_base,i`; the exact DD covariance
//! `C = diag(v_i) + v_r 1 1ᵀ` (correlated through the reference). Each DD is
//! first χ²-gated on its own (one degree of freedom, its innovation against
//! the state updated by the groups processed before it, variance
//! `h P hᵀ + C_ii`; counted by satellite). A phase DD beyond its gate
//! re-initialises its ambiguity (in practice a slip the test missed),
//! unless most DDs of its group fail, which blames the reference (its slot
//! is re-initialised and the group's phase skipped this epoch,
//! [`RtkSatCounts::ref_resets`]). The accepted ones are whitened with the
//! Cholesky factor `C = L Lᵀ` (`z̃ = L⁻¹ z`, `H̃ = L⁻¹ H`) and processed as
//! independent scalar updates, which equals the vector update
//! (`rtk_tests::whitened_equals_vector_update`).
//!
//! **Slots**: a satellite-signal common to both receivers above the mask
//! gets a slot, initialised from code, `a = (SDΦ − SDP)/λ`, with σ =
//! [`RtkConfig::amb_prior_m`]/λ and no correlation; a loss-of-lock flag
//! (either receiver) or a detected slip re-initialises it; a slot whose
//! satellite-signal is missing from an epoch is freed.
//!
//! **INS-predicted cycle slips**: per slot, the time-differenced SD phase
//! minus the time-differenced SD range predicted at the INS antenna (the
//! posterior at the previous epoch, the INS prediction now), minus the
//! median of this over all records (the receivers' clock changes, common
//! to every satellite and signal); tested against
//! `σ² = 2 (v_i,now + v_i,prev) + uᵀ P_Δr u` (phase noise of the four
//! phases; the covariance of the INS position change since the last epoch,
//! `P_Δr = P_rr + P_cc − P_rc − P_cr`, from a clone `c` of the position
//! error made after each epoch's update and propagated with the filter —
//! stochastic cloning, Roumeliotis & Burdick, ICRA 2002 — so position
//! uncertainty common to both epochs does not count) with the χ²₁ quantile
//! of [`RtkConfig::slip_probability`]. Needs ≥ 3 records with a
//! previous epoch (a median of two cannot tell which slipped).
//! Not run in [`RtkConfig::gnss_only`] mode.
//!
//! **Dual-frequency slips**: then, for each satellite with both signals in
//! slots and neither reset this epoch, the geometry-free and
//! Melbourne–Wübbena tests of [`crate::gnss::slip`] on the single
//! differences (thresholds and sources there); a slip re-initialises both
//! signals ([`RtkSatCounts::dual_slips`]).
//!
//! **Fixing** (Teunissen 1995 LAMBDA, [`crate::lambda`]): DD float
//! ambiguities `â = D a`, `Q = D P_aa Dᵀ` of the phase DDs used this epoch;
//! partial ambiguity resolution: the subset starts with all of them and
//! drops the one with the largest variance until the bootstrapped success
//! rate (Teunissen 1998, a lower bound of the ILS success rate) is
//! ≥ [`RtkConfig::success_min`] and the ratio test `s₂/s₁ ≥`
//! [`RtkConfig::ratio_min`] passes with ≥ [`RtkConfig::min_fix`]
//! ambiguities. Fixed solution by the conditional update
//! `x̌ = x̂ − P_x,â Q⁻¹ (â − ǎ)` (Teunissen 1995 eq. 7), reported beside the
//! float ([`RtkSolution`]); the float filter is not changed unless
//! fix-and-hold is on ([`RtkConfig::fix_and_hold`]: the fixed DDs fed back
//! as pseudo-measurements with variance 0.001 cycle², RTKLIB `holdamb`'s
//! `VAR_HOLDAMB`).
//!
//! Limits (honestly): the RTS smoother's records do not carry the
//! ambiguity block; RTK refuses tight coupling, augmented states and the
//! sensitivity covariance (their joint updates are not written); `with_rtk`
//! must be the last configuration call.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix equations

use super::tight::TightConfig;
use super::{apply_correction, skew, Eskf, FSparse, UpdateReject, I_ATT, I_POS, I_VEL, NX};
use crate::earth;
use crate::geodesy::{c_en, geodetic_to_ecef, Geodetic};
use crate::gnss::raw::{
    geometric_range, GnssSystem, RawEpoch, RawSat, Signal, FLAG_LOSS_OF_LOCK, MAX_RAW_SATS,
};
use crate::gnss::tropo::{day_of_year, slant_delay};
use crate::kalman;
use crate::lambda;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

mod gnss_only;

/// Ambiguity slots (module documentation).
pub const NAMB: usize = MAX_RAW_SATS;
/// Single-difference slant ionosphere slots, one per satellite
/// ([`RtkConfig::iono_estimate`]): an epoch holds at most
/// [`MAX_RAW_SATS`] records, two per dual-frequency satellite. A satellite
/// beyond them (single-frequency epochs of > 24 satellites) keeps the
/// white-noise weighting of [`RtkConfig::iono_ppm`].
pub const NION: usize = MAX_RAW_SATS / 2;
/// Index (within the block) of the first ionosphere slot.
const IION: usize = NAMB;
/// Ambiguities + ionosphere + the clone of the previous epoch's position
/// error.
const NK: usize = NAMB + NION + 3;
/// Index (within the block) of the position clone.
const ICL: usize = NAMB + NION;
/// Joint dimension (INS + block).
const NJ: usize = NX + NK;
/// Most (system, signal) groups of an epoch.
const NGROUP: usize = 12;
/// Largest position DOP of double differences that are to determine the
/// position on their own (RTKLIB `maxgdop`, `pos2-rejgdop`, default 30):
/// the code-DD solution of a GNSS-only (re)start
/// ([`Eskf::recentre_on_code`]) and the fixed phase DDs of a solution
/// reported as fixed ([`RtkSolution::position_fixed`]).
pub const MAX_DD_PDOP: f64 = 30.0;
/// Gauss–Newton steps of the code-DD solution (RTKLIB `pntpos` `MAXITR`
/// 10): it starts at the base, kilometres away.
const CODE_MAX_ITER: usize = 10;

/// Position DOP of double-difference rows, `√tr N⁻¹` with
/// `N = Σ_g H_gᵀ (I + 1 1ᵀ)⁻¹ H_g`: the unit-weight correlation of the DDs
/// of one group, which share their reference (`(I + 1 1ᵀ)⁻¹ = I − 1 1ᵀ /
/// (m_g + 1)`; the undifferenced PDOP with one clock per group). Groups
/// are keyed by the reference's record index. Counting DDs is not enough:
/// L1 and L2 of one satellite are two DDs along one line of sight.
struct DdDop {
    n: Mat3,
    grp: [(Vec3, usize); MAX_RAW_SATS],
}

impl DdDop {
    fn new() -> Self {
        DdDop {
            n: Mat3::zeros(),
            grp: [(Vec3::zeros(), 0); MAX_RAW_SATS],
        }
    }

    /// One DD row `h` (NED, per metre of position error) of the group whose
    /// reference is record `reference`.
    fn add(&mut self, reference: usize, h: Vec3) {
        self.n += h * h.transpose();
        if let Some(g) = self.grp.get_mut(reference) {
            g.0 += h;
            g.1 += 1;
        }
    }

    /// The unit-weight cofactor matrix of the position (`N⁻¹`) and the
    /// position DOP (∞ and `None` when the rows do not determine it).
    fn cofactor(&self) -> (f64, Option<Mat3>) {
        let mut nc = self.n;
        for (sg, mg) in self.grp.iter() {
            if *mg > 0 {
                nc -= sg * sg.transpose() / (*mg as f64 + 1.0);
            }
        }
        let cof = nc.cholesky().map(|c| c.inverse());
        let dop = cof
            .as_ref()
            .map_or(f64::INFINITY, |c| c.trace().max(0.0).sqrt());
        (if dop.is_nan() { f64::INFINITY } else { dop }, cof)
    }
}

/// Configuration of the RTK updates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtkConfig {
    /// Undifferenced phase σ² = a² + b²/sin²el [m].
    pub phase_a_m: f64,
    pub phase_b_m: f64,
    /// Code σ = `code_ratio` × phase σ (RTKLIB `stats-eratio1`), unless
    /// `code_model` is given.
    pub code_ratio: f64,
    /// Code variance of the receiver ([`TightConfig::pr_var_white`]:
    /// thermal noise by C/N0 and multipath by elevation, correlated
    /// multipath as its white equivalent) instead of `code_ratio`.
    pub code_model: Option<TightConfig>,
    /// Code multipath correlation time at the static base [s] for
    /// [`RtkConfig::code_model`]'s white equivalent (0: the rover's). A
    /// static antenna's multipath fades only as the satellite's elevation
    /// changes, with period λ / (2 h ω_el cos el) (Georgiadou & Kleusberg
    /// 1988, Manuscripta Geodaetica 13): minutes for reflectors metres away,
    /// far slower than a moving car's seconds.
    pub base_mp_tau_s: f64,
    /// Elevation mask at the rover [rad].
    pub elevation_mask_rad: f64,
    /// Relative humidity of the troposphere model at both sites.
    pub humidity: f64,
    /// χ² gate probability of each DD (one degree of freedom).
    pub gate_probability: f64,
    /// Probability of the cycle-slip test (1 − false-alarm rate).
    pub slip_probability: f64,
    /// Prior σ of a new SD ambiguity [m] (divided by λ for cycles).
    pub amb_prior_m: f64,
    /// Baseline-dependent (differential) ionosphere, σ of the single
    /// difference per unit baseline at the zenith on 1575.42 MHz [ppm =
    /// mm/km]: added to the SD code and phase variances as
    /// `(ppm · 10⁻⁶ · |b| · M(el) · γ_f)²` (`M` the single-layer obliquity,
    /// 350 km shell; `γ_f = (λ_f/λ_L1)²`). 0 = not modelled (RTKLIB's
    /// `stats-errphasebl` default).
    pub iono_ppm: f64,
    /// Estimate the differential ionosphere instead of weighting it as
    /// white noise: one state per satellite, the single-difference
    /// (rover − base) slant delay on 1575.42 MHz `I` [m] in the DD code
    /// (`+γ_f ΔI`) and phase (`−γ_f ΔI`) of every signal of the satellite
    /// (first-order ionosphere, Springer Handbook of GNSS 2017 ch. 26, the
    /// "ionosphere-weighted" model; RTKLIB `pos1-ionoopt = est-stec`).
    /// Gauss–Markov with σ = [`RtkConfig::iono_ppm`] × |baseline| × M(el)
    /// (prior and stationary σ) and correlation time
    /// [`RtkConfig::iono_tau_s`], plus the change the rover's own motion
    /// makes, `(iono_ppm · |Δb| · M)²` per epoch. The differential
    /// ionosphere is slow (minutes), so as white noise it is averaged down
    /// epoch after epoch and the fixed position inherits it as a bias
    /// with a σ that does not contain it. Needs `iono_ppm > 0`.
    pub iono_estimate: bool,
    /// Correlation time of the differential ionosphere states [s].
    pub iono_tau_s: f64,
    /// Inter-system DDs where two systems share a frequency: Galileo E1
    /// with GPS L1 (1575.42 MHz) and BeiDou B2I with Galileo E5b
    /// (1207.14 MHz) against one reference (Odijk & Teunissen 2013, GPS
    /// Solutions 17:521, "tightly combined" GPS + Galileo RTK). Valid only
    /// when the between-receiver inter-system bias is zero, i.e. rover and
    /// base receivers of the same type (their study: L1-E1 and L5-E5a ISBs
    /// absent for same-type receivers); with 4 satellites of 3 systems it is
    /// what leaves enough DDs to keep the position (4 satellites give 3
    /// DDs per shared frequency instead of ≤ 1 per system). Off by default.
    pub inter_system: bool,
    /// Float links between the DD groups: the phase DDs of every group are
    /// formed against one master reference (the highest satellite of all
    /// groups), so a group's own reference enters as the DD
    /// `SDΦ_ref,g − SDΦ_master` (different systems or frequencies; the
    /// receiver clock cancels in metres). Its ambiguity part
    /// `λ_g a_ref,g − λ_m a_master` plus the between-receiver hardware
    /// phase bias of the two signals is **not** an integer, and nothing
    /// here assumes it is: with single-difference ambiguity states it is
    /// the common part of group g's states, which the links make
    /// observable and the filter estimates as a float (constant, as the
    /// ambiguities; the between-receiver phase biases are stable over days,
    /// Odijk & Teunissen 2013, GPS Solutions 17:521; Paziewski & Wielgosz
    /// 2015, J. Geodesy 89:81, whose "tight combining" with an estimated
    /// inter-system bias this is, extended to any pair of frequencies). Fixing stays within each group
    /// (integer DDs only). What the links add is geometry: with few
    /// satellites of several systems each group has ≤ 1 DD, and the float
    /// links, learnt while the sky was full, keep every satellite's line
    /// of sight. Code DDs stay within groups (their hardware biases are
    /// metres, and code adds little once the phase is linked). The update
    /// is the exact one: all phase SDs against one reference with
    /// `C = diag(v_i) + v_m 1 1ᵀ`, an invertible transform of the
    /// per-group DDs plus one link per group. Off in [`RtkConfig::rtklib`]
    /// (RTKLIB's `ddres` forms DDs within a system and frequency).
    pub float_links: bool,
    /// Ratio test threshold and bootstrapped success-rate threshold.
    pub ratio_min: f64,
    pub success_min: f64,
    /// Fewest DD ambiguities a (partial) fix may have.
    pub min_fix: usize,
    /// Feed the fixed DDs back into the float filter.
    pub fix_and_hold: bool,
    /// GNSS-only kinematic mode, for comparison runs: position, velocity
    /// and ambiguities follow their own constant-velocity model (RTKLIB
    /// kinematic with dynamics), not the INS, and the INS-predicted slip
    /// test is off (`rtk/gnss_only.rs`). `gnss_only_sigma`: σ of the
    /// position [m] and velocity [m/s] at a (re)start from the code
    /// solution, and the posterior position σ beyond which it restarts
    /// (RTKLIB `VAR_POS`).
    pub gnss_only: bool,
    pub gnss_only_sigma: f64,
}

impl RtkConfig {
    /// RTKLIB's defaults (manual 2.4.3 Appendix F): phase a = b = 3 mm,
    /// code ratio 100, elevation mask 15° (`pos1-elmask`), ratio 3
    /// (`pos2-arthres`), hydrostatic troposphere only (relative mode,
    /// as `navfuse baseline`);
    /// - gate 0.9999 per DD (χ²₁ = 15.1, a 3.9σ test; the tight filter's);
    /// - slip test 0.9999: a 1-cycle slip (19 cm at L1) is > 10σ once the
    ///   INS velocity is known to 1–2 cm/s, while a false alarm (a reset)
    ///   costs ~1e-4 per satellite and epoch;
    /// - new ambiguity σ 30 m/λ (RTKLIB `stats-stdbias` 30): several times
    ///   the SD code error of the init, so the init's code error, which is
    ///   also a DD code measurement of that epoch, is not counted twice in
    ///   any material way, and the prior does not constrain the estimate;
    /// - success rate ≥ 0.999 of the bootstrapped estimator (Teunissen 1998,
    ///   J. Geodesy 72:606; Verhagen 2005 "The GNSS integer ambiguities:
    ///   estimation and validation" uses failure rates ≤ 0.001), with ≥ 4
    ///   ambiguities (position + redundancy);
    /// - fix-and-hold off (RTKLIB `pos2-armode` default continuous).
    pub fn rtklib() -> Self {
        RtkConfig {
            phase_a_m: 0.003,
            phase_b_m: 0.003,
            code_ratio: 100.0,
            code_model: None,
            base_mp_tau_s: 0.0,
            elevation_mask_rad: 15f64.to_radians(),
            humidity: 0.0,
            gate_probability: 0.9999,
            slip_probability: 0.9999,
            amb_prior_m: 30.0,
            iono_ppm: 0.0,
            iono_estimate: false,
            iono_tau_s: 600.0,
            inter_system: false,
            float_links: false,
            ratio_min: 3.0,
            success_min: 0.999,
            min_fix: 4,
            fix_and_hold: false,
            gnss_only: false,
            gnss_only_sigma: 30.0,
        }
    }

    /// A consumer receiver: [`RtkConfig::rtklib`] with the code variance of
    /// [`TightConfig::consumer`] (DLL thermal noise by C/N0, multipath
    /// 0.6 m / sin el) with its multipath correlated over 10 s at 1 Hz
    /// (weighted as the white noise of the same low-frequency power; the
    /// value `TightConfig` documents for a moving car), and the standard
    /// atmosphere's humidity 0.7 (RTKLIB `REL_HUMI`) in the troposphere
    /// model at both sites; the differential ionosphere σ 1 ppm
    /// ([`RtkConfig::iono_ppm`]: 1–2 ppm typical of mid-latitude baselines
    /// under quiet conditions, Wanninger 1993, Odijk 2002 ch. 5, Springer
    /// Handbook of GNSS 2017 ch. 26; the lower end: a stormy day makes the
    /// σ optimistic), estimated per satellite ([`RtkConfig::iono_estimate`])
    /// with a correlation time of 600 s: the mid-latitude differential
    /// ionosphere of short baselines is dominated by medium-scale
    /// travelling ionospheric disturbances of 10–60 min period
    /// (Hernández-Pajares et al. 2006, J. Geophys. Res. 111, A07S11); the
    /// short end, so the filter remembers less than the sky may. The
    /// base's code multipath correlated over 120 s
    /// ([`RtkConfig::base_mp_tau_s`]: λ / (2 h ω_el cos el) for reflectors
    /// 5–10 m from a rooftop antenna at GPS's highest elevation rate
    /// 1.46e-4 rad/s, cos el 0.7: 1.5–3 min; the short end, the smaller
    /// inflation). Measured on the `experiment rtk` scene (20 seeds): the
    /// float σ covered the truth 80–86 % of the time with the rover's 10 s
    /// at the base too, 95–99.6 % with 120 s. The groups float-linked
    /// ([`RtkConfig::float_links`]: no assumption about the receivers'
    /// inter-system or inter-frequency biases, only more geometry).
    pub fn consumer() -> Self {
        RtkConfig {
            float_links: true,
            iono_ppm: 1.0,
            iono_estimate: true,
            base_mp_tau_s: 120.0,
            code_model: Some(TightConfig {
                mp_tau_s: 10.0,
                interval_s: 1.0,
                ..TightConfig::consumer()
            }),
            humidity: super::tight::REL_HUMIDITY,
            ..Self::rtklib()
        }
    }

    fn is_valid(&self) -> bool {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        pos(self.phase_a_m)
            && self.phase_b_m.is_finite()
            && self.phase_b_m >= 0.0
            && pos(self.code_ratio)
            && self.elevation_mask_rad.is_finite()
            && (0.0..=1.0).contains(&self.humidity)
            && self.gate_probability > 0.0
            && self.gate_probability < 1.0
            && self.slip_probability > 0.0
            && self.slip_probability < 1.0
            && pos(self.amb_prior_m)
            && self.iono_ppm.is_finite()
            && self.iono_ppm >= 0.0
            && pos(self.iono_tau_s)
            && self.ratio_min >= 1.0
            && self.success_min > 0.0
            && self.success_min < 1.0
            && self.min_fix >= 1
            && self.min_fix <= NAMB
            && pos(self.gnss_only_sigma)
            && self.base_mp_tau_s.is_finite()
            && self.base_mp_tau_s >= 0.0
    }

    /// The DD group (system, signal) of a record: its own, or with
    /// [`RtkConfig::inter_system`] the group of the system sharing its
    /// frequency (Galileo E1 with GPS L1, BeiDou B2I with Galileo E5b).
    /// Each group's DDs are formed against its own highest satellite.
    pub fn dd_group(&self, system: GnssSystem, signal: Signal) -> (GnssSystem, Signal) {
        match (self.inter_system, signal) {
            (true, Signal::GalE1) => (GnssSystem::Gps, Signal::GpsL1Ca),
            (true, Signal::BdsB2I) => (GnssSystem::Galileo, Signal::GalE5b),
            _ => (system, signal),
        }
    }

    /// Undifferenced phase variance [m²] at elevation `el`.
    pub fn phase_var(&self, el: f64) -> f64 {
        let s = el.sin().max(0.05);
        self.phase_a_m * self.phase_a_m + self.phase_b_m * self.phase_b_m / (s * s)
    }

    /// Undifferenced code variance [m²] at elevation `el`, C/N0 `cn0`.
    pub fn code_var(&self, el: f64, cn0: f64) -> f64 {
        match &self.code_model {
            Some(tc) => tc.pr_var_white(el, cn0),
            None => self.phase_var(el) * self.code_ratio * self.code_ratio,
        }
    }

    /// The same at the static base ([`RtkConfig::base_mp_tau_s`]).
    pub fn base_code_var(&self, el: f64, cn0: f64) -> f64 {
        match (&self.code_model, self.base_mp_tau_s > 0.0) {
            (Some(tc), true) => TightConfig {
                mp_tau_s: self.base_mp_tau_s,
                ..*tc
            }
            .pr_var_white(el, cn0),
            _ => self.code_var(el, cn0),
        }
    }
}

/// Why [`Eskf::with_rtk`] refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RtkConfigError {
    /// A σ or probability out of range.
    Invalid,
    /// Tight coupling, augmented states or the sensitivity covariance is
    /// configured (their joint updates with the ambiguities are not written).
    Incompatible,
}

impl core::fmt::Display for RtkConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RtkConfigError::Invalid => write!(
                f,
                "rtk: need positive sigmas, probabilities in (0, 1), ratio >= 1, \
                 1 <= min_fix <= {NAMB}"
            ),
            RtkConfigError::Incompatible => write!(
                f,
                "rtk cannot run with tight coupling, augmented states or the \
                 sensitivity covariance"
            ),
        }
    }
}

/// Why [`Eskf::rtk_update`] did nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RtkError {
    /// RTK is not configured.
    NotEnabled,
    /// The filter has not started (no IMU sample yet).
    NotStarted,
    /// The base position is not finite.
    BadBase,
}

impl core::fmt::Display for RtkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RtkError::NotEnabled => write!(f, "rtk update without Eskf::with_rtk"),
            RtkError::NotStarted => write!(f, "rtk update before the first IMU sample"),
            RtkError::BadBase => write!(f, "rtk update: base position not finite"),
        }
    }
}

/// What happened to a satellite's records (all its signals), by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RtkSatCounts {
    pub code_used: u32,
    pub code_gated: u32,
    pub phase_used: u32,
    pub phase_gated: u32,
    /// Below the elevation mask.
    pub low_elevation: u32,
    /// Not observed (with phase and code) by the base.
    pub no_base: u32,
    /// No ephemeris, non-finite observable, GLONASS.
    pub bad: u32,
    /// No free ambiguity slot.
    pub capacity: u32,
    /// Slot initialisations on rise/acquisition.
    pub rises: u32,
    /// Slots freed because the satellite-signal was missing.
    pub sets: u32,
    /// Re-initialisations on a loss-of-lock flag.
    pub lli_resets: u32,
    /// Re-initialisations on an INS-detected cycle slip.
    pub slips: u32,
    /// Re-initialisations (of both signals) on a dual-frequency
    /// geometry-free or Melbourne–Wübbena slip ([`crate::gnss::slip`]).
    pub dual_slips: u32,
    /// Re-initialisations because the reference's DDs failed their gates.
    pub ref_resets: u32,
}

/// Counters of the RTK updates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtkStats {
    pub epochs: u64,
    /// Per system and PRN (index `system.index() · 64 + prn % 64`).
    pub per_sat: [RtkSatCounts; 256],
    /// Epochs whose slip test had < 3 records with a previous epoch.
    pub slip_untestable: u64,
    /// Reference satellite changes (per system and signal).
    pub reference_changes: u64,
    /// Fix decisions: attempts (epochs with ≥ 1 DD ambiguity), fixed
    /// (of which partial: fewer than all candidates), and the reason of the
    /// epochs not fixed (the last subset tried): too few ambiguities,
    /// success rate, ratio, LAMBDA failure.
    pub fix_attempts: u64,
    pub fixed: u64,
    /// Fixed on a subset, the position fixed (not weak geometry).
    pub fixed_partial: u64,
    /// Fixed, but the fixed DDs alone do not determine the position
    /// (position DOP > [`MAX_DD_PDOP`]): reported as float
    /// ([`RtkSolution::position_fixed`]).
    pub fixed_weak_geometry: u64,
    pub rejected_too_few: u64,
    pub rejected_success_rate: u64,
    pub rejected_ratio: u64,
    pub rejected_lambda: u64,
    /// Fixed DDs fed back (fix-and-hold).
    pub held: u64,
    /// Σ NIS and count of the used code and phase DDs (whitened).
    pub nis_code: (f64, u64),
    pub nis_phase: (f64, u64),
    /// INS-aided: epochs whose position failed the test against the code
    /// solution and was reset to it, the ambiguities with it
    /// ([`Eskf::rtk_test_position_on_code`]).
    pub position_resets: u64,
}

impl Default for RtkStats {
    fn default() -> Self {
        RtkStats {
            epochs: 0,
            per_sat: [RtkSatCounts::default(); 256],
            slip_untestable: 0,
            reference_changes: 0,
            fix_attempts: 0,
            fixed: 0,
            fixed_partial: 0,
            fixed_weak_geometry: 0,
            rejected_too_few: 0,
            rejected_success_rate: 0,
            rejected_ratio: 0,
            rejected_lambda: 0,
            held: 0,
            position_resets: 0,
            nis_code: (0.0, 0),
            nis_phase: (0.0, 0),
        }
    }
}

impl RtkStats {
    /// Counts of one satellite.
    pub fn sat(&self, system: GnssSystem, prn: u8) -> &RtkSatCounts {
        &self.per_sat[system.index() * 64 + prn as usize % 64]
    }
    /// Totals over all satellites.
    pub fn total(&self) -> RtkSatCounts {
        self.per_sat
            .iter()
            .fold(RtkSatCounts::default(), |a, s| RtkSatCounts {
                code_used: a.code_used + s.code_used,
                code_gated: a.code_gated + s.code_gated,
                phase_used: a.phase_used + s.phase_used,
                phase_gated: a.phase_gated + s.phase_gated,
                low_elevation: a.low_elevation + s.low_elevation,
                no_base: a.no_base + s.no_base,
                bad: a.bad + s.bad,
                capacity: a.capacity + s.capacity,
                rises: a.rises + s.rises,
                sets: a.sets + s.sets,
                lli_resets: a.lli_resets + s.lli_resets,
                slips: a.slips + s.slips,
                dual_slips: a.dual_slips + s.dual_slips,
                ref_resets: a.ref_resets + s.ref_resets,
            })
    }
}

/// `p −= ph phᵀ / s` in place on a symmetric `p`, as `p −= u uᵀ` with
/// `u = ph / √s`: column by column over the whole matrix (contiguous,
/// vectorised), and still exactly symmetric because `u_i u_j = u_j u_i`
/// in floating point; columns with `u_j = 0` (unused slots, states the row
/// does not reach) are left as they are (profiled hot: every DD row of
/// every epoch).
fn rank1_downdate(p: &mut SMatrix<f64, NJ, NJ>, ph: &SVector<f64, NJ>, s: f64) {
    let u = ph / s.sqrt();
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if std::is_x86_feature_detected!("avx2") {
        #[allow(unsafe_code)]
        // SAFETY: AVX2 was detected on this CPU just above.
        unsafe {
            rank1_downdate_avx2(p, &u)
        };
        return;
    }
    rank1_downdate_body(p, &u)
}

/// [`rank1_downdate`] compiled with AVX2 (4-wide f64 vectors).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
fn rank1_downdate_avx2(p: &mut SMatrix<f64, NJ, NJ>, u: &SVector<f64, NJ>) {
    rank1_downdate_body(p, u)
}

#[inline(always)]
fn rank1_downdate_body(p: &mut SMatrix<f64, NJ, NJ>, u: &SVector<f64, NJ>) {
    let us = u.as_slice();
    let ps = p.as_mut_slice();
    for (j, &uj) in us.iter().enumerate() {
        if uj == 0.0 {
            continue;
        }
        for (d, &ui) in ps[NJ * j..NJ * (j + 1)].iter_mut().zip(us) {
            *d -= ui * uj;
        }
    }
}

/// `p h` for a DD row `h` with a few non-zeros (position, attitude, two
/// ambiguities, two ionosphere states; more once whitened within a
/// group): the columns of `p` at the non-zeros only (profiled hot: the
/// dense product was most of `rtk_update`).
fn mul_sparse(p: &SMatrix<f64, NJ, NJ>, h: &SVector<f64, NJ>) -> SVector<f64, NJ> {
    let mut out = SVector::<f64, NJ>::zeros();
    for (k, &hk) in h.iter().enumerate() {
        if hk != 0.0 {
            out.axpy(hk, &p.column(k), 1.0);
        }
    }
    out
}

/// Key of an ambiguity: (system, PRN, signal).
pub type AmbKey = (GnssSystem, u8, Signal);

/// One fixed DD ambiguity `N_prn − N_ref` [cycles].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct FixedDd {
    pub system: GnssSystem,
    pub signal: Signal,
    pub prn: u8,
    pub ref_prn: u8,
    /// The reference's system and signal (differ from `system`, `signal`
    /// only with [`RtkConfig::inter_system`]).
    pub ref_system: GnssSystem,
    pub ref_signal: Signal,
    pub n: i64,
}

/// The result of one RTK epoch: float (the filter's state after the update)
/// and, when the validation passed, the fixed solution beside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtkSolution {
    pub t: f64,
    /// DDs used (code, phase).
    pub n_code: usize,
    pub n_phase: usize,
    /// DD ambiguities offered to LAMBDA and fixed.
    pub n_candidates: usize,
    pub n_fixed: usize,
    pub fixed: bool,
    /// Position DOP of the fixed phase DDs alone (unit weight, DD
    /// correlation per group; ∞ when not fixed or when they do not
    /// determine the position): how well the integers, without the INS,
    /// fix the antenna.
    pub fix_pdop: f64,
    /// Ratio and bootstrapped success rate of the subset finally tried.
    pub ratio: f64,
    pub success_rate: f64,
    /// IMU position: float (the filter) and fixed (equal to the float when
    /// not fixed), with their NED 1-σ [m].
    pub float_pos: Geodetic,
    pub float_std_ned: Vec3,
    pub pos: Geodetic,
    pub std_ned: Vec3,
    /// The fixed DD integers (`[..n_fixed]`).
    pub fixed_dd: [FixedDd; NAMB],
}

impl RtkSolution {
    /// A fixed solution in the sense of a receiver's "RTK fixed" (RTKLIB
    /// Q = 1): the integers validated **and** the fixed phase DDs alone
    /// determining the antenna position (`fix_pdop ≤` [`MAX_DD_PDOP`]).
    /// With fewer independent lines of sight (4 satellites of 2–3
    /// systems: one DD per group, L1 and L2 along one line) the validated
    /// integers still hold, but the position's remaining directions come
    /// from the INS, at decimetres. `experiment rtk --seeds 20` (its six
    /// filter rows pooled): 5 407 validated epochs with DOP > 100 or
    /// undetermined (horizontal RMS 0.33 m, largest 1.85 m, all but 2 in
    /// its 4-satellite window) against 60 974 with DOP ≤ 5 (RMS 3 mm,
    /// largest 4.2 cm) and none in between.
    pub fn position_fixed(&self) -> bool {
        self.fixed && self.fix_pdop <= MAX_DD_PDOP
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Slot {
    key: Option<AmbKey>,
    lambda: f64,
    /// Previous epoch: receiver time, SD phase [m], SD range predicted at
    /// the posterior antenna [m] (NaN: none).
    prev_t: f64,
    prev_phi: f64,
    prev_rho: f64,
    prev_var: f64,
    seen: bool,
}

impl Default for Slot {
    fn default() -> Self {
        Slot {
            key: None,
            lambda: 0.0,
            prev_t: f64::NAN,
            prev_phi: f64::NAN,
            prev_rho: f64::NAN,
            prev_var: 0.0,
            seen: false,
        }
    }
}

/// The RTK block of the filter.
#[derive(Clone, Debug)]
pub(super) struct Rtk {
    cfg: RtkConfig,
    /// Ambiguities [cycles], then the clone (unused, 0).
    x: SVector<f64, NK>,
    p_xa: SMatrix<f64, NX, NK>,
    p_aa: SMatrix<f64, NK, NK>,
    /// The clone holds a previous epoch's position error.
    clone_set: bool,
    slots: [Slot; NAMB],
    /// Ionosphere slots: satellite, seen this epoch.
    ion: [(Option<(GnssSystem, u8)>, bool); NION],
    /// Time of the ionosphere states [s] and the rover antenna (ECEF) then.
    ion_t: f64,
    ion_r: Vec3,
    /// Reference PRN of each (system, signal) group last epoch.
    refs: [(Option<(GnssSystem, Signal)>, u8); NGROUP],
    gate: f64,
    slip_gate: f64,
    /// GNSS-only mode: the constant-velocity model's last posterior.
    cv: Option<gnss_only::CvPosterior>,
    /// GNSS-only mode: the INS attitude rows of `P` during the update.
    att_aside: Option<gnss_only::AttRows>,
    /// GNSS-only mode: every code DD of the last epoch failed its gate
    /// (the filter has lost itself; `rtk/gnss_only.rs`).
    lost: bool,
    /// INS-aided: most code DDs of the last epoch failed their gate, so
    /// the next epoch tests the position against the code solution
    /// ([`Eskf::rtk_test_position_on_code`]).
    suspect: bool,
    /// Largest single-difference code variance of the last epoch [m²]
    /// (the unit variance of that test's code solution).
    code_var_max: f64,
    /// Dual-frequency slip detectors on the single differences.
    dual: crate::gnss::slip::DualFreqSlip,
    pub(super) stats: RtkStats,
}

/// The RTK block as the filter holds it: boxed where an allocator exists
/// (the `alloc`/`std` builds; allocated once, by [`Eskf::with_rtk`]), so
/// every filter without RTK — the plain path, the yaw bank's members —
/// does not carry its ≈ 60 kB of covariance (the experiments and the test
/// harness run filters on 2 MiB thread stacks,
/// `navfuse_pipeline::experiments::WORKER_STACK_BYTES`); inline without
/// an allocator.
#[cfg(feature = "alloc")]
pub(super) type RtkBlock = alloc::boxed::Box<Rtk>;
#[cfg(not(feature = "alloc"))]
pub(super) type RtkBlock = Rtk;

fn rtk_block(r: Rtk) -> RtkBlock {
    #[cfg(feature = "alloc")]
    {
        alloc::boxed::Box::new(r)
    }
    #[cfg(not(feature = "alloc"))]
    {
        r
    }
}

impl Rtk {
    pub(super) fn new(cfg: RtkConfig) -> Result<Self, RtkConfigError> {
        if !cfg.is_valid() {
            return Err(RtkConfigError::Invalid);
        }
        Ok(Rtk {
            cfg,
            x: SVector::zeros(),
            p_xa: SMatrix::zeros(),
            p_aa: SMatrix::zeros(),
            clone_set: false,
            slots: [Slot::default(); NAMB],
            ion: [(None, false); NION],
            ion_t: f64::NAN,
            ion_r: Vec3::zeros(),
            refs: [(None, 0); NGROUP],
            gate: kalman::chi2_quantile(1, cfg.gate_probability),
            slip_gate: kalman::chi2_quantile(1, cfg.slip_probability),
            cv: None,
            att_aside: None,
            lost: false,
            suspect: false,
            code_var_max: 0.0,
            dual: Default::default(),
            stats: RtkStats::default(),
        })
    }

    /// `P_xa ← Φ_x P_xa` over `dt` with the filter's `F`.
    /// `P_xa ← P_xa + F P_xa dt`, at every IMU sample, skipping the
    /// columns of unused slots (all zero, and F keeps them so).
    ///
    /// Sixteen columns at a time: they are copied into a row-major 21×16
    /// tile so that each non-zero `F[i,k]` is four 4-wide multiply-adds of
    /// tile row `k` into accumulator row `i` (independent chains in
    /// registers),
    /// instead of a scalar gather per column (profiled: a fifth of an RTK/INS
    /// run). Every element is still the sum over row `i` of `F` in the same
    /// order, then `+= acc·dt`: bit-identical to the column-by-column form.
    pub(super) fn propagate(&mut self, fs: &FSparse, dt: f64) {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if std::is_x86_feature_detected!("avx2") {
            #[allow(unsafe_code)]
            // SAFETY: AVX2 was detected on this CPU just above.
            unsafe {
                self.propagate_avx2(fs, dt)
            };
            return;
        }
        self.propagate_body(fs, dt)
    }

    /// [`Rtk::propagate`] compiled with AVX2 (4-wide f64 vectors).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[target_feature(enable = "avx2")]
    fn propagate_avx2(&mut self, fs: &FSparse, dt: f64) {
        self.propagate_body(fs, dt)
    }

    #[inline(always)]
    fn propagate_body(&mut self, fs: &FSparse, dt: f64) {
        const W: usize = 16;
        let ps = self.p_xa.as_mut_slice();
        let mut c0 = 0;
        while c0 < NK {
            let w = W.min(NK - c0);
            let block = &mut ps[NX * c0..NX * (c0 + w)];
            if block.iter().all(|v| *v == 0.0) {
                c0 += w;
                continue;
            }
            // Row-major tile: tile[k][l] = P_xa[k, c0 + l].
            let mut tile = [[0.0f64; W]; NX];
            for l in 0..w {
                for k in 0..NX {
                    tile[k][l] = block[NX * l + k];
                }
            }
            // One row of accumulators at a time (W/4 registers, independent
            // chains); the tile holds the old values, so the block is
            // written in place.
            for i in 0..NX {
                let mut a = [0.0f64; W];
                for j in fs.start[i]..fs.start[i + 1] {
                    let (k, v) = (fs.col[j].min(NX - 1), fs.val[j]);
                    let src = &tile[k];
                    for l in 0..W {
                        a[l] += v * src[l];
                    }
                }
                for l in 0..w {
                    block[NX * l + i] += a[l] * dt;
                }
            }
            c0 += w;
        }
    }

    fn full(&self, p: &SMatrix<f64, NX, NX>) -> SMatrix<f64, NJ, NJ> {
        let mut f = SMatrix::<f64, NJ, NJ>::zeros();
        f.fixed_view_mut::<NX, NX>(0, 0).copy_from(p);
        f.fixed_view_mut::<NX, NK>(0, NX).copy_from(&self.p_xa);
        f.fixed_view_mut::<NK, NX>(NX, 0)
            .copy_from(&self.p_xa.transpose());
        f.fixed_view_mut::<NK, NK>(NX, NX).copy_from(&self.p_aa);
        f
    }

    /// The blocks of `f`, symmetrised: `(A + Aᵀ)·0.5` element by element
    /// in place (the same operations as the matrix expression, so
    /// bit-identical, without its temporaries: profiled hot, every IMU-rate
    /// update of an RTK run passes here).
    fn split(&mut self, f: &SMatrix<f64, NJ, NJ>, p: &mut SMatrix<f64, NX, NX>) {
        for j in 0..NX {
            for i in 0..NX {
                p[(i, j)] = (f[(i, j)] + f[(j, i)]) * 0.5;
            }
        }
        for j in 0..NK {
            for i in 0..NX {
                self.p_xa[(i, j)] = (f[(i, NX + j)] + f[(NX + j, i)]) * 0.5;
            }
            for i in 0..NK {
                self.p_aa[(i, j)] = (f[(NX + i, NX + j)] + f[(NX + j, NX + i)]) * 0.5;
            }
        }
    }

    /// An INS-only update (position fix, NHC, ZUPT…) done jointly with the
    /// ambiguity block so their correlation stays consistent.
    ///
    /// `H` touches the 21 INS states only, so the Joseph form
    /// `(I − KH) P (I − KH)ᵀ + K R Kᵀ` is evaluated block by block in its
    /// expanded form `P − K Uᵀ − U Kᵀ + K S Kᵀ` (`U = P Hᵀ`, `S = H U + R`,
    /// algebraically the same matrix) without forming the joint 96×96
    /// covariance: `O(N² M)` with no 73 kB copies at every 10 Hz NHC
    /// update (profiled hot). Gate and de-weighting as `aug::gated_update`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn joint_update<const M: usize>(
        &mut self,
        dx: &mut super::StateVec,
        p: &mut SMatrix<f64, NX, NX>,
        h: &SMatrix<f64, M, NX>,
        r: &SMatrix<f64, M, M>,
        dz: &SVector<f64, M>,
        gate: Option<f64>,
        deweight_factor: f64,
    ) -> Result<(f64, bool), (UpdateReject, f64)> {
        // U = P Hᵀ by blocks: U_x = P_xx hᵀ, U_a = P_xaᵀ hᵀ.
        let u_x: SMatrix<f64, NX, M> = *p * h.transpose();
        let u_a: SMatrix<f64, NK, M> = self.p_xa.tr_mul(&h.transpose());
        let hu: SMatrix<f64, M, M> = h * u_x;
        let factor = |r: &SMatrix<f64, M, M>| {
            let s = hu + r;
            let s = (s + s.transpose()) * 0.5;
            let ch = nalgebra::Cholesky::new(s)?;
            let mut y = *dz;
            if !ch.l_dirty().solve_lower_triangular_mut(&mut y) {
                return None;
            }
            Some((s, ch, y.norm_squared()))
        };
        let Some((mut s, mut ch, nis)) = factor(r) else {
            return Err((UpdateReject::Singular, f64::INFINITY));
        };
        if !nis.is_finite() {
            return Err((UpdateReject::Singular, nis));
        }
        let mut deweighted = false;
        if let Some(g) = gate.filter(|g| nis > *g) {
            if nis > g * deweight_factor {
                return Err((UpdateReject::Gate, nis));
            }
            let Some((s2, ch2, _)) = factor(&(r * (nis / g))) else {
                return Err((UpdateReject::Singular, nis));
            };
            (s, ch, deweighted) = (s2, ch2, true);
        }
        // Kᵀ = S⁻¹ Uᵀ.
        let mut kt_x = u_x.transpose();
        ch.solve_mut(&mut kt_x);
        let mut kt_a = u_a.transpose();
        ch.solve_mut(&mut kt_a);
        let (k_x, k_a) = (kt_x.transpose(), kt_a.transpose());
        dx.copy_from(&(k_x * dz));
        self.x -= k_a * dz;
        // P ← P − K Uᵀ − U Kᵀ + K S Kᵀ, block by block.
        let sk_x: SMatrix<f64, M, NX> = s * kt_x;
        let sk_a: SMatrix<f64, M, NK> = s * kt_a;
        p.gemm(-1.0, &k_x, &u_x.transpose(), 1.0);
        p.gemm(-1.0, &u_x, &kt_x, 1.0);
        p.gemm(1.0, &k_x, &sk_x, 1.0);
        self.p_xa.gemm(-1.0, &k_x, &u_a.transpose(), 1.0);
        self.p_xa.gemm(-1.0, &u_x, &kt_a, 1.0);
        self.p_xa.gemm(1.0, &k_x, &sk_a, 1.0);
        self.p_aa.gemm(-1.0, &k_a, &u_a.transpose(), 1.0);
        self.p_aa.gemm(-1.0, &u_a, &kt_a, 1.0);
        self.p_aa.gemm(1.0, &k_a, &sk_a, 1.0);
        kalman::symmetrize(p);
        kalman::symmetrize(&mut self.p_aa);
        Ok((nis, deweighted))
    }

    fn find(&self, key: AmbKey) -> Option<usize> {
        self.slots.iter().position(|s| s.key == Some(key))
    }

    /// (Re)initialise slot `k` for `key` at `a0` cycles: no correlation,
    /// prior σ `amb_prior_m / λ`.
    fn init_slot(&mut self, k: usize, key: AmbKey, lambda: f64, a0: f64) {
        self.clear_slot(k);
        self.slots[k].key = Some(key);
        self.slots[k].lambda = lambda;
        self.x[k] = a0;
        let s = self.cfg.amb_prior_m / lambda;
        self.p_aa[(k, k)] = s * s;
    }

    fn clear_slot(&mut self, k: usize) {
        self.slots[k] = Slot::default();
        self.clear_state(k);
    }

    /// Zero state `k` of the block with its rows and columns.
    fn clear_state(&mut self, k: usize) {
        self.x[k] = 0.0;
        for i in 0..NX {
            self.p_xa[(i, k)] = 0.0;
        }
        for j in 0..NK {
            self.p_aa[(k, j)] = 0.0;
            self.p_aa[(j, k)] = 0.0;
        }
    }

    /// The ionosphere slot of satellite `sat`: found (marked seen) or
    /// allocated with variance `var0` and no correlation (`None`: full).
    /// Returns the slot and whether it still needs this epoch's time
    /// update (an old slot seen for the first time this epoch).
    fn ion_slot(&mut self, sat: (GnssSystem, u8), var0: f64) -> Option<(usize, bool)> {
        if let Some(k) = self.ion.iter().position(|x| x.0 == Some(sat)) {
            let first = !self.ion[k].1;
            self.ion[k].1 = true;
            return Some((k, first));
        }
        let k = self.ion.iter().position(|x| x.0.is_none())?;
        self.clear_state(IION + k);
        self.ion[k] = (Some(sat), true);
        self.p_aa[(IION + k, IION + k)] = var0;
        Some((k, false))
    }

    /// Gauss–Markov time update of ionosphere slot `k`: `x ← φ x`, its
    /// covariance row and column × φ (the diagonal × φ²), `+ q`.
    fn ion_propagate(&mut self, k: usize, phi: f64, q: f64) {
        let i = IION + k;
        self.x[i] *= phi;
        for r in 0..NX {
            self.p_xa[(r, i)] *= phi;
        }
        for j in 0..NK {
            self.p_aa[(i, j)] *= phi;
            self.p_aa[(j, i)] *= phi;
        }
        self.p_aa[(i, i)] += q;
    }

    /// Clone the current position error (stochastic cloning, Roumeliotis
    /// & Burdick 2002): the block's last 3 states get the position's rows.
    fn set_clone(&mut self, p: &SMatrix<f64, NX, NX>) {
        for c in 0..3 {
            for i in 0..NX {
                self.p_xa[(i, ICL + c)] = p[(i, I_POS + c)];
            }
            for j in 0..ICL {
                let v = self.p_xa[(I_POS + c, j)];
                self.p_aa[(ICL + c, j)] = v;
                self.p_aa[(j, ICL + c)] = v;
            }
            for d in 0..3 {
                self.p_aa[(ICL + c, ICL + d)] = p[(I_POS + c, I_POS + d)];
            }
            self.x[ICL + c] = 0.0;
        }
        self.clone_set = true;
    }

    /// Covariance [m²] (NED) of the position change since the clone:
    /// `P_rr + P_cc − P_rc − P_cr`.
    fn change_cov(&self, p: &SMatrix<f64, NX, NX>) -> Mat3 {
        let mut m = Mat3::zeros();
        for c in 0..3 {
            for d in 0..3 {
                m[(c, d)] = p[(I_POS + c, I_POS + d)] + self.p_aa[(ICL + c, ICL + d)]
                    - self.p_xa[(I_POS + c, ICL + d)]
                    - self.p_xa[(I_POS + d, ICL + c)];
            }
        }
        m
    }

    /// Reference PRN of group `g` last epoch; records the new one and
    /// counts a change.
    fn set_ref(&mut self, g: (GnssSystem, Signal), prn: u8) {
        match self.refs.iter().position(|r| r.0 == Some(g)) {
            Some(i) => {
                if self.refs[i].1 != prn {
                    self.stats.reference_changes += 1;
                    self.refs[i].1 = prn;
                }
            }
            None => {
                if let Some(i) = self.refs.iter().position(|r| r.0.is_none()) {
                    self.refs[i] = (Some(g), prn);
                }
            }
        }
    }

    /// Geometry-free and Melbourne–Wübbena tests ([`crate::gnss::slip`])
    /// on the single differences of each satellite with both signals in a
    /// slot: the receiver clocks cancel in both combinations and the
    /// ionosphere mostly, and one test covers a slip at either receiver.
    /// Variances: the records' SD phase and code variances. A slip
    /// re-initialises both signals' slots (GF cannot tell which one
    /// slipped; RTKLIB flags both too); a record already reset (rise,
    /// loss of lock) restarts the satellite's arc.
    fn dual_slip_tests(&mut self, recs: &mut [Rec], t: f64) {
        for i in 0..recs.len() {
            let r1 = recs[i];
            if r1.slot == usize::MAX || !r1.key_sig.is_first() {
                continue;
            }
            let Some(sig2) = Signal::second_of(r1.key_sys) else {
                continue;
            };
            let Some(j) = recs.iter().position(|r| {
                r.key_sys == r1.key_sys
                    && r.key_prn == r1.key_prn
                    && r.key_sig == sig2
                    && r.slot != usize::MAX
            }) else {
                continue;
            };
            let r2 = recs[j];
            let key = (r1.key_sys, r1.key_prn);
            if r1.reset || r2.reset {
                self.dual.restart(key);
            }
            let o = crate::gnss::slip::DualObs {
                t,
                f1_hz: r1.key_sig.frequency_hz(0),
                f2_hz: sig2.frequency_hz(0),
                l1_m: r1.sd_phi,
                l2_m: r2.sd_phi,
                p1_m: r1.sd_code,
                p2_m: r2.sd_code,
                var_l1: r1.v_phi,
                var_l2: r2.v_phi,
                var_p1: r1.v_code,
                var_p2: r2.v_code,
            };
            if self.dual.update(key, &o).slip() {
                for k in [i, j] {
                    let r = &mut recs[k];
                    if !r.reset {
                        let a0 = (r.sd_phi - r.sd_code) / r.lambda;
                        self.init_slot(r.slot, (r.key_sys, r.key_prn, r.key_sig), r.lambda, a0);
                        self.slots[r.slot].seen = true;
                        r.reset = true;
                    }
                }
                self.stats.per_sat[r1.key_sys.index() * 64 + r1.key_prn as usize % 64]
                    .dual_slips += 1;
            }
        }
    }

    /// Float ambiguities [cycles] and their covariance (for tests and
    /// diagnostics): `(key, value, σ)` of slot `k`.
    fn slot_estimate(&self, k: usize) -> Option<(AmbKey, f64, f64)> {
        self.slots[k]
            .key
            .map(|key| (key, self.x[k], self.p_aa[(k, k)].max(0.0).sqrt()))
    }
}

/// One matched record of an epoch.
#[derive(Clone, Copy, Debug, Default)]
struct Rec {
    key_sys: GnssSystem,
    key_prn: u8,
    key_sig: Signal,
    /// DD group ([`RtkConfig::inter_system`]).
    grp: (GnssSystem, Signal),
    slot: usize,
    el: f64,
    lambda: f64,
    /// SD phase and code [m], and the SD prediction without ambiguity [m]
    /// for phase and code (troposphere, satellite clocks, ionosphere).
    sd_phi: f64,
    sd_code: f64,
    pred_phi: f64,
    pred_code: f64,
    /// SD variances [m²] (with the differential ionosphere's when it is
    /// not estimated).
    v_phi: f64,
    v_code: f64,
    /// Differential ionosphere: σ of the SD slant delay on 1575.42 MHz
    /// [m], the signal's factor γ_f, its variance on the signal [m²], and
    /// the ionosphere slot (usize::MAX: not estimated).
    sig_ion: f64,
    gamma: f64,
    v_iono: f64,
    ion: usize,
    u_n: Vec3,
    /// Usable this epoch for code / phase.
    use_code: bool,
    use_phase: bool,
    reset: bool,
}

/// One DD row before whitening.
#[derive(Clone, Copy)]
struct DdRow {
    h: SVector<f64, NJ>,
    dz: f64,
    /// Record index of the satellite (its variance `v_i`) and the reference.
    rec: usize,
}

/// Rover antenna: ECEF position, c_en, lever arm in n, latitude, height.
struct Ant {
    r_e: Vec3,
    c_en: Mat3,
    l_n: Vec3,
    lat: f64,
    h: f64,
}

/// Median (sorted in place; NaN when empty).
fn median(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(|a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Equal));
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Receiver clock bias × c [m] of an epoch at the antenna position `r_e`:
/// the median GPS (else any system) pseudorange residual after range,
/// satellite clock and troposphere (standard atmosphere). A receiver
/// epoch's true time is its stamp minus this / c (RTKLIB corrects the
/// solution time with the single-point clock the same way).
pub fn receiver_clock_bias_m(ep: &RawEpoch, r_e: &Vec3) -> Option<f64> {
    let g = crate::geodesy::ecef_to_geodetic(r_e);
    let cen = c_en(g.lat, g.lon);
    let doy = day_of_year(ep.t);
    let mut res = [[0.0f64; MAX_RAW_SATS]; 2];
    let mut n = [0usize; 2];
    for s in ep.sats() {
        if !s.sat.valid || !s.obs.pseudorange_m.is_finite() {
            continue;
        }
        let (rho, los) = geometric_range(&s.sat.pos_e, r_e);
        let el = (-(cen * los).z).clamp(-1.0, 1.0).asin();
        if el < 0.0 {
            continue;
        }
        let trop = slant_delay(el, g.lat, g.h, doy, super::tight::REL_HUMIDITY);
        let k = usize::from(s.obs.system != GnssSystem::Gps);
        res[k][n[k]] = s.obs.pseudorange_m - (rho - s.sat.clock_m + trop + s.sat.iono_m as f64);
        n[k] += 1;
    }
    let k = if n[0] > 0 { 0 } else { 1 };
    (n[k] > 0).then(|| median(&mut res[k][..n[k]]))
}

impl Eskf {
    /// Add the RTK block ([`rtk`](self)). Refused with tight coupling,
    /// augmented states or the sensitivity covariance; call it last.
    pub fn with_rtk(mut self, cfg: RtkConfig) -> Result<Self, RtkConfigError> {
        if self.tight.is_some() || self.aug.is_some() || self.sens.is_some() {
            return Err(RtkConfigError::Incompatible);
        }
        self.rtk = Some(rtk_block(Rtk::new(cfg)?));
        Ok(self)
    }

    /// Counters of the RTK updates (`None`: off).
    pub fn rtk_stats(&self) -> Option<&RtkStats> {
        self.rtk.as_ref().map(|r| &r.stats)
    }

    /// The float SD ambiguity of `key` [cycles] with its σ (`None`: no slot).
    pub fn rtk_ambiguity(&self, key: AmbKey) -> Option<(f64, f64)> {
        let r = self.rtk.as_ref()?;
        let k = r.find(key)?;
        r.slot_estimate(k).map(|(_, a, s)| (a, s))
    }

    /// Slots in use.
    pub fn rtk_slots_used(&self) -> usize {
        self.rtk
            .as_ref()
            .map_or(0, |r| r.slots.iter().filter(|s| s.key.is_some()).count())
    }

    fn rtk_antenna(&self) -> Ant {
        let (lat, lon, h) = self.antenna_position();
        let c = self.nav.c_bn();
        Ant {
            r_e: geodetic_to_ecef(&Geodetic { lat, lon, h }),
            c_en: c_en(lat, lon),
            l_n: c * self.cfg.lever_arm_b,
            lat,
            h,
        }
    }

    /// RTK update at the filter's current time with the rover epoch `rover`
    /// (its true time = the filter time; see [`receiver_clock_bias_m`]), the
    /// base epoch `base` matched to it, and the base antenna position
    /// `base_e` (ECEF) (module documentation).
    pub fn rtk_update(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
    ) -> Result<RtkSolution, RtkError> {
        if self.rtk.is_none() {
            return Err(RtkError::NotEnabled);
        }
        if !self.t.is_finite() {
            return Err(RtkError::NotStarted);
        }
        if !(base_e.iter().all(|v| v.is_finite()) && base_e.norm() > 6.0e6) {
            return Err(RtkError::BadBase);
        }
        let cfg = self
            .rtk
            .as_ref()
            .map(|r| r.cfg)
            .ok_or(RtkError::NotEnabled)?;
        if cfg.gnss_only {
            // No INS: constant-velocity prediction (rtk/gnss_only.rs).
            self.gnss_only_predict(rover, base, base_e, &cfg);
        } else if self.rtk.as_ref().is_some_and(|r| r.suspect) {
            self.rtk_test_position_on_code(rover, base, base_e, &cfg);
        }
        let bg = crate::geodesy::ecef_to_geodetic(base_e);
        let cen_b = c_en(bg.lat, bg.lon);
        let doy = day_of_year(rover.t);
        let a = self.rtk_antenna();
        let Some(rt) = &mut self.rtk else {
            return Err(RtkError::NotEnabled);
        };
        // Covariance of the INS position change since the last epoch.
        let p_dr = if rt.clone_set {
            rt.change_cov(&self.p)
        } else {
            Mat3::identity() * 1e6
        };
        rt.stats.epochs += 1;
        for s in rt.slots.iter_mut() {
            s.seen = false;
        }
        // 1. Match rover and base records; predictions and variances.
        let mut recs = [Rec::default(); MAX_RAW_SATS];
        let mut nr = 0usize;
        for s in rover.sats() {
            let o = &s.obs;
            let key = o.system.index() * 64 + o.prn as usize % 64;
            let ok = |r: &RawSat| {
                r.sat.valid && r.obs.pseudorange_m.is_finite() && r.obs.carrier_m.is_finite()
            };
            if !ok(s) || o.system == GnssSystem::Glonass {
                rt.stats.per_sat[key].bad += 1;
                continue;
            }
            let Some(b) = base.sats().iter().find(|b| {
                b.obs.system == o.system && b.obs.prn == o.prn && b.obs.signal == o.signal && ok(b)
            }) else {
                rt.stats.per_sat[key].no_base += 1;
                continue;
            };
            let (rho_r, los_r) = geometric_range(&s.sat.pos_e, &a.r_e);
            let u_n = a.c_en * los_r;
            let el = (-u_n.z).clamp(-1.0, 1.0).asin();
            if el < cfg.elevation_mask_rad {
                rt.stats.per_sat[key].low_elevation += 1;
                continue;
            }
            let (rho_b, los_b) = geometric_range(&b.sat.pos_e, base_e);
            let el_b = (-(cen_b * los_b).z).clamp(-1.0, 1.0).asin();
            let t_r = slant_delay(el, a.lat, a.h, doy, cfg.humidity);
            let t_b = slant_delay(el_b.max(0.0), bg.lat, bg.h, doy, cfg.humidity);
            let geo = (rho_r - s.sat.clock_m + t_r) - (rho_b - b.sat.clock_m + t_b);
            let iono = s.sat.iono_m as f64 - b.sat.iono_m as f64;
            // Differential ionosphere (RtkConfig::iono_ppm): single-layer
            // obliquity at 350 km, γ_f = (λ_f / λ_L1)².
            let re = 6_371_000.0;
            let sz = re / (re + 350_000.0) * el.cos();
            let obl = 1.0 / (1.0 - sz * sz).max(1e-6).sqrt();
            let gamma = (o.wavelength_m() / (299_792_458.0 / 1575.42e6)).powi(2);
            let sig_ion = cfg.iono_ppm * 1e-6 * (a.r_e - base_e).norm() * obl;
            let v_iono = {
                let s_i = sig_ion * gamma;
                s_i * s_i
            };
            let (cn_r, cn_b) = (o.cn0_dbhz as f64, b.obs.cn0_dbhz as f64);
            recs[nr] = Rec {
                key_sys: o.system,
                key_prn: o.prn,
                key_sig: o.signal,
                grp: cfg.dd_group(o.system, o.signal),
                slot: usize::MAX,
                el,
                lambda: o.wavelength_m(),
                sd_phi: o.carrier_m - b.obs.carrier_m,
                sd_code: o.pseudorange_m - b.obs.pseudorange_m,
                pred_phi: geo - iono,
                pred_code: geo + iono,
                v_phi: cfg.phase_var(el) + cfg.phase_var(el_b),
                v_code: cfg.code_var(el, cn_r) + cfg.base_code_var(el_b, cn_b),
                sig_ion,
                gamma,
                v_iono,
                ion: usize::MAX,
                u_n,
                use_code: true,
                use_phase: true,
                reset: (o.flags | b.obs.flags) & FLAG_LOSS_OF_LOCK != 0,
            };
            nr += 1;
        }
        // 1b. Differential ionosphere: states per satellite
        // (RtkConfig::iono_estimate), else white noise in the variances.
        if cfg.iono_estimate && cfg.iono_ppm > 0.0 {
            let (phi, db) = if rt.ion_t.is_finite() {
                let dt = (rover.t - rt.ion_t).max(0.0);
                ((-dt / cfg.iono_tau_s).exp(), (a.r_e - rt.ion_r).norm())
            } else {
                (1.0, 0.0)
            };
            for x in rt.ion.iter_mut() {
                x.1 = false;
            }
            // Only satellites with two signals this epoch: with one, the
            // SD ionosphere and the ambiguity are told apart by the code
            // alone, so the float ambiguities would wait minutes for code
            // averaging (a 5-satellite L1-only car never fixed in 120 s);
            // a single-frequency satellite keeps the white weighting below.
            let mut dual = [false; MAX_RAW_SATS];
            for i in 0..nr {
                let r = &recs[i];
                dual[i] = recs[..nr].iter().any(|q| {
                    q.key_sys == r.key_sys && q.key_prn == r.key_prn && q.key_sig != r.key_sig
                });
            }
            for (r, _) in recs[..nr].iter_mut().zip(dual).filter(|(_, d)| *d) {
                let s2 = r.sig_ion * r.sig_ion;
                if let Some((k, upd)) = rt.ion_slot((r.key_sys, r.key_prn), s2) {
                    if upd {
                        // Stationary part plus the rover's own motion.
                        let m = r.sig_ion / (a.r_e - base_e).norm().max(1.0);
                        let q = s2 * (1.0 - phi * phi) + (m * db).powi(2);
                        rt.ion_propagate(k, phi, q);
                    }
                    r.ion = k;
                }
            }
            for k in 0..NION {
                if rt.ion[k].0.is_some() && !rt.ion[k].1 {
                    rt.ion[k].0 = None;
                    rt.clear_state(IION + k);
                }
            }
            rt.ion_t = rover.t;
            rt.ion_r = a.r_e;
        }
        for r in recs[..nr].iter_mut() {
            if r.ion == usize::MAX {
                r.v_phi += r.v_iono;
                r.v_code += r.v_iono;
            }
        }
        // 2. Slots: find or allocate; loss of lock resets.
        for i in 0..nr {
            let r = &mut recs[i];
            let key: AmbKey = (r.key_sys, r.key_prn, r.key_sig);
            let sk = r.key_sys.index() * 64 + r.key_prn as usize % 64;
            let a0 = (r.sd_phi - r.sd_code) / r.lambda;
            match rt.find(key) {
                Some(k) => {
                    if r.reset {
                        rt.init_slot(k, key, r.lambda, a0);
                        rt.stats.per_sat[sk].lli_resets += 1;
                    }
                    r.slot = k;
                }
                None => match rt.slots.iter().position(|s| s.key.is_none()) {
                    Some(k) => {
                        rt.init_slot(k, key, r.lambda, a0);
                        rt.stats.per_sat[sk].rises += 1;
                        r.slot = k;
                        r.reset = true;
                    }
                    None => {
                        rt.stats.per_sat[sk].capacity += 1;
                        r.use_phase = false;
                        r.use_code = false;
                        continue;
                    }
                },
            }
            rt.slots[r.slot].seen = true;
        }
        // Free the slots of satellite-signals not in this epoch.
        for k in 0..NAMB {
            if let Some((sys, prn, _)) = rt.slots[k].key {
                if !rt.slots[k].seen {
                    rt.stats.per_sat[sys.index() * 64 + prn as usize % 64].sets += 1;
                    rt.clear_slot(k);
                }
            }
        }
        // 3a. INS-predicted cycle-slip test (not in GNSS-only mode).
        if !cfg.gnss_only {
            let mut d = [0.0f64; MAX_RAW_SATS];
            let mut dv = [0.0f64; MAX_RAW_SATS];
            let mut nd = 0usize;
            let mut idx = [0usize; MAX_RAW_SATS];
            for i in 0..nr {
                let r = &recs[i];
                if r.slot == usize::MAX || r.reset {
                    continue;
                }
                let sl = &rt.slots[r.slot];
                if !sl.prev_t.is_finite() {
                    continue;
                }
                d[nd] = (r.sd_phi - sl.prev_phi) - (r.pred_phi - sl.prev_rho);
                idx[nd] = i;
                nd += 1;
            }
            if nd >= 3 {
                dv[..nd].copy_from_slice(&d[..nd]);
                let common = median(&mut dv[..nd]);
                for j in 0..nd {
                    let i = idx[j];
                    let r = recs[i];
                    let sl = rt.slots[r.slot];
                    let ins = (r.u_n.transpose() * p_dr * r.u_n)[(0, 0)].max(0.0);
                    let var = 2.0 * (r.v_phi + sl.prev_var) + ins;
                    let e = d[j] - common;
                    if e * e > rt.slip_gate * var {
                        let key = (r.key_sys, r.key_prn, r.key_sig);
                        rt.init_slot(r.slot, key, r.lambda, (r.sd_phi - r.sd_code) / r.lambda);
                        rt.slots[r.slot].seen = true;
                        recs[i].reset = true;
                        let sk = r.key_sys.index() * 64 + r.key_prn as usize % 64;
                        rt.stats.per_sat[sk].slips += 1;
                    }
                }
            } else if nd > 0 {
                rt.stats.slip_untestable += 1;
            }
        }
        // 3b. Dual-frequency GF / MW slip tests (no INS needed) on the
        // satellites the INS test left alone: it resets only the signal
        // that slipped, GF / MW both.
        rt.dual_slip_tests(&mut recs[..nr], rover.t);
        // 4. Reference per (system, signal): highest elevation.
        let mut groups: [Option<(GnssSystem, Signal)>; NGROUP] = [None; NGROUP];
        let mut gref = [usize::MAX; NGROUP];
        let mut ng = 0usize;
        for i in 0..nr {
            if recs[i].slot == usize::MAX {
                continue;
            }
            let g = recs[i].grp;
            let gi = match groups[..ng].iter().position(|x| *x == Some(g)) {
                Some(gi) => gi,
                None if ng < NGROUP => {
                    groups[ng] = Some(g);
                    ng += 1;
                    ng - 1
                }
                None => continue,
            };
            if gref[gi] == usize::MAX || recs[i].el > recs[gref[gi]].el {
                gref[gi] = i;
            }
        }
        for gi in 0..ng {
            if let Some(g) = groups[gi] {
                if gref[gi] != usize::MAX && ng > 0 {
                    rt.set_ref(g, recs[gref[gi]].key_prn);
                }
            }
        }
        // 5. DDs: gate each, whiten the accepted ones, scalar updates.
        let gate = rt.gate;
        let mut pf = rt.full(&self.p);
        let mut dxf = SVector::<f64, NJ>::zeros();
        let xamb = rt.x;
        let mut n_code = 0usize;
        let mut n_code_gated = 0usize;
        let mut n_phase = 0usize;
        let mut nis = [(0.0f64, 0u64); 2];
        let mut used_phase = [false; MAX_RAW_SATS];
        // Passes: code then phase per group; with float links the phase of
        // every group in one last pass against the master reference, the
        // highest of the groups' references (RtkConfig::float_links).
        let master = (0..ng)
            .map(|gi| gref[gi])
            .filter(|&i| i != usize::MAX)
            .fold(usize::MAX, |m, i| {
                if m == usize::MAX || recs[i].el > recs[m].el {
                    i
                } else {
                    m
                }
            });
        let linked = cfg.float_links && master != usize::MAX;
        for pass in 0..=2 * ng {
            let (ir, only, phase) = if pass < 2 * ng {
                let (gi, phase) = (pass / 2, pass % 2 == 1);
                if phase && linked {
                    continue;
                }
                let Some(g) = groups[gi] else { continue };
                (gref[gi], Some(g), phase)
            } else if linked {
                (master, None, true)
            } else {
                break;
            };
            if ir == usize::MAX {
                continue;
            }
            let mut rows = [DdRow {
                h: SVector::zeros(),
                dz: 0.0,
                rec: 0,
            }; MAX_RAW_SATS];
            let mut nrow = 0usize;
            let mut failed = [0usize; MAX_RAW_SATS];
            let mut nfail = 0usize;
            let rf = recs[ir];
            for i in 0..nr {
                let r = recs[i];
                if i == ir || r.slot == usize::MAX || only.is_some_and(|g| r.grp != g) {
                    continue;
                }
                let du = r.u_n - rf.u_n;
                let mut h = SVector::<f64, NJ>::zeros();
                let ha = -(du.transpose() * skew(&a.l_n));
                for k in 0..3 {
                    h[I_POS + k] = -du[k];
                    h[I_ATT + k] = ha[(0, k)];
                }
                // Estimated SD ionosphere: +γ on code, −γ on phase.
                let sgn = if phase { -1.0 } else { 1.0 };
                let mut ion = 0.0;
                if r.ion != usize::MAX {
                    h[NX + IION + r.ion] += sgn * r.gamma;
                    ion += sgn * r.gamma * xamb[IION + r.ion];
                }
                if rf.ion != usize::MAX {
                    h[NX + IION + rf.ion] -= sgn * rf.gamma;
                    ion -= sgn * rf.gamma * xamb[IION + rf.ion];
                }
                let (dz, var) = if phase {
                    h[NX + r.slot] = r.lambda;
                    h[NX + rf.slot] = -rf.lambda;
                    let pred = (r.pred_phi + r.lambda * xamb[r.slot])
                        - (rf.pred_phi + rf.lambda * xamb[rf.slot]);
                    (pred + ion - (r.sd_phi - rf.sd_phi), r.v_phi + rf.v_phi)
                } else {
                    (
                        (r.pred_code - rf.pred_code) + ion - (r.sd_code - rf.sd_code),
                        r.v_code + rf.v_code,
                    )
                };
                // Marginal gate on this epoch's prior.
                let innov = dz - h.dot(&dxf);
                let ph = mul_sparse(&pf, &h);
                let s = h.dot(&ph) + var;
                if !(innov.is_finite() && s > 0.0) || innov * innov > gate * s {
                    failed[nfail] = i;
                    nfail += 1;
                    continue;
                }
                rows[nrow] = DdRow { h, dz, rec: i };
                nrow += 1;
            }
            let ntried = nrow + nfail;
            let ref_suspect = phase && ntried >= 2 && 2 * nfail > ntried;
            for &i in &failed[..nfail] {
                let r = recs[i];
                let c = &mut rt.stats.per_sat[r.key_sys.index() * 64 + r.key_prn as usize % 64];
                if phase {
                    c.phase_gated += 1;
                    recs[i].use_phase = false;
                    // A phase DD beyond its gate is in practice a slip
                    // the test missed: re-initialise (unless the
                    // reference is to blame).
                    if !ref_suspect {
                        reset_joint(rt, &mut pf, &mut dxf, &recs[i]);
                    }
                } else {
                    c.code_gated += 1;
                    recs[i].use_code = false;
                    n_code_gated += 1;
                }
            }
            if ref_suspect {
                reset_joint(rt, &mut pf, &mut dxf, &rf);
                recs[ir].reset = true;
                let sk = rf.key_sys.index() * 64 + rf.key_prn as usize % 64;
                rt.stats.per_sat[sk].ref_resets += 1;
                continue;
            }
            if nrow == 0 {
                continue;
            }
            // Exact DD covariance C = diag(v_i) + v_ref 1 1ᵀ, whitened.
            let vref = if phase { rf.v_phi } else { rf.v_code };
            let mut c = SMatrix::<f64, MAX_RAW_SATS, MAX_RAW_SATS>::identity();
            for p_ in 0..nrow {
                for q in 0..nrow {
                    c[(p_, q)] = vref;
                }
                let ri = recs[rows[p_].rec];
                c[(p_, p_)] += if phase { ri.v_phi } else { ri.v_code };
            }
            let Some(l) = cholesky_leading(&c, nrow) else {
                continue;
            };
            whiten(&l, &mut rows[..nrow]);
            for row in rows[..nrow].iter() {
                let innov = row.dz - row.h.dot(&dxf);
                let ph = mul_sparse(&pf, &row.h);
                let s = row.h.dot(&ph) + 1.0;
                if !(s > 0.0 && innov.is_finite()) {
                    continue;
                }
                dxf += ph * (innov / s);
                rank1_downdate(&mut pf, &ph, s);
                let k = usize::from(phase);
                nis[k].0 += innov * innov / s;
                nis[k].1 += 1;
            }
            for row in rows[..nrow].iter() {
                let r = recs[row.rec];
                let sk = r.key_sys.index() * 64 + r.key_prn as usize % 64;
                if phase {
                    rt.stats.per_sat[sk].phase_used += 1;
                    used_phase[row.rec] = true;
                    n_phase += 1;
                } else {
                    rt.stats.per_sat[sk].code_used += 1;
                    n_code += 1;
                }
            }
            if phase {
                used_phase[ir] = true;
            }
        }
        // GNSS-only: lost when no code DD passed its gate and some were
        // tried (rtk/gnss_only.rs; the INS-aided path is not changed).
        if cfg.gnss_only {
            rt.lost = n_code == 0 && n_code_gated > 0;
        } else {
            let tried = n_code + n_code_gated;
            rt.suspect = tried >= 3 && 2 * n_code_gated > tried;
            rt.code_var_max = recs[..nr]
                .iter()
                .map(|r| r.v_code)
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
        }
        rt.stats.nis_code.0 += nis[0].0;
        rt.stats.nis_code.1 += nis[0].1;
        rt.stats.nis_phase.0 += nis[1].0;
        rt.stats.nis_phase.1 += nis[1].1;
        // Apply the correction.
        if n_code + n_phase > 0 {
            let p_prior = self.p;
            rt.split(&pf, &mut self.p);
            rt.x -= dxf.fixed_rows::<NK>(NX);
            let dx: super::StateVec = dxf.fixed_rows::<NX>(0).into();
            if self.cfg.smoother_every > 0 && self.rec_p_prior.is_none() {
                self.rec_p_prior = Some(p_prior);
            }
            apply_correction(&mut self.nav, &mut self.err, &dx);
            self.rec_dx += dx;
            self.rec_updated = true;
        }
        // 6. Fixing.
        let mut sol = self.rtk_fix(&recs[..nr], &gref[..ng], &used_phase);
        if sol.fixed && cfg.fix_and_hold {
            self.rtk_hold(&sol, &recs[..nr], &gref[..ng]);
        }
        // 7. Remember this epoch for the slip test (posterior antenna).
        let a2 = self.rtk_antenna();
        let Some(rt) = &mut self.rtk else {
            return Err(RtkError::NotEnabled);
        };
        for i in 0..nr {
            let r = recs[i];
            if r.slot == usize::MAX {
                continue;
            }
            let Some(s) = rover.sats().iter().find(|s| {
                s.obs.system == r.key_sys && s.obs.prn == r.key_prn && s.obs.signal == r.key_sig
            }) else {
                continue;
            };
            let (rho_r, _) = geometric_range(&s.sat.pos_e, &a2.r_e);
            let (rho_r0, _) = geometric_range(&s.sat.pos_e, &a.r_e);
            let sl = &mut rt.slots[r.slot];
            sl.prev_t = rover.t;
            sl.prev_phi = r.sd_phi;
            sl.prev_rho = r.pred_phi + (rho_r - rho_r0);
            sl.prev_var = r.v_phi;
        }
        rt.set_clone(&self.p);
        if cfg.gnss_only {
            self.gnss_only_store();
        }
        sol.t = self.t;
        sol.n_code = n_code;
        sol.n_phase = n_phase;
        Ok(sol)
    }

    /// GNSS-only mode: move the position onto the code-DD least-squares
    /// solution (unweighted Gauss–Newton, the relative-mode analogue of
    /// RTKLIB's single-point prior), so a car that moved while the
    /// satellites were gone does not start hundreds of metres off. DDs
    /// grouped as the update groups them ([`RtkConfig::inter_system`]).
    ///
    /// **Independent of the filter state**: the iteration starts at the
    /// base antenna (the one position a relative-mode rover is known to be
    /// near), as RTKLIB's `pntpos` starts from its own last solution, never
    /// from the RTK filter's. Started from the filter's state, a filter
    /// that had lost itself could not restart: 27 600 km off (seed 19 of
    /// `experiment rtk` with a perturbed scene) the satellites' elevations
    /// at the iterate or the 6 steps did not give a solution, and it
    /// coasted for the rest of the run.
    ///
    /// Refused (position restored, `false`) without redundancy — fewer than
    /// 4 DDs for the 3 unknowns: an exactly determined code solution has no
    /// check and, with 4 satellites, a DOP that put it 300 m off (seed 12 of
    /// `experiment rtk`) — when its geometry is too weak, or when it does not
    /// converge to 1 cm in [`CODE_MAX_ITER`] steps. Geometry: RTKLIB's
    /// `valsol` rejects a single-point solution whose GDOP exceeds
    /// `maxgdop` (default 30, `pos2-rejgdop`; [`crate::gnss::spp`] the
    /// same); here the clocks are differenced out, so the test is on the
    /// position DOP of the code DDs with their unit-weight correlation
    /// (`C = I + 1 1ᵀ` per group: the undifferenced PDOP with one clock per
    /// group), `√tr N⁻¹ ≤` [`MAX_DD_PDOP`]. Counting DDs is not enough:
    /// L1 and L2 of one satellite are two DDs along one line of sight, so 4
    /// satellites of 2 systems give 4 DDs of rank 2, and the "solution"
    /// moved along the unobserved (near-vertical) direction to a false
    /// root 27 600 km below the base (seed 19 above, t = 449 s).
    fn recentre_on_code(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
        cfg: &RtkConfig,
    ) -> bool {
        self.code_solution(rover, base, base_e, cfg).is_some()
    }

    /// [`Eskf::recentre_on_code`]'s solution: on success the nominal
    /// position is moved onto it and the unit-weight cofactor matrix of
    /// the position (NED error state, `(Hᵀ C⁻¹ H)⁻¹` with `C = I + 1 1ᵀ`
    /// per group) is returned; else the position is restored.
    fn code_solution(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
        cfg: &RtkConfig,
    ) -> Option<Mat3> {
        let saved = (self.nav.lat, self.nav.lon, self.nav.h);
        let b0 = crate::geodesy::ecef_to_geodetic(base_e);
        (self.nav.lat, self.nav.lon, self.nav.h) = (b0.lat, b0.lon, b0.h);
        for _ in 0..CODE_MAX_ITER {
            let a = self.rtk_antenna();
            let doy = day_of_year(rover.t);
            let bg = crate::geodesy::ecef_to_geodetic(base_e);
            // (group, el, u_n, code residual meas − pred) per record.
            let mut rows = [(
                (GnssSystem::Gps, Signal::GpsL1Ca),
                0.0f64,
                Vec3::zeros(),
                0.0f64,
            ); MAX_RAW_SATS];
            let mut n = 0usize;
            for s in rover.sats() {
                let o = &s.obs;
                if !s.sat.valid || !o.pseudorange_m.is_finite() || o.system == GnssSystem::Glonass {
                    continue;
                }
                let Some(b) = base.sats().iter().find(|b| {
                    b.obs.system == o.system
                        && b.obs.prn == o.prn
                        && b.obs.signal == o.signal
                        && b.sat.valid
                        && b.obs.pseudorange_m.is_finite()
                }) else {
                    continue;
                };
                let (rho_r, los) = geometric_range(&s.sat.pos_e, &a.r_e);
                let u_n = a.c_en * los;
                let el = (-u_n.z).clamp(-1.0, 1.0).asin();
                if el < cfg.elevation_mask_rad {
                    continue;
                }
                let (rho_b, _) = geometric_range(&b.sat.pos_e, base_e);
                let t_r = slant_delay(el, a.lat, a.h, doy, cfg.humidity);
                let t_b = slant_delay(el, bg.lat, bg.h, doy, cfg.humidity);
                let pred = (rho_r - s.sat.clock_m + t_r) - (rho_b - b.sat.clock_m + t_b);
                let grp = match (cfg.inter_system, o.signal) {
                    (true, Signal::GalE1) => (GnssSystem::Gps, Signal::GpsL1Ca),
                    (true, Signal::BdsB2I) => (GnssSystem::Galileo, Signal::GalE5b),
                    _ => (o.system, o.signal),
                };
                rows[n] = (grp, el, u_n, (o.pseudorange_m - b.obs.pseudorange_m) - pred);
                n += 1;
            }
            let mut nm = Mat3::zeros();
            let mut rhs = Vec3::zeros();
            let mut m = 0usize;
            let mut geometry = DdDop::new();
            for i in 0..n {
                // Reference of the group: its highest satellite.
                let mut r = i;
                for j in 0..n {
                    if rows[j].0 == rows[i].0 && rows[j].1 > rows[r].1 {
                        r = j;
                    }
                }
                if r == i {
                    continue;
                }
                let hrow = -(rows[i].2 - rows[r].2);
                let dz = -(rows[i].3 - rows[r].3);
                nm += hrow * hrow.transpose();
                rhs += hrow * dz;
                m += 1;
                geometry.add(r, hrow);
            }
            let (dop, cof) = geometry.cofactor();
            if dop > MAX_DD_PDOP {
                break;
            }
            let Some(inv) = nm.try_inverse().filter(|_| m >= 4) else {
                break;
            };
            let dr = inv * rhs;
            if !dr.iter().all(|v| v.is_finite()) {
                break;
            }
            let (rm, rn) = earth::radii(self.nav.lat);
            self.nav.lat -= dr[0] / (rm + self.nav.h);
            self.nav.lon -= dr[1] / ((rn + self.nav.h) * self.nav.lat.cos());
            self.nav.h += dr[2];
            if dr.norm() < 0.01 {
                return cof;
            }
        }
        (self.nav.lat, self.nav.lon, self.nav.h) = saved;
        None
    }

    /// INS-aided: after an epoch in which most code DDs failed their
    /// gate, test the position against the code solution computed
    /// independently of it (from the base, [`Eskf::code_solution`]):
    /// `d = p̂ − p_code`, `S = P_pos + σ² Q_code` (the two independent;
    /// σ² the largest SD code variance of the last epoch, so `S` errs
    /// large), reset when `dᵀ S⁻¹ d` exceeds the χ²₃ quantile of
    /// [`RtkConfig::gate_probability`]. Reset: the position moves onto the
    /// code solution with covariance `σ² Q_code`, its cross-covariances are
    /// dropped (Bar-Shalom, Li & Kirubarajan 2001 §8.6: the position was
    /// wrong with a small σ, so what it was correlated with is suspect
    /// too) and every ambiguity is freed, to be initialised from code at
    /// its next epoch: the float ambiguities had taken up the position
    /// error (an INS position 20 m off with σ 0.2 m, core test
    /// `ins_aided_rtk_resets_a_position_inconsistent_with_code`, stayed
    /// 20 m off with 5 of 7 code DDs gated at every epoch and the phase
    /// DDs all used).
    ///
    /// Why two stages: a majority of gated code DDs alone can be one bad
    /// reference satellite; a code solution alone fails its χ² on code
    /// outliers. A consistent filter fails the majority of ≥ 3 DDs with
    /// probability of order `3 (1 − p)²` and then the χ² test with `1 − p`
    /// (`p` the gate probability, 1e-4 → ~3e-12 per epoch).
    pub(super) fn rtk_test_position_on_code(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
        cfg: &RtkConfig,
    ) {
        let var = match &mut self.rtk {
            Some(r) => {
                r.suspect = false;
                r.code_var_max
            }
            None => return,
        };
        let here = Geodetic {
            lat: self.nav.lat,
            lon: self.nav.lon,
            h: self.nav.h,
        };
        let Some(cof) = self.code_solution(rover, base, base_e, cfg) else {
            return;
        };
        let code = (self.nav.lat, self.nav.lon, self.nav.h);
        (self.nav.lat, self.nav.lon, self.nav.h) = (here.lat, here.lon, here.h);
        // Nominal − code solution, NED (the error state's sign).
        let code_g = Geodetic {
            lat: code.0,
            lon: code.1,
            h: code.2,
        };
        let d = crate::geodesy::ned_from_geodetic(&code_g, &here);
        let q_code = cof * var.max(f64::MIN_POSITIVE);
        let s = self.p.fixed_view::<3, 3>(I_POS, I_POS).into_owned() + q_code;
        let Some(si) = s.try_inverse() else { return };
        let nis = d.dot(&(si * d));
        // NaN (a degenerate S) is no evidence: keep the position.
        if nis.is_nan() || nis <= kalman::chi2_quantile(3, cfg.gate_probability) {
            return;
        }
        (self.nav.lat, self.nav.lon, self.nav.h) = code;
        for k in I_POS..I_POS + 3 {
            for j in 0..NX {
                self.p[(k, j)] = 0.0;
                self.p[(j, k)] = 0.0;
            }
        }
        self.p
            .fixed_view_mut::<3, 3>(I_POS, I_POS)
            .copy_from(&q_code);
        let Some(rt) = &mut self.rtk else { return };
        for k in I_POS..I_POS + 3 {
            for j in 0..NK {
                rt.p_xa[(k, j)] = 0.0;
            }
        }
        for k in 0..NAMB {
            if rt.slots[k].key.is_some() {
                rt.clear_slot(k);
            }
        }
        rt.clone_set = false;
        rt.stats.position_resets += 1;
    }

    /// LAMBDA with partial ambiguity resolution on the DD ambiguities of
    /// the phase DDs used this epoch (module documentation).
    fn rtk_fix(&mut self, recs: &[Rec], gref: &[usize], used: &[bool]) -> RtkSolution {
        let (lat, lon, h) = (self.nav.lat, self.nav.lon, self.nav.h);
        let float_pos = Geodetic { lat, lon, h };
        let std = |p: &SMatrix<f64, 3, 3>| {
            Vec3::new(p[(0, 0)], p[(1, 1)], p[(2, 2)]).map(|v| v.max(0.0).sqrt())
        };
        let p_pos: SMatrix<f64, 3, 3> = self.p.fixed_view::<3, 3>(I_POS, I_POS).into_owned();
        let mut sol = RtkSolution {
            t: self.t,
            n_code: 0,
            n_phase: 0,
            n_candidates: 0,
            n_fixed: 0,
            fixed: false,
            fix_pdop: f64::INFINITY,
            ratio: 0.0,
            success_rate: 0.0,
            float_pos,
            float_std_ned: std(&p_pos),
            pos: float_pos,
            std_ned: std(&p_pos),
            fixed_dd: [FixedDd::default(); NAMB],
        };
        let Some(rt) = &mut self.rtk else { return sol };
        // Candidates: (slot i, slot ref, record i, record ref).
        let mut cand = [(0usize, 0usize, 0usize, 0usize); NAMB];
        let mut nc = 0usize;
        for &ir in gref {
            if ir == usize::MAX || !used[ir] {
                continue;
            }
            let rf = recs[ir];
            for (i, r) in recs.iter().enumerate() {
                if i == ir || !used[i] || r.slot == usize::MAX || r.grp != rf.grp || nc >= NAMB {
                    continue;
                }
                cand[nc] = (r.slot, rf.slot, i, ir);
                nc += 1;
            }
        }
        sol.n_candidates = nc;
        if nc == 0 {
            return sol;
        }
        rt.stats.fix_attempts += 1;
        let p_aa = rt.p_aa;
        let qdd = |a: &(usize, usize, usize, usize), b: &(usize, usize, usize, usize)| {
            let p = &p_aa;
            p[(a.0, b.0)] - p[(a.0, b.1)] - p[(a.1, b.0)] + p[(a.1, b.1)]
        };
        // Order by variance, smallest first; drop from the end.
        let mut order = [0usize; NAMB];
        for k in 0..nc {
            order[k] = k;
        }
        // Unstable sort (no allocation, no_std) with the index as tie-break:
        // the same order as a stable sort.
        order[..nc].sort_unstable_by(|&i, &j| {
            qdd(&cand[i], &cand[i])
                .total_cmp(&qdd(&cand[j], &cand[j]))
                .then(i.cmp(&j))
        });
        let mut n = nc.min(lambda::MAX_N);
        let mut reason = 0u8; // 0 too few, 1 success, 2 ratio, 3 lambda
        let mut a_hat = [0.0f64; NAMB];
        let mut q = [0.0f64; NAMB * NAMB];
        while n >= rt.cfg.min_fix {
            for u in 0..n {
                let cu = cand[order[u]];
                a_hat[u] = rt.x[cu.0] - rt.x[cu.1];
                for v in 0..n {
                    q[u * n + v] = qdd(&cu, &cand[order[v]]);
                }
            }
            // One decorrelation for the success rate and the search.
            let dec = lambda::Decorrelated::new(&q[..n * n], n);
            let ps = dec.as_ref().map_or(0.0, |d| d.success_rate());
            sol.success_rate = ps;
            if ps < rt.cfg.success_min {
                reason = 1;
                n -= 1;
                continue;
            }
            let res = match dec.and_then(|d| d.search(&a_hat[..n], 2, lambda::MAX_NODES)) {
                Ok(r) => r,
                Err(_) => {
                    reason = 3;
                    n -= 1;
                    continue;
                }
            };
            sol.ratio = res.ratio();
            if sol.ratio < rt.cfg.ratio_min {
                reason = 2;
                n -= 1;
                continue;
            }
            // Fixed: conditional update of the position.
            let mut qm = SMatrix::<f64, NAMB, NAMB>::identity();
            let mut da = SVector::<f64, NAMB>::zeros();
            let mut pxa = SMatrix::<f64, 3, NAMB>::zeros();
            for u in 0..n {
                let cu = cand[order[u]];
                for v in 0..n {
                    qm[(u, v)] = q[u * n + v];
                }
                da[u] = a_hat[u] - res.fixed[0][u];
                for k in 0..3 {
                    pxa[(k, u)] = rt.p_xa[(I_POS + k, cu.0)] - rt.p_xa[(I_POS + k, cu.1)];
                }
            }
            let Some(ch) = qm.cholesky() else {
                reason = 3;
                n -= 1;
                continue;
            };
            let w = ch.solve(&da);
            let dpos = pxa * w;
            let pq = ch.solve(&pxa.transpose());
            let p_fix = p_pos - pxa * pq;
            let (rm, rn) = earth::radii(lat);
            sol.pos = Geodetic {
                lat: lat - dpos[0] / (rm + h),
                lon: lon - dpos[1] / ((rn + h) * lat.cos()),
                h: h + dpos[2],
            };
            sol.std_ned = std(&p_fix);
            sol.fixed = true;
            sol.n_fixed = n;
            let mut geometry = DdDop::new();
            for u in 0..n {
                let cu = cand[order[u]];
                let (ri, rr) = (recs[cu.2], recs[cu.3]);
                geometry.add(cu.3, -(ri.u_n - rr.u_n));
                sol.fixed_dd[u] = FixedDd {
                    system: ri.key_sys,
                    signal: ri.key_sig,
                    prn: ri.key_prn,
                    ref_prn: rr.key_prn,
                    ref_system: rr.key_sys,
                    ref_signal: rr.key_sig,
                    n: res.fixed[0][u] as i64,
                };
            }
            sol.fix_pdop = geometry.cofactor().0;
            rt.stats.fixed += 1;
            if !sol.position_fixed() {
                rt.stats.fixed_weak_geometry += 1;
            } else if n < nc {
                rt.stats.fixed_partial += 1;
            }
            return sol;
        }
        match reason {
            1 => rt.stats.rejected_success_rate += 1,
            2 => rt.stats.rejected_ratio += 1,
            3 => rt.stats.rejected_lambda += 1,
            _ => rt.stats.rejected_too_few += 1,
        }
        sol
    }

    /// Fix-and-hold: the fixed DDs as pseudo-measurements `a_i − a_r = ň`
    /// with variance 0.001 cycle² (RTKLIB `VAR_HOLDAMB`).
    fn rtk_hold(&mut self, sol: &RtkSolution, recs: &[Rec], _gref: &[usize]) {
        let Some(rt) = &mut self.rtk else { return };
        let mut pf = rt.full(&self.p);
        let mut dxf = SVector::<f64, NJ>::zeros();
        let mut held = 0u64;
        for f in &sol.fixed_dd[..sol.n_fixed] {
            let slot_of = |sys: GnssSystem, sig: Signal, prn: u8| {
                recs.iter()
                    .find(|r| r.key_sys == sys && r.key_sig == sig && r.key_prn == prn)
                    .map(|r| r.slot)
            };
            let (Some(i), Some(j)) = (
                slot_of(f.system, f.signal, f.prn),
                slot_of(f.ref_system, f.ref_signal, f.ref_prn),
            ) else {
                continue;
            };
            if i == usize::MAX || j == usize::MAX {
                continue;
            }
            let mut hv = SVector::<f64, NJ>::zeros();
            hv[NX + i] = 1.0;
            hv[NX + j] = -1.0;
            let dz = (rt.x[i] - rt.x[j]) - f.n as f64;
            let innov = dz - hv.dot(&dxf);
            let ph = mul_sparse(&pf, &hv);
            let s = hv.dot(&ph) + 0.001;
            dxf += ph * (innov / s);
            rank1_downdate(&mut pf, &ph, s);
            held += 1;
        }
        if held == 0 {
            return;
        }
        rt.stats.held += held;
        rt.split(&pf, &mut self.p);
        rt.x -= dxf.fixed_rows::<NK>(NX);
        let dx: super::StateVec = dxf.fixed_rows::<NX>(0).into();
        apply_correction(&mut self.nav, &mut self.err, &dx);
        self.rec_dx += dx;
        self.rec_updated = true;
    }
}

/// Re-initialise the slot of record `r` inside an epoch's update: in the
/// block (state, slot) and in the working joint covariance `pf` and
/// correction `dxf`.
fn reset_joint(rt: &mut Rtk, pf: &mut SMatrix<f64, NJ, NJ>, dxf: &mut SVector<f64, NJ>, r: &Rec) {
    let k = r.slot;
    rt.init_slot(
        k,
        (r.key_sys, r.key_prn, r.key_sig),
        r.lambda,
        (r.sd_phi - r.sd_code) / r.lambda,
    );
    rt.slots[k].seen = true;
    for j in 0..NJ {
        pf[(NX + k, j)] = 0.0;
        pf[(j, NX + k)] = 0.0;
    }
    pf[(NX + k, NX + k)] = rt.p_aa[(k, k)];
    dxf[NX + k] = 0.0;
}

/// Whiten DD rows with the lower Cholesky factor `l` of their covariance:
/// forward substitution `L z̃ = z`, `L H̃ = H` (row by row).
/// Lower Cholesky factor of the leading `n × n` block of a symmetric `a`
/// (zeros elsewhere; `None` unless positive definite): the group's DD
/// covariance without factoring the padding (profiled: the padded 48 × 48
/// factorisation was a few per cent of an RTK/INS run). Golub & Van Loan
/// Alg. 4.2.1.
fn cholesky_leading(
    a: &SMatrix<f64, MAX_RAW_SATS, MAX_RAW_SATS>,
    n: usize,
) -> Option<SMatrix<f64, MAX_RAW_SATS, MAX_RAW_SATS>> {
    let n = n.min(MAX_RAW_SATS);
    let mut l = SMatrix::<f64, MAX_RAW_SATS, MAX_RAW_SATS>::zeros();
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let ljj = d.sqrt();
        l[(j, j)] = ljj;
        for i in j + 1..n {
            let mut v = a[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = v / ljj;
        }
    }
    Some(l)
}

fn whiten(l: &SMatrix<f64, MAX_RAW_SATS, MAX_RAW_SATS>, rows: &mut [DdRow]) {
    for j in 0..rows.len() {
        let mut h = rows[j].h;
        let mut dz = rows[j].dz;
        for k in 0..j {
            h -= rows[k].h * l[(j, k)];
            dz -= rows[k].dz * l[(j, k)];
        }
        rows[j].h = h / l[(j, j)];
        rows[j].dz = dz / l[(j, j)];
    }
}

/// A correction and covariance of the joint state (tests).
#[cfg(test)]
pub(super) type JointUpdate = (SVector<f64, NJ>, SMatrix<f64, NJ, NJ>);

/// The whitening and the vector update, for the tests: `(dx, P)` after
/// processing DD rows `h` (`m` of them), innovations `dz` and SD variances
/// `v` (reference `v_ref`) either whitened-sequentially or as one vector
/// update.
#[cfg(test)]
pub(super) fn dd_update_both(
    p0: &SMatrix<f64, NJ, NJ>,
    h: &[SVector<f64, NJ>],
    dz: &[f64],
    v: &[f64],
    v_ref: f64,
) -> (JointUpdate, JointUpdate) {
    let m = h.len();
    let mut c = SMatrix::<f64, MAX_RAW_SATS, MAX_RAW_SATS>::identity();
    for i in 0..m {
        for j in 0..m {
            c[(i, j)] = v_ref;
        }
        c[(i, i)] += v[i];
    }
    let l = c.cholesky().expect("pd").l();
    let mut rows: [DdRow; MAX_RAW_SATS] = [DdRow {
        h: SVector::zeros(),
        dz: 0.0,
        rec: 0,
    }; MAX_RAW_SATS];
    for i in 0..m {
        rows[i] = DdRow {
            h: h[i],
            dz: dz[i],
            rec: i,
        };
    }
    whiten(&l, &mut rows[..m]);
    let mut p = *p0;
    let mut dx = SVector::<f64, NJ>::zeros();
    for row in rows[..m].iter() {
        let innov = row.dz - row.h.dot(&dx);
        let ph = p * row.h;
        let s = row.h.dot(&ph) + 1.0;
        dx += ph * (innov / s);
        p -= ph * ph.transpose() / s;
    }
    // Vector update (dynamic, test only).
    let hm = nalgebra::DMatrix::<f64>::from_fn(m, NJ, |i, j| h[i][j]);
    let cm = nalgebra::DMatrix::<f64>::from_fn(m, m, |i, j| c[(i, j)]);
    let pm = nalgebra::DMatrix::<f64>::from_fn(NJ, NJ, |i, j| p0[(i, j)]);
    let zm = nalgebra::DVector::<f64>::from_fn(m, |i, _| dz[i]);
    let s = &hm * &pm * hm.transpose() + cm;
    let k = &pm * hm.transpose() * s.try_inverse().expect("inv");
    let dxv = &k * zm;
    let pv = &pm - &k * &hm * &pm;
    let dx2 = SVector::<f64, NJ>::from_fn(|i, _| dxv[i]);
    let p2 = SMatrix::<f64, NJ, NJ>::from_fn(|i, j| pv[(i, j)]);
    ((dx, p), (dx2, p2))
}

/// Joint dimension, for the tests.
#[cfg(test)]
pub(super) const NJ_TEST: usize = NJ;

impl Eskf {
    /// The RTK configuration in use (`None`: off).
    pub fn rtk_config(&self) -> Option<RtkConfig> {
        self.rtk.as_ref().map(|r| r.cfg)
    }

    /// Replace the RTK configuration between epochs (ambiguity slots,
    /// states and counters kept; the gates recomputed). For callers that
    /// change a choice per epoch, e.g. the pipeline's GNSS-only parity path
    /// (`navfuse_pipeline::rtk_gnss`), which sets [`RtkConfig::min_fix`] to
    /// the number of candidates so that only the full set may fix, as
    /// `navfuse baseline` does. Refused when off or invalid.
    pub fn rtk_set_config(&mut self, cfg: RtkConfig) -> Result<(), RtkConfigError> {
        if !cfg.is_valid() {
            return Err(RtkConfigError::Invalid);
        }
        let r = self.rtk.as_mut().ok_or(RtkConfigError::Incompatible)?;
        r.cfg = cfg;
        r.gate = kalman::chi2_quantile(1, cfg.gate_probability);
        r.slip_gate = kalman::chi2_quantile(1, cfg.slip_probability);
        Ok(())
    }

    /// Forget the position and velocity prior before the next RTK epoch:
    /// their rows and columns (with the ambiguities too) zeroed, variance
    /// `sigma_m²` per axis (m, m/s), the estimate kept where it is (the last
    /// epoch's posterior when nothing propagated it). `navfuse baseline`'s
    /// kinematic mode. Unlike [`RtkConfig::gnss_only`] the position is not
    /// re-centred on the code solution, so the rover troposphere and lines
    /// of sight are evaluated at the last estimate (cm off) rather than at a
    /// code solution (metres off): the modelled slant delay changes by
    /// ~0.3 mm per metre of height (Saastamoinen zenith delay 2.3 m over
    /// the ~7 km scale height) times the mapping function, and that
    /// derivative is not in `H`, so on the GEONET pair the re-centred
    /// linearisation moved the fixed baseline by up to 1.7 mm
    /// (`navfuse_pipeline::rtk_gnss`). No effect when off.
    pub fn rtk_forget_position(&mut self, sigma_m: f64) {
        let Some(r) = &mut self.rtk else { return };
        let s2 = sigma_m * sigma_m;
        for k in I_POS..I_VEL + 3 {
            for j in 0..NX {
                self.p[(k, j)] = 0.0;
                self.p[(j, k)] = 0.0;
            }
            self.p[(k, k)] = s2;
            for j in 0..NK {
                r.p_xa[(k, j)] = 0.0;
            }
        }
    }
}
