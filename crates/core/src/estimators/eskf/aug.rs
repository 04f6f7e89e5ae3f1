//! Augmented error states of the ESKF, off by default (then nothing of this
//! module runs and every output is bit-identical to the 21-state filter).
//!
//! Eight states after the 21 of [`super::NX`], kept outside the 21×21
//! covariance so the per-sample cost of the plain filter does not change:
//! `P = [[P_xx, P_xa], [P_xaᵀ, P_aa]]`, with `P_xx` the filter's own `Cov`.
//! The model has no coupling from these states into the INS error dynamics
//! (`F = blockdiag(F_x, F_a)`), so propagation is `P_xa ← Φ_x P_xa Φ_aᵀ`,
//! `P_aa ← Φ_a P_aa Φ_aᵀ + Q_a` (a 21×4 sparse product per sample); updates
//! are done jointly on the 25×25 matrix (GNSS and constraint rates only).
//!
//! * `b` (3, NED [m]): first-order Gauss–Markov GNSS position error
//!   (Groves 2nd ed. §14.3.2 / Brown & Hwang 4th ed. §4.2):
//!   `ḃ = −b/τ + w`, PSD `2σ²/τ`, discretised exactly: `Φ = e^{−dt/τ}`,
//!   `Q_d = σ²(1 − e^{−2dt/τ})`. Measurement `z = p_ant + b + v` (H = +I).
//!   The white part of R is then `σ_fix² − σ_b²` per axis (the receiver's
//!   reported σ covers both parts), floored at `(σ_fix/4)²` so a fix whose
//!   reported σ is smaller than σ_b still has a positive white part (a
//!   numerical guard, not a tuning: it only acts when the configured σ_b
//!   exceeds ~97 % of the fix's own σ).
//! * `τ` (1, [s]): IMU–GNSS time offset with the convention of
//!   `[input] imu_time_offset`: true (GNSS) time = IMU stamp + τ. A fix
//!   applied at filter (IMU-stamp) time `t` is therefore valid at filter time
//!   `t − τ`: `ẑ_pos = p̂_ant − v_ant τ̂`, `ẑ_vel = v̂_ant − a_n τ̂`, so
//!   `H_τ = −v_ant` (position; the velocity's `−a_n` is not used, see
//!   `Eskf::gnss_update`). Random walk with
//!   PSD `q_τ` (0: a constant). For `τ̂ > 0` the prediction is not
//!   extrapolated but taken from the last [`HIST`] IMU-rate velocities:
//!   `ẑ_pos = p̂_ant − ∫_{t−τ̂}^{t} v dt`, `ẑ_vel = v̂_ant − (v(t) − v(t−τ̂))`
//!   (antenna velocities; differences of the uncorrected history, so later feedback cancels), which
//!   stays exact through a turn's onset where `v τ̂`, `a τ̂` do not; a fix valid
//!   after the filter time (`τ̂ < 0`) is extrapolated to first order.
//!
//! * `s` (1): odometer scale-factor error, a random walk with PSD
//!   `scale_rw_psd` from the odometer configuration (active only when the
//!   filter has odometer aiding, [`crate::measurements::odometer`]).
//!
//! * `m` (3): the non-holonomic constraint's systematic terms
//!   ([`NhcMountStates`]): the pitch `θ_m` and yaw `ψ_m` of the vehicle
//!   frame against the IMU body frame [rad] and the IMU's forward offset
//!   `l_x` from the non-holonomic point (the rear, non-steered axle) [m],
//!   random constants. The constrained velocity is the vehicle-frame
//!   velocity of that point, `u_v = (I − [m×]) (v_b + ω_b × l)`,
//!   `m = (0, θ_m, ψ_m)`, `l = (l_x, 0, 0)`: to first order
//!   `u_y = v_y + ω_z l_x − ψ_m v_x`, `u_z = v_z − ω_y l_x + θ_m v_x`
//!   (Groves 2nd ed. §16.2.2 on the vehicle frame; Shin 2005, "Estimation
//!   techniques for low-cost inertial navigation", §4.3.3 on the lever
//!   arm of the non-holonomic point). Active only with NHC.
//!
//! Error signs follow the position state: `δa = â − a`, feedback `â ← â − δa`.

