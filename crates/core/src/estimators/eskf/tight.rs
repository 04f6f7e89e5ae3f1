//! Tightly coupled GNSS/INS (issue 14): the ESKF updated with each
//! satellite's pseudorange and Doppler instead of a receiver's position fix.
//! Off by default; the plain filter does not run any of this and stays
//! bit-identical ([`super::Eskf::with_tight_coupling`]).
//!
//! **Clock states** ([`NC`] = 5, kept outside the 21×21 covariance like the
//! augmented states of [`super::aug`]): receiver clock bias `b` of the
//! reference system (GPS) [m], its drift `d` [m/s], and the inter-system
//! biases of Galileo, BeiDou and GLONASS relative to it [m]. Model
//! (Brown & Hwang, *Introduction to Random Signals and Applied Kalman
//! Filtering*, 4th ed., §9.3): `ḃ = d + w_b`, `ḋ = w_d` with PSDs
//! `S_b = h₀/2 · c²`, `S_d = 2π² h₋₂ · c²` from the oscillator's power-law
//! (Allan) coefficients; discretely `Φ = [[1, dt], [0, 1]]`,
//! `Q = [[S_b dt + S_d dt³/3, S_d dt²/2], [S_d dt²/2, S_d dt]]`. The
//! inter-system biases are random walks ([`TightConfig::isb_rw_psd`]),
//! zero-variance until their system is first seen. No coupling into the INS
//! error dynamics: `P_xc ← Φ_x P_xc Φ_cᵀ`, `P_cc ← Φ_c P_cc Φ_cᵀ + Q_c`.
//!
//! **Measurements** (Groves 2nd ed. §14.3.3, RTKLIB `pntpos`), predicted at
//! the antenna `r_a = r + C_bn l` (lever arm `l`, body) with earth rotation
//! during travel ([`crate::gnss::raw::geometric_range`]):
//! - pseudorange `ρ̂ = |r_s − r_a| + sagnac + b_sys − c·δt_s + T + I`,
//!   `T` Saastamoinen + Niell ([`crate::gnss::tropo`], relative humidity
//!   [`REL_HUMIDITY`]), `I` the record's broadcast correction;
//!   `H = [−uᵀ, 0, −uᵀ[l_n×], 0…, 1 (b), 1 (isb_sys)]`, `u` the NED unit line
//!   of sight antenna → satellite (`δr_a = δr + [l_n×] φ`, as the loose
//!   position update);
//! - range rate from Doppler `−λ D = u·(v_s − v_a) + sagnac rate + d − c·δṫ_s`,
//!   `v_a = v + C_bn (ω_ib^b × l)`: `H = [0, −uᵀ, −uᵀ[(C_bn ω×l)×], …, 1 (d)]`.
//!
//! Each satellite is a scalar update (sequential processing of independent
//! measurements equals the batch update; Groves §3.2.6) with its own χ² gate
//! (one degree of freedom, [`TightConfig::gate_probability`]); what happened
//! to each satellite is counted by satellite and reason ([`TightStats`]). One
//! or two satellites still update the filter: the clock absorbs the common
//! part, the rest constrains position along the line-of-sight differences.
//!
//! **Weights**: `σ_ρ² = σ_code² + σ_mp² + σ_T² + var_sat` (the last two in the
//! satellite's consider state when it has a slot) with
//! `σ_code = σ_code,ref · 10^((C/N0_ref − C/N0)/20)` (DLL thermal noise
//! ∝ (C/N0)^−½, Kaplan & Hegarty 2nd ed. eq. 5.78; a record without C/N0
//! uses the reference), `σ_mp = σ_mp,zenith / sin el` capped (elevation
//! model, RTKLIB `varerr`), `σ_T = 0.3 m / (sin el + 0.1)` (RTKLIB
//! `ERR_SAAS`), `var_sat` the record's orbit/clock/ionosphere variance.
//!
//! **Satellite errors** ([`NS`] slots, on by default,
//! [`TightConfig::consider_sat_errors`]): the slowly varying part of each
//! satellite's pseudorange error is a Gauss–Markov Schmidt consider state
//! (in the covariance and the gain, never estimated), so minutes of one
//! satellite are not averaged as if its error were white; R keeps the white
//! part. A slot is freed when its satellite is missing from an epoch.
//!
//! Limits (honestly): multipath (τ ~ seconds) is weighted as white; tight coupling refuses augmented
//! states (their joint update is not written); with the RTS smoother on,
//! the clock block is not part of the smoother records (its gain ignores the
//! clock–INS correlation); carrier phase is carried in the records but not
//! used; GLONASS inter-frequency biases are not modelled.

use super::aug::gated_update;
use super::{apply_correction, skew, Eskf, FSparse, UpdateReject, I_ATT, I_POS, I_VEL, NX};
use crate::geodesy::{c_en, geodetic_to_ecef, Geodetic};
use crate::gnss::raw::{
    geometric_range, geometric_range_rate, GnssSystem, RawEpoch, RawSat, MAX_RAW_SATS,
};
use crate::gnss::tropo::{day_of_year, slant_delay};
use crate::gnss::C_LIGHT;
use crate::kalman;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

