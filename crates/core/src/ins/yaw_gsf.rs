//! In-motion yaw alignment without a magnetometer: a Gaussian-sum filter (GSF)
//! over yaw hypotheses, fed by IMU increments and GNSS NED velocity.
//!
//! The idea is PX4 EKF2's `EKFGSF_yaw` (P. Riseborough, PX4/ecl PR #766, "EKF: Add
//! Emergency yaw recovery using EKF-GSF estimator"): a bank of [`GSF_MODELS`]
//! three-state EKFs `[v_N, v_E, ψ]`, started at `ψ_k = k·2π/N`, each
//! predicting horizontal velocity from the specific force rotated with its own
//! yaw and updated with the GNSS velocity; the model weights follow the
//! Gaussian-sum rule `w_k ← w_k · N(ν_k; 0, S_k) / Σ` (Alspach & Sorenson 1972;
//! Groves 2nd ed. §3.4.5 on multiple-hypothesis filtering) and the composite yaw
//! is the weighted circular mean with the mixture variance
//! `σ² = Σ w_k (P_ψψ,k + (ψ_k − ψ̄)²)`.
//!
//! **Formulation used here** (differs from PX4, which runs one AHRS per model):
//! one shared attitude `c_ba` from the body frame to an *azimuth-free* frame `a`
//! (z axis down, along NED "down"; x/y at an unknown azimuth) is integrated from
//! the gyro increments. Model `k` states that NED is `a` rotated about the
//! vertical by `ψ_k`: `c_bn,k = R_z(ψ_k) c_ba`. The body yaw of model `k` is the
//! yaw of `c_bn,k`; rotating about the NED vertical by δ changes the ZYX yaw by
//! exactly δ, so the model yaw σ is the body yaw σ. Velocity prediction
//! (Groves eq. 5.54 without Coriolis/transport rate, which are < 3 mm/s² at
//! 20 m/s and are covered by the accelerometer-bias noise):
//! `v_h += R_z(ψ_k) (c_ba Δv_b)_h`, `F = [[1,0,−Δv_E],[0,1,Δv_N],[0,0,1]]`.
//!
//! **Tilt** is a 2-state Kalman filter on the horizontal attitude error φ of
//! `c_ba` (Groves §14.2 psi-angle model, `ĉ_ba = (I − [φ×]) c_ba`), started from
//! the first sample's gravity direction (levelling, Groves eq. 5.101) with the σ
//! of an unknown platform acceleration. At each GNSS epoch the mean specific
//! force over the interval, `f̄_a = Σ c_ba Δv_b / T`, is compared with the
//! platform acceleration from the GNSS velocity difference
//! `a_n = (v_n,k − v_n,k−1)/Δt` minus gravity (this is the centripetal and
//! longitudinal compensation, so no static window is needed). `a_n` enters the
//! `a` frame through the mixture of yaw hypotheses: its mean `ρ R_z(−ψ̄) a_n`
//! (ρ = E cos(ψ − ψ̄)) and a measurement variance `|a_h|²(1 − ρ²)/2` per axis,
//! so while yaw is unknown the tilt update honestly says "gravity and
//! acceleration are not separable". Before the first GNSS velocity the tilt
//! is corrected toward −g once per second with the platform-acceleration σ.
//!
//! **Gyro bias** is not estimated. The caller may give one (e.g. from a static
//! window, [`YawGsf::set_gyro_bias`]); the residual σ `gyro_bias_std` (which
//! should include the earth rate, ≤ 15°/h, also not modelled) makes the yaw
//! and tilt variance grow as `(σ_bg t)²` (process noise `2 σ_bg² t dt`, t since
//! start), which is conservative: the bank is an alignment aid for the first
//! minutes, to be handed over to the ESKF once [`YawEstimate::converged`].
//!
//! Frames and signs: body FRD, navigation NED; specific force `f_b` (a level
//! IMU at rest measures `f_b ≈ (0, 0, −g)`); `c_bn` maps body to NED
//! (`v_n = c_bn v_b`); angles in rad, yaw in (−π, π].
//! Nothing is allocated: fixed-size arrays and nalgebra static matrices.