use super::{FSparse, UpdateReject, NX};
use crate::measurements::odometer::OdometerConfig;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::Vec3;
use nalgebra::{SMatrix, SVector};

/// Number of augmented states.
pub const NA: usize = 8;
/// Full dimension with the augmented states.
pub const NF: usize = NX + NA;
/// Index (within the augmented states) of the GNSS position error `b`, NED.
pub const IA_GNSS: usize = 0;
/// Index (within the augmented states) of the time offset `τ`.
pub const IA_TAU: usize = 3;
/// Index (within the augmented states) of the odometer scale-factor error
/// `s` (measured speed = (1 + s) · true speed; [`crate::measurements::odometer`]).
pub const IA_ODO: usize = 4;
/// Index (within the augmented states) of the NHC mounting pitch `θ_m`,
/// followed by the yaw `ψ_m` and the forward lever `l_x` ([`NhcMountStates`]).
pub const IA_MNT: usize = 5;

/// Systematic terms of the non-holonomic constraint as states (module doc):
/// the mounting pitch and yaw of the IMU in the vehicle and its forward
/// offset from the non-holonomic point. Without them the NHC treats these
/// constant violations as white noise, repeated at every update, and pulls
/// the heading by the mounting yaw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NhcMountStates {
    /// Initial estimate: mounting pitch [rad], yaw [rad], forward offset
    /// from the non-holonomic point [m] (finite).
    pub initial: Vec3,
    /// Their initial 1-σ, same order and units (> 0).
    pub std: Vec3,
}

impl NhcMountStates {
    /// Zero initial estimate with the angle and lever σ given.
    pub fn prior(angle_std_rad: f64, lever_std_m: f64) -> Self {
        NhcMountStates {
            initial: Vec3::zeros(),
            std: Vec3::new(angle_std_rad, angle_std_rad, lever_std_m),
        }
    }
}

/// First-order Gauss–Markov GNSS position-error states.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssErrorStates {
    /// Correlation time τ [s] (> 0).
    pub tau_s: f64,
    /// Steady-state σ per NED axis [m] (≥ 0; also the initial σ).
    pub sigma_m: Vec3,
    /// Schmidt–Kalman "consider" states: `b` enters the covariance, the
    /// innovation covariance and the gain of the other states, but is never
    /// estimated (its gain rows are zero, `b̂ ≡ 0`, `P_bb` only propagates).
    /// See [`crate::kalman::update_joseph_masked`].
    pub consider: bool,
}

/// IMU–GNSS time-offset state (convention: true time = IMU stamp + τ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeOffsetState {
    /// Initial estimate [s] (on top of any offset already applied to the stamps).
    pub initial_s: f64,
    /// Initial 1-σ [s] (> 0).
    pub std_s: f64,
    /// Random-walk PSD [s²/s] (0: a constant offset).
    pub rw_psd: f64,
    /// Schmidt–Kalman "consider" state (as [`GnssErrorStates::consider`]):
    /// τ is not estimated (τ̂ stays `initial_s`), but its σ enters the
    /// innovation covariance (`H_τ = −v_ant`: a position error `v τ` that
    /// stays as long as the speed does) and the gain of the other states.
    /// For an offset already applied to the stamps with an uncertainty:
    /// the σ then covers what the remaining error does to the solution.
    pub consider: bool,
}

/// Which augmented states to estimate ([`super::Eskf::with_augmented_states`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AugmentedStates {
    pub gnss_error: Option<GnssErrorStates>,
    pub time_offset: Option<TimeOffsetState>,
    /// NHC mounting states (used only when the filter has NHC).
    pub nhc_mount: Option<NhcMountStates>,
}

impl AugmentedStates {
    /// Nothing augmented (the default): the 21-state filter.
    pub fn is_off(&self) -> bool {
        self.gnss_error.is_none() && self.time_offset.is_none() && self.nhc_mount.is_none()
    }
}