/// Number of clock states.
pub const NC: usize = 5;
/// Index of the reference-system clock bias [m].
pub const IC_BIAS: usize = 0;
/// Index of the clock drift [m/s].
pub const IC_DRIFT: usize = 1;
/// Index of the first inter-system bias (Galileo; then BeiDou, GLONASS) [m].
pub const IC_ISB: usize = 2;
/// Satellite-error slots (Schmidt consider states, see [`TightConfig::sat_error_tau_s`]).
pub const NS: usize = 12;
/// Clock + slot states kept beside the 21×21 covariance.
const NK: usize = NC + NS;
const NT: usize = NX + NK;

/// Relative humidity of the standard atmosphere for the tropospheric
/// model (RTKLIB `REL_HUMI`, 0.7).
pub const REL_HUMIDITY: f64 = 0.7;

/// Oscillator power-law coefficients (fractional-frequency PSD
/// `S_y(f) = h₀ + h₋₂/f²`, white frequency and random-walk frequency; the
/// flicker term h₋₁ is neglected as usual in two-state models).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockModel {
    pub h0: f64,
    pub h_m2: f64,
}

impl ClockModel {
    /// Temperature-compensated crystal oscillator (TCXO), the clock of
    /// consumer receivers: h₀ = 2e-19, h₋₂ = 2e-20 (Brown & Hwang 4th ed.
    /// Table 9.1).
    pub const TCXO: ClockModel = ClockModel {
        h0: 2e-19,
        h_m2: 2e-20,
    };
    /// PSDs of the bias [m²/s] and drift [m²/s³] driving noises:
    /// `S_b = h₀/2 · c²`, `S_d = 2π² h₋₂ · c²` (Brown & Hwang eq. 9.3.8).
    pub fn psd(&self) -> (f64, f64) {
        let c2 = C_LIGHT * C_LIGHT;
        (
            0.5 * self.h0 * c2,
            2.0 * core::f64::consts::PI * core::f64::consts::PI * self.h_m2 * c2,
        )
    }
}

/// Configuration of the tightly coupled updates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TightConfig {
    pub clock: ClockModel,
    /// Code thermal noise σ at `cn0_ref_dbhz` [m].
    pub code_sigma_m: f64,
    /// C/N0 of `code_sigma_m` and `doppler_sigma_mps` [dB-Hz].
    pub cn0_ref_dbhz: f64,
    /// Code multipath σ at the zenith [m] (σ / sin el, capped at `mp_cap_m`).
    pub mp_zenith_m: f64,
    pub mp_cap_m: f64,
    /// Range-rate (Doppler) σ at `cn0_ref_dbhz` and the zenith [m/s].
    pub doppler_sigma_mps: f64,
    /// Records below this elevation [rad] or C/N0 [dB-Hz] are not used.
    pub elevation_mask_rad: f64,
    pub min_cn0_dbhz: f64,
    /// χ² gate probability of each scalar update (e.g. 0.9999).
    pub gate_probability: f64,
    /// Use Doppler.
    pub use_doppler: bool,
    /// Random-walk PSD of the inter-system biases [m²/s].
    pub isb_rw_psd: f64,
    /// Carry each satellite's slowly varying pseudorange error (orbit,
    /// clock, ionosphere, troposphere; variance = the record's `var_m2` +
    /// the troposphere model's) as a first-order Gauss–Markov Schmidt
    /// "consider" state (Schmidt 1966; Simon 2006 §7.5): it enters the
    /// covariance and the gain but is never estimated, so a satellite seen
    /// for minutes is not averaged as if its error were white.
    pub consider_sat_errors: bool,
    /// Its correlation time [s].
    pub sat_error_tau_s: f64,
    /// Correlation time of code multipath [s] and the update interval
    /// [s]: multipath is weighted as white noise with its variance scaled
    /// by `(1 + φ)/(1 − φ)`, `φ = e^(−interval/τ)` — the white noise with
    /// the same low-frequency power (PSD at 0 of the Gauss–Markov
    /// sequence, Brown & Hwang §2.10), so averaging consecutive epochs does
    /// not shrink it. 0: no scaling.
    pub mp_tau_s: f64,
    pub interval_s: f64,
}

impl TightConfig {
    /// A consumer single-frequency receiver with a patch antenna:
    /// - code 0.5 m at 45 dB-Hz: DLL σ = T_c √(B_L d / (2 C/N0)) with
    ///   T_c = 293 m, B_L = 0.5 Hz, d = 0.5 chip (Kaplan & Hegarty 2nd ed.
    ///   eq. 5.78) gives 0.58 m;
    /// - multipath 0.6 m / sin el, capped at 3 m: open-sky C/A code
    ///   multipath of order 1 m at low elevation (Braasch, in Parkinson &
    ///   Spilker 1996, vol. 1 ch. 14);
    /// - range rate 0.05 m/s: u-blox M8 datasheet velocity accuracy
    ///   0.05 m/s (UBX-16012619);
    /// - mask 10°, 25 dB-Hz (below that consumer receivers lose code lock);
    /// - gate 0.9999 (χ²₁ = 15.1): a 3.9σ outlier test per satellite;
    /// - TCXO clock; inter-system biases nearly constant (hardware delays):
    ///   random walk 1 mm/√s;
    /// - satellite errors as consider states with τ = 1800 s: the broadcast
    ///   ionosphere residual follows the diurnal ionosphere (hours) and the
    ///   broadcast orbit/clock error the 2 h upload cycle; 30 min is the
    ///   shorter, less confident end (the simulator's ionosphere uses the
    ///   same value: the experiment tests the method, not this τ);
    /// - multipath correlation 10 s at 1 Hz: reflections of a moving car
    ///   decorrelate within seconds to tens of seconds (again the
    ///   simulator's value).
    pub fn consumer() -> Self {
        TightConfig {
            clock: ClockModel::TCXO,
            code_sigma_m: 0.5,
            cn0_ref_dbhz: 45.0,
            mp_zenith_m: 0.6,
            mp_cap_m: 3.0,
            doppler_sigma_mps: 0.05,
            elevation_mask_rad: 10f64.to_radians(),
            min_cn0_dbhz: 25.0,
            gate_probability: 0.9999,
            use_doppler: true,
            isb_rw_psd: 1e-6,
            consider_sat_errors: false,
            sat_error_tau_s: 1800.0,
            mp_tau_s: 0.0,
            interval_s: 1.0,
        }
    }