use crate::attitude::{dcm_from_euler, euler_from_dcm, quat_from_euler, quat_from_rotvec};
use crate::attitude::{dcm_from_quat, quat_mul, quat_normalize, quat_rotate, quat_update};
use crate::attitude::{skew, wrap_pi};
use crate::ins::align::level;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::types::ImuSample;
use crate::{Mat3, Vec3};
use core::f64::consts::PI;
use nalgebra::{Matrix2, Quaternion, Vector2};

/// Number of yaw hypotheses. 12 models = 30° spacing; with the per-model prior
/// σ of half the spacing the sum of Gaussians is flat within a few % over the
/// circle, and each EKF starts within its small-angle region (≤ 15°).
pub const GSF_MODELS: usize = 12;

/// Lowest model weight kept after normalisation. A model knocked out by one
/// bad epoch (GNSS glitch) can regain the lead after a few consistent epochs;
/// its share in the mixture variance is ≤ N·1e-7·π² ≈ (0.2°)², far below
/// the convergence threshold.
const WEIGHT_FLOOR: f64 = 1e-7;

/// χ²(2) 0.999 quantile: tilt updates with a larger NIS (GNSS velocity
/// glitch, unmodelled shock) are skipped.
const TILT_GATE: f64 = 13.815_510_557_964_274;

/// Longest span [s] over which a GNSS velocity change counts as a seen
/// horizontal acceleration ([`YawEstimate::horizontal_accel_seen`]). Why:
/// yaw is observable from how the horizontal velocity *changed* while the
/// specific force was integrated, not from how fast; a 1 s difference
/// misses the slow manoeuvres of boats (≤ 0.5 m/s², 0 → 5 m/s in 10 s) and
/// walkers under consumer GNSS (5σ of a 1 s difference with 0.1 m/s
/// velocity noise is 0.7 m/s²). Over 10 s a consumer gyro's turn-on bias
/// (0.5°/s) has turned the frame by 5°, still inside the members'
/// small-angle region; longer spans would let the unestimated bias fake or
/// hide the change.
pub const ACCEL_SPAN_S: f64 = 10.0;
/// Stored past velocities for [`ACCEL_SPAN_S`] (one per ≥ 1 s).
const VEL_HISTORY: usize = 10;

/// Largest |t_gnss − t_imu| [s] accepted: the GNSS velocity is extrapolated
/// from the last IMU sample over this gap at most (events must come in time order).
const MAX_GNSS_IMU_GAP: f64 = 0.2;

/// Interval [s] of the uncompensated tilt updates before any GNSS velocity.
const UNAIDED_TILT_INTERVAL: f64 = 1.0;

/// Noise model and thresholds of [`YawGsf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GsfConfig {
    /// Gyro angle random walk [rad/√s].
    pub arw: f64,
    /// Accelerometer velocity random walk [m/s/√s].
    pub vrw: f64,
    /// Gyro bias subtracted from every increment [rad/s], body FRD.
    pub gyro_bias_b: Vec3,
    /// 1-σ of the gyro bias left after `gyro_bias_b`, per axis [rad/s]
    /// (include the earth rate, which is not modelled).
    pub gyro_bias_std: f64,
    /// 1-σ accelerometer bias per axis [m/s²]; floors the tilt σ at σ_ba/g.
    pub accel_bias_std: f64,
    /// 1-σ horizontal platform acceleration [m/s²] assumed when it is not known
    /// from GNSS (initial levelling, updates before the first GNSS velocity).
    pub platform_accel_std: f64,
    /// Gravity magnitude [m/s²].
    pub gravity: f64,
    /// Yaw σ [rad] below which the estimate is reported converged.
    pub converged_std: f64,
    /// A horizontal acceleration from GNSS counts as "seen" when it exceeds this
    /// many σ of its velocity-difference noise.
    pub accel_significance: f64,
}

