//! Seed 001: loosely coupled GNSS/INS error-state Kalman filter with feedback
//! (`SEEDS.md §1`), extended to the 21-state KF-GINS model and to land-vehicle
//! aiding.
//!
//! **Nominal state** ([`NavState`] + [`ImuErrors`]): IMU position, NED velocity,
//! attitude `q_bn`, gyro/accel biases and scale factors; propagated by the
//! strapdown mechanization ([`crate::ins::mech`], `SEEDS.md §1` eq. 5–6) on
//! compensated increments `Δθ = (Δθ̃ − b_g dt)/(1 + s_g)`, `Δv = (Δṽ − b_a dt)/(1 + s_a)`.
//!
//! **Error state** (21, this order): `δr` NED position error [m], `δv` NED
//! velocity error [m/s], `φ` attitude error in the n-frame (psi angle) [rad],
//! `δb_g`, `δb_a`, `δs_g`, `δs_a`. Signs: `δr = r̂ − r`, `δv = v̂ − v`,
//! `C_bn = (I + [φ×]) Ĉ_bn`, `b = b̂ + δb`, `s = ŝ + δs`. With
//! [`EskfConfig::scale_factors`] off the scale states are held at zero with
//! zero variance: that is the 15-state filter of `SEEDS.md §1` eq. 9.
//! The bias and scale states are first-order Gauss–Markov processes with
//! correlation time `T` (driving PSD 2σ²/T); `T = ∞` gives random walks.
//!
//! **Propagation** (every IMU sample): `Φ = I + F dt` with the standard NED
//! psi-angle error model (`SEEDS.md §1` eq. 11; Titterton & Weston ch. 12;
//! Groves §14.2), `Q_d = G Q_c Gᵀ dt` and
//! `P ← Φ P Φᵀ + (Φ Q_d Φᵀ + Q_d)/2`, evaluated as `Φ (P + Q_d/2) Φᵀ + Q_d/2`
//! with the sparse block structure of `F` (no dense 21×21 product).
//!
//! **Updates** (`SEEDS.md §1` eq. 13, in metres): GNSS antenna position
//! (lever arm applied), GNSS antenna velocity, height only, zero velocity
//! (ZUPT), zero angular rate (ZARU), non-holonomic constraint (NHC). Joseph-form
//! covariance update, optional χ² innovation gate (rejections are counted),
//! feedback and reset after each update (`SEEDS.md §1` eq. 7, 10).
//!
//! A GNSS fix between two IMU samples is applied at its own time: the IMU
//! interval is split at the fix (increments scaled linearly), as KF-GINS does.
//!
//! Optional, off by default (outputs then unchanged): innovation-based
//! adaptive noise of the NHC/ZUPT/ZARU constraints ([`Eskf::with_adaptive_noise`],
//! [`super::adaptive`]) and a GNSS σ multiplier by solution quality
//! ([`Eskf::with_gnss_quality_scale`]); augmented error states for a
//! Gauss–Markov GNSS position error and the IMU–GNSS time offset
//! ([`Eskf::with_augmented_states`], [`aug`]).

use super::adaptive::{
    AdaptedNoise, AdaptiveConstraints, GnssQualityScale, NisAdaptation, NisScale, NoiseEstimator,
};
use crate::earth;
use crate::ins::mech::{mechanize_with, quat_from_rotvec, EarthAt, NavState};
use crate::kalman;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

mod aiding;
mod aug;
mod rtk;
mod sens;
mod tight;
pub use aiding::{AidingConfig, AidingStats, MAX_LAG_S};
use aug::{gated_update, Aug};
pub use aug::{
    AugConfigError, AugSmootherRecord, AugmentedEstimate, AugmentedStates, GnssErrorStates,
    NhcMountStates, TimeOffsetState, IA_GNSS, IA_MNT, IA_ODO, IA_TAU, NA, NF,
};
pub use rtk::{
    receiver_clock_bias_m, AmbKey, FixedDd, RtkConfig, RtkConfigError, RtkError, RtkSatCounts,
    RtkSolution, RtkStats, MAX_DD_PDOP, NAMB,
};
use sens::Sens;
pub use sens::SensitivityModel;
pub use tight::{
    ClockEstimate, ClockModel, SatCounts, TightConfig, TightConfigError, TightStats, IC_BIAS,
    IC_DRIFT, IC_ISB, NC, REL_HUMIDITY,
};

/// Number of error states.
pub const NX: usize = 21;
/// Index of `δr` (NED position error).
pub const I_POS: usize = 0;
/// Index of `δv`.
pub const I_VEL: usize = 3;
/// Index of `φ` (n-frame attitude error).
pub const I_ATT: usize = 6;
/// Index of `δb_g`.
pub const I_BG: usize = 9;
/// Index of `δb_a`.
pub const I_BA: usize = 12;
/// Index of `δs_g`.
pub const I_SG: usize = 15;
/// Index of `δs_a`.
pub const I_SA: usize = 18;

/// Error-state covariance.
pub type Cov = SMatrix<f64, NX, NX>;
/// Error-state vector.
pub type StateVec = SVector<f64, NX>;

/// IMU sensor errors (the estimated part of the nominal state).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ImuErrors {
    /// Gyro bias, body [rad/s].
    pub bg: Vec3,
    /// Accelerometer bias, body [m/s²].
    pub ba: Vec3,
    /// Gyro scale-factor error [-].
    pub sg: Vec3,
    /// Accelerometer scale-factor error [-].
    pub sa: Vec3,
}

/// IMU noise model, SI units (per axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuNoise {
    /// Angular random walk [rad/√s].
    pub arw: Vec3,
    /// Velocity random walk [m/s/√s].
    pub vrw: Vec3,
    /// Gyro bias steady-state σ [rad/s] (Gauss–Markov); with `corr_time = ∞`
    /// the random-walk PSD is `bg_std²` per second.
    pub bg_std: Vec3,
    /// Accelerometer bias σ [m/s²].
    pub ba_std: Vec3,
    /// Gyro scale-factor σ [-].
    pub sg_std: Vec3,
    /// Accelerometer scale-factor σ [-].
    pub sa_std: Vec3,
    /// Gauss–Markov correlation time [s]; `f64::INFINITY` for random walks.
    pub corr_time: f64,
}

/// Initial 1-σ uncertainties.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitStd {
    /// Position, NED [m].
    pub pos: Vec3,
    /// Velocity, NED [m/s].
    pub vel: Vec3,
    /// Attitude error φ, NED [rad].
    pub att: Vec3,
    /// Gyro bias [rad/s].
    pub bg: Vec3,
    /// Accelerometer bias [m/s²].
    pub ba: Vec3,
    /// Gyro scale factor [-].
    pub sg: Vec3,
    /// Accelerometer scale factor [-].
    pub sa: Vec3,
}

/// Non-holonomic constraint: the vehicle does not slip sideways or jump
/// (body lateral and vertical velocity ≈ 0). Applied at the IMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NhcConfig {
    /// 1-σ of the lateral (y) and vertical (z) body velocity [m/s].
    pub std: f64,
    /// Minimum time between NHC updates [s].
    pub interval: f64,
    /// Apply only above this speed [m/s] (at standstill ZUPT does the job).
    pub min_speed: f64,
}

/// Standstill detection and zero-velocity / zero-angular-rate updates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZuptConfig {
    /// Detector window [samples], ≤ [`ZUPT_MAX_WINDOW`].
    pub window: usize,
    /// Standstill if the std of |f| over the window is below this [m/s²] …
    pub max_accel_std: f64,
    /// … and the std of each gyro axis over the window is below this [rad/s] …
    pub max_gyro_std: f64,
    /// … and the window-mean specific force is within this of gravity at the
    /// current attitude [m/s²] (catches smooth acceleration) …
    pub max_accel_dev: f64,
    /// … and the filter's speed plus its 1-σ horizontal velocity uncertainty
    /// is below this [m/s] (an estimate that cannot exclude motion above the
    /// gate cannot confirm rest: in a GNSS outage σ_v grows and a quiet IMU on
    /// a platform cruising smoothly is no longer taken for a standstill).
    pub max_speed: f64,
    /// 1-σ of the zero-velocity pseudo-measurement [m/s].
    pub vel_std: f64,
    /// 1-σ of the window-mean angular rate for ZARU [rad/s]; `None`: no ZARU.
    pub zaru_std: Option<f64>,
    /// Minimum time between updates [s].
    pub interval: f64,
}

/// Largest standstill-detector window.
pub const ZUPT_MAX_WINDOW: usize = 256;

/// Filter configuration (everything that is not the initial state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EskfConfig {
    /// IMU noise and error processes.
    pub noise: ImuNoise,
    /// GNSS antenna position in the body frame FRD, from the IMU [m].
    pub lever_arm_b: Vec3,
    /// Estimate scale factors (21 states, the KF-GINS model); off: 15 states.
    pub scale_factors: bool,
    /// χ² gate probability for GNSS and constraint updates (e.g. 0.9999); `None`: no gate.
    pub gate_probability: Option<f64>,
    /// Innovations with NIS between the gate and this multiple of it are
    /// applied with R scaled by NIS/gate instead of rejected (robust
    /// de-weighting of a filter that is briefly overconfident); beyond it they
    /// are rejected and counted. 1: plain gate.
    pub gate_deweight_factor: f64,
    /// After this many consecutive gated-out GNSS positions the next one is
    /// applied without the gate (recovers from a filter that has drifted away
    /// and become overconfident); 0: never.
    pub gnss_force_after: u32,
    /// Use the GNSS velocity when a fix carries one.
    pub use_gnss_velocity: bool,
    /// After this time [s] the GNSS horizontal position is no longer used: only
    /// velocity and height aid the INS (`SEEDS.md §1`, the paper's after-370 s mode).
    pub position_until: Option<f64>,
    /// Non-holonomic constraint.
    pub nhc: Option<NhcConfig>,
    /// Zero-velocity updates.
    pub zupt: Option<ZuptConfig>,
    /// Keep a checkpoint every this many IMU samples for the RTS smoother
    /// (and at every update); 0: no smoother records.
    pub smoother_every: usize,
    /// Odometer, baseline heading, magnetometer (issue 17; default: none).
    pub aiding: AidingConfig,
}

impl EskfConfig {
    /// The seed 001 paper's noise (`SEEDS.md §1` eq. 12) as a preset:
    /// Q = diag(0, 0.05²·I, 0.01²·I, 0) per second (velocity and attitude random
    /// walk), constant biases, 15 states, position + velocity aiding.
    /// The paper's R is in rad² for latitude/longitude; here the GNSS σ of each
    /// fix is used (the paper's R converts to 0.70 m, 0.21 m, 1.07 m at 35° N).
    pub fn seed001() -> Self {
        EskfConfig {
            noise: ImuNoise {
                arw: Vec3::repeat(0.01),
                vrw: Vec3::repeat(0.05),
                bg_std: Vec3::zeros(),
                ba_std: Vec3::zeros(),
                sg_std: Vec3::zeros(),
                sa_std: Vec3::zeros(),
                corr_time: f64::INFINITY,
            },
            lever_arm_b: Vec3::zeros(),
            scale_factors: false,
            gate_probability: None,
            gnss_force_after: 0,
            gate_deweight_factor: 1.0,
            use_gnss_velocity: true,
            position_until: None,
            nhc: None,
            zupt: None,
            smoother_every: 0,
            aiding: AidingConfig::default(),
        }
    }
}

/// Counters of what the filter did with its inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EskfStats {
    pub imu_samples: u64,
    /// IMU samples with a non-positive or non-finite interval (skipped).
    pub imu_rejected_bad: u64,
    pub gnss_pos_used: u64,
    pub gnss_pos_rejected_gate: u64,
    /// Updates beyond the gate but within `gate_deweight_factor` × gate,
    /// applied with an inflated R.
    pub deweighted: u64,
    /// Fixes applied without the gate after `gnss_force_after` rejections.
    pub gnss_pos_forced: u64,
    /// Fixes dropped because they were older than the filter time or not finite.
    pub gnss_rejected_bad: u64,
    pub gnss_vel_used: u64,
    pub gnss_vel_rejected_gate: u64,
    pub height_used: u64,
    pub height_rejected_gate: u64,
    pub nhc_used: u64,
    pub nhc_rejected_gate: u64,
    pub zupt_used: u64,
    pub zupt_rejected_gate: u64,
    pub zaru_used: u64,
    /// Updates skipped because the innovation covariance was not invertible.
    pub singular: u64,
    /// Odometer, heading and magnetometer updates.
    pub aiding: AidingStats,
}

/// One checkpoint of the forward filter for the RTS smoother (Rauch, Tung &
/// Striebel 1965; Groves §3.4.2), in error-state form with feedback.
#[derive(Clone, Copy, Debug)]
pub struct SmootherRecord {
    /// Time [s].
    pub t: f64,
    /// Nominal state after all updates at this checkpoint.
    pub nav: NavState,
    /// IMU errors after all updates.
    pub errors: ImuErrors,
    /// Sum of the error estimates fed back at this checkpoint (error of the
    /// prior nominal state).
    pub dx_fed_back: StateVec,
    /// Smoother gain from the previous checkpoint to this one:
    /// `A = P⁺_{k−1} Φᵀ (P⁻_k)⁻¹` (zero for the first record).
    pub gain_prev: Cov,
    /// Covariance after the updates (for the smoothed uncertainty).
    pub p_post_diag: StateVec,
    /// The augmented states' part of the gain and feedback (`None`: not
    /// augmented; `gain_prev` is then the whole gain).
    pub aug: Option<AugSmootherRecord>,
    /// The part of the previous checkpoint's smoothed covariance that does
    /// not come from this one: `B_{k−1} = P⁺_{k−1} − A_k P⁻_k A_kᵀ` in
    /// Joseph form ([`rts_smooth`]); zero for the first record.
    pub p_base_prev: Cov,
    /// With a sensitivity covariance ([`Eskf::start_sensitivity`]): what it
    /// adds to the filter's covariance at this checkpoint ([`SensExtra`]),
    /// used by [`rts_smooth`].
    pub p_extra: Option<SensExtra>,
}

/// What the sensitivity covariance (module `sens`) adds at one smoother
/// checkpoint: diagonals and position cross terms (NE, ED, DN) [state
/// units², m²].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensExtra {
    /// Sensitivity minus the filter's own covariance (either can be the
    /// larger): the forward σ reported is the filter's plus this.
    pub forward: (StateVec, Vec3),
    /// The part of the sensitivity covariance driven by the correlated GNSS
    /// error alone (sensitivity minus its white twin, position variances
    /// capped at var(b); module `sens`, "Smoothed σ"): what the smoother
    /// cannot average away.
    pub correlated: (StateVec, Vec3),
}