    fn is_valid(&self) -> bool {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        pos(self.clock.h0)
            && pos(self.clock.h_m2)
            && pos(self.code_sigma_m)
            && self.cn0_ref_dbhz.is_finite()
            && self.mp_zenith_m.is_finite()
            && self.mp_zenith_m >= 0.0
            && self.mp_cap_m >= self.mp_zenith_m
            && pos(self.doppler_sigma_mps)
            && self.elevation_mask_rad.is_finite()
            && self.min_cn0_dbhz.is_finite()
            && self.gate_probability > 0.0
            && self.gate_probability < 1.0
            && self.isb_rw_psd.is_finite()
            && self.isb_rw_psd >= 0.0
            && pos(self.sat_error_tau_s)
            && self.mp_tau_s >= 0.0
            && self.interval_s >= 0.0
    }

    /// Pseudorange σ² [m²] at elevation `el` [rad] and C/N0 `cn0` (≤ 0:
    /// unknown), without the record's own variance: white + troposphere.
    pub fn pr_var(&self, el: f64, cn0: f64) -> f64 {
        self.pr_var_white(el, cn0) + self.trop_var(el)
    }

    /// The white part: code noise and multipath.
    pub fn pr_var_white(&self, el: f64, cn0: f64) -> f64 {
        let s = el.sin().max(0.05);
        let code = self.code_sigma_m * self.cn0_factor(cn0);
        let mp = (self.mp_zenith_m / s).min(self.mp_cap_m);
        let k = if self.mp_tau_s > 0.0 && self.interval_s > 0.0 {
            let phi = (-self.interval_s / self.mp_tau_s).exp();
            (1.0 + phi) / (1.0 - phi)
        } else {
            1.0
        };
        code * code + mp * mp * k
    }

    /// Troposphere model error σ² (RTKLIB `ERR_SAAS` 0.3 m / (sin el + 0.1)).
    pub fn trop_var(&self, el: f64) -> f64 {
        let t = 0.3 / (el.sin().max(0.05) + 0.1);
        t * t
    }

    /// Range-rate σ² [m²/s²].
    pub fn rr_var(&self, el: f64, cn0: f64) -> f64 {
        let s = el.sin().max(0.05);
        let sd = self.doppler_sigma_mps * self.cn0_factor(cn0) / s.sqrt();
        sd * sd
    }

    fn cn0_factor(&self, cn0: f64) -> f64 {
        if cn0 > 0.0 && cn0.is_finite() {
            10f64.powf(((self.cn0_ref_dbhz - cn0) / 20.0).max(0.0))
        } else {
            1.0
        }
    }
}

/// Why [`super::Eskf::with_tight_coupling`] refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TightConfigError {
    /// A σ, PSD or probability out of range.
    Invalid,
    /// Augmented states (GNSS error, time offset, odometer) are configured.
    WithAugmented,
}

impl core::fmt::Display for TightConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TightConfigError::Invalid => write!(
                f,
                "tight coupling: need positive clock coefficients and sigmas, \
                 multipath cap >= zenith sigma, gate probability in (0, 1)"
            ),
            TightConfigError::WithAugmented => write!(
                f,
                "tight coupling cannot run with augmented states \
                 (GNSS error, time offset, odometer) yet"
            ),
        }
    }
}

/// What happened to a satellite's records, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SatCounts {
    pub pr_used: u32,
    pub pr_gated: u32,
    pub dop_used: u32,
    pub dop_gated: u32,
    /// Below the elevation mask.
    pub low_elevation: u32,
    /// Below the C/N0 threshold.
    pub low_cn0: u32,
    /// No ephemeris, non-finite observable, or a singular update.
    pub bad: u32,
}

/// Counters of the tightly coupled updates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TightStats {
    pub epochs: u64,
    /// Epochs that came before the filter time (not applied).
    pub epochs_stale: u64,
    /// Records beyond an epoch's capacity.
    pub records_dropped: u64,
    /// Records of a signal other than its system's first civil one (a
    /// second frequency): the tight filter is single-frequency (one code
    /// bias and one ionosphere per satellite), so they are skipped here.
    pub records_other_signal: u64,
    /// Clock (re)initialisations (first epoch, receiver clock jumps).
    pub clock_inits: u64,
    /// Per system and PRN (index `system.index() * 64 + prn % 64`).
    pub per_sat: [SatCounts; 256],
    /// Σ NIS and count of the applied pseudorange and Doppler updates
    /// (mean NIS ≈ 1 when the weights are right).
    pub nis_pr: (f64, u64),
    pub nis_dop: (f64, u64),
}

impl Default for TightStats {
    fn default() -> Self {
        TightStats {
            epochs: 0,
            epochs_stale: 0,
            records_dropped: 0,
            records_other_signal: 0,
            clock_inits: 0,
            per_sat: [SatCounts::default(); 256],
            nis_pr: (0.0, 0),
            nis_dop: (0.0, 0),
        }
    }
}