impl GsfConfig {
    /// Industrial MEMS IMU (datasheet level, ADIS1646x/STIM-class order of
    /// magnitude): ARW 0.3°/√h, VRW 0.05 m/s/√h, residual gyro bias
    /// √(10² + 15²) ≈ 18°/h (in-run bias plus the unmodelled earth rate),
    /// accelerometer bias 3 mg.
    pub fn industrial_mems() -> Self {
        let deg = PI / 180.0;
        GsfConfig {
            arw: 0.3 * deg / 60.0,
            vrw: 0.05 / 60.0,
            gyro_bias_b: Vec3::zeros(),
            gyro_bias_std: (10.0f64.hypot(15.0)) * deg / 3600.0,
            accel_bias_std: 0.03,
            // Sustained (1 s mean) horizontal accelerations of pedestrians, boats
            // and road vehicles in normal use stay within ≈ 0.2 g.
            platform_accel_std: 2.0,
            gravity: 9.806_65,
            // Hand-over to the ESKF: at 3σ = 6° its small-angle error model
            // neglects 1 − cos 6° ≈ 0.55 % of the rotated specific force, the
            // size of a MEMS accelerometer scale-factor error.
            converged_std: 2.0 * deg,
            // 5σ: a 2-D false alarm from noise has probability e^(−12.5) ≈ 4e-6.
            accel_significance: 5.0,
        }
    }
}

impl Default for GsfConfig {
    fn default() -> Self {
        Self::industrial_mems()
    }
}

/// Composite yaw of the bank.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawEstimate {
    /// Body yaw (ZYX, FRD → NED) [rad], (−π, π].
    pub yaw: f64,
    /// 1-σ of `yaw` from the mixture [rad] (≈ 1.8 rad when nothing is known).
    pub std: f64,
    /// Roll, pitch (ZYX) [rad] of the shared tilt estimate.
    pub roll: f64,
    pub pitch: f64,
    /// `std < converged_std` and a significant horizontal acceleration was seen.
    pub converged: bool,
    /// Largest significant horizontal acceleration seen from GNSS [m/s²]
    /// (0 while none exceeded `accel_significance` σ): from consecutive
    /// velocities, or the mean over a velocity change within
    /// [`ACCEL_SPAN_S`] that exceeded `accel_significance` σ.
    pub horizontal_accel_seen: f64,
}

/// Rejected input (the filter state is left unchanged).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GsfError {
    /// An IMU sample with a NaN/infinite field or `dt ≤ 0`, at time `t`.
    BadImu { t: f64 },
    /// An IMU sample not later than the previous one.
    ImuTimeNotIncreasing { t: f64, last: f64 },
    /// A GNSS velocity with a NaN/infinite value or a std ≤ 0, at time `t`.
    BadGnssVelocity { t: f64 },
    /// A GNSS velocity more than 0.2 s from the last IMU sample or not later
    /// than the previous GNSS velocity.
    GnssTimeOutOfOrder { t: f64, t_imu: f64 },
}

impl core::fmt::Display for GsfError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            GsfError::BadImu { t } => {
                write!(f, "IMU sample at t = {t}: non-finite field or dt <= 0")
            }
            GsfError::ImuTimeNotIncreasing { t, last } => {
                write!(
                    f,
                    "IMU sample at t = {t} is not after the previous one ({last})"
                )
            }
            GsfError::BadGnssVelocity { t } => {
                write!(f, "GNSS velocity at t = {t}: non-finite value or std <= 0")
            }
            GsfError::GnssTimeOutOfOrder { t, t_imu } => write!(
                f,
                "GNSS velocity at t = {t} is out of order (last IMU sample t = {t_imu}); \
                 push events in time order"
            ),
        }
    }
}

/// One yaw hypothesis: horizontal NED velocity and the yaw offset ψ of
/// frame `a` from NED (`c_bn = R_z(ψ) c_ba`).
#[derive(Clone, Copy, Debug)]
struct Model {
    v: Vector2<f64>,
    psi: f64,
    p: Mat3,
}