/// Output of the RTS backward pass at one checkpoint.
#[derive(Clone, Copy, Debug)]
pub struct SmoothedEpoch {
    pub t: f64,
    pub nav: NavState,
    pub errors: ImuErrors,
    /// Diagonal of the smoothed error-state covariance `P^s_k` (never above
    /// the forward `P⁺_k` diagonal).
    pub p_diag: StateVec,
    /// Off-diagonal position terms of `P^s_k` [m²]: (NE, ED, DN), NED
    /// position error frame (RTKLIB `.pos` cross terms, [`pos_cross_ned`]).
    pub p_pos_cross: Vec3,
}

/// The off-diagonal position covariances (NE, ED, DN) [m²] of `p` (NED
/// position error states at [`I_POS`]).
pub fn pos_cross_ned(p: &Cov) -> Vec3 {
    Vec3::new(
        p[(I_POS, I_POS + 1)],
        p[(I_POS + 1, I_POS + 2)],
        p[(I_POS + 2, I_POS)],
    )
}

/// Backward RTS pass over the forward filter's checkpoints (oldest first).
/// `δs_k = A_{k+1} (δx_fb,k+1 + δs_{k+1})`, smoothed state = filtered ⊕ δs_k.
///
/// Smoothed covariance (Rauch, Tung & Striebel 1965; Groves 2nd ed. eq.
/// 3.78): `P^s_k = B_k + A_{k+1} P^s_{k+1} A_{k+1}ᵀ`, `P^s_last = p_last`
/// (the last record's filtered covariance, [`Eskf::last_record_covariance`]),
/// with `B_k = P⁺_k − A P⁻ Aᵀ` stored by the forward pass in the Joseph form
/// `(I − AΦ) P⁺ (I − AΦ)ᵀ + A Q Aᵀ` (a sum of positive semi-definite terms;
/// the plain difference loses all precision when an update after an outage
/// shrinks metres² to centimetres²). The smoothed variance never exceeds the
/// filtered one in exact arithmetic; the diagonal written is clamped to
/// `[0, P⁺_kk]` against rounding. With augmented states the recursion runs
/// on the joint state (`A`, `B` and `P^s` over the 21 + [`NA`] states): the
/// augmented blocks carry their share into the INS block — for a
/// considered GNSS error b, the part both passes share, which the 21-state
/// recursion dropped (smoothed σ too small by ~1.25 on a simulated phone-IMU
/// uav with consumer GNSS, coverage 0.85).
/// Calls `out` newest first (no allocation).
pub fn rts_smooth(records: &[SmootherRecord], p_last: &Cov, mut out: impl FnMut(&SmoothedEpoch)) {
    let n = records.len();
    if n == 0 {
        return;
    }
    let mut ds = StateVec::zeros();
    let mut ds_a = SVector::<f64, NA>::zeros();
    let mut ps = *p_last;
    let last = &records[n - 1];
    let mut ps_full = last.aug.as_ref().map(|a| a.post_full(p_last));
    // The correlated GNSS error b is common to the forward and backward
    // passes, so the smoother does not average it away: the part of the
    // forward covariance b drives is added to the smoothed white-model one
    // (module `sens`, "Smoothed σ"), capped at the forward σ reported so that
    // smoothed ≤ forward holds at every epoch. At the last checkpoint the
    // smoothed covariance is the filtered one.
    let extra = |r: &SmootherRecord, d: StateVec, c: Vec3, last: bool| match r.p_extra {
        None => (d, c),
        Some(x) if last => (d + x.forward.0, c + x.forward.1),
        Some(x) => {
            let cap = r.p_post_diag + x.forward.0;
            let d = (d + x.correlated.0).zip_map(&cap, f64::min);
            let mut c = c + x.correlated.1;
            // Keep the position block positive semi-definite after the cap.
            for (k, (i, j)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                let m = (d[I_POS + i] * d[I_POS + j]).max(0.0).sqrt();
                c[k] = c[k].clamp(-m, m);
            }
            (d, c)
        }
    };
    let (p_diag, p_pos_cross) = extra(last, last.p_post_diag, pos_cross_ned(p_last), true);
    out(&SmoothedEpoch {
        t: last.t,
        nav: last.nav,
        errors: last.errors,
        p_diag,
        p_pos_cross,
    });
    for k in (0..n - 1).rev() {
        let next = &records[k + 1];
        let e = next.dx_fed_back + ds;
        match &next.aug {
            None => ds = next.gain_prev * e,
            Some(a) => {
                let ea = a.dx_fed_back + ds_a;
                ds = next.gain_prev * e + a.gain_xa * ea;
                ds_a = a.gain_ax * e + a.gain_aa * ea;
            }
        }
        match (&next.aug, &mut ps_full) {
            // With augmented states the joint recursion: the augmented
            // blocks of A and B carry their share (e.g. a considered GNSS
            // error b, which both passes share) into the INS block.
            (Some(a), Some(f)) => {
                let g = a.gain_full(&next.gain_prev);
                *f = a.base_full(&next.p_base_prev) + g * *f * g.transpose();
                ps = f.fixed_view::<NX, NX>(0, 0).into_owned();
            }
            _ => ps = next.p_base_prev + next.gain_prev * ps * next.gain_prev.transpose(),
        }
        let mut nav = records[k].nav;
        let mut errors = records[k].errors;
        apply_correction(&mut nav, &mut errors, &ds);
        let p_diag = records[k]
            .p_post_diag
            .zip_map(&ps.diagonal(), |p, q| q.clamp(0.0, p.max(0.0)));
        let (p_diag, p_pos_cross) = extra(&records[k], p_diag, pos_cross_ned(&ps), false);
        out(&SmoothedEpoch {
            t: records[k].t,
            nav,
            errors,
            p_diag,
            p_pos_cross,
        });
    }
}

/// `B = (I − AΦ) P⁺ (I − AΦ)ᵀ + A Q Aᵀ` of [`rts_smooth`] for the smoother
/// gain `a`, the transition `phi` between two checkpoints and the
/// covariances after the first (`post`) and before the second's updates
/// (`prior`), with `Q` the diagonal of `P⁻ − Φ P⁺ Φᵀ` floored at 0 (see
/// `maybe_record`). For the 21 states and the joint augmented ones.
pub(super) fn smoother_base<const N: usize>(
    a: &SMatrix<f64, N, N>,
    phi: &SMatrix<f64, N, N>,
    post: &SMatrix<f64, N, N>,
    prior: &SMatrix<f64, N, N>,
) -> SMatrix<f64, N, N> {
    let q_full = prior - phi * post * phi.transpose();
    let q = SMatrix::<f64, N, N>::from_diagonal(&q_full.diagonal().map(|x| x.max(0.0)));
    let i_a = SMatrix::<f64, N, N>::identity() - a * phi;
    i_a * post * i_a.transpose() + a * q * a.transpose()
}

/// `P ← Φ (P + Q_d/2) Φᵀ + Q_d/2`, `Φ = I + F dt` with `fs` already set to
/// this interval's `F` (`q`: the velocity and angle blocks of `Q_d` and the
/// bias PSDs). Shared by the filter's covariance and the sensitivity one.
#[inline(always)]
fn propagate_p(
    p: &mut Cov,
    fs: &FSparse,
    t: &mut Cov,
    m: &mut Cov,
    q: (&Mat3, &Mat3, &[Vec3; 4]),
    dt: f64,
) {
    let (qv, qa, q_bias) = q;
    for i in 0..3 {
        for j in 0..3 {
            p[(I_VEL + i, I_VEL + j)] += 0.5 * qv[(i, j)];
            p[(I_ATT + i, I_ATT + j)] += 0.5 * qa[(i, j)];
        }
    }
    for (b, q) in q_bias.iter().enumerate() {
        for k in 0..3 {
            p[(I_BG + 3 * b + k, I_BG + 3 * b + k)] += 0.5 * q[k] * dt;
        }
    }
    // With X symmetric: T = X Fᵀ, M = Tᵀ = F X, N = M Fᵀ = F X Fᵀ, and
    // Φ X Φᵀ = X + dt (T + M) + dt² N. Only contiguous column axpys.
    fs.x_ft::<NX>(p, t, NX);
    {
        // M = Tᵀ (fixed-size loops so the compiler unrolls them).
        let ts: &[f64; NX * NX] = t.as_slice().try_into().unwrap_or(&[0.0; NX * NX]);
        let ms = m.as_mut_slice();
        for c in 0..NX {
            for r in 0..NX {
                ms[NX * r + c] = ts[NX * c + r];
            }
        }
    }
    // N = M Fᵀ = F X Fᵀ with the full F: Φ X Φᵀ is then exact, so P stays
    // positive semi-definite even at long steps or over days without
    // updates (a truncated second-order term does not guarantee that).
    // Only the lower triangle of P is formed (fused with the sum
    // X + dt (T + M) + dt² N), then mirrored: P stays exactly symmetric.
    let dt2 = dt * dt;
    {
        let ps: &mut [f64; NX * NX] = p
            .as_mut_slice()
            .try_into()
            .unwrap_or_else(|_| unreachable!());
        let ts: &[f64; NX * NX] = t.as_slice().try_into().unwrap_or_else(|_| unreachable!());
        let ms: &[f64; NX * NX] = m.as_slice().try_into().unwrap_or_else(|_| unreachable!());
        macro_rules! lower_cols {
            ($($c:literal)*) => {
                $(fs.lower_col::<$c>(ms, ts, ps, dt, dt2);)*
            };
        }
        lower_cols!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20);
        for c in 0..NX {
            for r in c + 1..NX {
                ps[NX * r + c] = ps[NX * c + r];
            }
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            p[(I_VEL + i, I_VEL + j)] += 0.5 * qv[(i, j)];
            p[(I_ATT + i, I_ATT + j)] += 0.5 * qa[(i, j)];
        }
    }
    for (b, q) in q_bias.iter().enumerate() {
        for k in 0..3 {
            p[(I_BG + 3 * b + k, I_BG + 3 * b + k)] += 0.5 * q[k] * dt;
        }
    }
}

/// Feed back an error estimate into the nominal state (`SEEDS.md §1` eq. 7, 10).
pub fn apply_correction(nav: &mut NavState, errors: &mut ImuErrors, dx: &StateVec) {
    let (rm, rn) = earth::radii(nav.lat);
    let dr = dx.fixed_rows::<3>(I_POS);
    nav.lat -= dr[0] / (rm + nav.h);
    nav.lon -= dr[1] / ((rn + nav.h) * nav.lat.cos());
    nav.h += dr[2];
    nav.v_n -= dx.fixed_rows::<3>(I_VEL);
    let phi: Vec3 = dx.fixed_rows::<3>(I_ATT).into();
    nav.q_bn = quat_from_rotvec(&phi) * nav.q_bn;
    nav.q_bn.renormalize_fast();
    errors.bg += dx.fixed_rows::<3>(I_BG);
    errors.ba += dx.fixed_rows::<3>(I_BA);
    errors.sg += dx.fixed_rows::<3>(I_SG);
    errors.sa += dx.fixed_rows::<3>(I_SA);
}

/// Non-zero 3×3 blocks of the continuous error model `F` at one epoch.
#[derive(Clone, Copy, Debug, Default)]
struct FBlocks {
    pp: Mat3,
    vp: Mat3,
    vv: Mat3,
    va: Mat3,
    c_bn: Mat3,
    vsa: Mat3,
    ap: Mat3,
    av: Mat3,
    aa: Mat3,
    asg: Mat3,
    /// −1/T of the Gauss–Markov states.
    beta: f64,
    scale: bool,
}

/// Largest number of non-zero entries of `F`.
const F_MAX_NNZ: usize = 128;

/// `F` in compressed-row form: row `i` has the entries
/// `(col[j], val[j])` for `j` in `start[i]..start[i+1]`. Rebuilt in place
/// every sample (no zero-fill of the buffers).
#[derive(Clone, Debug)]
struct FSparse {
    start: [usize; NX + 1],
    col: [usize; F_MAX_NNZ],
    val: [f64; F_MAX_NNZ],
}

impl FSparse {
    fn new() -> Self {
        FSparse {
            start: [0; NX + 1],
            col: [0; F_MAX_NNZ],
            val: [0.0; F_MAX_NNZ],
        }
    }

    /// Append block-row `b` (rows `3b..3b+3`) from `(column offset, block)`
    /// pairs, skipping zero entries (branch-free; fixed sizes, so unrolled).
    #[inline(always)]
    fn fill_rows<const NB: usize>(
        &mut self,
        mut n: usize,
        b: usize,
        blocks: [(usize, &Mat3); NB],
    ) -> usize {
        for r in 0..3 {
            self.start[3 * b + r] = n;
            for (c0, m) in blocks.iter() {
                for k in 0..3 {
                    let v = m[(r, k)];
                    let i = n.min(F_MAX_NNZ - 1);
                    self.col[i] = c0 + k;
                    self.val[i] = v;
                    n += (v != 0.0) as usize;
                }
            }
        }
        n
    }

    /// Fill from blocks (position, velocity, attitude block-rows); bias/scale
    /// rows are `β` on the diagonal for indices below `diag_end`.
    #[inline(always)]
    fn fill(
        &mut self,
        pos: [(usize, &Mat3); 2],
        vel: [(usize, &Mat3); 5],
        att: [(usize, &Mat3); 5],
        beta: f64,
        diag_end: usize,
    ) {
        let n = self.fill_rows(0, 0, pos);
        let n = self.fill_rows(n, 1, vel);
        let mut n = self.fill_rows(n, 2, att);
        for i in I_BG..NX {
            self.start[i] = n;
            if beta != 0.0 && i < diag_end {
                self.col[n] = i;
                self.val[n] = beta;
                n += 1;
            }
        }
        self.start[NX] = n;
    }

    /// All of `F`.
    #[inline(always)]
    fn set_full(&mut self, b: &FBlocks) {
        let id = Mat3::identity();
        let nc = -b.c_bn;
        let z = Mat3::zeros();
        let (vsa, asg) = if b.scale { (&b.vsa, &b.asg) } else { (&z, &z) };
        self.fill(
            [(I_POS, &b.pp), (I_VEL, &id)],
            [
                (I_POS, &b.vp),
                (I_VEL, &b.vv),
                (I_ATT, &b.va),
                (I_BA, &b.c_bn),
                (I_SA, vsa),
            ],
            [
                (I_POS, &b.ap),
                (I_VEL, &b.av),
                (I_ATT, &b.aa),
                (I_BG, &nc),
                (I_SG, asg),
            ],
            b.beta,
            if b.scale { NX } else { I_SG },
        );
    }