impl TightStats {
    /// Counts of one satellite.
    pub fn sat(&self, system: GnssSystem, prn: u8) -> &SatCounts {
        &self.per_sat[system.index() * 64 + prn as usize % 64]
    }
    /// Totals over all satellites.
    pub fn total(&self) -> SatCounts {
        self.per_sat
            .iter()
            .fold(SatCounts::default(), |a, s| SatCounts {
                pr_used: a.pr_used + s.pr_used,
                pr_gated: a.pr_gated + s.pr_gated,
                dop_used: a.dop_used + s.dop_used,
                dop_gated: a.dop_gated + s.dop_gated,
                low_elevation: a.low_elevation + s.low_elevation,
                low_cn0: a.low_cn0 + s.low_cn0,
                bad: a.bad + s.bad,
            })
    }
}

/// Clock estimate with 1-σ.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ClockEstimate {
    pub bias_m: f64,
    pub bias_std_m: f64,
    pub drift_mps: f64,
    pub drift_std_mps: f64,
    /// Inter-system biases (Galileo, BeiDou, GLONASS) [m], 0 until seen.
    pub isb_m: [f64; 3],
}

/// The tight-coupling block of the filter.
#[derive(Clone, Debug)]
pub(super) struct Tight {
    cfg: TightConfig,
    /// Clock states then slot states (slots always 0: consider).
    x: SVector<f64, NK>,
    p_xc: SMatrix<f64, NX, NK>,
    p_cc: SMatrix<f64, NK, NK>,
    /// Which satellite (`system.index() · 64 + prn`) owns each slot, its
    /// steady-state variance [m²], and whether the current epoch has it.
    slot_key: [Option<u16>; NS],
    slot_var: [f64; NS],
    slot_seen: [bool; NS],
    /// Gain mask of the joint update: 0 on the slots (consider), 1 else.
    mask: SVector<f64, NT>,
    s_b: f64,
    s_d: f64,
    clock_init: bool,
    isb_seen: [bool; 3],
    gate: f64,
    /// Epoch being assembled from records, and the complete one waiting for
    /// its time.
    building: RawEpoch,
    pending: Option<RawEpoch>,
    pub(super) stats: TightStats,
}

impl Tight {
    pub(super) fn new(cfg: TightConfig) -> Result<Self, TightConfigError> {
        if !cfg.is_valid() {
            return Err(TightConfigError::Invalid);
        }
        let (s_b, s_d) = cfg.clock.psd();
        Ok(Tight {
            cfg,
            x: SVector::zeros(),
            p_xc: SMatrix::zeros(),
            p_cc: SMatrix::zeros(),
            slot_key: [None; NS],
            slot_var: [0.0; NS],
            slot_seen: [false; NS],
            mask: SVector::from_fn(|i, _| if i >= NX + NC { 0.0 } else { 1.0 }),
            s_b,
            s_d,
            clock_init: false,
            isb_seen: [false; 3],
            gate: kalman::chi2_quantile(1, cfg.gate_probability),
            building: RawEpoch::default(),
            pending: None,
            stats: TightStats::default(),
        })
    }

    /// Propagate the clock block over `dt` with the filter's `F` (set for
    /// this interval).
    pub(super) fn propagate(&mut self, fs: &FSparse, dt: f64) {
        let fp = fs.f_times(&self.p_xc);
        self.p_xc += fp * dt;
        // · Φ_cᵀ: column b += dt · column d.
        for i in 0..NX {
            self.p_xc[(i, IC_BIAS)] += dt * self.p_xc[(i, IC_DRIFT)];
        }
        let mut phi = SMatrix::<f64, NK, NK>::identity();
        phi[(IC_BIAS, IC_DRIFT)] = dt;
        let phi_s = (-dt / self.cfg.sat_error_tau_s).exp();
        for k in 0..NS {
            if self.slot_key[k].is_some() {
                phi[(NC + k, NC + k)] = phi_s;
                for i in 0..NX {
                    self.p_xc[(i, NC + k)] *= phi_s;
                }
            }
        }
        self.p_cc = phi * self.p_cc * phi.transpose();
        for k in 0..NS {
            if self.slot_key[k].is_some() {
                self.p_cc[(NC + k, NC + k)] += self.slot_var[k] * (1.0 - phi_s * phi_s);
            }
        }
        let (sb, sd) = (self.s_b, self.s_d);
        if self.clock_init {
            self.p_cc[(IC_BIAS, IC_BIAS)] += sb * dt + sd * dt * dt * dt / 3.0;
            self.p_cc[(IC_BIAS, IC_DRIFT)] += sd * dt * dt / 2.0;
            self.p_cc[(IC_DRIFT, IC_BIAS)] += sd * dt * dt / 2.0;
            self.p_cc[(IC_DRIFT, IC_DRIFT)] += sd * dt;
        }
        for k in 0..3 {
            if self.isb_seen[k] {
                self.p_cc[(IC_ISB + k, IC_ISB + k)] += self.cfg.isb_rw_psd * dt;
            }
        }
        self.x[IC_BIAS] += self.x[IC_DRIFT] * dt;
    }