/// Previous GNSS velocity epoch.
#[derive(Clone, Copy, Debug)]
struct GnssEpoch {
    t: f64,
    v_n: Vec3,
    std: Vec3,
}

/// Gaussian-sum yaw filter; see the module documentation.
#[derive(Clone, Debug)]
pub struct YawGsf {
    cfg: GsfConfig,
    /// Shared attitude body → azimuth-free frame `a` (Hamilton, scalar first).
    q_ba: Quaternion<f64>,
    /// Covariance of the horizontal tilt error φ of `c_ba` [rad²].
    p_tilt: Matrix2<f64>,
    initialised: bool,
    t0: f64,
    t_imu: f64,
    /// Last specific force in frame `a` [m/s²] (extrapolation to the GNSS time).
    f_a_last: Vec3,
    /// Σ c_ba Δv_b [m/s] and its time span [s] since the last tilt update.
    acc_dv_a: Vec3,
    acc_t: f64,
    last_gnss: Option<GnssEpoch>,
    /// Last GNSS interval [s] (1 s until two epochs are seen).
    gnss_interval: f64,
    models: [Model; GSF_MODELS],
    weights: [f64; GSF_MODELS],
    bank_started: bool,
    accel_seen: f64,
    /// GNSS velocities of the last [`ACCEL_SPAN_S`], one per ≥ 1 s (ring).
    vel_hist: [Option<GnssEpoch>; VEL_HISTORY],
    vel_hist_next: usize,
}

impl YawGsf {
    /// A filter waiting for its first IMU sample.
    pub fn new(cfg: GsfConfig) -> Self {
        let model = Model {
            v: Vector2::zeros(),
            psi: 0.0,
            p: Mat3::zeros(),
        };
        YawGsf {
            cfg,
            q_ba: Quaternion::identity(),
            p_tilt: Matrix2::zeros(),
            initialised: false,
            t0: 0.0,
            t_imu: 0.0,
            f_a_last: Vec3::zeros(),
            acc_dv_a: Vec3::zeros(),
            acc_t: 0.0,
            last_gnss: None,
            gnss_interval: 1.0,
            models: [model; GSF_MODELS],
            weights: [1.0 / GSF_MODELS as f64; GSF_MODELS],
            bank_started: false,
            accel_seen: 0.0,
            vel_hist: [None; VEL_HISTORY],
            vel_hist_next: 0,
        }
    }

    /// Set the gyro bias [rad/s] (body FRD) subtracted from every increment and
    /// the 1-σ [rad/s] of what is left (e.g. from a static window).
    pub fn set_gyro_bias(&mut self, gyro_bias_b: &Vec3, std: f64) {
        self.cfg.gyro_bias_b = *gyro_bias_b;
        self.cfg.gyro_bias_std = std;
    }

    /// Variance growth rate [rad²/s] of an attitude angle at time `t`: ARW
    /// plus the unestimated gyro bias, d/dt (σ_bg t)² = 2 σ_bg² t.
    fn attitude_q(&self, t: f64) -> f64 {
        self.cfg.arw * self.cfg.arw + 2.0 * self.cfg.gyro_bias_std.powi(2) * (t - self.t0).max(0.0)
    }