/// Estimates of the augmented states.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AugmentedEstimate {
    /// GNSS position error, NED [m], and its 1-σ (zero when not estimated).
    pub gnss_error_n: Vec3,
    pub gnss_error_std: Vec3,
    /// Time offset [s] and its 1-σ (zero when not estimated).
    pub time_offset_s: f64,
    pub time_offset_std_s: f64,
    /// Odometer scale-factor error (fraction) and its 1-σ (zero when no
    /// odometer aiding).
    pub odometer_scale: f64,
    pub odometer_scale_std: f64,
    /// NHC mounting pitch, yaw [rad] and forward lever [m] with their 1-σ
    /// (zero when not estimated).
    pub nhc_mount: Vec3,
    pub nhc_mount_std: Vec3,
}

/// Why [`super::Eskf::with_augmented_states`] refused a configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AugConfigError {
    /// GNSS error states: need τ > 0 and finite σ ≥ 0.
    GnssError,
    /// Time-offset state: need finite initial value, σ > 0, PSD ≥ 0.
    TimeOffset,
    /// Odometer: see [`OdometerConfig::is_valid`].
    Odometer,
    /// NHC mounting states: need finite σ > 0.
    NhcMount,
    /// The sensitivity covariance follows the 21-state (or augmented)
    /// update only, not the joint update of tight coupling.
    TightCoupling,
}

impl core::fmt::Display for AugConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            AugConfigError::GnssError => {
                write!(
                    f,
                    "GNSS error states: need tau_s > 0 and finite sigma_m >= 0"
                )
            }
            AugConfigError::TightCoupling => write!(
                f,
                "sensitivity covariance: not available with tight coupling"
            ),
            AugConfigError::TimeOffset => write!(
                f,
                "time-offset state: need a finite initial value, std > 0 and a random-walk PSD >= 0"
            ),
            AugConfigError::NhcMount => write!(
                f,
                "NHC mounting states: need finite initial values and sigma > 0"
            ),
            AugConfigError::Odometer => write!(
                f,
                "odometer: need a finite lever arm, sigma > 0, scale std > 0, scale PSD >= 0, \
                 NHC sigma > 0 and max_age_s > 0"
            ),
        }
    }
}

/// IMU-rate velocity history for the time-offset prediction (samples; at
/// 200 Hz 1.3 s, beyond which the rest of τ̂ is extrapolated).
pub const HIST: usize = 256;

/// Augmented-state block of the smoother checkpoint ([`super::SmootherRecord`]).
#[derive(Clone, Copy, Debug)]
pub struct AugSmootherRecord {
    /// Augmented error estimates fed back at this checkpoint.
    pub dx_fed_back: SVector<f64, NA>,
    /// Blocks of the full smoother gain `A` other than the 21×21 one.
    pub gain_xa: SMatrix<f64, NX, NA>,
    pub gain_ax: SMatrix<f64, NA, NX>,
    pub gain_aa: SMatrix<f64, NA, NA>,
    /// Blocks of the joint `B_{k−1}` (Joseph form, [`super::rts_smooth`])
    /// other than the 21×21 one (which is `p_base_prev`).
    pub base_xa: SMatrix<f64, NX, NA>,
    pub base_aa: SMatrix<f64, NA, NA>,
    /// The filtered covariance's augmented blocks at this checkpoint (the
    /// smoothed covariance starts from them at the last one).
    pub post_xa: SMatrix<f64, NX, NA>,
    pub post_aa: SMatrix<f64, NA, NA>,
}