    /// Take one record; a complete epoch becomes pending.
    pub(super) fn accept(&mut self, r: &RawSat) {
        if self.building.n > 0 && r.obs.t != self.building.t {
            self.close();
        }
        if self.building.n == 0 {
            self.building = RawEpoch::new(r.obs.t);
        }
        if !r.obs.signal.is_first() {
            self.stats.records_other_signal += 1;
        } else if !self.building.push(*r) {
            self.stats.records_dropped += 1;
        }
        if r.obs.last_in_epoch {
            self.close();
        }
    }

    fn close(&mut self) {
        if self.building.n > 0 {
            if self.pending.is_some() {
                self.stats.epochs_stale += 1;
            }
            self.pending = Some(self.building);
            self.building.n = 0;
        }
    }

    /// Time of the pending epoch.
    pub(super) fn due(&self) -> Option<f64> {
        self.pending.map(|e| e.t)
    }

    fn full(&self, p: &SMatrix<f64, NX, NX>) -> SMatrix<f64, NT, NT> {
        let mut f = SMatrix::<f64, NT, NT>::zeros();
        f.fixed_view_mut::<NX, NX>(0, 0).copy_from(p);
        f.fixed_view_mut::<NX, NK>(0, NX).copy_from(&self.p_xc);
        f.fixed_view_mut::<NK, NX>(NX, 0)
            .copy_from(&self.p_xc.transpose());
        f.fixed_view_mut::<NK, NK>(NX, NX).copy_from(&self.p_cc);
        f
    }

    fn split(&mut self, f: &SMatrix<f64, NT, NT>, p: &mut SMatrix<f64, NX, NX>) {
        p.copy_from(&f.fixed_view::<NX, NX>(0, 0));
        self.p_xc =
            (f.fixed_view::<NX, NK>(0, NX) + f.fixed_view::<NK, NX>(NX, 0).transpose()) * 0.5;
        let cc = f.fixed_view::<NK, NK>(NX, NX);
        self.p_cc = (cc + cc.transpose()) * 0.5;
    }

    /// An INS-only update `h` (no clock terms) done jointly with the clock
    /// block, so the clock–INS covariance stays consistent
    /// ([`super::Eskf::update_aug`] with tight coupling on).
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
        let mut pf = self.full(p);
        let mut hf = SMatrix::<f64, M, NT>::zeros();
        hf.fixed_view_mut::<M, NX>(0, 0).copy_from(h);
        let mut dxf = SVector::<f64, NT>::zeros();
        let mask = self.consider_mask();
        let res = gated_update(
            &mut dxf,
            &mut pf,
            &hf,
            r,
            dz,
            gate,
            deweight_factor,
            mask,
            None,
        );
        if res.is_ok() {
            self.split(&pf, p);
            dx.copy_from(&dxf.fixed_rows::<NX>(0));
            self.x -= dxf.fixed_rows::<NK>(NX);
        }
        res
    }

    /// The consider mask when slots are in use.
    fn consider_mask(&self) -> Option<&SVector<f64, NT>> {
        self.slot_key
            .iter()
            .any(|k| k.is_some())
            .then_some(&self.mask)
    }

    /// The slot of satellite `key`, allocating a free one with variance
    /// `var` (`None`: all slots taken, or slots off).
    fn slot(&mut self, key: u16, var: f64) -> Option<usize> {
        if !self.cfg.consider_sat_errors {
            return None;
        }
        let k = match self.slot_key.iter().position(|s| *s == Some(key)) {
            Some(k) => k,
            None => {
                let k = self.slot_key.iter().position(|s| s.is_none())?;
                self.slot_key[k] = Some(key);
                self.slot_var[k] = var;
                self.p_cc[(NC + k, NC + k)] = var;
                k
            }
        };
        self.slot_seen[k] = true;
        Some(k)
    }

    /// Free the slots of satellites the epoch did not have (their error is
    /// forgotten: a satellite coming back starts with its prior variance).
    fn free_unseen_slots(&mut self) {
        for k in 0..NS {
            if self.slot_key[k].is_some() && !self.slot_seen[k] {
                self.slot_key[k] = None;
                self.x[NC + k] = 0.0;
                for i in 0..NX {
                    self.p_xc[(i, NC + k)] = 0.0;
                }
                for j in 0..NK {
                    self.p_cc[(NC + k, j)] = 0.0;
                    self.p_cc[(j, NC + k)] = 0.0;
                }
            }
            self.slot_seen[k] = false;
        }
    }

    pub(super) fn estimate(&self) -> ClockEstimate {
        let sd = |i: usize| self.p_cc[(i, i)].max(0.0).sqrt();
        ClockEstimate {
            bias_m: self.x[IC_BIAS],
            bias_std_m: sd(IC_BIAS),
            drift_mps: self.x[IC_DRIFT],
            drift_std_mps: sd(IC_DRIFT),
            isb_m: [self.x[IC_ISB], self.x[IC_ISB + 1], self.x[IC_ISB + 2]],
        }
    }
}

/// Antenna geometry of the current state.
struct Antenna {
    r_e: Vec3,
    v_e: Vec3,
    c_en: Mat3,
    l_n: Vec3,
    lever_v: Vec3,
    lat: f64,
    h: f64,
}

/// Median of `v[..n]` (sorted in place).
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

impl Eskf {
    /// Couple the INS tightly to raw GNSS records ([`crate::types::Event::RawGnss`];
    /// module [`tight`](self)). Position fixes (`Event::Gnss`) are still
    /// used if given. Refused with augmented states configured.
    pub fn with_tight_coupling(mut self, cfg: TightConfig) -> Result<Self, TightConfigError> {
        if self.aug.is_some() {
            return Err(TightConfigError::WithAugmented);
        }
        self.tight = Some(Tight::new(cfg)?);
        Ok(self)
    }