    /// `out.col(i)[..L] = Σ_k F[i,k] · x.col(k)[..L]` for `i < rows`, i.e. the
    /// first `L` rows of `out = x Fᵀ` (column-major; each output column is
    /// accumulated in registers).
    #[inline(always)]
    fn x_ft<const L: usize>(&self, x: &Cov, out: &mut Cov, rows: usize) {
        let xs = x.as_slice();
        let os = out.as_mut_slice();
        for i in 0..rows {
            let mut acc = [0.0f64; L];
            for j in self.start[i]..self.start[i + 1] {
                let k = self.col[j];
                let v = self.val[j];
                let src: &[f64; L] = xs[NX * k..NX * k + L].try_into().unwrap_or(&[0.0; L]);
                for r in 0..L {
                    acc[r] += v * src[r];
                }
            }
            os[NX * i..NX * i + L].copy_from_slice(&acc);
        }
    }
}

impl FSparse {
    /// `F x` for a 21×K block `x` (the cross-covariance of augmented states).
    fn f_times<const K: usize>(&self, x: &SMatrix<f64, NX, K>) -> SMatrix<f64, NX, K> {
        let mut out = SMatrix::<f64, NX, K>::zeros();
        for i in 0..NX {
            for j in self.start[i]..self.start[i + 1] {
                let (k, v) = (self.col[j].min(NX - 1), self.val[j]);
                for c in 0..K {
                    out[(i, c)] += v * x[(k, c)];
                }
            }
        }
        out
    }

    /// Column `C` of the lower triangle of `X + dt (T + M) + dt² N` added into
    /// `p` (rows `C..NX`), with `N = M Fᵀ` accumulated in registers in the
    /// same order as [`FSparse::x_ft`] (so the result is bit-identical).
    #[inline(always)]
    fn lower_col<const C: usize>(
        &self,
        m: &[f64; NX * NX],
        t: &[f64; NX * NX],
        p: &mut [f64; NX * NX],
        dt: f64,
        dt2: f64,
    ) {
        let mut acc = [0.0f64; NX];
        for j in self.start[C]..self.start[C + 1] {
            let k = self.col[j].min(NX - 1);
            let v = self.val[j];
            let src: &[f64; NX] = m[NX * k..NX * k + NX]
                .try_into()
                .unwrap_or_else(|_| unreachable!());
            for r in C..NX {
                acc[r] += v * src[r];
            }
        }
        let o = NX * C;
        for r in C..NX {
            p[o + r] += dt * (t[o + r] + m[o + r]) + dt2 * acc[r];
        }
    }
}

/// Instruction set of the covariance propagation, chosen once per filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    /// The target's baseline (SSE2 on x86-64).
    Generic,
    /// AVX2, detected at run time (x86-64 with `std` only).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx2,
}

impl Kernel {
    fn detect() -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if std::is_x86_feature_detected!("avx2") {
            return Kernel::Avx2;
        }
        Kernel::Generic
    }
}

/// Standstill detector over a ring buffer of the last samples (no allocation).
#[derive(Clone, Copy, Debug)]
struct StandstillDetector {
    f: [Vec3; ZUPT_MAX_WINDOW],
    w: [Vec3; ZUPT_MAX_WINDOW],
    len: usize,
    head: usize,
}

impl StandstillDetector {
    fn new() -> Self {
        StandstillDetector {
            f: [Vec3::zeros(); ZUPT_MAX_WINDOW],
            w: [Vec3::zeros(); ZUPT_MAX_WINDOW],
            len: 0,
            head: 0,
        }
    }
    fn push(&mut self, f: Vec3, w: Vec3, window: usize) {
        let window = window.clamp(2, ZUPT_MAX_WINDOW);
        self.f[self.head] = f;
        self.w[self.head] = w;
        self.head = (self.head + 1) % window;
        self.len = (self.len + 1).min(window);
    }
    /// (std |f|, max per-axis gyro std, mean gyro, mean f) when the window is full.
    fn stats(&self, window: usize) -> Option<(f64, f64, Vec3, Vec3)> {
        let window = window.clamp(2, ZUPT_MAX_WINDOW);
        if self.len < window {
            return None;
        }
        let n = window as f64;
        let (mut sf, mut sf2, mut fsum) = (0.0, 0.0, Vec3::zeros());
        let (mut sw, mut sw2) = (Vec3::zeros(), Vec3::zeros());
        for i in 0..window {
            let fn_ = self.f[i].norm();
            fsum += self.f[i];
            sf += fn_;
            sf2 += fn_ * fn_;
            sw += self.w[i];
            sw2 += self.w[i].component_mul(&self.w[i]);
        }
        let mf = sf / n;
        let vf = (sf2 / n - mf * mf).max(0.0);
        let mw = sw / n;
        let vw = (sw2 / n - mw.component_mul(&mw)).map(|v| v.max(0.0));
        Some((vf.sqrt(), vw.max().sqrt(), mw, fsum / n))
    }
}

/// Which measurement an update used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateKind {
    GnssPosition,
    GnssVelocity,
    Height,
    Zupt,
    Zaru,
    Nhc,
    Odometer,
    Heading,
    Mag,
    /// Tight coupling: the pseudoranges of one raw epoch (one entry per
    /// epoch: NIS summed over the satellites used, `dof` their number).
    Pseudorange,
    /// Tight coupling: the Doppler range rates of one raw epoch (as above).
    Doppler,
}

impl UpdateKind {
    /// Short stable name (`gnss_pos`, `gnss_vel`, `height`, `zupt`, `zaru`,
    /// `nhc`, `odometer`, `heading`, `mag`, `pseudorange`, `doppler`).
    pub fn name(self) -> &'static str {
        match self {
            UpdateKind::GnssPosition => "gnss_pos",
            UpdateKind::GnssVelocity => "gnss_vel",
            UpdateKind::Height => "height",
            UpdateKind::Zupt => "zupt",
            UpdateKind::Zaru => "zaru",
            UpdateKind::Nhc => "nhc",
            UpdateKind::Odometer => "odometer",
            UpdateKind::Heading => "heading",
            UpdateKind::Mag => "mag",
            UpdateKind::Pseudorange => "pseudorange",
            UpdateKind::Doppler => "doppler",
        }
    }
}

/// One measurement update tried during the last `push`: its normalised
/// innovation squared and whether it was applied (false: rejected by the χ²
/// gate). For innovation monitoring (NIS against χ²(dof) bounds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateLog {
    /// Filter time of the update [s].
    pub t: f64,
    pub kind: UpdateKind,
    /// νᵀ S⁻¹ ν with the unscaled R.
    pub nis: f64,
    /// Measurement dimension.
    pub dof: u8,
    pub accepted: bool,
}

/// Updates one `push` can try at most (GNSS position, height, velocity,
/// ZUPT, ZARU, NHC, with room to spare).
const JOURNAL_LEN: usize = 8;

/// The seed 001 / KF-GINS error-state filter. See the module documentation.
#[derive(Clone, Debug)]
pub struct Eskf {
    cfg: EskfConfig,
    /// The updates of the last `push` (first `journal_len` entries).
    journal: [UpdateLog; JOURNAL_LEN],
    journal_len: usize,
    nav: NavState,
    err: ImuErrors,
    p: Cov,
    /// Process noise PSD per axis: vrw², arw², and the Gauss–Markov drivers.
    q_vrw: Vec3,
    q_arw: Vec3,
    q_bias: [Vec3; 4],
    /// Previous (compensated) IMU increments and time.
    t: f64,
    dtheta_pre: Vec3,
    dvel_pre: Vec3,
    started: bool,
    pending: Option<GnssFix>,
    last_nhc: f64,
    last_zupt: f64,
    gnss_consecutive_rejects: u32,
    last_zaru: f64,
    last_dt: f64,
    standstill: bool,
    /// Time [s] and horizontal speed [m/s] of the latest GNSS evidence of
    /// motion (velocity of a fix, else the chord from the previous fix).
    gnss_motion: (f64, f64),
    last_fix: Option<GnssFix>,
    detector: StandstillDetector,
    stats: EskfStats,
    // Smoother bookkeeping.
    /// Transpose of the transition matrix accumulated since the last checkpoint.
    rec_phi_t: Cov,
    rec_p_post: Cov,
    rec_dx: StateVec,
    rec_p_prior: Option<Cov>,
    rec_count: usize,
    rec_updated: bool,
    rec_have_prev: bool,
    record: Option<SmootherRecord>,
    f_sparse: FSparse,
    kernel: Kernel,
    scratch_t: Cov,
    scratch_m: Cov,
    /// Last compensated angular rate [rad/s] and specific force [m/s²], body.
    w_ib_b: Vec3,
    f_b: Vec3,
    adapt: Adaptive,
    /// Augmented states (`None`: the 21-state filter).
    aug: Option<Aug>,
    aiding: aiding::AidingState,
    /// Covariance of the error under a correlated GNSS error model, with
    /// this filter's gains (`None`: σ from `p`; [`Eskf::start_sensitivity`]).
    sens: Option<Sens>,
    /// The sensitivity covariance under the smoother's own model
    /// ([`Eskf::start_smoother_sensitivity`]; `None`: the smoother uses
    /// `sens`'s), run only with the smoother.
    sens_s: Option<Sens>,
    /// The white twin of `sens_s`, else of `sens` (module `sens`, "Smoothed
    /// σ"), run only with the smoother.
    sens_w: Option<Sens>,
    /// Tight coupling to raw GNSS (`None`: off, the plain filter).
    tight: Option<tight::Tight>,
    /// RTK ambiguity block (`None`: off; module `rtk`).
    rtk: Option<rtk::RtkBlock>,
}

/// The adaptive parts of the filter (all `None` by default).
#[derive(Clone, Copy, Debug, Default)]
struct Adaptive {
    nhc: Option<NoiseEstimator<2>>,
    zupt: Option<NoiseEstimator<3>>,
    zaru: Option<NoiseEstimator<3>>,
    gnss_quality: Option<GnssQualityScale>,
    /// R scales of GNSS position and velocity from their windowed NIS.
    nis_pos: Option<NisScale>,
    nis_vel: Option<NisScale>,
}

/// Why [`Eskf::with_adaptive_noise`] refused a configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdaptiveConfigError {
    /// Adaptation asked for a constraint the filter does not apply (`nhc`,
    /// `zupt`, `zaru`).
    NotConfigured(&'static str),
    /// Bounds, window or gate of that constraint's `AdaptiveNoise` (or its
    /// starting σ) are invalid: need window ≥ 1, 0 < min_std ≤ max_std,
    /// gate probability in (0, 1), starting σ > 0.
    Invalid(&'static str),
}

impl core::fmt::Display for AdaptiveConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            AdaptiveConfigError::NotConfigured(c) => {
                write!(f, "adaptive {c} noise asked for, but {c} is not configured")
            }
            AdaptiveConfigError::Invalid(c) => write!(
                f,
                "adaptive {c} noise: need window >= 1, 0 < min_std <= max_std, \
                 gate probability in (0, 1) and a positive starting sigma"
            ),
        }
    }
}

/// Which GNSS fix timing case applies to an IMU interval (KF-GINS `isToUpdate`).
const TIME_ALIGN: f64 = 1e-3;

impl Eskf {
    /// A filter at `nav` with sensor errors `errors` and initial σ `std`.
    pub fn new(cfg: EskfConfig, nav: NavState, errors: ImuErrors, std: &InitStd) -> Self {
        let mut p = Cov::zeros();
        let blocks = [
            (I_POS, std.pos),
            (I_VEL, std.vel),
            (I_ATT, std.att),
            (I_BG, std.bg),
            (I_BA, std.ba),
            (
                I_SG,
                if cfg.scale_factors {
                    std.sg
                } else {
                    Vec3::zeros()
                },
            ),
            (
                I_SA,
                if cfg.scale_factors {
                    std.sa
                } else {
                    Vec3::zeros()
                },
            ),
        ];
        for (i, s) in blocks {
            for k in 0..3 {
                p[(i + k, i + k)] = s[k] * s[k];
            }
        }
        let n = &cfg.noise;
        let gm = |s: Vec3| {
            if n.corr_time.is_finite() && n.corr_time > 0.0 {
                s.component_mul(&s) * (2.0 / n.corr_time)
            } else {
                s.component_mul(&s)
            }
        };
        let (sg_q, sa_q) = if cfg.scale_factors {
            (gm(n.sg_std), gm(n.sa_std))
        } else {
            (Vec3::zeros(), Vec3::zeros())
        };
        Eskf {
            nav,
            err: errors,
            p,
            q_vrw: n.vrw.component_mul(&n.vrw),
            q_arw: n.arw.component_mul(&n.arw),
            q_bias: [gm(n.bg_std), gm(n.ba_std), sg_q, sa_q],
            t: f64::NAN,
            dtheta_pre: Vec3::zeros(),
            dvel_pre: Vec3::zeros(),
            started: false,
            pending: None,
            last_nhc: f64::NEG_INFINITY,
            last_zupt: f64::NEG_INFINITY,
            gnss_consecutive_rejects: 0,
            last_zaru: f64::NEG_INFINITY,
            last_dt: 0.01,
            standstill: false,
            gnss_motion: (f64::NEG_INFINITY, 0.0),
            last_fix: None,
            detector: StandstillDetector::new(),
            stats: EskfStats::default(),
            journal: [UpdateLog {
                t: 0.0,
                kind: UpdateKind::GnssPosition,
                nis: 0.0,
                dof: 0,
                accepted: false,
            }; JOURNAL_LEN],
            journal_len: 0,
            rec_phi_t: Cov::identity(),
            rec_p_post: p,
            rec_dx: StateVec::zeros(),
            rec_p_prior: None,
            rec_count: 0,
            rec_updated: false,
            rec_have_prev: false,
            record: None,
            w_ib_b: Vec3::zeros(),
            f_b: Vec3::zeros(),
            f_sparse: FSparse::new(),
            kernel: Kernel::detect(),
            scratch_t: Cov::zeros(),
            scratch_m: Cov::zeros(),
            adapt: Adaptive::default(),
            aug: None,
            aiding: aiding::AidingState::default(),
            sens: None,
            sens_s: None,
            sens_w: None,
            tight: None,
            rtk: None,
            cfg,
        }
        .with_odometer_scale()
    }

