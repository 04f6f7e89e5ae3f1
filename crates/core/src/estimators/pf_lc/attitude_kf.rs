//! The attitude Kalman filter of seed 002 (`SEEDS.md §2`, fig. 6): gyro
//! propagation, accelerometer tilt correction near 1 g, HDR and HSR, SVD
//! re-orthonormalisation.
//!
//! Frames: body FRD, navigation NED; `c_bn` maps body to navigation. The
//! earth rate (15°/h) is neglected against the MEMS gyro errors this filter
//! is for (ADIS16365: 0.8°/s noise).
//!
//! Error state `x = [φ (3), δb_g (3)]`: the true DCM is `(I + [φ×]) ĉ_bn`,
//! the true gyro bias `b̂ + δb_g`. Propagation (Groves §14.2.4, psi-angle
//! form without earth rate): `φ̇ = −c_bn δb_g`, gyro white noise (ARW) and
//! bias random walk. After each correction the error is fed back and reset.
//!
//! Measurements:
//! - *Tilt.* Averaged specific force `f̄_b` over `tilt_avg_samples`, used when
//!   `| |f̄| − g | < tilt_gate_g·g` and `|ω̄| < tilt_gyro_gate_rad_s` (no
//!   sustained acceleration or turn): `z = (0,0,−g) − ĉ_bn f̄_b ≈ −[f̂_n×] φ`
//!   (north and east rows).
//! - *Course (optional, not in the paper).* Given a ground course from the
//!   position filter while driving straight: `z = course − ψ̂ ≈ φ_D`.
//!
//! HDR (Borenstein & Ojeda 2009, heuristic drift reduction): while the
//! averaged yaw rate is below `hdr_threshold_rad_s` the vehicle is taken to
//! drive straight and the z-gyro bias estimate moves by a fixed step
//! `hdr_step_rad_s` toward cancelling the residual rate (an integral
//! controller: `b_z ← b_z + i_c·sign(ω_z − b_z)`).
//!
//! HSR (heuristic scale regulation; seed 002 names it without detail, our
//! reading): in the same quasi-static windows the accelerometer scale `s`
//! relaxes toward `g/|f̄|` with gain `hsr_gain` (the seed 001 static scale
//! `s_a = g/|f_avg|`, applied continuously). `f_b ← s·f_b`.
//!
//! The DCM is re-orthonormalised with the SVD (singular values → 1,
//! `attitude::orthonormalize`) every `orthonormalize_every` samples.

#[allow(unused_imports)]
use crate::prelude::*;

use crate::attitude::{dcm_from_euler, dcm_from_rotvec, euler_from_dcm, orthonormalize, skew};
use crate::geodesy::wrap_pi;
use crate::kalman;
use crate::types::{ImuSample, Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

type M6 = SMatrix<f64, 6, 6>;

/// Parameters of the attitude KF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeKfConfig {
    /// Gravity magnitude used by the tilt measurement [m/s²].
    pub gravity_m_s2: f64,
    /// Length of the initial static alignment [s] (mean f → roll/pitch,
    /// mean ω → gyro bias).
    pub align_time_s: f64,
    /// The alignment estimates the gyro bias only if the gyro norm's sample
    /// σ during it is below this [rad/s] (else bias 0).
    pub align_static_gyro_sd_rad_s: f64,
    /// Gyro angle random walk [rad/√s].
    pub arw_rad_sqrt_s: f64,
    /// Gyro bias random walk [rad/s/√s].
    pub gyro_bias_rw_rad_s_sqrt_s: f64,
    /// Initial σ of roll/pitch after alignment [rad].
    pub init_tilt_sigma_rad: f64,
    /// Initial σ of yaw when it is set from the course [rad].
    pub init_yaw_sigma_rad: f64,
    /// Initial σ of the gyro bias after alignment [rad/s].
    pub init_gyro_bias_sigma_rad_s: f64,
    /// Samples averaged per tilt measurement.
    pub tilt_avg_samples: u32,
    /// Tilt used when | |f̄| − g | < this · g.
    pub tilt_gate_g: f64,
    /// Tilt used when |ω̄| < this [rad/s].
    pub tilt_gyro_gate_rad_s: f64,
    /// σ of the tilt measurement per axis (vehicle acceleration, vibration) [m/s²].
    pub tilt_sigma_m_s2: f64,
    /// HDR: straight driving when |ω̄_z − b_z| < this [rad/s].
    pub hdr_threshold_rad_s: f64,
    /// HDR integral step per tilt window [rad/s] (0 disables HDR).
    pub hdr_step_rad_s: f64,
    /// HSR gain per quasi-static window (0 disables HSR).
    pub hsr_gain: f64,
    /// Bounds of the HSR scale.
    pub hsr_scale_bounds: [f64; 2],
    /// Re-orthonormalise the DCM every this many samples.
    pub orthonormalize_every: u32,
    /// σ of the course measurement [rad].
    pub course_sigma_rad: f64,
    /// χ² gate for tilt and course updates (NIS).
    pub gate_nis: f64,
    /// After this many consecutive gated course updates the yaw is reset to
    /// the course (a yaw error beyond the gate is otherwise never repaired).
    pub course_reset_after: u32,
    /// Remove the vehicle's centripetal acceleration `ω_b × v_b` from the
    /// tilt measurement when the caller gives the velocity
    /// ([`AttitudeKf::set_velocity`]; navfuse extension, Groves §10.1.3's
    /// motion compensation of accelerometer levelling). Without it a steady
    /// turn (|f| ≈ g, slow yaw rate: the gates pass it) levels the filter on
    /// the tilted apparent vertical and the turn's acceleration is lost from
    /// the horizontal channel.
    pub centripetal_compensation: bool,
}