    /// Forget the position's prior: its covariance rows and columns (with
    /// the clock/slot cross terms of tight coupling) are zeroed and its
    /// variance set to `sigma_m²` per axis; the estimate is kept.
    ///
    /// Why: a position aligned on single-point fixes carries the same
    /// satellite errors as the pseudoranges the tight filter then uses
    /// (the fix is a least-squares image of those ranges). Kept as an
    /// independent prior, it is counted twice (Bar-Shalom, Li &
    /// Kirubarajan 2001, §8.6 on fusing correlated estimates): the
    /// satellite consider states start uncorrelated with it, and the
    /// filter reports the σ of two independent measurements of one error.
    pub fn forget_position_prior(&mut self, sigma_m: f64) {
        for k in I_POS..I_POS + 3 {
            for j in 0..NX {
                self.p[(k, j)] = 0.0;
                self.p[(j, k)] = 0.0;
            }
            self.p[(k, k)] = sigma_m * sigma_m;
            if let Some(t) = &mut self.tight {
                for j in 0..NK {
                    t.p_xc[(k, j)] = 0.0;
                }
            }
        }
    }

    /// Counters of the tight coupling (`None`: off).
    pub fn tight_stats(&self) -> Option<&TightStats> {
        self.tight.as_ref().map(|t| &t.stats)
    }

    /// Receiver clock estimate (`None`: tight coupling off).
    pub fn clock(&self) -> Option<ClockEstimate> {
        self.tight.as_ref().map(|t| t.estimate())
    }

    pub(super) fn push_raw(&mut self, r: &RawSat) {
        if let Some(t) = &mut self.tight {
            t.accept(r);
        }
    }

    /// Before the IMU interval `(self.t, imu.t]`: apply a pending raw epoch
    /// at or before its start, or split the interval at an epoch inside it
    /// (propagating to it and updating there). Returns the rest of the
    /// interval when split. An epoch at the interval's end is left for
    /// [`Eskf::tight_after`]. Does nothing without tight coupling.
    pub(super) fn tight_before(
        &mut self,
        imu: &crate::types::ImuSample,
    ) -> Option<crate::types::ImuSample> {
        let te = self.tight.as_ref()?.due()?;
        let (t0, t1) = (self.t, imu.t);
        if te < t0 - super::TIME_ALIGN {
            if let Some(t) = &mut self.tight {
                t.pending = None;
                t.stats.epochs_stale += 1;
            }
            return None;
        }
        if te <= t0 + super::TIME_ALIGN {
            self.raw_update();
            return None;
        }
        if te >= t1 - super::TIME_ALIGN {
            return None;
        }
        let lambda = (te - t0) / (t1 - t0);
        self.propagate(&(imu.dtheta_b * lambda), &(imu.dvel_b * lambda), te - t0);
        self.t = te;
        self.raw_update();
        Some(crate::types::ImuSample {
            t: t1,
            dt: t1 - te,
            dtheta_b: imu.dtheta_b * (1.0 - lambda),
            dvel_b: imu.dvel_b * (1.0 - lambda),
        })
    }

    /// After the IMU interval ending at `self.t`: apply an epoch due now.
    pub(super) fn tight_after(&mut self) {
        let Some(te) = self.tight.as_ref().and_then(|t| t.due()) else {
            return;
        };
        if (te - self.t).abs() <= super::TIME_ALIGN {
            self.raw_update();
        }
    }

    fn antenna(&self) -> Antenna {
        let (lat, lon, h) = self.antenna_position();
        let c = self.nav.c_bn();
        let lever_v = c * self.w_ib_b.cross(&self.cfg.lever_arm_b);
        let c_en = c_en(lat, lon);
        let c_ne = c_en.transpose();
        Antenna {
            r_e: geodetic_to_ecef(&Geodetic { lat, lon, h }),
            v_e: c_ne * (self.nav.v_n + lever_v),
            c_en,
            l_n: c * self.cfg.lever_arm_b,
            lever_v,
            lat,
            h,
        }
    }

    /// Pseudorange residual `measured − predicted without receiver clock` [m],
    /// NED line of sight and elevation.
    fn pr_residual(s: &RawSat, a: &Antenna, doy: f64) -> (f64, Vec3, Vec3, f64) {
        let (rho, los_e) = geometric_range(&s.sat.pos_e, &a.r_e);
        let u_n = a.c_en * los_e;
        let el = (-u_n.z).clamp(-1.0, 1.0).asin();
        let trop = slant_delay(el.max(0.0), a.lat, a.h, doy, REL_HUMIDITY);
        let pred = rho - s.sat.clock_m + trop + s.sat.iono_m as f64;
        (s.obs.pseudorange_m - pred, u_n, los_e, el)
    }

    /// Range-rate residual `measured − predicted without drift` [m/s].
    fn rr_residual(s: &RawSat, a: &Antenna, los_e: &Vec3) -> f64 {
        let rr_meas = -s.obs.wavelength_m() * s.obs.doppler_hz;
        let pred = geometric_range_rate(&s.sat, &a.r_e, &a.v_e, los_e) - s.sat.clock_rate_mps;
        rr_meas - pred
    }