    /// The odometer's scale-factor state lives in the augmented block
    /// ([`aug`]): create it when odometer aiding is configured (an invalid
    /// odometer configuration leaves the filter without it; the pipeline
    /// validates first).
    fn with_odometer_scale(mut self) -> Self {
        if let Some(o) = &self.cfg.aiding.odometer {
            self.aug = Aug::new(AugmentedStates::default(), Some(o)).ok();
            if let Some(g) = &mut self.aug {
                g.reset_record();
            }
        }
        self
    }

    /// Correlate the initial tilt with the accelerometer bias, for a filter
    /// whose roll and pitch were found from the measured specific force
    /// (static levelling or the in-motion force pair, with the bias
    /// estimate `b̂_a` as given): the force then carries the unknown bias
    /// `δb_a`, and the tilt error it leaves is fixed by it,
    /// `φ × f_n = Ĉ_bn δb_a`, i.e. `φ_⊥ = [f_n×] Ĉ_bn δb_a / |f_n|²`
    /// (Groves 2nd ed. §14.2.1: levelling error = accelerometer bias / g),
    /// here with `f_n = (0, 0, −g)`. Independent priors on both would claim
    /// that level, straight motion separates them (each σ then shrinks by
    /// up to √2 with no evidence, and the filter holds a wrong tilt at 5σ:
    /// seen on a multirotor with a 17.7 mg bias, 1° of pitch).
    ///
    /// Sets `P[φ, b_a] = A P[b_a, b_a]`, `A = [f_n×] Ĉ_bn / g²`, scaled
    /// down where the tilt σ given is below the bias share σ_ba/g (the
    /// joint covariance stays positive semidefinite).
    pub fn with_tilt_from_force(mut self) -> Self {
        let g = crate::earth::STANDARD_GRAVITY;
        let a = skew(&Vec3::new(0.0, 0.0, -g)) * self.nav.c_bn() / (g * g);
        let p_ba: Mat3 = self.p.fixed_view::<3, 3>(I_BA, I_BA).into_owned();
        let cross = a * p_ba;
        let mut rho: f64 = 1.0;
        for r in 0..2 {
            let need = (a.row(r) * p_ba * a.row(r).transpose())[(0, 0)];
            let have = self.p[(I_ATT + r, I_ATT + r)];
            if need > have && need > 0.0 {
                rho = rho.min((have / need).sqrt());
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                self.p[(I_ATT + r, I_BA + c)] = rho * cross[(r, c)];
                self.p[(I_BA + c, I_ATT + r)] = rho * cross[(r, c)];
            }
        }
        self
    }

    /// Adapt the noise of the constraint updates named in `a` from their
    /// innovations (bounded IAE, see [`super::adaptive`]), each started from
    /// the configured σ (`NhcConfig::std`, `ZuptConfig::vel_std`,
    /// `ZuptConfig::zaru_std`). NHC adapts body y and z separately, ZUPT the
    /// NED axes, ZARU the body axes. Without this call the fixed σ is used
    /// and every output is unchanged.
    pub fn with_adaptive_noise(
        mut self,
        a: AdaptiveConstraints,
    ) -> Result<Self, AdaptiveConfigError> {
        use AdaptiveConfigError::{Invalid, NotConfigured};
        self.adapt.nhc = match (a.nhc, self.cfg.nhc) {
            (None, _) => None,
            (Some(_), None) => return Err(NotConfigured("nhc")),
            (Some(c), Some(n)) => Some(NoiseEstimator::new(c, n.std).ok_or(Invalid("nhc"))?),
        };
        self.adapt.zupt = match (a.zupt, self.cfg.zupt) {
            (None, _) => None,
            (Some(_), None) => return Err(NotConfigured("zupt")),
            (Some(c), Some(z)) => Some(NoiseEstimator::new(c, z.vel_std).ok_or(Invalid("zupt"))?),
        };
        self.adapt.zaru = match (a.zaru, self.cfg.zupt.and_then(|z| z.zaru_std)) {
            (None, _) => None,
            (Some(_), None) => return Err(NotConfigured("zaru")),
            (Some(c), Some(s)) => Some(NoiseEstimator::new(c, s).ok_or(Invalid("zaru"))?),
        };
        Ok(self)
    }

    /// Estimate the augmented states named in `a` ([`aug`]): a first-order
    /// Gauss–Markov GNSS position error (NED [m]) and/or the IMU–GNSS time
    /// offset τ [s] (true time = IMU stamp + τ). `a` all off (the default)
    /// changes nothing.
    /// The NHC mounting states are kept only when the filter has NHC.
    pub fn with_augmented_states(mut self, mut a: AugmentedStates) -> Result<Self, AugConfigError> {
        if self.cfg.nhc.is_none() {
            a.nhc_mount = None;
        }
        let odo = self.cfg.aiding.odometer;
        self.aug = if a.is_off() && odo.is_none() {
            None
        } else {
            Some(Aug::new(a, odo.as_ref())?)
        };
        if let Some(g) = &mut self.aug {
            g.reset_record();
        }
        Ok(self)
    }

    /// From now on report σ from the covariance of this filter's error under
    /// the correlated GNSS error model `m` (module `sens`): the filter's
    /// gains, states and decisions are unchanged, only
    /// [`Eskf::solution`]'s σ, [`Eskf::reported_covariance`] and the
    /// smoothed σ change. Refused (`Err`) when the filter already models
    /// the GNSS error as Gauss–Markov states or `m` is invalid.
    pub fn start_sensitivity(&mut self, m: SensitivityModel) -> Result<(), AugConfigError> {
        if self.tight.is_some() || self.rtk.is_some() {
            return Err(AugConfigError::TightCoupling);
        }
        let odo = self.cfg.aiding.odometer.as_ref();
        self.sens = Some(Sens::new(m, &self.p, self.aug.as_ref(), odo, true)?);
        if self.cfg.smoother_every > 0 && self.sens_s.is_none() {
            self.sens_w = Some(Sens::new(m, &self.p, self.aug.as_ref(), odo, false)?);
        }
        Ok(())
    }

    /// The smoothed σ takes the correlated part of the fix error under `m`
    /// instead of under [`Eskf::start_sensitivity`]'s model (module `sens`,
    /// "Smoothed σ", with "Smoother's own model"): for a split of the fix
    /// error the data bound only from below, the smoother takes the upper
    /// end. The forward σ (the filter's, or the sensitivity model's) and
    /// every solution are unchanged; the smoothed σ stays capped at the
    /// forward σ. A no-op without the smoother; refused as
    /// [`Eskf::start_sensitivity`] is.
    pub fn start_smoother_sensitivity(
        &mut self,
        m: SensitivityModel,
    ) -> Result<(), AugConfigError> {
        if self.tight.is_some() {
            return Err(AugConfigError::TightCoupling);
        }
        if self.cfg.smoother_every == 0 {
            return Ok(());
        }
        let odo = self.cfg.aiding.odometer.as_ref();
        self.sens_s = Some(Sens::new(m, &self.p, self.aug.as_ref(), odo, true)?);
        self.sens_w = Some(Sens::new(m, &self.p, self.aug.as_ref(), odo, false)?);
        Ok(())
    }

    /// The covariance σ is reported from: the sensitivity covariance when
    /// [`Eskf::start_sensitivity`] was called, else the filter's own.
    pub fn reported_covariance(&self) -> &Cov {
        self.sens.as_ref().map_or(&self.p, |s| &s.p)
    }

    /// Estimates of the augmented states (`None` when not augmented).
    pub fn augmented(&self) -> Option<AugmentedEstimate> {
        self.aug.as_ref().map(|a| a.estimate())
    }

    /// Multiply each GNSS fix's position σ (`std_ned`, not the velocity σ) by
    /// `s.factor(fix.quality)`. [`GnssQualityScale::IDENTITY`] changes nothing.
    pub fn with_gnss_quality_scale(mut self, s: GnssQualityScale) -> Self {
        self.adapt.gnss_quality = Some(s);
        self
    }

    /// Inflate the R of GNSS position and velocity fixes from their windowed
    /// NIS, bounded and never below the reported σ ([`NisAdaptation`]).
    /// Without this call (or while the NIS agrees with the model) every
    /// output is unchanged. `None` if `a` is invalid.
    pub fn with_nis_adaptation(mut self, a: NisAdaptation) -> Option<Self> {
        let cap = self
            .cfg
            .gate_probability
            .map_or(f64::INFINITY, |p| kalman::chi2_quantile(3, p));
        self.adapt.nis_pos = Some(NisScale::new(a, 3, cap)?);
        self.adapt.nis_vel = Some(NisScale::new(a, 3, cap)?);
        Some(self)
    }

    /// The NIS adaptation of GNSS position and velocity: (λ now, complete
    /// windows, windows that raised λ, largest λ) each; `None` when off.
    pub fn nis_adaptation(&self) -> Option<[(f64, u64, u64, f64); 2]> {
        let f = |s: &NisScale| {
            let (w, r, m) = s.summary();
            (s.scale(), w, r, m)
        };
        Some([
            f(self.adapt.nis_pos.as_ref()?),
            f(self.adapt.nis_vel.as_ref()?),
        ])
    }

    /// The adapted constraint σ now, with the innovations used and rejected
    /// (`None` fields: that constraint is not adaptive).
    pub fn adapted_noise(&self) -> AdaptedNoise {
        let a = &self.adapt;
        AdaptedNoise {
            nhc_std: a.nhc.map(|e| e.std()),
            zupt_std: a.zupt.map(|e| e.std()),
            zaru_std: a.zaru.map(|e| e.std()),
            nhc_counts: a.nhc.map_or((0, 0), |e| e.counts()),
            zupt_counts: a.zupt.map_or((0, 0), |e| e.counts()),
            zaru_counts: a.zaru.map_or((0, 0), |e| e.counts()),
        }
    }

    /// Configuration in use.
    pub fn config(&self) -> &EskfConfig {
        &self.cfg
    }
    /// Current nominal navigation state (IMU).
    pub fn nav(&self) -> &NavState {
        &self.nav
    }
    /// Current IMU error estimates.
    pub fn imu_errors(&self) -> &ImuErrors {
        &self.err
    }
    /// Current error-state covariance.
    pub fn covariance(&self) -> &Cov {
        &self.p
    }
    /// Raise the position σ (NED [m], the error state's frame) to at
    /// least `std_ned` per axis by adding the missing variance to the
    /// diagonal; the rest of the covariance is kept, so it stays positive
    /// semi-definite. For a hand-over where earlier updates treated a
    /// correlated error as white (a yaw bank aided by single-point fixes,
    /// then RTK: the bank's position σ shrinks as 1/√n while the fixes
    /// share a slowly varying error of their own σ). Only the 21 INS
    /// states; call it before adding side blocks. Returns the variance
    /// added per axis [m²].
    ///
    /// Not the same rule as [`Eskf::forget_position_prior`] (tight
    /// coupling): there the single-point fixes are least-squares images of
    /// the very pseudoranges the filter then uses, so the position prior
    /// would count their errors twice and is forgotten; the double
    /// differences of RTK cancel the satellite errors those fixes carry,
    /// so the position stays independent information and only its
    /// understated σ is raised.
    pub fn floor_position_std(&mut self, std_ned: &Vec3) -> Vec3 {
        let mut added = Vec3::zeros();
        for k in 0..3 {
            let want = std_ned[k] * std_ned[k];
            let have = self.p[(I_POS + k, I_POS + k)];
            if want.is_finite() && want > have {
                self.p[(I_POS + k, I_POS + k)] = want;
                added[k] = want - have;
            }
        }
        added
    }
    /// The error state `δx` that [`apply_correction`] would need to move
    /// this filter's nominal state onto `(nav, errors)`: position NED [m]
    /// (nominal − other, linearised at this filter's position), velocity
    /// (nominal − other), attitude `φ` with `q_other = q(φ) q_nominal`, IMU
    /// errors (other − nominal). Used as the spread term of a Gaussian-sum
    /// merge.
    pub fn error_state_to(&self, nav: &NavState, errors: &ImuErrors) -> StateVec {
        let (rm, rn) = earth::radii(self.nav.lat);
        let mut dx = StateVec::zeros();
        dx[I_POS] = -(nav.lat - self.nav.lat) * (rm + self.nav.h);
        dx[I_POS + 1] = -(nav.lon - self.nav.lon) * (rn + self.nav.h) * self.nav.lat.cos();
        dx[I_POS + 2] = nav.h - self.nav.h;
        dx.fixed_rows_mut::<3>(I_VEL)
            .copy_from(&(self.nav.v_n - nav.v_n));
        let dq = nav.q_bn * self.nav.q_bn.inverse();
        dx.fixed_rows_mut::<3>(I_ATT).copy_from(&dq.scaled_axis());
        dx.fixed_rows_mut::<3>(I_BG)
            .copy_from(&(errors.bg - self.err.bg));
        dx.fixed_rows_mut::<3>(I_BA)
            .copy_from(&(errors.ba - self.err.ba));
        dx.fixed_rows_mut::<3>(I_SG)
            .copy_from(&(errors.sg - self.err.sg));
        dx.fixed_rows_mut::<3>(I_SA)
            .copy_from(&(errors.sa - self.err.sa));
        dx
    }
    /// Widen the covariance by the spread of a merged mixture component:
    /// `P ← P + w δx δxᵀ` (`w` ≥ 0 its share of the merged weight, `δx`
    /// from [`Eskf::error_state_to`]). The second moment of a two-component
    /// Gaussian sum about this component's mean, when the components'
    /// covariances are alike (moment-preserving mixture reduction, Salmond
    /// 1990; Runnalls 2007): what one filter must carry when it stands for
    /// both hypotheses. Non-finite input is ignored.
    pub fn add_mixture_spread(&mut self, dx: &StateVec, w: f64) {
        if !(w.is_finite() && w > 0.0) || dx.iter().any(|x| !x.is_finite()) {
            return;
        }
        self.p += (dx * dx.transpose()) * w;
    }
    /// What happened to the inputs so far.
    pub fn stats(&self) -> &EskfStats {
        &self.stats
    }
    /// Time of the current state [s] (NaN before the first IMU sample).
    pub fn time(&self) -> f64 {
        self.t
    }
    /// The measurement updates tried during the last `push`, in order
    /// (singular ones are not listed; they are counted in the stats).
    pub fn updates(&self) -> &[UpdateLog] {
        &self.journal[..self.journal_len]
    }
    fn log_update(&mut self, kind: UpdateKind, dof: usize, nis: f64, accepted: bool) {
        match kind {
            UpdateKind::GnssPosition => {
                if let Some(s) = &mut self.adapt.nis_pos {
                    s.observe(nis);
                }
            }
            UpdateKind::GnssVelocity => {
                if let Some(s) = &mut self.adapt.nis_vel {
                    s.observe(nis);
                }
            }
            _ => {}
        }
        if self.journal_len < JOURNAL_LEN {
            self.journal[self.journal_len] = UpdateLog {
                t: self.t,
                kind,
                nis,
                dof: dof as u8,
                accepted,
            };
            self.journal_len += 1;
        }
    }
    /// Whether the standstill detector currently reports standstill.
    pub fn is_standstill(&self) -> bool {
        self.standstill
    }
    /// The filtered covariance at the last smoother checkpoint made (the
    /// start of [`rts_smooth`]'s backward covariance recursion).
    pub fn last_record_covariance(&self) -> &Cov {
        &self.rec_p_post
    }
    /// The smoother checkpoint made by the last `push`, if any.
    pub fn take_record(&mut self) -> Option<SmootherRecord> {
        self.record.take()
    }