impl Default for AttitudeKfConfig {
    fn default() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        AttitudeKfConfig {
            gravity_m_s2: crate::earth::STANDARD_GRAVITY,
            align_time_s: 2.0,
            align_static_gyro_sd_rad_s: 5.0 * deg,
            arw_rad_sqrt_s: 0.08 * deg,
            gyro_bias_rw_rad_s_sqrt_s: 0.005 * deg,
            init_tilt_sigma_rad: 2.0 * deg,
            init_yaw_sigma_rad: 10.0 * deg,
            init_gyro_bias_sigma_rad_s: 0.2 * deg,
            tilt_avg_samples: 10,
            tilt_gate_g: 0.03,
            tilt_gyro_gate_rad_s: 5.0 * deg,
            tilt_sigma_m_s2: 0.3,
            hdr_threshold_rad_s: 1.0 * deg,
            hdr_step_rad_s: 0.0005 * deg,
            hsr_gain: 0.001,
            hsr_scale_bounds: [0.95, 1.05],
            orthonormalize_every: 100,
            course_sigma_rad: 3.0 * deg,
            gate_nis: 25.0,
            course_reset_after: 20,
            centripetal_compensation: true,
        }
    }
}

/// Counters of the attitude filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AttitudeStats {
    pub samples: u64,
    pub tilt_updates: u64,
    pub tilt_gated: u64,
    pub tilt_skipped_dynamic: u64,
    pub course_updates: u64,
    pub course_gated: u64,
    pub course_resets: u64,
    pub hdr_steps: u64,
    pub rejected_nonfinite: u64,
}

/// Gyro/accelerometer attitude filter (see the module doc).
#[derive(Clone, Debug)]
pub struct AttitudeKf {
    cfg: AttitudeKfConfig,
    c_bn: Mat3,
    b_g: Vec3,
    accel_scale: f64,
    p: M6,
    aligned: bool,
    yaw_valid: bool,
    // Alignment and window accumulators.
    acc_dv: Vec3,
    acc_dth: Vec3,
    acc_dt: f64,
    acc_n: u32,
    acc_w2: f64,
    acc_w: f64,
    since_ortho: u32,
    course_rejects: u32,
    /// Vehicle velocity in NED from the caller (for the centripetal term).
    v_n: Option<Vec3>,
    stats: AttitudeStats,
}

impl AttitudeKf {
    pub fn new(cfg: AttitudeKfConfig) -> Self {
        AttitudeKf {
            cfg,
            c_bn: Mat3::identity(),
            b_g: Vec3::zeros(),
            accel_scale: 1.0,
            p: M6::zeros(),
            aligned: false,
            yaw_valid: false,
            acc_dv: Vec3::zeros(),
            acc_dth: Vec3::zeros(),
            acc_dt: 0.0,
            acc_n: 0,
            acc_w2: 0.0,
            acc_w: 0.0,
            since_ortho: 0,
            course_rejects: 0,
            v_n: None,
            stats: AttitudeStats::default(),
        }
    }