    /// Initialise the clock (and new inter-system biases) from the medians
    /// of the epoch's residuals, σ generous against the position σ.
    fn init_clock(&mut self, ep: &RawEpoch, force: bool) {
        let a = self.antenna();
        let doy = day_of_year(ep.t);
        let pos_sd = (self.p[(I_POS, I_POS)]
            + self.p[(I_POS + 1, I_POS + 1)]
            + self.p[(I_POS + 2, I_POS + 2)])
            .max(0.0)
            .sqrt();
        let vel_sd = (self.p[(I_VEL, I_VEL)]
            + self.p[(I_VEL + 1, I_VEL + 1)]
            + self.p[(I_VEL + 2, I_VEL + 2)])
            .max(0.0)
            .sqrt();
        let Some(t) = &mut self.tight else { return };
        let mut res = [[0.0f64; MAX_RAW_SATS]; 4];
        let mut nres = [0usize; 4];
        let mut rr = [0.0f64; MAX_RAW_SATS];
        let mut nrr = 0;
        for s in ep.sats() {
            if !s.sat.valid || !s.obs.pseudorange_m.is_finite() {
                continue;
            }
            let (r, _, los_e, el) = Self::pr_residual(s, &a, doy);
            if el < t.cfg.elevation_mask_rad {
                continue;
            }
            let k = s.obs.system.index();
            res[k][nres[k]] = r;
            nres[k] += 1;
            if s.obs.doppler_hz.is_finite() {
                rr[nrr] = Self::rr_residual(s, &a, &los_e);
                nrr += 1;
            }
        }
        if !t.clock_init || force {
            if nres[0] == 0 {
                return;
            }
            t.x[IC_BIAS] = median(&mut res[0][..nres[0]]);
            t.x[IC_DRIFT] = if nrr > 0 { median(&mut rr[..nrr]) } else { 0.0 };
            // Any correlation with the INS is dropped (conservative).
            for j in 0..NC {
                for i in 0..NX {
                    t.p_xc[(i, j)] = 0.0;
                }
                for i in 0..NK {
                    t.p_cc[(i, j)] = 0.0;
                    t.p_cc[(j, i)] = 0.0;
                }
            }
            let sb = 3.0 * pos_sd + 30.0;
            let sd = 3.0 * vel_sd + 3.0;
            t.p_cc[(IC_BIAS, IC_BIAS)] = sb * sb;
            t.p_cc[(IC_DRIFT, IC_DRIFT)] = sd * sd;
            t.isb_seen = [false; 3];
            t.x.fixed_rows_mut::<3>(IC_ISB).fill(0.0);
            t.clock_init = true;
            t.stats.clock_inits += 1;
        }
        for k in 1..4 {
            if !t.isb_seen[k - 1] && nres[k] > 0 {
                t.x[IC_ISB + k - 1] = median(&mut res[k][..nres[k]]) - t.x[IC_BIAS];
                let sb = 3.0 * pos_sd + 30.0;
                t.p_cc[(IC_ISB + k - 1, IC_ISB + k - 1)] = sb * sb + t.p_cc[(IC_BIAS, IC_BIAS)];
                t.isb_seen[k - 1] = true;
            }
        }
    }

    /// One scalar update of the joint state (INS + clock), gated.
    fn tight_scalar(
        &mut self,
        h: &SMatrix<f64, 1, NT>,
        var: f64,
        dz: f64,
    ) -> Result<f64, UpdateReject> {
        let Some(t) = &mut self.tight else {
            return Err(UpdateReject::Singular);
        };
        if !(dz.is_finite() && var.is_finite() && var > 0.0) {
            return Err(UpdateReject::Singular);
        }
        let p_prior = self.p;
        let mut pf = t.full(&self.p);
        let mut dxf = SVector::<f64, NT>::zeros();
        let r = SMatrix::<f64, 1, 1>::new(var);
        let dzv = SVector::<f64, 1>::new(dz);
        let mask = t.consider_mask();
        match gated_update(
            &mut dxf,
            &mut pf,
            h,
            &r,
            &dzv,
            Some(t.gate),
            1.0,
            mask,
            None,
        ) {
            Ok((nis, _)) => {
                t.split(&pf, &mut self.p);
                t.x -= dxf.fixed_rows::<NK>(NX);
                let dx: super::StateVec = dxf.fixed_rows::<NX>(0).into();
                if self.cfg.smoother_every > 0 && self.rec_p_prior.is_none() {
                    self.rec_p_prior = Some(p_prior);
                }
                apply_correction(&mut self.nav, &mut self.err, &dx);
                self.rec_dx += dx;
                self.rec_updated = true;
                Ok(nis)
            }
            Err((e, _)) => Err(e),
        }
    }