    /// Solution at the current time with 1-σ from the covariance
    /// ([`Eskf::reported_covariance`]).
    pub fn solution(&self) -> NavSolution {
        let p = self.reported_covariance();
        let d = |i: usize| {
            Vec3::new(
                p[(i, i)].max(0.0).sqrt(),
                p[(i + 1, i + 1)].max(0.0).sqrt(),
                p[(i + 2, i + 2)].max(0.0).sqrt(),
            )
        };
        NavSolution {
            t: self.t,
            lat: self.nav.lat,
            lon: self.nav.lon,
            h: self.nav.h,
            v_n: self.nav.v_n,
            rpy: self.nav.rpy(),
            std_pos_ned: d(I_POS),
            std_v_n: d(I_VEL),
            std_rpy: d(I_ATT),
        }
    }

    /// Antenna position (lat, lon, h) of the current state.
    pub fn antenna_position(&self) -> (f64, f64, f64) {
        let (rm, rn) = earth::radii(self.nav.lat);
        let l_n = self.nav.c_bn() * self.cfg.lever_arm_b;
        (
            self.nav.lat + l_n.x / (rm + self.nav.h),
            self.nav.lon + l_n.y / ((rn + self.nav.h) * self.nav.lat.cos()),
            self.nav.h - l_n.z,
        )
    }

    fn compensate(&self, dtheta: &Vec3, dvel: &Vec3, dt: f64) -> (Vec3, Vec3) {
        let e = &self.err;
        let dth = (dtheta - e.bg * dt).component_div(&(Vec3::repeat(1.0) + e.sg));
        let dv = (dvel - e.ba * dt).component_div(&(Vec3::repeat(1.0) + e.sa));
        (dth, dv)
    }

    /// Mechanize over one (part of an) IMU interval and propagate `P`.
    fn propagate(&mut self, dtheta_raw: &Vec3, dvel_raw: &Vec3, dt: f64) {
        let (dth, dv) = self.compensate(dtheta_raw, dvel_raw, dt);
        let pre = self.nav;
        let c_bn = pre.c_bn();
        let e0 = EarthAt::new(pre.lat, pre.h);
        self.nav = mechanize_with(
            &pre,
            &c_bn,
            &e0,
            &self.dtheta_pre,
            &self.dvel_pre,
            &dth,
            &dv,
            dt,
        );
        self.dtheta_pre = dth;
        self.dvel_pre = dv;
        self.w_ib_b = dth / dt;
        self.f_b = dv / dt;
        let fb = self.error_model(&pre, &c_bn, &e0, &self.w_ib_b, &self.f_b);
        self.propagate_cov(&fb, &c_bn, dt);
        for sn in [&mut self.sens, &mut self.sens_s, &mut self.sens_w]
            .into_iter()
            .flatten()
        {
            sn.propagate_aug(&self.f_sparse, dt);
        }
        if let Some(a) = &mut self.aug {
            a.propagate(&self.f_sparse, dt);
            if a.has_time_offset() {
                // Antenna velocity: its integral is the antenna displacement,
                // lever-arm rotation included.
                let lever_v = self.nav.c_bn() * self.w_ib_b.cross(&self.cfg.lever_arm_b);
                a.push_history(self.t + dt, self.nav.v_n + lever_v);
            }
        }
        if let Some(tc) = &mut self.tight {
            tc.propagate(&self.f_sparse, dt);
        }
        if let Some(r) = &mut self.rtk {
            r.propagate(&self.f_sparse, dt);
        }
    }

    /// `F` blocks at `s` (the state at the start of the interval), KF-GINS's
    /// NED model with position error in metres.
    fn error_model(&self, s: &NavState, c: &Mat3, e: &EarthAt, w_b: &Vec3, f_b: &Vec3) -> FBlocks {
        let (rm, rn, rmh, rnh) = (e.rm, e.rn, e.rmh, e.rnh);
        let (sl, cl) = (e.sin_lat, e.cos_lat);
        let tl = sl / cl;
        let (vn, ve, vd) = (s.v_n.x, s.v_n.y, s.v_n.z);
        let wie = earth::OMEGA_IE;
        let g = e.g;
        let c = *c;
        let w_in = e.w_ie() + e.w_en(&s.v_n);

        let pp = Mat3::new(
            -vd / rmh,
            0.0,
            vn / rmh,
            ve * tl / rnh,
            -(vd + vn * tl) / rnh,
            ve / rnh,
            0.0,
            0.0,
            0.0,
        );
        let vp = Mat3::new(
            -2.0 * ve * wie * cl / rmh - ve * ve / (rmh * rnh * cl * cl),
            0.0,
            vn * vd / (rmh * rmh) - ve * ve * tl / (rnh * rnh),
            2.0 * wie * (vn * cl - vd * sl) / rmh + vn * ve / (rmh * rnh * cl * cl),
            0.0,
            (ve * vd + vn * ve * tl) / (rnh * rnh),
            2.0 * wie * ve * sl / rmh,
            0.0,
            -ve * ve / (rnh * rnh) - vn * vn / (rmh * rmh) + 2.0 * g / ((rm * rn).sqrt() + s.h),
        );
        let vv = Mat3::new(
            vd / rmh,
            -2.0 * (wie * sl + ve * tl / rnh),
            vn / rmh,
            2.0 * wie * sl + ve * tl / rnh,
            (vd + vn * tl) / rnh,
            2.0 * wie * cl + ve / rnh,
            -2.0 * vn / rmh,
            -2.0 * (wie * cl + ve / rnh),
            0.0,
        );
        let f_n = c * f_b;
        let va = skew(&f_n);
        let ap = Mat3::new(
            -wie * sl / rmh,
            0.0,
            ve / (rnh * rnh),
            0.0,
            0.0,
            -vn / (rmh * rmh),
            -wie * cl / rmh - ve / (rmh * rnh * cl * cl),
            0.0,
            -ve * tl / (rnh * rnh),
        );
        let av = Mat3::new(
            0.0,
            1.0 / rnh,
            0.0,
            -1.0 / rmh,
            0.0,
            0.0,
            0.0,
            -tl / rnh,
            0.0,
        );
        let aa = -skew(&w_in);
        let scale = self.cfg.scale_factors;
        let (vsa, asg) = if scale {
            (
                c * Mat3::from_diagonal(f_b),
                -(c * Mat3::from_diagonal(w_b)),
            )
        } else {
            (Mat3::zeros(), Mat3::zeros())
        };
        let t = self.cfg.noise.corr_time;
        FBlocks {
            pp,
            vp,
            vv,
            va,
            c_bn: c,
            vsa,
            ap,
            av,
            aa,
            asg,
            beta: if t.is_finite() && t > 0.0 {
                -1.0 / t
            } else {
                0.0
            },
            scale,
        }
    }

    /// `P ← Φ (P + Q_d/2) Φᵀ + Q_d/2`, `Φ = I + F dt`, with `F` sparse.
    ///
    /// Runs the same code compiled for AVX2 when the CPU has it (see
    /// [`Kernel`]); no FMA contraction is enabled, so both give bit-identical
    /// covariances.
    fn propagate_cov(&mut self, fb: &FBlocks, c_bn: &Mat3, dt: f64) {
        match self.kernel {
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            #[allow(unsafe_code)]
            // SAFETY: `Kernel::Avx2` is only chosen by `Kernel::detect` after
            // `is_x86_feature_detected!("avx2")` returned true on this CPU.
            Kernel::Avx2 => unsafe { self.propagate_cov_avx2(fb, c_bn, dt) },
            Kernel::Generic => self.propagate_cov_body(fb, c_bn, dt),
        }
    }

    /// [`Eskf::propagate_cov_body`] compiled with AVX2 (4-wide f64 vectors).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[target_feature(enable = "avx2")]
    fn propagate_cov_avx2(&mut self, fb: &FBlocks, c_bn: &Mat3, dt: f64) {
        self.propagate_cov_body(fb, c_bn, dt)
    }

    #[inline(always)]
    fn propagate_cov_body(&mut self, fb: &FBlocks, c_bn: &Mat3, dt: f64) {
        // Q_d = G Q_c Gᵀ dt: G maps velocity and angle noise through C_bn.
        let c = *c_bn;
        let qv = c * Mat3::from_diagonal(&self.q_vrw) * c.transpose() * dt;
        let qa = c * Mat3::from_diagonal(&self.q_arw) * c.transpose() * dt;
        // Exactly symmetric (rounding of C D Cᵀ is not), so P stays symmetric
        // without updates.
        let qv = 0.5 * (qv + qv.transpose());
        let qa = 0.5 * (qa + qa.transpose());
        self.f_sparse.set_full(fb);
        let q = (&qv, &qa, &self.q_bias);
        let (fs, t, m) = (&self.f_sparse, &mut self.scratch_t, &mut self.scratch_m);
        propagate_p(&mut self.p, fs, t, m, q, dt);
        for sn in [&mut self.sens, &mut self.sens_s, &mut self.sens_w]
            .into_iter()
            .flatten()
        {
            // The sensitivity covariances: same Φ and Q (sens module).
            propagate_p(&mut sn.p, fs, t, m, q, dt);
        }
        if self.cfg.smoother_every > 0 {
            // Ψ = Φ_accᵀ; Φ_acc ← Φ Φ_acc ⇔ Ψ ← Ψ + dt Ψ Fᵀ.
            self.f_sparse.set_full(fb);
            let d = &mut self.scratch_t;
            self.f_sparse.x_ft::<NX>(&self.rec_phi_t, d, NX);
            self.rec_phi_t += *d * dt;
        }
    }