    pub fn config(&self) -> &AttitudeKfConfig {
        &self.cfg
    }
    pub fn stats(&self) -> &AttitudeStats {
        &self.stats
    }
    /// Body→NED DCM (yaw meaningful only when [`Self::yaw_valid`]).
    pub fn c_bn(&self) -> &Mat3 {
        &self.c_bn
    }
    pub fn gyro_bias(&self) -> &Vec3 {
        &self.b_g
    }
    pub fn accel_scale(&self) -> f64 {
        self.accel_scale
    }
    pub fn is_aligned(&self) -> bool {
        self.aligned
    }
    pub fn yaw_valid(&self) -> bool {
        self.yaw_valid
    }
    /// Roll, pitch, yaw [rad] (ZYX).
    pub fn rpy(&self) -> Vec3 {
        euler_from_dcm(&self.c_bn)
    }
    /// 1-σ of the attitude error (north, east, down tilt/yaw) [rad].
    pub fn std_phi(&self) -> Vec3 {
        Vec3::new(self.p[(0, 0)], self.p[(1, 1)], self.p[(2, 2)]).map(|v| v.max(0.0).sqrt())
    }

    fn reset_acc(&mut self) {
        self.acc_dv = Vec3::zeros();
        self.acc_dth = Vec3::zeros();
        self.acc_dt = 0.0;
        self.acc_n = 0;
        self.acc_w2 = 0.0;
        self.acc_w = 0.0;
    }