impl AugSmootherRecord {
    /// The joint smoother gain `A` with `gain_xx` as its 21×21 block.
    pub(super) fn gain_full(&self, gain_xx: &SMatrix<f64, NX, NX>) -> FullCov {
        join(gain_xx, &self.gain_xa, &self.gain_ax, &self.gain_aa)
    }
    /// The joint `B` with `base_xx` as its 21×21 block.
    pub(super) fn base_full(&self, base_xx: &SMatrix<f64, NX, NX>) -> FullCov {
        join(
            base_xx,
            &self.base_xa,
            &self.base_xa.transpose(),
            &self.base_aa,
        )
    }
    /// The joint filtered covariance with `p_xx` as its 21×21 block.
    pub(super) fn post_full(&self, p_xx: &SMatrix<f64, NX, NX>) -> FullCov {
        join(
            p_xx,
            &self.post_xa,
            &self.post_xa.transpose(),
            &self.post_aa,
        )
    }
}

/// `[[xx, xa], [ax, aa]]`.
fn join(
    xx: &SMatrix<f64, NX, NX>,
    xa: &SMatrix<f64, NX, NA>,
    ax: &SMatrix<f64, NA, NX>,
    aa: &SMatrix<f64, NA, NA>,
) -> FullCov {
    let mut f = FullCov::zeros();
    f.fixed_view_mut::<NX, NX>(0, 0).copy_from(xx);
    f.fixed_view_mut::<NX, NA>(0, NX).copy_from(xa);
    f.fixed_view_mut::<NA, NX>(NX, 0).copy_from(ax);
    f.fixed_view_mut::<NA, NA>(NX, NX).copy_from(aa);
    f
}

pub(super) type FullCov = SMatrix<f64, NF, NF>;

/// The augmented part of the filter (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub(super) struct Aug {
    pub(super) cfg: AugmentedStates,
    /// Nominal values `b̂` [m], `τ̂` [s].
    pub(super) x: SVector<f64, NA>,
    pub(super) p_xa: SMatrix<f64, NX, NA>,
    pub(super) p_aa: SMatrix<f64, NA, NA>,
    /// −1/τ per state (0: random walk or inactive).
    beta: SVector<f64, NA>,
    /// Steady-state variance of the GM states; random-walk PSD of τ.
    var: SVector<f64, NA>,
    active: [bool; NA],
    /// Gain mask over the joint state: 0 for consider states, 1 otherwise
    /// (`None`: no consider state, the plain Joseph update).
    pub(super) gain_mask: Option<SVector<f64, NF>>,
    // Smoother bookkeeping (as the filter's `rec_*`).
    pub(super) rec_phi: SVector<f64, NA>,
    pub(super) rec_p_post: (SMatrix<f64, NX, NA>, SMatrix<f64, NA, NA>),
    pub(super) rec_p_prior: Option<(SMatrix<f64, NX, NA>, SMatrix<f64, NA, NA>)>,
    pub(super) rec_dx: SVector<f64, NA>,
    /// Ring buffer of (time [s], antenna velocity NED [m/s]), newest at `head − 1`.
    hist_t: [f64; HIST],
    hist_v: [Vec3; HIST],
    hist_head: usize,
    hist_len: usize,
}