    /// Joseph-form update ([`kalman::update_joseph`]) with feedback; `dz = ẑ − z`
    /// (predicted minus measured, so `dz = H δx + v`). Returns the NIS if
    /// applied. With `gate` and a configured gate probability, an innovation
    /// beyond the χ² quantile `g` is de-weighted (`R ← R·NIS/g`, Huber-type
    /// M-estimation; Groves §17.3.3) up to `g · gate_deweight_factor`, and
    /// rejected beyond.
    fn update<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, NX>,
        r: &SMatrix<f64, M, M>,
        dz: &SVector<f64, M>,
        gate: bool,
        kind: UpdateKind,
    ) -> Result<f64, UpdateReject> {
        self.update_aug(h, &SMatrix::zeros(), r, dz, gate, kind)
    }

    /// [`Eskf::update`] with the measurement's dependence `h_a` on the
    /// augmented states (ignored when the filter is not augmented; joint
    /// 25-state update when it is).
    fn update_aug<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, NX>,
        h_a: &SMatrix<f64, M, NA>,
        r: &SMatrix<f64, M, M>,
        dz: &SVector<f64, M>,
        gate: bool,
        kind: UpdateKind,
    ) -> Result<f64, UpdateReject> {
        if !dz.iter().all(|v| v.is_finite()) {
            return Err(UpdateReject::Singular);
        }
        let p_prior = self.p;
        let mut dx = StateVec::zeros();
        let g = match (gate, self.cfg.gate_probability) {
            (true, Some(pg)) => Some(kalman::chi2_quantile(M, pg)),
            _ => None,
        };
        let fd = self.cfg.gate_deweight_factor;
        // The gain applied, for the sensitivity covariance.
        let mut k_x = SMatrix::<f64, NX, M>::zeros();
        let mut k_f = SMatrix::<f64, NF, M>::zeros();
        let want_k = self.sens.is_some() || self.sens_s.is_some();
        let res = match &mut self.aug {
            // With tight coupling every update is joint with the clock
            // states (their correlation with the INS must follow); the
            // sensitivity covariance is not started then
            // ([`Eskf::start_sensitivity`]).
            None => match &mut self.tight {
                None => match &mut self.rtk {
                    None => {
                        let k = want_k.then_some(&mut k_x);
                        gated_update(&mut dx, &mut self.p, h, r, dz, g, fd, None, k)
                    }
                    Some(a) => a.joint_update(&mut dx, &mut self.p, h, r, dz, g, fd),
                },
                Some(t) => t.joint_update(&mut dx, &mut self.p, h, r, dz, g, fd),
            },
            Some(a) => {
                let mut pf = a.full(&self.p);
                let mut hf = SMatrix::<f64, M, NF>::zeros();
                hf.fixed_view_mut::<M, NX>(0, 0).copy_from(h);
                hf.fixed_view_mut::<M, NA>(0, NX).copy_from(h_a);
                let mut dxf = SVector::<f64, NF>::zeros();
                let k = want_k.then_some(&mut k_f);
                let res = gated_update(
                    &mut dxf,
                    &mut pf,
                    &hf,
                    r,
                    dz,
                    g,
                    fd,
                    a.gain_mask.as_ref(),
                    k,
                );
                if res.is_ok() {
                    if self.cfg.smoother_every > 0 && a.rec_p_prior.is_none() {
                        a.rec_p_prior = Some((a.p_xa, a.p_aa));
                    }
                    a.split(&pf, &mut self.p);
                    dx.copy_from(&dxf.fixed_rows::<NX>(0));
                    a.correct(&dxf.fixed_rows::<NA>(NX).into());
                }
                res
            }
        };
        // The R the update applied: de-weighting (R·NIS/g) is the filter's
        // estimate of this measurement's actual noise, so the sensitivity
        // covariance takes it too.
        let mut r_used = *r;
        let nis = match res {
            Ok((nis, deweighted)) => {
                if deweighted {
                    self.stats.deweighted += 1;
                    if let Some(gq) = g {
                        r_used *= nis / gq;
                    }
                }
                nis
            }
            Err((UpdateReject::Gate, nis)) => {
                self.log_update(kind, M, nis, false);
                return Err(UpdateReject::Gate);
            }
            Err((UpdateReject::Singular, _)) => {
                self.stats.singular += 1;
                return Err(UpdateReject::Singular);
            }
        };
        if self.cfg.smoother_every > 0 && self.rec_p_prior.is_none() {
            self.rec_p_prior = Some(p_prior);
        }
        if want_k {
            // The gain applied, split into the filter's and the augmented rows.
            let (kx, ka) = if self.aug.is_some() {
                let ka = k_f.fixed_rows::<NA>(NX).into_owned();
                (k_f.fixed_rows::<NX>(0).into_owned(), Some(ka))
            } else {
                (k_x, None)
            };
            for sn in [&mut self.sens, &mut self.sens_s, &mut self.sens_w]
                .into_iter()
                .flatten()
            {
                sn.update(h, h_a, &r_used, &kx, ka.as_ref(), kind);
            }
        }
        apply_correction(&mut self.nav, &mut self.err, &dx);
        self.rec_dx += dx;
        self.rec_updated = true;
        self.log_update(kind, M, nis, true);
        Ok(nis)
    }

    /// GNSS updates for `fix` at the current state time.
    fn gnss_update(&mut self, fix: &GnssFix) {
        let c = self.nav.c_bn();
        let l_n = c * self.cfg.lever_arm_b;
        let (rm, rn) = earth::radii(self.nav.lat);
        let (lat_a, lon_a, h_a) = self.antenna_position();
        let mut dz_pos = Vec3::new(
            (lat_a - fix.lat) * (rm + self.nav.h),
            (lon_a - fix.lon) * (rn + self.nav.h) * self.nav.lat.cos(),
            -(h_a - fix.h),
        );
        let position_allowed = self.cfg.position_until.is_none_or(|t| fix.t <= t);
        let mut std = match self.adapt.gnss_quality {
            Some(q) => fix.std_ned * q.factor(fix.quality),
            None => fix.std_ned,
        };
        // Augmented states: ẑ = p̂_ant + b̂ − v_ant τ̂ (module `aug`).
        let mut h_pos_a = SMatrix::<f64, 3, NA>::zeros();
        if let Some(a) = &self.aug {
            let v_ant = self.nav.v_n + c * self.w_ib_b.cross(&self.cfg.lever_arm_b);
            let b = a.x.fixed_rows::<3>(IA_GNSS);
            let tau = a.x[IA_TAU];
            let shift = if tau > 0.0 {
                a.shift(tau).0
            } else {
                v_ant * tau
            };
            dz_pos += b - shift;
            h_pos_a
                .fixed_view_mut::<3, 3>(0, IA_GNSS)
                .copy_from(&Mat3::identity());
            h_pos_a.set_column(IA_TAU, &(-v_ant));
            if a.has_gnss_error() {
                // The reported σ covers white + correlated parts; b carries
                // the correlated one.
                let sb = a.gnss_sigma();
                std = Vec3::from_fn(|k, _| {
                    (std[k] * std[k] - sb[k] * sb[k])
                        .max(std[k] * std[k] / 16.0)
                        .sqrt()
                });
            }
        }
        if position_allowed {
            let mut h = SMatrix::<f64, 3, NX>::zeros();
            h.fixed_view_mut::<3, 3>(0, I_POS)
                .copy_from(&Mat3::identity());
            h.fixed_view_mut::<3, 3>(0, I_ATT).copy_from(&skew(&l_n));
            let lambda = self.adapt.nis_pos.map_or(1.0, |a| a.scale());
            let r = Mat3::from_diagonal(&std.component_mul(&std)) * lambda;
            let force = self.cfg.gnss_force_after > 0
                && self.gnss_consecutive_rejects >= self.cfg.gnss_force_after;
            match self.update_aug(&h, &h_pos_a, &r, &dz_pos, !force, UpdateKind::GnssPosition) {
                Ok(_) => {
                    self.stats.gnss_pos_used += 1;
                    if force {
                        self.stats.gnss_pos_forced += 1;
                    }
                    self.gnss_consecutive_rejects = 0;
                }
                Err(UpdateReject::Gate) => {
                    self.stats.gnss_pos_rejected_gate += 1;
                    self.gnss_consecutive_rejects += 1;
                }
                Err(UpdateReject::Singular) => {}
            }
        } else {
            // Height only.
            let mut h = SMatrix::<f64, 1, NX>::zeros();
            h[(0, I_POS + 2)] = 1.0;
            h.fixed_view_mut::<1, 3>(0, I_ATT)
                .copy_from(&skew(&l_n).fixed_view::<1, 3>(2, 0));
            let r = SMatrix::<f64, 1, 1>::new(std.z * std.z);
            let dz = SVector::<f64, 1>::new(dz_pos.z);
            let h_a = h_pos_a.fixed_rows::<1>(2).into_owned();
            match self.update_aug(&h, &h_a, &r, &dz, true, UpdateKind::Height) {
                Ok(_) => self.stats.height_used += 1,
                Err(UpdateReject::Gate) => self.stats.height_rejected_gate += 1,
                Err(UpdateReject::Singular) => {}
            }
        }
        if self.cfg.use_gnss_velocity {
            if let (Some(v_meas), Some(sv)) = (fix.v_n, fix.std_v_n) {
                // Antenna velocity: v + C_bn (ω_ib^b × l) (earth-rate term neglected).
                let c = self.nav.c_bn();
                let lever_v = c * self.w_ib_b.cross(&self.cfg.lever_arm_b);
                let mut dz = self.nav.v_n + lever_v - v_meas;
                // ẑ_vel = v̂_ant − a_n τ̂ (a_n ≈ C_bn f_b + g_n; Coriolis neglected).
                // The velocity is predicted at t − τ̂ too, but is not used to
                // estimate τ (`H_τ = 0` instead of −a_n): on simulated drives
                // with turn onsets its first-order sensitivity biased τ̂ by up
                // to 14 ms, the position channel alone by < 3 ms (aug_tests).
                // A consider τ is never estimated, so there the sensitivity
                // is kept: its σ then reaches the velocity too (−a_n σ_τ).
                let mut h_a = SMatrix::<f64, 3, NA>::zeros();
                if let Some(a) = &self.aug {
                    let e = EarthAt::new(self.nav.lat, self.nav.h);
                    let a_n = c * self.f_b + Vec3::new(0.0, 0.0, e.g);
                    let tau = a.x[IA_TAU];
                    dz -= if tau > 0.0 { a.shift(tau).1 } else { a_n * tau };
                    if a.time_offset_considered() {
                        h_a.set_column(IA_TAU, &(-a_n));
                    }
                }
                let mut h = SMatrix::<f64, 3, NX>::zeros();
                h.fixed_view_mut::<3, 3>(0, I_VEL)
                    .copy_from(&Mat3::identity());
                h.fixed_view_mut::<3, 3>(0, I_ATT)
                    .copy_from(&skew(&lever_v));
                let lambda = self.adapt.nis_vel.map_or(1.0, |a| a.scale());
                let r = Mat3::from_diagonal(&sv.component_mul(&sv)) * lambda;
                match self.update_aug(&h, &h_a, &r, &dz, true, UpdateKind::GnssVelocity) {
                    Ok(_) => self.stats.gnss_vel_used += 1,
                    Err(UpdateReject::Gate) => self.stats.gnss_vel_rejected_gate += 1,
                    Err(UpdateReject::Singular) => {}
                }
            }
        }
    }

    /// Vehicle constraints after the IMU sample at the current time.
    fn vehicle_updates(&mut self) {
        let t = self.t;
        if let Some(z) = self.cfg.zupt {
            self.detector.push(self.f_b, self.w_ib_b, z.window);
            let c_nb = self.nav.c_bn().transpose();
            let e = EarthAt::new(self.nav.lat, self.nav.h);
            let f_rest_b = c_nb * Vec3::new(0.0, 0.0, -e.g);
            // An IMU cannot tell rest from smooth uniform motion (a quiet
            // robot cruising slowly): a GNSS speed above `max_speed` within
            // the last 2 s (two 1 Hz fixes) vetoes the standstill.
            let gnss_moving = t - self.gnss_motion.0 <= 2.0 && self.gnss_motion.1 > z.max_speed;
            // Without that veto (an outage) only the filter's own speed says
            // rest, and only when its σ allows it (see `ZuptConfig::max_speed`).
            let sigma_vh = (self.p[(I_VEL, I_VEL)] + self.p[(I_VEL + 1, I_VEL + 1)])
                .max(0.0)
                .sqrt();
            self.standstill = match self.detector.stats(z.window) {
                Some((sf, sw, _, f_mean)) => {
                    sf < z.max_accel_std
                        && sw < z.max_gyro_std
                        && (f_mean - f_rest_b).norm() < z.max_accel_dev
                        && self.nav.v_n.norm() + sigma_vh < z.max_speed
                        && !gnss_moving
                }
                None => false,
            };
            if self.standstill && t - self.last_zupt >= z.interval {
                self.last_zupt = t;
                let mut h = SMatrix::<f64, 3, NX>::zeros();
                h.fixed_view_mut::<3, 3>(0, I_VEL)
                    .copy_from(&Mat3::identity());
                let dz = self.nav.v_n;
                let r = constraint_r(&mut self.adapt.zupt, &self.p, &h, &dz, z.vel_std);
                let zupt_ok = match self.update(&h, &r, &dz, true, UpdateKind::Zupt) {
                    Ok(_) => {
                        self.stats.zupt_used += 1;
                        true
                    }
                    Err(UpdateReject::Gate) => {
                        self.stats.zupt_rejected_gate += 1;
                        false
                    }
                    Err(UpdateReject::Singular) => false,
                };
                // ZARU only when the zero-velocity test passed too.
                if let (true, Some(zs), Some((_, _, w_mean, _))) =
                    (zupt_ok, z.zaru_std, self.detector.stats(z.window))
                {
                    // Window-mean compensated rate minus the earth rate = δb_g.
                    let w_ie_b = self.nav.c_bn().transpose() * earth::omega_ie_n(self.nav.lat);
                    let dz = w_mean - w_ie_b;
                    let mut h = SMatrix::<f64, 3, NX>::zeros();
                    h.fixed_view_mut::<3, 3>(0, I_BG)
                        .copy_from(&Mat3::identity());
                    // The window mean holds the bias of its samples: one ZARU per window.
                    let window_s = z.window as f64 * self.last_dt;
                    if t - self.last_zaru >= window_s {
                        let r = constraint_r(&mut self.adapt.zaru, &self.p, &h, &dz, zs);
                        if self.update(&h, &r, &dz, true, UpdateKind::Zaru).is_ok() {
                            self.last_zaru = t;
                            self.stats.zaru_used += 1;
                        }
                    }
                }
                return;
            }
        }
        if let Some(n) = self.cfg.nhc {
            if self.standstill
                || self.odometer_nhc_recent()
                || t - self.last_nhc < n.interval
                || self.nav.v_n.norm() < n.min_speed
            {
                return;
            }
            self.last_nhc = t;
            let c_nb = self.nav.c_bn().transpose();
            let v_b = c_nb * self.nav.v_n;
            let h_v = c_nb;
            let h_a = -(c_nb * skew(&self.nav.v_n));
            let mut h = SMatrix::<f64, 2, NX>::zeros();
            for r in 0..2 {
                for k in 0..3 {
                    h[(r, I_VEL + k)] = h_v[(r + 1, k)];
                    h[(r, I_ATT + k)] = h_a[(r + 1, k)];
                }
            }
            let mut dz = SVector::<f64, 2>::new(v_b.y, v_b.z);
            // The mounting states (module `aug`): u_y = v_y + ω_z l_x − ψ_m v_x,
            // u_z = v_z − ω_y l_x + θ_m v_x.
            let mut h_a = SMatrix::<f64, 2, NA>::zeros();
            if let Some(a) = self.aug.as_ref().filter(|a| a.has_nhc_mount()) {
                let (th, psi, lx) = (a.x[IA_MNT], a.x[IA_MNT + 1], a.x[IA_MNT + 2]);
                let w = self.w_ib_b;
                dz.x += w.z * lx - psi * v_b.x;
                dz.y += -w.y * lx + th * v_b.x;
                h_a[(0, IA_MNT + 1)] = -v_b.x;
                h_a[(0, IA_MNT + 2)] = w.z;
                h_a[(1, IA_MNT)] = v_b.x;
                h_a[(1, IA_MNT + 2)] = -w.y;
            }
            let r = constraint_r(&mut self.adapt.nhc, &self.p, &h, &dz, n.std);
            match self.update_aug(&h, &h_a, &r, &dz, true, UpdateKind::Nhc) {
                Ok(_) => self.stats.nhc_used += 1,
                Err(UpdateReject::Gate) => self.stats.nhc_rejected_gate += 1,
                Err(UpdateReject::Singular) => {}
            }
        }
    }

    /// Smoother checkpoint bookkeeping after a full IMU sample.
    fn maybe_record(&mut self) {
        let every = self.cfg.smoother_every;
        if every == 0 {
            return;
        }
        self.rec_count += 1;
        if !(self.rec_updated || self.rec_count >= every) {
            return;
        }
        // A = P⁺_{k−1} Φᵀ (P⁻_k)⁻¹, via Cholesky of the symmetric P⁻ (the
        // covariance before the first update since the last checkpoint).
        let p_prior = self.rec_p_prior.take().unwrap_or(self.p);
        let mut aug_base_xx = None;
        let (gain, aug) = match &mut self.aug {
            None => {
                let gain = if self.rec_have_prev {
                    let b = self.rec_phi_t.transpose() * self.rec_p_post; // (P⁺Φᵀ)ᵀ = Φ P⁺
                    match p_prior.cholesky() {
                        Some(ch) => ch.solve(&b).transpose(),
                        None => Cov::zeros(),
                    }
                } else {
                    Cov::zeros()
                };
                (gain, None)
            }
            Some(a) => {
                // The joint A and B: B's augmented blocks carry what the
                // smoother cannot average (e.g. a considered GNSS error b)
                // into the smoothed covariance (`rts_smooth`).
                let (full, base) = if self.rec_have_prev {
                    a.smoother_gain_base(&self.rec_p_post, &self.rec_phi_t, &p_prior)
                } else {
                    (SMatrix::zeros(), SMatrix::zeros())
                };
                let rec = AugSmootherRecord {
                    dx_fed_back: a.rec_dx,
                    gain_xa: full.fixed_view::<NX, NA>(0, NX).into_owned(),
                    gain_ax: full.fixed_view::<NA, NX>(NX, 0).into_owned(),
                    gain_aa: full.fixed_view::<NA, NA>(NX, NX).into_owned(),
                    base_xa: base.fixed_view::<NX, NA>(0, NX).into_owned(),
                    base_aa: base.fixed_view::<NA, NA>(NX, NX).into_owned(),
                    post_xa: a.p_xa,
                    post_aa: a.p_aa,
                };
                a.reset_record();
                aug_base_xx = Some(base.fixed_view::<NX, NX>(0, 0).into_owned());
                (full.fixed_view::<NX, NX>(0, 0).into_owned(), Some(rec))
            }
        };
        // Joseph form of B = P⁺ − A P⁻ Aᵀ with Q = P⁻ − Φ P⁺ Φᵀ (rts_smooth).
        // P⁻ is taken before the first update, which may sit a fraction of
        // an IMU interval before this checkpoint while Φ spans the whole
        // interval: that Q can have negative diagonal terms (measured on
        // drive_0708: −3 % of the position variance), which would drive
        // smoothed variances below zero. The process noise added between
        // checkpoints is (per axis) white: keep the diagonal of Q, floored
        // at 0, which makes B positive semi-definite ([`smoother_base`]).
        // With augmented states B is the joint one's INS block (above).
        let base = if let Some(b) = aug_base_xx {
            b
        } else if self.rec_have_prev {
            smoother_base(
                &gain,
                &self.rec_phi_t.transpose(),
                &self.rec_p_post,
                &p_prior,
            )
        } else {
            Cov::zeros()
        };
        self.record = Some(SmootherRecord {
            t: self.t,
            nav: self.nav,
            errors: self.err,
            dx_fed_back: self.rec_dx,
            gain_prev: gain,
            p_post_diag: self.p.diagonal(),
            aug,
            p_base_prev: base,
            p_extra: self.sens_s.as_ref().or(self.sens.as_ref()).map(|sc| {
                let minus = |a: &Cov, o: &Cov| {
                    (
                        a.diagonal() - o.diagonal(),
                        pos_cross_ned(a) - pos_cross_ned(o),
                    )
                };
                // The forward σ reported: the filter's own without `sens`.
                let forward = self.sens.as_ref().map_or_else(
                    || (StateVec::zeros(), Vec3::zeros()),
                    |sn| minus(&sn.p, &self.p),
                );
                SensExtra {
                    forward,
                    correlated: self.sens_w.as_ref().map_or(forward, |w| {
                        // Capped at var(b) per position axis (module `sens`).
                        let (d, c) = minus(&sc.p, &w.p);
                        let mut d = d.map(|x| x.max(0.0));
                        for (i, v) in sc.var_b().iter().enumerate() {
                            d[I_POS + i] = d[I_POS + i].min(*v);
                        }
                        (d, c)
                    }),
                }
            }),
        });
        self.rec_have_prev = true;
        self.rec_p_post = self.p;
        self.rec_phi_t = Cov::identity();
        self.rec_dx = StateVec::zeros();
        self.rec_count = 0;
        self.rec_updated = false;
    }

    /// Process one IMU sample (KF-GINS `newImuProcess`): propagate, and apply
    /// a pending GNSS fix at its own time inside or at the ends of the interval.
    fn push_imu(&mut self, imu: &ImuSample) -> Option<NavSolution> {
        let finite = imu.dt.is_finite()
            && imu.t.is_finite()
            && imu
                .dtheta_b
                .iter()
                .chain(imu.dvel_b.iter())
                .all(|v| v.is_finite());
        if !finite || imu.dt <= 0.0 || (self.started && imu.t <= self.t) {
            self.stats.imu_rejected_bad += 1;
            return None;
        }
        self.stats.imu_samples += 1;
        if !self.started {
            // The initial state holds at the end of the first interval.
            let (dth, dv) = self.compensate(&imu.dtheta_b, &imu.dvel_b, imu.dt);
            self.dtheta_pre = dth;
            self.dvel_pre = dv;
            self.w_ib_b = dth / imu.dt;
            self.f_b = dv / imu.dt;
            self.t = imu.t;
            self.started = true;
            self.pending = self.pending.filter(|g| g.t > imu.t);
            return Some(self.solution());
        }
        self.last_dt = imu.dt;
        // Tight coupling: a raw GNSS epoch inside the interval splits it
        // (module `tight`; nothing happens without tight coupling).
        let rest;
        let imu = match self.tight_before(imu) {
            Some(r) => {
                rest = r;
                &rest
            }
            None => imu,
        };
        let t0 = self.t;
        let t1 = imu.t;
        let mut fix = None;
        if let Some(g) = self.pending {
            if g.t <= t1 + TIME_ALIGN {
                fix = Some(g);
                self.pending = None;
            }
        }
        match fix {
            Some(g) if (g.t - t0).abs() < TIME_ALIGN => {
                self.gnss_update(&g);
                self.propagate(&imu.dtheta_b, &imu.dvel_b, imu.dt);
            }
            Some(g) if (t1 - g.t).abs() <= TIME_ALIGN => {
                self.propagate(&imu.dtheta_b, &imu.dvel_b, imu.dt);
                self.t = t1;
                self.gnss_update(&g);
            }
            Some(g) if g.t > t0 && g.t < t1 => {
                let lambda = (g.t - t0) / (t1 - t0);
                let dt1 = g.t - t0;
                self.propagate(&(imu.dtheta_b * lambda), &(imu.dvel_b * lambda), dt1);
                self.t = g.t;
                self.gnss_update(&g);
                self.propagate(
                    &(imu.dtheta_b * (1.0 - lambda)),
                    &(imu.dvel_b * (1.0 - lambda)),
                    imu.dt - dt1,
                );
            }
            Some(_) => {
                // Older than the current state: cannot be applied.
                self.stats.gnss_rejected_bad += 1;
                self.propagate(&imu.dtheta_b, &imu.dvel_b, imu.dt);
            }
            None => self.propagate(&imu.dtheta_b, &imu.dvel_b, imu.dt),
        }
        self.t = t1;
        self.tight_after();
        if self.cfg.nhc.is_some() || self.cfg.zupt.is_some() {
            self.vehicle_updates();
        }
        self.maybe_record();
        Some(self.solution())
    }

    fn push_gnss(&mut self, g: &GnssFix) {
        let ok = g.t.is_finite()
            && g.lat.is_finite()
            && g.lon.is_finite()
            && g.h.is_finite()
            && g.std_ned.iter().all(|s| s.is_finite() && *s > 0.0);
        if !ok || (self.started && g.t < self.t - TIME_ALIGN) {
            self.stats.gnss_rejected_bad += 1;
            return;
        }
        // GNSS evidence of motion for the standstill detector's veto.
        let speed = match (g.v_n, self.last_fix) {
            (Some(v), _) if v.x.is_finite() && v.y.is_finite() => Some(v.xy().norm()),
            (_, Some(p)) if g.t - p.t > 0.05 && g.t - p.t <= 2.0 => {
                let (rm, rn) = earth::radii(p.lat);
                let dn = (g.lat - p.lat) * (rm + p.h);
                let de = (g.lon - p.lon) * (rn + p.h) * p.lat.cos();
                // Only a chord longer than 3σ of its ends counts as motion.
                let s3 =
                    3.0 * (g.std_ned.xy().norm_squared() + p.std_ned.xy().norm_squared()).sqrt();
                let len = dn.hypot(de);
                Some(if len > s3 { len / (g.t - p.t) } else { 0.0 })
            }
            _ => None,
        };
        if let Some(v) = speed {
            self.gnss_motion = (g.t, v);
        }
        self.last_fix = Some(*g);
        if let Some(old) = self.pending.replace(*g) {
            // Two fixes inside one IMU interval: the older one is superseded.
            let _ = old;
            self.stats.gnss_rejected_bad += 1;
        }
    }
}