    /// Process one IMU sample: `dtheta_b` [rad] and `dvel_b` [m/s] increments
    /// over `dt` ending at `t`, body FRD, specific force (level at rest:
    /// `dvel_b ≈ (0, 0, −g dt)`).
    pub fn push_imu(&mut self, imu: &ImuSample) -> Result<(), GsfError> {
        let finite = imu.t.is_finite()
            && imu.dt.is_finite()
            && imu
                .dtheta_b
                .iter()
                .chain(imu.dvel_b.iter())
                .all(|v| v.is_finite());
        if !finite || imu.dt <= 0.0 {
            return Err(GsfError::BadImu { t: imu.t });
        }
        if !self.initialised {
            // Levelling from the first sample (Groves eq. 5.101); the unknown
            // platform acceleration sets the tilt σ.
            let (roll, pitch) = level(&(imu.dvel_b / imu.dt));
            self.q_ba = quat_from_euler(&Vec3::new(roll, pitch, 0.0));
            let s = self.cfg.platform_accel_std / self.cfg.gravity;
            self.p_tilt = Matrix2::identity() * (s * s);
            self.t0 = imu.t;
            self.t_imu = imu.t;
            self.initialised = true;
            return Ok(());
        }
        if imu.t <= self.t_imu {
            return Err(GsfError::ImuTimeNotIncreasing {
                t: imu.t,
                last: self.t_imu,
            });
        }
        let dt = imu.dt;
        let dth = imu.dtheta_b - self.cfg.gyro_bias_b * dt;
        // Velocity increment in frame `a` with the first-order rotation
        // correction (Groves eq. 5.97 without sculling).
        let dv_a = quat_rotate(&self.q_ba, &(imu.dvel_b + dth.cross(&imu.dvel_b) * 0.5));
        quat_update(&mut self.q_ba, &dth);
        self.t_imu = imu.t;
        self.f_a_last = dv_a / dt;
        self.acc_dv_a += dv_a;
        self.acc_t += dt;

        let q_att = self.attitude_q(imu.t) * dt;
        self.p_tilt += Matrix2::identity() * q_att;

        if self.bank_started {
            // Tilt error acts as a horizontal specific-force error g·φ that is
            // constant over a GNSS interval T: white noise of PSD (gφ)² T gives
            // the same velocity variance (gφT)² at the next epoch.
            let tilt_var = self.p_tilt[(0, 0)].max(self.p_tilt[(1, 1)]);
            let g2 = self.cfg.gravity * self.cfg.gravity;
            let q_v = (self.cfg.vrw.powi(2) + g2 * tilt_var * self.gnss_interval) * dt;
            for m in self.models.iter_mut() {
                let (s, c) = m.psi.sin_cos();
                let dn = c * dv_a.x - s * dv_a.y;
                let de = s * dv_a.x + c * dv_a.y;
                m.v += Vector2::new(dn, de);
                let mut f = Mat3::identity();
                f[(0, 2)] = -de;
                f[(1, 2)] = dn;
                m.p = f * m.p * f.transpose();
                m.p[(0, 0)] += q_v;
                m.p[(1, 1)] += q_v;
                m.p[(2, 2)] += q_att;
            }
        } else if self.last_gnss.is_none() && self.acc_t >= UNAIDED_TILT_INTERVAL {
            // No GNSS yet: correct toward gravity, platform acceleration unknown.
            let f_mean = self.acc_dv_a / self.acc_t;
            let f_exp = Vec3::new(0.0, 0.0, -self.cfg.gravity);
            let r = self.cfg.platform_accel_std.powi(2) + self.cfg.vrw.powi(2) / self.acc_t;
            self.tilt_update(&f_mean, &f_exp, r);
            self.acc_dv_a = Vec3::zeros();
            self.acc_t = 0.0;
        }
        Ok(())
    }