    /// Process one IMU sample. Returns the specific force in NED for this
    /// interval, `ĉ_bn · s·Δv_b` [m/s] (a velocity increment), once aligned.
    pub fn push(&mut self, s: &ImuSample) -> Option<Vec3> {
        if !(s.dt > 0.0
            && s.dt.is_finite()
            && s.dtheta_b.iter().all(|x| x.is_finite())
            && s.dvel_b.iter().all(|x| x.is_finite()))
        {
            self.stats.rejected_nonfinite += 1;
            return None;
        }
        self.stats.samples += 1;
        self.acc_dv += s.dvel_b;
        self.acc_dth += s.dtheta_b;
        self.acc_dt += s.dt;
        self.acc_n += 1;
        let wn = s.dtheta_b.norm() / s.dt;
        self.acc_w += wn;
        self.acc_w2 += wn * wn;
        if !self.aligned {
            if self.acc_dt >= self.cfg.align_time_s {
                self.align();
            }
            return None;
        }
        // Gyro propagation (DCM, rotation vector of the bias-corrected increment).
        let dth = s.dtheta_b - self.b_g * s.dt;
        self.c_bn *= dcm_from_rotvec(&dth);
        self.since_ortho += 1;
        if self.since_ortho >= self.cfg.orthonormalize_every {
            self.c_bn = orthonormalize(&self.c_bn);
            self.since_ortho = 0;
        }
        let mut f = M6::identity();
        f.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-self.c_bn * s.dt));
        let mut q = M6::zeros();
        let qa = self.cfg.arw_rad_sqrt_s.powi(2) * s.dt;
        let qb = self.cfg.gyro_bias_rw_rad_s_sqrt_s.powi(2) * s.dt;
        for i in 0..3 {
            q[(i, i)] = qa;
            q[(i + 3, i + 3)] = qb;
        }
        kalman::predict(&mut self.p, &f, &q);
        let dv_n = self.c_bn * (s.dvel_b * self.accel_scale);
        if self.acc_n >= self.cfg.tilt_avg_samples {
            self.window_update();
            self.reset_acc();
        }
        Some(dv_n)
    }

    fn align(&mut self) {
        let f = self.acc_dv / self.acc_dt;
        let n = self.acc_n as f64;
        let w_mean = self.acc_w / n;
        let w_sd = (self.acc_w2 / n - w_mean * w_mean).max(0.0).sqrt();
        let roll = (-f.y).atan2(-f.z);
        let pitch = f.x.atan2((f.y * f.y + f.z * f.z).sqrt());
        self.c_bn = dcm_from_euler(&Vec3::new(roll, pitch, 0.0));
        // A static start gives the gyro bias directly.
        self.b_g = if w_sd < self.cfg.align_static_gyro_sd_rad_s {
            self.acc_dth / self.acc_dt
        } else {
            Vec3::zeros()
        };
        let (st, sb) = (
            self.cfg.init_tilt_sigma_rad,
            self.cfg.init_gyro_bias_sigma_rad_s,
        );
        self.p = M6::zeros();
        for i in 0..2 {
            self.p[(i, i)] = st * st;
        }
        self.p[(2, 2)] = (core::f64::consts::PI).powi(2);
        for i in 3..6 {
            self.p[(i, i)] = sb * sb;
        }
        self.aligned = true;
        self.reset_acc();
    }

    fn feedback(&mut self, x: &SVector<f64, 6>) {
        let phi = Vec3::new(x[0], x[1], x[2]);
        self.c_bn = orthonormalize(&((Mat3::identity() + skew(&phi)) * self.c_bn));
        self.b_g += Vec3::new(x[3], x[4], x[5]);
    }

    /// Tilt, HDR and HSR over one averaging window.
    fn window_update(&mut self) {
        let g = self.cfg.gravity_m_s2;
        let w_b = self.acc_dth / self.acc_dt - self.b_g;
        let mut f_b = self.acc_dv / self.acc_dt * self.accel_scale;
        if let (true, true, Some(v_n)) =
            (self.cfg.centripetal_compensation, self.yaw_valid, self.v_n)
        {
            // f = a − g with a_b = ω_b × v_b for a body-fixed velocity.
            f_b -= w_b.cross(&(self.c_bn.transpose() * v_n));
        }
        let quasi_static = (f_b.norm() - g).abs() < self.cfg.tilt_gate_g * g
            && w_b.norm() < self.cfg.tilt_gyro_gate_rad_s;
        if !quasi_static {
            self.stats.tilt_skipped_dynamic += 1;
        } else {
            let f_n = self.c_bn * f_b;
            let mut h = SMatrix::<f64, 2, 6>::zeros();
            let fx = -skew(&f_n);
            h.fixed_view_mut::<2, 3>(0, 0)
                .copy_from(&fx.fixed_view::<2, 3>(0, 0));
            let nu = SVector::<f64, 2>::new(-f_n.x, -f_n.y);
            let r = SMatrix::<f64, 2, 2>::identity() * self.cfg.tilt_sigma_m_s2.powi(2);
            let mut x = SVector::<f64, 6>::zeros();
            let u =
                kalman::update_joseph(&mut x, &mut self.p, &h, &r, &nu, Some(self.cfg.gate_nis));
            if u.accepted {
                self.feedback(&x);
                self.stats.tilt_updates += 1;
            } else {
                self.stats.tilt_gated += 1;
            }
            // HSR: scale toward g / |f| (raw, before the scale).
            if self.cfg.hsr_gain > 0.0 {
                let raw = (self.acc_dv / self.acc_dt).norm();
                if raw > 0.0 {
                    let [lo, hi] = self.cfg.hsr_scale_bounds;
                    self.accel_scale = (self.accel_scale
                        + self.cfg.hsr_gain * (g / raw - self.accel_scale))
                        .clamp(lo, hi);
                }
            }
        }
        // HDR: straight driving → integral step on the z-gyro bias.
        if self.cfg.hdr_step_rad_s > 0.0 && w_b.z.abs() < self.cfg.hdr_threshold_rad_s {
            self.b_g.z += self.cfg.hdr_step_rad_s * w_b.z.signum();
            self.stats.hdr_steps += 1;
        }
    }

    /// The vehicle velocity in NED [m/s] (None: unknown), used by
    /// [`AttitudeKfConfig::centripetal_compensation`].
    pub fn set_velocity(&mut self, v_n: Option<Vec3>) {
        self.v_n = v_n;
    }

    /// Set the yaw (keeping roll and pitch), e.g. from the first GNSS course.
    pub fn set_yaw(&mut self, yaw: f64) {
        let rpy = self.rpy();
        self.c_bn = dcm_from_euler(&Vec3::new(rpy.x, rpy.y, yaw));
        let s = self.cfg.init_yaw_sigma_rad;
        for i in 0..6 {
            self.p[(2, i)] = 0.0;
            self.p[(i, 2)] = 0.0;
        }
        self.p[(2, 2)] = s * s;
        self.yaw_valid = true;
    }

    /// Course measurement `course` [rad, from north, clockwise] (optional aiding).
    pub fn update_course(&mut self, course: f64) -> bool {
        if !self.yaw_valid || !course.is_finite() {
            return false;
        }
        let mut h = SMatrix::<f64, 1, 6>::zeros();
        h[(0, 2)] = 1.0;
        let nu = SVector::<f64, 1>::new(wrap_pi(course - self.rpy().z));
        let r = SMatrix::<f64, 1, 1>::new(self.cfg.course_sigma_rad.powi(2));
        let mut x = SVector::<f64, 6>::zeros();
        let u = kalman::update_joseph(&mut x, &mut self.p, &h, &r, &nu, Some(self.cfg.gate_nis));
        if u.accepted {
            self.feedback(&x);
            self.stats.course_updates += 1;
            self.course_rejects = 0;
        } else {
            self.stats.course_gated += 1;
            self.course_rejects += 1;
            if self.course_rejects >= self.cfg.course_reset_after {
                self.set_yaw(course);
                self.course_rejects = 0;
                self.stats.course_resets += 1;
            }
        }
        u.accepted
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::pf_lc::rng::SplitMix64;

    const G: f64 = crate::earth::STANDARD_GRAVITY;

    /// Static IMU at attitude `rpy` with gyro bias `bias`, noise from `rng`.
    fn static_sample(t: f64, c_bn: &Mat3, bias: &Vec3, rng: &mut SplitMix64) -> ImuSample {
        let dt = 0.01;
        let f_b = c_bn.transpose() * Vec3::new(0.0, 0.0, -G);
        let n = |r: &mut SplitMix64, s: f64| Vec3::new(r.normal(), r.normal(), r.normal()) * s;
        ImuSample {
            t,
            dt,
            dtheta_b: bias * dt + n(rng, 0.8f64.to_radians() * dt),
            dvel_b: f_b * dt + n(rng, 0.09 * dt),
        }
    }

    /// A filter with `cfg` after 3 s level and at rest (its alignment), and
    /// the noise generator with `seed` as left by those samples.
    fn aligned_level(cfg: AttitudeKfConfig, seed: u64) -> (AttitudeKf, SplitMix64) {
        let mut rng = SplitMix64::new(seed);
        let mut a = AttitudeKf::new(cfg);
        for k in 0..300 {
            a.push(&static_sample(
                k as f64 * 0.01,
                &Mat3::identity(),
                &Vec3::zeros(),
                &mut rng,
            ));
        }
        (a, rng)
    }

    #[test]
    fn aligns_level_and_estimates_gyro_bias_then_holds_tilt() {
        let truth = dcm_from_euler(&Vec3::new(0.05, -0.03, 0.0));
        let bias = Vec3::new(0.02, -0.015, 0.01);
        let mut rng = SplitMix64::new(5);
        let mut a = AttitudeKf::new(AttitudeKfConfig {
            hdr_step_rad_s: 0.0,
            ..Default::default()
        });
        for k in 0..6000 {
            a.push(&static_sample(k as f64 * 0.01, &truth, &bias, &mut rng));
        }
        let rpy = a.rpy();
        assert!(
            (rpy.x - 0.05).abs() < 0.005 && (rpy.y + 0.03).abs() < 0.005,
            "{rpy}"
        );
        assert!((a.gyro_bias() - bias).norm() < 0.003, "{}", a.gyro_bias());
        assert!(a.stats().tilt_updates > 500);
    }

    /// A level car in a steady 4°/s turn at 19 m/s (centripetal 1.3 m/s²,
    /// so |f| − g and the yaw rate pass the quasi-static gates): with the
    /// velocity given, the tilt updates keep the roll level; without it they
    /// level the filter on the apparent vertical, ~7.6° off.
    #[test]
    fn steady_turn_keeps_level_with_centripetal_compensation() {
        let run = |compensate: bool| {
            let cfg = AttitudeKfConfig {
                hdr_step_rad_s: 0.0,
                centripetal_compensation: compensate,
                ..Default::default()
            };
            let (mut a, mut rng) = aligned_level(cfg, 9);
            a.set_yaw(0.0);
            let (v, w) = (19.0, 4.0f64.to_radians());
            let mut yaw = 0.0f64;
            let mut worst: f64 = 0.0;
            for k in 0..6000 {
                let dt = 0.01;
                a.set_velocity(Some(Vec3::new(v * yaw.cos(), v * yaw.sin(), 0.0)));
                let f_b = Vec3::new(0.0, v * w, -G);
                let n =
                    |r: &mut SplitMix64, s: f64| Vec3::new(r.normal(), r.normal(), r.normal()) * s;
                a.push(&ImuSample {
                    t: 3.0 + k as f64 * dt,
                    dt,
                    dtheta_b: Vec3::new(0.0, 0.0, w * dt) + n(&mut rng, 0.1f64.to_radians() * dt),
                    dvel_b: f_b * dt + n(&mut rng, 0.05 * dt),
                });
                yaw += w * dt;
                worst = worst.max(a.rpy().x.abs());
            }
            worst.to_degrees()
        };
        let (with, without) = (run(true), run(false));
        eprintln!("steady turn: max |roll| {with:.2}° compensated, {without:.2}° not");
        assert!(with < 0.5, "compensated roll {with}°");
        assert!(without > 3.0, "uncompensated roll {without}°");
    }

    #[test]
    fn tilt_correction_pulls_back_a_wrong_roll() {
        let truth = Mat3::identity();
        let (mut a, mut rng) = aligned_level(AttitudeKfConfig::default(), 6);
        // Disturb roll by 3° and watch the tilt updates remove it.
        a.c_bn = dcm_from_euler(&Vec3::new(3f64.to_radians(), 0.0, 0.0)) * a.c_bn;
        for k in 300..3300 {
            a.push(&static_sample(
                k as f64 * 0.01,
                &truth,
                &Vec3::zeros(),
                &mut rng,
            ));
        }
        assert!(a.rpy().x.abs() < 0.3f64.to_radians(), "{}", a.rpy());
    }

    #[test]
    fn hdr_removes_residual_yaw_rate_bias_when_straight() {
        let truth = Mat3::identity();
        let cfg = AttitudeKfConfig {
            hdr_step_rad_s: 1e-5,
            ..Default::default()
        };
        let (mut a, mut rng) = aligned_level(cfg, 8);
        a.set_yaw(0.0);
        // Bias appears after alignment (a turn-on drift) — HDR must take it out.
        let bias = Vec3::new(0.0, 0.0, 0.005);
        for k in 300..12300 {
            a.push(&static_sample(k as f64 * 0.01, &truth, &bias, &mut rng));
        }
        assert!((a.gyro_bias().z - 0.005).abs() < 0.001, "{}", a.gyro_bias());
        assert!(a.stats().hdr_steps > 100);
        // Without HDR the bias stays uncorrected.
        let cfg = AttitudeKfConfig {
            hdr_step_rad_s: 0.0,
            ..Default::default()
        };
        let (mut b, mut rng) = aligned_level(cfg, 8);
        for k in 300..12300 {
            b.push(&static_sample(k as f64 * 0.01, &truth, &bias, &mut rng));
        }
        assert!(b.gyro_bias().z.abs() < 0.002);
    }

    #[test]
    fn course_update_corrects_yaw() {
        let (mut a, _) = aligned_level(AttitudeKfConfig::default(), 9);
        a.set_yaw(0.2);
        for _ in 0..50 {
            a.update_course(0.0);
        }
        assert!(a.rpy().z.abs() < 0.02, "{}", a.rpy());
        assert_eq!(a.stats().course_updates, 50);
        // A yaw 90° off is beyond the gate: after `course_reset_after` gated
        // courses it is reset.
        a.set_yaw(1.57);
        let n = a.config().course_reset_after;
        for _ in 0..n {
            assert!(!a.update_course(0.0));
        }
        assert!(
            a.rpy().z.abs() < 1e-9 && a.stats().course_resets == 1,
            "{}",
            a.rpy()
        );
    }
}