/// R of a constraint update with innovation `dz`: without adaptation
/// `σ² I` (`fixed_std`); with it, the estimate after folding in `dz` with
/// `diag(H P⁻ Hᵀ)` (the windowed innovation covariance includes the current
/// epoch, as in Mohamed & Schwarz 1999 and Sage–Husa; an innovation beyond
/// the ceiling gate is not folded in, see [`super::adaptive`]).
fn constraint_r<const M: usize>(
    est: &mut Option<NoiseEstimator<M>>,
    p: &Cov,
    h: &SMatrix<f64, M, NX>,
    dz: &SVector<f64, M>,
    fixed_std: f64,
) -> SMatrix<f64, M, M> {
    match est {
        Some(e) => {
            let hp: SMatrix<f64, M, NX> = h * p;
            let hph = SVector::<f64, M>::from_fn(|i, _| hp.row(i).dot(&h.row(i)));
            let _ = e.observe(dz, &hph);
            SMatrix::<f64, M, M>::from_diagonal(&e.r_diag())
        }
        None => SMatrix::<f64, M, M>::identity() * (fixed_std * fixed_std),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UpdateReject {
    Gate,
    Singular,
}

#[inline]
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

impl Estimator for Eskf {
    fn name(&self) -> &'static str {
        "eskf"
    }
    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        self.journal_len = 0;
        match ev {
            Event::Imu(s) => self.push_imu(s),
            Event::Gnss(g) => {
                self.push_gnss(g);
                None
            }
            // Issue 17 aiding (module `aiding`; ignored unless configured).
            Event::Odometer(o) => {
                self.push_odometer(o);
                None
            }
            Event::Heading(h) => {
                self.push_heading(h);
                None
            }
            Event::Mag(m) => {
                self.push_mag(m);
                None
            }
            // Carrier phase is CP-ATT's input.
            Event::CarrierPhase(_) => None,
            // Raw GNSS: used with tight coupling only (module `tight`).
            Event::RawGnss(r) => {
                self.push_raw(r);
                None
            }
        }
    }
}