impl Aug {
    /// `odo`: the odometer configuration (activates the scale state).
    pub(super) fn new(
        cfg: AugmentedStates,
        odo: Option<&OdometerConfig>,
    ) -> Result<Self, AugConfigError> {
        let mut x = SVector::<f64, NA>::zeros();
        let mut p_aa = SMatrix::<f64, NA, NA>::zeros();
        let mut beta = SVector::<f64, NA>::zeros();
        let mut var = SVector::<f64, NA>::zeros();
        let mut active = [false; NA];
        let mut gain_mask = None;
        if let Some(g) = cfg.gnss_error {
            let ok = g.tau_s.is_finite()
                && g.tau_s > 0.0
                && g.sigma_m.iter().all(|s| s.is_finite() && *s >= 0.0);
            if !ok {
                return Err(AugConfigError::GnssError);
            }
            for k in 0..3 {
                beta[IA_GNSS + k] = -1.0 / g.tau_s;
                var[IA_GNSS + k] = g.sigma_m[k] * g.sigma_m[k];
                p_aa[(IA_GNSS + k, IA_GNSS + k)] = var[IA_GNSS + k];
                active[IA_GNSS + k] = true;
            }
            if g.consider {
                let mut m = SVector::<f64, NF>::repeat(1.0);
                for k in 0..3 {
                    m[NX + IA_GNSS + k] = 0.0;
                }
                gain_mask = Some(m);
            }
        }
        if let Some(t) = cfg.time_offset {
            let ok = t.initial_s.is_finite()
                && t.std_s.is_finite()
                && t.std_s > 0.0
                && t.rw_psd.is_finite()
                && t.rw_psd >= 0.0;
            if !ok {
                return Err(AugConfigError::TimeOffset);
            }
            x[IA_TAU] = t.initial_s;
            var[IA_TAU] = t.rw_psd;
            p_aa[(IA_TAU, IA_TAU)] = t.std_s * t.std_s;
            active[IA_TAU] = true;
            if t.consider {
                gain_mask.get_or_insert_with(|| SVector::<f64, NF>::repeat(1.0))[NX + IA_TAU] = 0.0;
            }
        }
        if let Some(m) = cfg.nhc_mount {
            let ok = m.std.iter().all(|s| s.is_finite() && *s > 0.0)
                && m.initial.iter().all(|x| x.is_finite());
            if !ok {
                return Err(AugConfigError::NhcMount);
            }
            for k in 0..3 {
                x[IA_MNT + k] = m.initial[k];
                p_aa[(IA_MNT + k, IA_MNT + k)] = m.std[k] * m.std[k];
                active[IA_MNT + k] = true;
            }
        }
        if let Some(o) = odo {
            if !o.is_valid() {
                return Err(AugConfigError::Odometer);
            }
            var[IA_ODO] = o.scale_rw_psd;
            p_aa[(IA_ODO, IA_ODO)] = o.scale_std * o.scale_std;
            active[IA_ODO] = true;
        }
        Ok(Aug {
            cfg,
            x,
            p_xa: SMatrix::zeros(),
            p_aa,
            beta,
            var,
            active,
            gain_mask,
            rec_phi: SVector::repeat(1.0),
            rec_p_post: (SMatrix::zeros(), p_aa),
            rec_p_prior: None,
            rec_dx: SVector::zeros(),
            hist_t: [0.0; HIST],
            hist_v: [Vec3::zeros(); HIST],
            hist_head: 0,
            hist_len: 0,
        })
    }

    /// Whether the time offset is estimated.
    pub(super) fn has_time_offset(&self) -> bool {
        self.cfg.time_offset.is_some()
    }

    /// Whether the NHC mounting states are estimated.
    pub(super) fn has_nhc_mount(&self) -> bool {
        self.cfg.nhc_mount.is_some()
    }

    /// Whether the time offset is a consider state (never estimated).
    pub(super) fn time_offset_considered(&self) -> bool {
        self.cfg.time_offset.is_some_and(|t| t.consider)
    }

    /// Record the antenna velocity `v_n` at time `t` (after each propagation).
    pub(super) fn push_history(&mut self, t: f64, v_n: Vec3) {
        self.hist_t[self.hist_head] = t;
        self.hist_v[self.hist_head] = v_n;
        self.hist_head = (self.hist_head + 1) % HIST;
        self.hist_len = (self.hist_len + 1).min(HIST);
    }

    /// `(∫_{t−τ}^{t} v dt, v(t) − v(t−τ))` from the history (trapezoid,
    /// linear interpolation), `t` the newest entry, for `τ ≥ 0`; the part of
    /// τ older than the history is extrapolated with the oldest velocity.
    /// Zero without history.
    pub(super) fn shift(&self, tau: f64) -> (Vec3, Vec3) {
        if self.hist_len == 0 || tau <= 0.0 {
            return (Vec3::zeros(), Vec3::zeros());
        }
        let at = |i: usize| {
            let k = (self.hist_head + HIST - 1 - i) % HIST;
            (self.hist_t[k], self.hist_v[k])
        };
        let (t_now, v_now) = at(0);
        let t_end = t_now - tau;
        let mut dp = Vec3::zeros();
        let (mut t1, mut v1) = (t_now, v_now);
        for i in 1..self.hist_len {
            let (t0, v0) = at(i);
            if t0 <= t_end {
                let w = if t1 > t0 {
                    (t1 - t_end) / (t1 - t0)
                } else {
                    0.0
                };
                let v_end = v1 + (v0 - v1) * w;
                dp += (v1 + v_end) * (0.5 * (t1 - t_end));
                return (dp, v_now - v_end);
            }
            dp += (v1 + v0) * (0.5 * (t1 - t0));
            (t1, v1) = (t0, v0);
        }
        dp += v1 * (t1 - t_end);
        (dp, v_now - v1)
    }