    /// Kalman update of the tilt error from a mean specific force `f_mean_a`
    /// against its expectation `f_exp_a` (frame `a`, m/s²) with per-axis
    /// variance `r` [m²/s⁴]. Residual `f̂ − f = −φ × f = [f×] φ`, horizontal
    /// rows and the two tilt columns; correction `c_ba ← exp([φ×]) ĉ_ba`.
    fn tilt_update(&mut self, f_mean_a: &Vec3, f_exp_a: &Vec3, r: f64) {
        let k3 = skew(f_exp_a);
        let h = Matrix2::new(k3[(0, 0)], k3[(0, 1)], k3[(1, 0)], k3[(1, 1)]);
        let nu = Vector2::new(f_mean_a.x - f_exp_a.x, f_mean_a.y - f_exp_a.y);
        let s = h * self.p_tilt * h.transpose() + Matrix2::identity() * r;
        let Some(s_inv) = s.try_inverse() else {
            return;
        };
        if (nu.transpose() * s_inv * nu)[0] > TILT_GATE {
            return;
        }
        let k = self.p_tilt * h.transpose() * s_inv;
        let phi = k * nu;
        let ikh = Matrix2::identity() - k * h;
        self.p_tilt = ikh * self.p_tilt * ikh.transpose() + k * k.transpose() * r;
        self.p_tilt = (self.p_tilt + self.p_tilt.transpose()) * 0.5;
        // An accelerometer bias looks like tilt and turns with the body: the
        // tilt σ cannot drop below σ_ba / g.
        let floor = (self.cfg.accel_bias_std / self.cfg.gravity).powi(2);
        for i in 0..2 {
            self.p_tilt[(i, i)] = self.p_tilt[(i, i)].max(floor);
        }
        let dq = quat_from_rotvec(&Vec3::new(phi.x, phi.y, 0.0));
        self.q_ba = quat_normalize(&quat_mul(&dq, &self.q_ba));
    }

    /// Circular mean ψ̄ of the model yaw offsets, ρ = E cos(ψ − ψ̄) (each model
    /// wrapped-Gaussian: E cos δ = cos δ_k e^(−P_ψψ/2)) and the mixture variance.
    fn mixture(&self) -> (f64, f64, f64) {
        let (mut sx, mut sy) = (0.0, 0.0);
        for (m, w) in self.models.iter().zip(self.weights.iter()) {
            let damp = (-0.5 * m.p[(2, 2)]).exp();
            sx += w * damp * m.psi.cos();
            sy += w * damp * m.psi.sin();
        }
        let mean = sy.atan2(sx);
        let rho = sx.hypot(sy);
        let var = self
            .models
            .iter()
            .zip(self.weights.iter())
            .map(|(m, w)| w * (m.p[(2, 2)] + wrap_pi(m.psi - mean).powi(2)))
            .sum();
        (mean, rho, var)
    }