#[cfg(test)]
mod adaptive_tests;
#[cfg(test)]
mod aiding_tests;
#[cfg(test)]
mod aug_tests;
#[cfg(test)]
mod rtk_tests;
#[cfg(test)]
mod tight_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins::mech::q_bn_from_rpy;

    const LAT: f64 = 0.7;
    const H: f64 = 1600.0;

    fn noise() -> ImuNoise {
        ImuNoise {
            arw: Vec3::repeat(0.2f64.to_radians() / 60.0),
            vrw: Vec3::repeat(0.05 / 60.0),
            bg_std: Vec3::repeat(5.0f64.to_radians() / 3600.0),
            ba_std: Vec3::repeat(3e-3),
            sg_std: Vec3::repeat(1e-3),
            sa_std: Vec3::repeat(1e-3),
            corr_time: 3600.0,
        }
    }

    /// `floor_position_std` raises only the position diagonal that is below
    /// the floor, by exactly the missing variance, and leaves every other
    /// element (and a position σ already above the floor) as it was.
    #[test]
    fn floor_position_std_adds_only_the_missing_position_variance() {
        let nav = NavState {
            lat: LAT,
            lon: 0.3,
            h: H,
            v_n: Vec3::new(3.0, -1.0, 0.0),
            q_bn: q_bn_from_rpy(&Vec3::new(0.02, -0.01, 0.5)),
        };
        let mut e = Eskf::new(config(), nav, ImuErrors::default(), &std0());
        let p0 = *e.covariance();
        let s0 = p0[(I_POS + 1, I_POS + 1)].sqrt();
        let floor = Vec3::new(2.0, 0.5 * s0, f64::NAN);
        let added = e.floor_position_std(&floor);
        let p1 = *e.covariance();
        assert_eq!(p1[(I_POS, I_POS)], 4.0);
        assert_eq!(added.x, 4.0 - p0[(I_POS, I_POS)]);
        assert_eq!((added.y, added.z), (0.0, 0.0));
        let mut d = p1 - p0;
        d[(I_POS, I_POS)] = 0.0;
        assert_eq!(d.abs().max(), 0.0);
    }

    /// `error_state_to` is what `apply_correction` needs: applying it to
    /// this filter's nominal state lands on the other (to first order), and
    /// the mixture spread adds `w δx δxᵀ` only.
    #[test]
    fn error_state_to_inverts_apply_correction_and_spread_adds_its_outer_product() {
        let nav = |yaw_deg: f64, dn: f64| NavState {
            lat: LAT + dn / 6.4e6,
            lon: 0.3,
            h: H,
            v_n: Vec3::new(3.0, -1.0, 0.1 * dn),
            q_bn: q_bn_from_rpy(&Vec3::new(0.02, -0.01, yaw_deg.to_radians())),
        };
        let mut e = Eskf::new(config(), nav(40.0, 0.0), ImuErrors::default(), &std0());
        let other_err = ImuErrors {
            bg: Vec3::new(1e-4, -2e-4, 3e-3),
            ba: Vec3::new(0.01, 0.0, -0.02),
            ..Default::default()
        };
        let other = nav(43.0, 2.0);
        let dx = e.error_state_to(&other, &other_err);
        let (mut n, mut er) = (*e.nav(), *e.imu_errors());
        apply_correction(&mut n, &mut er, &dx);
        assert!(((n.lat - other.lat) * 6.4e6).abs() < 1e-6);
        assert!((n.v_n - other.v_n).norm() < 1e-12);
        assert!(n.q_bn.angle_to(&other.q_bn) < 1e-12);
        assert!((er.bg - other_err.bg).norm() < 1e-15 && (er.ba - other_err.ba).norm() < 1e-15);
        assert!((dx[I_ATT + 2] - 3f64.to_radians()).abs() < 1e-3);
        let p0 = *e.covariance();
        e.add_mixture_spread(&dx, 0.25);
        assert!(
            (e.covariance() - p0 - dx * dx.transpose() * 0.25)
                .abs()
                .max()
                < 1e-15
        );
        e.add_mixture_spread(&dx, f64::NAN);
        e.add_mixture_spread(&dx, -1.0);
        assert!(
            (e.covariance() - p0 - dx * dx.transpose() * 0.25)
                .abs()
                .max()
                < 1e-15
        );
    }

    pub(super) fn std0() -> InitStd {
        InitStd {
            pos: Vec3::repeat(0.1),
            vel: Vec3::repeat(0.1),
            att: Vec3::new(0.5, 0.5, 2.0).map(f64::to_radians),
            bg: Vec3::repeat(50.0f64.to_radians() / 3600.0),
            ba: Vec3::repeat(0.02),
            sg: Vec3::repeat(1e-3),
            sa: Vec3::repeat(1e-3),
        }
    }

    pub(super) fn config() -> EskfConfig {
        EskfConfig {
            noise: noise(),
            lever_arm_b: Vec3::new(0.2, -0.1, -0.5),
            scale_factors: true,
            gate_probability: Some(0.9999),
            gate_deweight_factor: 100.0,
            gnss_force_after: 5,
            use_gnss_velocity: false,
            position_until: None,
            nhc: None,
            zupt: None,
            smoother_every: 0,
            aiding: Default::default(),
        }
    }

    pub(super) fn start() -> NavState {
        NavState {
            lat: LAT,
            lon: -1.8,
            h: H,
            v_n: Vec3::zeros(),
            q_bn: q_bn_from_rpy(&Vec3::new(0.01, -0.02, 0.5)),
        }
    }

    /// Deterministic pseudo-noise in [−1, 1] (no RNG dependency in core).
    fn wobble(k: u64, axis: u64) -> f64 {
        let x = (k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(axis * 1442695040888963407))
            >> 11;
        (x as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// Static IMU increments with biases `bg`, `ba` and small noise.
    pub(super) fn static_sample(k: u64, dt: f64, bg: &Vec3, ba: &Vec3) -> ImuSample {
        let s = start();
        let c_nb = s.c_bn().transpose();
        let w = c_nb * earth::omega_ie_n(LAT) + bg;
        let f = c_nb * (-earth::gravity_n(LAT, H)) + ba;
        let n = |a: u64| wobble(k, a);
        ImuSample {
            t: k as f64 * dt,
            dt,
            dtheta_b: (w + Vec3::new(n(0), n(1), n(2)) * 1e-4) * dt,
            dvel_b: (f + Vec3::new(n(3), n(4), n(5)) * 1e-3) * dt,
        }
    }

    pub(super) fn fix_at(s: &NavState, t: f64, lever: &Vec3, off_n: Vec3) -> GnssFix {
        let (rm, rn) = earth::radii(s.lat);
        let l = s.c_bn() * lever + off_n;
        GnssFix {
            t,
            lat: s.lat + l.x / (rm + s.h),
            lon: s.lon + l.y / ((rn + s.h) * s.lat.cos()),
            h: s.h - l.z,
            std_ned: Vec3::repeat(0.05),
            ..Default::default()
        }
    }

    /// Finite, exactly symmetric, and positive definite (Cholesky of the
    /// correlation matrix, which is independent of the states' units).
    fn is_spd(p: &Cov) -> bool {
        if !p.iter().all(|v| v.is_finite()) || p != &p.transpose() {
            return false;
        }
        let d = p.diagonal();
        if d.iter().any(|v| *v <= 0.0) {
            return false;
        }
        let s = d.map(|v| 1.0 / v.sqrt());
        let corr = Cov::from_fn(|i, j| p[(i, j)] * s[i] * s[j]);
        corr.cholesky().is_some()
    }

    #[test]
    fn every_covariance_kernel_gives_bit_identical_results() {
        let bg = Vec3::new(20.0, -30.0, 10.0).map(|d: f64| d.to_radians() / 3600.0);
        let ba = Vec3::new(0.01, -0.005, 0.0);
        let truth = start();
        let detected = Eskf::new(config(), truth, ImuErrors::default(), &std0());
        let mut generic = detected.clone();
        generic.kernel = Kernel::Generic;
        let mut filters = [detected, generic];
        let dt = 0.01;
        for k in 1..=3_000u64 {
            let s = static_sample(k, dt, &bg, &ba);
            for f in filters.iter_mut() {
                if k % 100 == 50 {
                    let off = Vec3::new(0.3, -0.2, 0.1) * (k as f64 * 1e-3).sin();
                    f.push(&Event::Gnss(fix_at(
                        &truth,
                        s.t - 0.5 * dt,
                        &config().lever_arm_b,
                        off,
                    )));
                }
                f.push(&Event::Imu(s));
            }
        }
        let [a, b] = &filters;
        assert_eq!(a.covariance(), b.covariance());
        assert_eq!(a.solution().lat.to_bits(), b.solution().lat.to_bits());
        assert_eq!(a.imu_errors().bg, b.imu_errors().bg);
    }

    #[test]
    fn static_with_fixes_estimates_gyro_bias_and_stays_put() {
        let bg = Vec3::new(20.0, -30.0, 10.0).map(|d: f64| d.to_radians() / 3600.0);
        let ba = Vec3::new(0.01, -0.005, 0.0);
        let truth = start();
        let mut f = Eskf::new(config(), truth, ImuErrors::default(), &std0());
        let dt = 0.01;
        for k in 1..=30_000u64 {
            let s = static_sample(k, dt, &bg, &ba);
            if k % 100 == 50 {
                f.push(&Event::Gnss(fix_at(
                    &truth,
                    s.t - 0.5 * dt,
                    &config().lever_arm_b,
                    Vec3::zeros(),
                )));
            }
            f.push(&Event::Imu(s));
        }
        let e = f.imu_errors();
        // Horizontal gyro bias (levelling) is observable at rest; vertical through gyrocompassing.
        assert!(
            (e.bg.x - bg.x).abs() < 3e-6 && (e.bg.y - bg.y).abs() < 3e-6,
            "bg {:?} vs {:?}",
            e.bg,
            bg
        );
        assert!((e.ba.z - ba.z).abs() < 5e-3, "ba_z {}", e.ba.z);
        let sol = f.solution();
        let (rm, _) = earth::radii(LAT);
        assert!(((sol.lat - LAT) * rm).abs() < 0.05);
        assert!(is_spd(f.covariance()));
        assert_eq!(f.stats().gnss_pos_used, 300);
    }

    #[test]
    fn outliers_are_rejected_and_counted() {
        let truth = start();
        let mut f = Eskf::new(config(), truth, ImuErrors::default(), &std0());
        let dt = 0.01;
        let mut injected = 0;
        let mut journal_rejected = 0usize;
        for k in 1..=15_000u64 {
            let s = static_sample(k, dt, &Vec3::zeros(), &Vec3::zeros());
            if k % 100 == 0 {
                let off = if k > 5_000 && k % 700 == 0 {
                    injected += 1;
                    Vec3::new(30.0, -20.0, 5.0)
                } else {
                    Vec3::zeros()
                };
                f.push(&Event::Gnss(fix_at(
                    &truth,
                    s.t,
                    &config().lever_arm_b,
                    off,
                )));
            }
            f.push(&Event::Imu(s));
            // The fix is applied inside the IMU interval that contains it: the
            // journal of that push lists its position update with the gate
            // decision the stats count, and other pushes list none.
            let pos: Vec<&UpdateLog> = f
                .updates()
                .iter()
                .filter(|u| u.kind == UpdateKind::GnssPosition)
                .collect();
            assert_eq!(
                pos.len(),
                (k % 100 == 0) as usize,
                "k {k}: {:?}",
                f.updates()
            );
            if let Some(u) = pos.first() {
                assert!(u.nis.is_finite() && u.dof == 3);
                journal_rejected += !u.accepted as usize;
            }
        }
        assert!(injected > 10);
        assert_eq!(f.stats().gnss_pos_rejected_gate, injected);
        assert_eq!(journal_rejected as u64, injected);
        let (rm, rn) = earth::radii(LAT);
        let sol = f.solution();
        let dn = (sol.lat - LAT) * rm;
        let de = (sol.lon + 1.8) * rn * LAT.cos();
        assert!(dn.hypot(de) < 0.05, "{dn} {de}");
    }

    #[test]
    fn twenty_four_hours_static_stays_finite_and_spd() {
        // A vehicle parked for a day: 24 h at 1 Hz (86 400 samples; the rate
        // only sets the debug-build test time), fixes every 10 s except for a
        // 1-h gap at hour 12 (free inertial; a longer unaided run is dominated
        // by the exponentially unstable vertical channel, time constant
        // √(R/2g) ≈ 570 s, which is physics, not numerics). P must stay
        // finite, symmetric and positive definite, the state finite.
        let dt = 1.0;
        let bg = Vec3::new(5.0, -3.0, 2.0).map(|d: f64| d.to_radians() / 3600.0);
        let truth = start();
        let mut f = Eskf::new(config(), truth, ImuErrors::default(), &std0());
        let n = (24.0 * 3600.0 / dt) as u64;
        for k in 1..=n {
            let s = static_sample(k, dt, &bg, &Vec3::zeros());
            if k % 10 == 0 && !(12.0 * 3600.0..13.0 * 3600.0).contains(&s.t) {
                f.push(&Event::Gnss(fix_at(
                    &truth,
                    s.t,
                    &config().lever_arm_b,
                    Vec3::zeros(),
                )));
            }
            let sol = f.push(&Event::Imu(s)).unwrap();
            assert!(
                sol.lat.is_finite() && sol.h.is_finite() && sol.v_n.iter().all(|v| v.is_finite()),
                "state not finite at {} h: {sol:?} {:?}",
                s.t / 3600.0,
                f.stats()
            );
            if k % 3_600 == 0 {
                assert!(is_spd(f.covariance()), "P not SPD after {} h", s.t / 3600.0);
            }
        }
        assert!(is_spd(f.covariance()));
        assert_eq!(f.stats().imu_samples, n);
    }

    #[test]
    fn smoother_reduces_the_error_inside_an_outage() {
        // Static with a gyro bias; fixes except in [100, 160) s. The smoothed
        // position inside the gap must be closer to the truth than the forward one.
        let bg = Vec3::new(0.0, 0.0, 50.0).map(|d: f64| d.to_radians() / 3600.0);
        let ba = Vec3::new(0.02, 0.0, 0.0);
        let truth = start();
        let mut cfg = config();
        cfg.smoother_every = 10;
        let mut f = Eskf::new(cfg, truth, ImuErrors::default(), &std0());
        let dt = 0.01;
        let mut records = [None; 0].to_vec();
        let mut fwd_err_max: f64 = 0.0;
        let (rm, rn) = earth::radii(LAT);
        let err = |lat: f64, lon: f64| ((lat - LAT) * rm).hypot((lon + 1.8) * rn * LAT.cos());
        for k in 1..=20_000u64 {
            let s = static_sample(k, dt, &bg, &ba);
            if k % 100 == 0 && !(10_000..16_000).contains(&k) {
                f.push(&Event::Gnss(fix_at(
                    &truth,
                    s.t,
                    &cfg.lever_arm_b,
                    Vec3::zeros(),
                )));
            }
            let sol = f.push(&Event::Imu(s)).unwrap();
            if (10_000..16_000).contains(&k) {
                fwd_err_max = fwd_err_max.max(err(sol.lat, sol.lon));
            }
            if let Some(r) = f.take_record() {
                records.push(Some(r));
            }
        }
        let recs: std::vec::Vec<SmootherRecord> = records.into_iter().flatten().collect();
        let mut sm_err_max: f64 = 0.0;
        // Smoothed σ ≤ forward σ at every checkpoint, strictly smaller in
        // the middle of the outage (where both sides of fixes bound it).
        let (mut k, mut mid) = (recs.len(), None);
        rts_smooth(&recs, f.last_record_covariance(), |e| {
            k -= 1;
            let fwd = recs[k].p_post_diag;
            assert_eq!(recs[k].t, e.t);
            for i in 0..NX {
                assert!(
                    e.p_diag[i] <= fwd[i] && e.p_diag[i] >= 0.0,
                    "state {i} at {}: smoothed {} forward {}",
                    e.t,
                    e.p_diag[i],
                    fwd[i]
                );
            }
            if (100.0..160.0).contains(&e.t) {
                sm_err_max = sm_err_max.max(err(e.nav.lat, e.nav.lon));
            }
            if (e.t - 150.0).abs() < 0.05 {
                mid = Some((e.p_diag[I_POS].sqrt(), fwd[I_POS].sqrt()));
            }
        });
        let (sm_mid, fwd_mid) = mid.expect("a checkpoint at 150 s");
        assert!(
            sm_mid < 0.7 * fwd_mid,
            "σN at 150 s: smoothed {sm_mid} forward {fwd_mid}"
        );
        assert!(fwd_err_max > 0.2, "forward drift {fwd_err_max}");
        assert!(
            sm_err_max < 0.5 * fwd_err_max,
            "smoothed {sm_err_max} forward {fwd_err_max}"
        );
    }

    /// A tilt levelled from a biased accelerometer: with the correlation
    /// the velocity-error rate it leaves, `φ × f_n − Ĉ_bn δb_a` (horizontal),
    /// has zero variance (tilt and bias cancel in level motion); with
    /// independent priors it would be 2 (σ_ba/g)² g². The joint
    /// covariance stays positive semidefinite, and a tilt σ below σ_ba/g
    /// scales the correlation down instead of breaking it.
    #[test]
    fn tilt_from_force_cancels_the_bias_in_the_force() {
        for yaw in [0.0, 0.5, 2.0, -2.5] {
            let nav = NavState {
                q_bn: q_bn_from_rpy(&Vec3::new(0.01, -0.02, yaw)),
                lat: LAT,
                h: H,
                ..Default::default()
            };
            let g = 9.806_65;
            let mut std = std0();
            std.att = Vec3::new(0.02 / g, 0.02 / g, 0.03);
            let e = Eskf::new(config(), nav, ImuErrors::default(), &std);
            let combo = |p: &Cov| {
                // Rows: g φ_x − u_E, g φ_y + u_N, u = Ĉ_bn δb_a.
                let c = nav.c_bn();
                let mut h = SMatrix::<f64, 2, NX>::zeros();
                h[(0, I_ATT)] = g;
                h[(1, I_ATT + 1)] = g;
                for k in 0..3 {
                    h[(0, I_BA + k)] = -c[(1, k)];
                    h[(1, I_BA + k)] = c[(0, k)];
                }
                h * p * h.transpose()
            };
            let before = combo(&e.p);
            assert!((before[(0, 0)] - 2.0 * 0.02f64.powi(2)).abs() < 1e-9);
            let e = e.with_tilt_from_force();
            let after = combo(&e.p);
            assert!(
                after[(0, 0)].abs() < 1e-6 * 4e-4 && after[(1, 1)].abs() < 1e-6 * 4e-4,
                "{after}"
            );
            assert!(e.p.cholesky().is_some() || e.p.symmetric_eigenvalues().min() > -1e-12);
            // Tilt σ half the bias share: correlation halved, still PSD.
            std.att = Vec3::new(0.01 / g, 0.01 / g, 0.03);
            let e = Eskf::new(config(), nav, ImuErrors::default(), &std).with_tilt_from_force();
            assert!(e.p.symmetric_eigenvalues().min() > -1e-12);
        }
    }
}