    /// GM σ per NED axis (zero when the GNSS error states are off).
    pub(super) fn gnss_sigma(&self) -> Vec3 {
        self.cfg.gnss_error.map_or(Vec3::zeros(), |g| g.sigma_m)
    }

    pub(super) fn has_gnss_error(&self) -> bool {
        self.cfg.gnss_error.is_some()
    }

    /// Propagate over `dt` with the filter's current `F` (`fs`, already set
    /// for this interval): `P_xa ← (I + F dt) P_xa Φ_a`, `P_aa ← Φ_a P_aa Φ_a + Q_a`.
    pub(super) fn propagate(&mut self, fs: &FSparse, dt: f64) {
        let phi = SVector::<f64, NA>::from_fn(|i, _| {
            if self.beta[i] != 0.0 {
                (self.beta[i] * dt).exp()
            } else {
                1.0
            }
        });
        let fp = fs.f_times(&self.p_xa);
        self.p_xa += fp * dt;
        for j in 0..NA {
            for i in 0..NX {
                self.p_xa[(i, j)] *= phi[j];
            }
            for i in 0..NA {
                self.p_aa[(i, j)] *= phi[i] * phi[j];
            }
        }
        for i in 0..NA {
            if !self.active[i] {
                continue;
            }
            self.p_aa[(i, i)] += if self.beta[i] != 0.0 {
                self.var[i] * (1.0 - phi[i] * phi[i])
            } else {
                self.var[i] * dt
            };
        }
        self.rec_phi.component_mul_assign(&phi);
    }

    /// The joint covariance with the filter's `p`.
    pub(super) fn full(&self, p: &SMatrix<f64, NX, NX>) -> FullCov {
        join(p, &self.p_xa, &self.p_xa.transpose(), &self.p_aa)
    }

    /// Split the joint covariance back (symmetrising the cross block).
    pub(super) fn split(&mut self, f: &FullCov, p: &mut SMatrix<f64, NX, NX>) {
        p.copy_from(&f.fixed_view::<NX, NX>(0, 0));
        self.p_xa =
            (f.fixed_view::<NX, NA>(0, NX) + f.fixed_view::<NA, NX>(NX, 0).transpose()) * 0.5;
        let aa = f.fixed_view::<NA, NA>(NX, NX);
        self.p_aa = (aa + aa.transpose()) * 0.5;
    }

    /// Feed back the augmented error estimate.
    pub(super) fn correct(&mut self, dxa: &SVector<f64, NA>) {
        self.x -= dxa;
        self.rec_dx += dxa;
    }

    pub(super) fn estimate(&self) -> AugmentedEstimate {
        let sd = |i: usize| self.p_aa[(i, i)].max(0.0).sqrt();
        AugmentedEstimate {
            gnss_error_n: self.x.fixed_rows::<3>(IA_GNSS).into(),
            gnss_error_std: Vec3::new(sd(IA_GNSS), sd(IA_GNSS + 1), sd(IA_GNSS + 2)),
            time_offset_s: self.x[IA_TAU],
            time_offset_std_s: sd(IA_TAU),
            odometer_scale: self.x[IA_ODO],
            odometer_scale_std: sd(IA_ODO),
            nhc_mount: self.x.fixed_rows::<3>(IA_MNT).into(),
            nhc_mount_std: Vec3::new(sd(IA_MNT), sd(IA_MNT + 1), sd(IA_MNT + 2)),
        }
    }