    /// Process a GNSS velocity `v_n` [m/s] (NED) at time `t` with per-axis 1-σ
    /// `std_v_n` [m/s]. Only the horizontal part feeds the bank; the vertical
    /// part enters the platform acceleration of the tilt update.
    pub fn push_gnss_velocity(
        &mut self,
        t: f64,
        v_n: &Vec3,
        std_v_n: &Vec3,
    ) -> Result<(), GsfError> {
        let finite = t.is_finite() && v_n.iter().chain(std_v_n.iter()).all(|v| v.is_finite());
        if !finite || std_v_n.iter().any(|s| *s <= 0.0) {
            return Err(GsfError::BadGnssVelocity { t });
        }
        if !self.initialised {
            // Nothing to difference against: the interval would lack IMU data.
            return Ok(());
        }
        let dt_x = t - self.t_imu;
        let newer = self.last_gnss.is_none_or(|g| t > g.t);
        if dt_x.abs() > MAX_GNSS_IMU_GAP || !newer {
            return Err(GsfError::GnssTimeOutOfOrder {
                t,
                t_imu: self.t_imu,
            });
        }
        let (psi_mean, rho, _) = self.mixture();

        if let Some(prev) = self.last_gnss {
            let dt_g = t - prev.t;
            let a_n = (v_n - prev.v_n) / dt_g;
            // Per-axis variance of the horizontal acceleration from the difference.
            let var_a =
                (prev.std.x.powi(2) + prev.std.y.powi(2) + std_v_n.x.powi(2) + std_v_n.y.powi(2))
                    / (2.0 * dt_g * dt_g);
            let a_h = a_n.x.hypot(a_n.y);
            if a_h > self.cfg.accel_significance * var_a.sqrt() {
                self.accel_seen = self.accel_seen.max(a_h);
            }
            self.velocity_change_seen(t, v_n, std_v_n);
            if self.acc_t > 0.0 {
                let f_mean = self.acc_dv_a / self.acc_t;
                let (s, c) = psi_mean.sin_cos();
                // R_z(−ψ̄) a_n, shrunk by ρ: the mixture mean of a_n in frame `a`.
                let ax = rho * (c * a_n.x + s * a_n.y);
                let ay = rho * (-s * a_n.x + c * a_n.y);
                let f_exp = Vec3::new(ax, ay, a_n.z - self.cfg.gravity);
                let r =
                    var_a + self.cfg.vrw.powi(2) / self.acc_t + 0.5 * a_h * a_h * (1.0 - rho * rho);
                self.tilt_update(&f_mean, &f_exp, r);
            }
            self.gnss_interval = dt_g;
        }
        self.acc_dv_a = Vec3::zeros();
        self.acc_t = 0.0;

        let r = Matrix2::new(std_v_n.x.powi(2), 0.0, 0.0, std_v_n.y.powi(2));
        if !self.bank_started {
            // Prior σ = half the spacing: see GSF_MODELS.
            let sigma0 = PI / GSF_MODELS as f64;
            for (k, m) in self.models.iter_mut().enumerate() {
                m.v = Vector2::new(v_n.x, v_n.y);
                m.psi = wrap_pi(k as f64 * 2.0 * PI / GSF_MODELS as f64);
                m.p = Mat3::from_diagonal(&Vec3::new(r[(0, 0)], r[(1, 1)], sigma0 * sigma0));
            }
            self.weights = [1.0 / GSF_MODELS as f64; GSF_MODELS];
            self.bank_started = true;
        } else {
            self.update_bank(v_n, &r, dt_x);
        }
        let now = GnssEpoch {
            t,
            v_n: *v_n,
            std: *std_v_n,
        };
        self.last_gnss = Some(now);
        let prev = (self.vel_hist_next + VEL_HISTORY - 1) % VEL_HISTORY;
        if self.vel_hist[prev].is_none_or(|e| t - e.t >= 1.0 - 1e-6) {
            self.vel_hist[self.vel_hist_next] = Some(now);
            self.vel_hist_next = (self.vel_hist_next + 1) % VEL_HISTORY;
        }
        Ok(())
    }

    /// The horizontal velocity change against each stored velocity of the
    /// last [`ACCEL_SPAN_S`]: significant when it exceeds
    /// `accel_significance` σ of the difference (per-axis variance
    /// `(σ²_N,0 + σ²_E,0 + σ²_N,1 + σ²_E,1)/2`, as the 1 s test); counted as
    /// its mean acceleration.
    fn velocity_change_seen(&mut self, t: f64, v_n: &Vec3, std_v_n: &Vec3) {
        for e in self.vel_hist.iter().flatten() {
            let dt = t - e.t;
            if dt <= 0.0 || dt > ACCEL_SPAN_S + 1e-6 {
                continue;
            }
            let dv = (v_n - e.v_n).xy().norm();
            let var =
                (e.std.x.powi(2) + e.std.y.powi(2) + std_v_n.x.powi(2) + std_v_n.y.powi(2)) / 2.0;
            if dv > self.cfg.accel_significance * var.sqrt() {
                self.accel_seen = self.accel_seen.max(dv / dt);
            }
        }
    }