    /// Apply the pending raw epoch at the current filter time.
    fn raw_update(&mut self) {
        let Some(ep) = self.tight.as_mut().and_then(|t| t.pending.take()) else {
            return;
        };
        let Some(cfg) = self.tight.as_ref().map(|t| t.cfg) else {
            return;
        };
        if let Some(t) = &mut self.tight {
            t.stats.epochs += 1;
            t.stats.records_dropped += ep.dropped as u64;
        }
        self.init_clock(&ep, false);
        // A receiver clock jump (millisecond steering) moves every residual
        // by far more than any error budget: re-initialise.
        {
            let a = self.antenna();
            let doy = day_of_year(ep.t);
            let mut d = [0.0f64; MAX_RAW_SATS];
            let mut n = 0;
            let b = self.tight.as_ref().map_or(0.0, |t| t.x[IC_BIAS]);
            for s in ep.sats() {
                if s.sat.valid && s.obs.system == GnssSystem::Gps && s.obs.pseudorange_m.is_finite()
                {
                    d[n] = Self::pr_residual(s, &a, doy).0 - b;
                    n += 1;
                }
            }
            if n > 0 && median(&mut d[..n]).abs() > 1000.0 {
                self.init_clock(&ep, true);
            }
        }
        let doy = day_of_year(ep.t);
        // Journal: one entry per epoch and observable (Σ NIS, used, tried).
        let mut j_pr = (0.0f64, 0usize, 0usize);
        let mut j_dop = (0.0f64, 0usize, 0usize);
        for s in ep.sats() {
            let key = s.obs.system.index() * 64 + s.obs.prn as usize % 64;
            let bump = |e: &mut Eskf, f: &dyn Fn(&mut SatCounts)| {
                if let Some(t) = &mut e.tight {
                    f(&mut t.stats.per_sat[key]);
                }
            };
            if !s.sat.valid || !s.obs.pseudorange_m.is_finite() {
                bump(self, &|c| c.bad += 1);
                continue;
            }
            let cn0 = s.obs.cn0_dbhz as f64;
            if cn0 > 0.0 && cn0 < cfg.min_cn0_dbhz {
                bump(self, &|c| c.low_cn0 += 1);
                continue;
            }
            let isb_k = match s.obs.system {
                GnssSystem::Gps => None,
                sys => Some(IC_ISB + sys.index() - 1),
            };
            // Pseudorange.
            let a = self.antenna();
            let (res, u_n, _, el) = Self::pr_residual(s, &a, doy);
            if el < cfg.elevation_mask_rad {
                bump(self, &|c| c.low_elevation += 1);
                continue;
            }
            let Some(clk) = self.tight.as_ref().map(|t| t.x) else {
                return;
            };
            let bias = clk[IC_BIAS] + isb_k.map_or(0.0, |k| clk[k]);
            let dz = bias - res;
            let mut h = SMatrix::<f64, 1, NT>::zeros();
            let ha = -(u_n.transpose() * skew(&a.l_n));
            for k in 0..3 {
                h[(0, I_POS + k)] = -u_n[k];
                h[(0, I_ATT + k)] = ha[(0, k)];
            }
            h[(0, NX + IC_BIAS)] = 1.0;
            if let Some(k) = isb_k {
                h[(0, NX + k)] = 1.0;
            }
            // The slowly varying part (orbit, clock, ionosphere,
            // troposphere) is the satellite's consider state; R keeps the
            // white part. Without a slot all of it is white.
            let slow = s.sat.var_m2 as f64 + cfg.trop_var(el);
            let slot = self.tight.as_mut().and_then(|t| t.slot(key as u16, slow));
            let var = match slot {
                Some(k) => {
                    h[(0, NX + NC + k)] = 1.0;
                    cfg.pr_var_white(el, cn0)
                }
                None => cfg.pr_var_white(el, cn0) + slow,
            };
            match self.tight_scalar(&h, var, dz) {
                Ok(nis) => {
                    bump(self, &|c| c.pr_used += 1);
                    self.tight_nis(nis, true);
                    j_pr = (j_pr.0 + nis, j_pr.1 + 1, j_pr.2 + 1);
                }
                Err(UpdateReject::Gate) => {
                    bump(self, &|c| c.pr_gated += 1);
                    j_pr.2 += 1;
                }
                Err(UpdateReject::Singular) => bump(self, &|c| c.bad += 1),
            }
            // Doppler.
            if !cfg.use_doppler || !s.obs.doppler_hz.is_finite() {
                continue;
            }
            let a = self.antenna();
            let (_, u_n, los_e, el) = Self::pr_residual(s, &a, doy);
            let Some(clk) = self.tight.as_ref().map(|t| t.x) else {
                return;
            };
            let dz = clk[IC_DRIFT] - Self::rr_residual(s, &a, &los_e);
            let mut h = SMatrix::<f64, 1, NT>::zeros();
            let ha = -(u_n.transpose() * skew(&a.lever_v));
            for k in 0..3 {
                h[(0, I_VEL + k)] = -u_n[k];
                h[(0, I_ATT + k)] = ha[(0, k)];
            }
            h[(0, NX + IC_DRIFT)] = 1.0;
            match self.tight_scalar(&h, cfg.rr_var(el, cn0), dz) {
                Ok(nis) => {
                    bump(self, &|c| c.dop_used += 1);
                    self.tight_nis(nis, false);
                    j_dop = (j_dop.0 + nis, j_dop.1 + 1, j_dop.2 + 1);
                }
                Err(UpdateReject::Gate) => {
                    bump(self, &|c| c.dop_gated += 1);
                    j_dop.2 += 1;
                }
                Err(UpdateReject::Singular) => bump(self, &|c| c.bad += 1),
            }
        }
        if let Some(t) = &mut self.tight {
            t.free_unseen_slots();
        }
        for (kind, j) in [
            (super::UpdateKind::Pseudorange, j_pr),
            (super::UpdateKind::Doppler, j_dop),
        ] {
            if j.2 > 0 {
                self.log_update(kind, j.1, j.0, j.1 > 0);
            }
        }
    }

    fn tight_nis(&mut self, nis: f64, pr: bool) {
        if let Some(t) = &mut self.tight {
            let s = if pr {
                &mut t.stats.nis_pr
            } else {
                &mut t.stats.nis_dop
            };
            s.0 += nis;
            s.1 += 1;
        }
    }
}