    /// Smoother gain over the joint state, `A = P⁺ Φᵀ (P⁻)⁻¹`, and the
    /// joint `B` of [`super::rts_smooth`] ([`super::smoother_base`]), from
    /// the filter's blocks (`phi_t_x`: Φ_xᵀ accumulated since the last
    /// checkpoint). Inactive states have zero variance and no correlation:
    /// a unit variance in P⁻ makes P⁻ invertible for the gain without
    /// changing the other rows. A zero gain when P⁻ is not positive definite.
    pub(super) fn smoother_gain_base(
        &self,
        p_post_x: &SMatrix<f64, NX, NX>,
        phi_t_x: &SMatrix<f64, NX, NX>,
        p_prior_x: &SMatrix<f64, NX, NX>,
    ) -> (FullCov, FullCov) {
        let (xa, aa) = self.rec_p_post;
        let post = join(p_post_x, &xa, &xa.transpose(), &aa);
        let (pxa, paa) = self.rec_p_prior.unwrap_or((self.p_xa, self.p_aa));
        let prior = join(p_prior_x, &pxa, &pxa.transpose(), &paa);
        // Φ = blockdiag(Φ_x, diag(φ_a)).
        let mut phi = FullCov::zeros();
        phi.fixed_view_mut::<NX, NX>(0, 0)
            .copy_from(&phi_t_x.transpose());
        for i in 0..NA {
            phi[(NX + i, NX + i)] = self.rec_phi[i];
        }
        let mut prior_inv = prior;
        for i in 0..NA {
            if !self.active[i] {
                prior_inv[(NX + i, NX + i)] = 1.0;
            }
        }
        let b = phi * post;
        let gain = prior_inv
            .cholesky()
            .map_or_else(FullCov::zeros, |ch| ch.solve(&b).transpose());
        let base = super::smoother_base(&gain, &phi, &post, &prior);
        (gain, base)
    }

    /// Start a new smoother interval after a checkpoint.
    pub(super) fn reset_record(&mut self) {
        self.rec_p_post = (self.p_xa, self.p_aa);
        self.rec_phi = SVector::repeat(1.0);
        self.rec_dx = SVector::zeros();
        self.rec_p_prior = None;
    }
}

/// Joseph update with the χ² gate and de-weighting of [`super::Eskf::update`],
/// for any state dimension; with `mask` the Schmidt–Kalman update
/// ([`crate::kalman::update_joseph_masked`]). `Ok((nis, deweighted))`; `Err((reject, nis))`.
/// With `gain`, the gain finally applied is written there.
#[allow(clippy::too_many_arguments)]
pub(super) fn gated_update<const N: usize, const M: usize>(
    dx: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    dz: &SVector<f64, M>,
    gate: Option<f64>,
    deweight_factor: f64,
    mask: Option<&SVector<f64, N>>,
    mut gain: Option<&mut SMatrix<f64, N, M>>,
) -> Result<(f64, bool), (UpdateReject, f64)> {
    let mut upd =
        |dx: &mut SVector<f64, N>, p: &mut SMatrix<f64, N, N>, r: &SMatrix<f64, M, M>, g| {
            crate::kalman::update_joseph_gain(dx, p, h, r, dz, g, mask, gain.as_deref_mut())
        };
    let mut info = upd(dx, p, r, gate);
    if info.singular() || !info.nis.is_finite() {
        return Err((UpdateReject::Singular, info.nis));
    }
    if info.accepted {
        return Ok((info.nis, false));
    }
    // Gated: de-weight or reject.
    let g = gate.unwrap_or(f64::INFINITY);
    if info.nis > g * deweight_factor {
        return Err((UpdateReject::Gate, info.nis));
    }
    let rs = r * (info.nis / g);
    let nis = info.nis;
    info = upd(dx, p, &rs, None);
    if !info.accepted {
        return Err((UpdateReject::Singular, nis));
    }
    Ok((nis, true))
}