    /// EKF velocity update of every model and the Gaussian-sum weight update
    /// (log domain, normalised by the largest, floored at [`WEIGHT_FLOOR`]).
    fn update_bank(&mut self, v_n: &Vec3, r: &Matrix2<f64>, dt_x: f64) {
        let mut log_l = [0.0; GSF_MODELS];
        for (m, ll) in self.models.iter_mut().zip(log_l.iter_mut()) {
            let (s, c) = m.psi.sin_cos();
            // Predicted velocity at the GNSS time: extrapolated over dt_x.
            let fa = self.f_a_last;
            let pred = m.v + Vector2::new(c * fa.x - s * fa.y, s * fa.x + c * fa.y) * dt_x;
            let nu = Vector2::new(v_n.x, v_n.y) - pred;
            let p_vv = m.p.fixed_view::<2, 2>(0, 0).into_owned();
            let s_mat = p_vv + r;
            let Some(s_inv) = s_mat.try_inverse() else {
                *ll = f64::NEG_INFINITY;
                continue;
            };
            let p_xv = m.p.fixed_view::<3, 2>(0, 0).into_owned();
            let k = p_xv * s_inv;
            let dx = k * nu;
            m.v += Vector2::new(dx.x, dx.y);
            m.psi = wrap_pi(m.psi + dx.z);
            // Joseph form: (I − KH) P (I − KH)ᵀ + K R Kᵀ, H = [I₂ 0].
            let mut ikh = Mat3::identity();
            for i in 0..3 {
                for j in 0..2 {
                    ikh[(i, j)] -= k[(i, j)];
                }
            }
            m.p = ikh * m.p * ikh.transpose() + k * r * k.transpose();
            m.p = (m.p + m.p.transpose()) * 0.5;
            let nis = (nu.transpose() * s_inv * nu)[0];
            *ll = -0.5 * nis - 0.5 * s_mat.determinant().max(f64::MIN_POSITIVE).ln();
        }
        let mut lw = [0.0; GSF_MODELS];
        let mut best = f64::NEG_INFINITY;
        for i in 0..GSF_MODELS {
            lw[i] = self.weights[i].ln() + log_l[i];
            if lw[i].is_finite() {
                best = best.max(lw[i]);
            }
        }
        if !best.is_finite() {
            return;
        }
        let mut sum = 0.0;
        for (w, l) in self.weights.iter_mut().zip(lw.iter()) {
            *w = if l.is_finite() { (l - best).exp() } else { 0.0 };
            sum += *w;
        }
        let mut sum2 = 0.0;
        for w in self.weights.iter_mut() {
            *w = (*w / sum).max(WEIGHT_FLOOR);
            sum2 += *w;
        }
        for w in self.weights.iter_mut() {
            *w /= sum2;
        }
    }

    /// Body → NED DCM of the composite: `R_z(ψ̄) c_ba` (None before the bank starts).
    pub fn c_bn(&self) -> Option<Mat3> {
        if !self.bank_started {
            return None;
        }
        let (psi, _, _) = self.mixture();
        Some(dcm_from_euler(&Vec3::new(0.0, 0.0, psi)) * dcm_from_quat(&self.q_ba))
    }

    /// Composite yaw with its σ, roll/pitch and convergence (None before the
    /// first IMU sample and the first GNSS velocity).
    pub fn estimate(&self) -> Option<YawEstimate> {
        let c_bn = self.c_bn()?;
        let (_, _, var) = self.mixture();
        let rpy = euler_from_dcm(&c_bn);
        let std = var.max(0.0).sqrt();
        Some(YawEstimate {
            yaw: rpy.z,
            std,
            roll: rpy.x,
            pitch: rpy.y,
            converged: std < self.cfg.converged_std && self.accel_seen > 0.0,
            horizontal_accel_seen: self.accel_seen,
        })
    }

    /// Per model: body yaw [rad], yaw σ [rad] and weight (diagnostics).
    pub fn models(&self) -> [(f64, f64, f64); GSF_MODELS] {
        let mut out = [(0.0, 0.0, 0.0); GSF_MODELS];
        let yaw_a = euler_from_dcm(&dcm_from_quat(&self.q_ba)).z;
        for (o, (m, w)) in out
            .iter_mut()
            .zip(self.models.iter().zip(self.weights.iter()))
        {
            *o = (wrap_pi(yaw_a + m.psi), m.p[(2, 2)].sqrt(), *w);
        }
        out
    }

    /// The configuration in use (with any gyro bias set since).
    pub fn config(&self) -> &GsfConfig {
        &self.cfg
    }
}

#[cfg(test)]
#[path = "yaw_gsf_tests.rs"]
mod tests;
