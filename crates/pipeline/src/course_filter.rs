//! Heading of a non-holonomic vehicle from the GNSS course over several
//! epochs, carried between them by the z gyro: a two-state Kalman filter
//! (yaw ψ, z-gyro bias b) used by the alignment ([`crate::align`]) before
//! the ESKF starts.
//!
//! One epoch's course `c = atan2(v_E, v_N)` has σ_c ≈ σ_⊥ / speed (the
//! velocity σ across the track over the speed): a slow robot with a
//! consumer receiver (0.1 m/s Doppler σ, ≤ 1.5 m/s) never gets a single
//! epoch's course below 3°. The epochs' Doppler errors are independent,
//! and the gyro links the headings of successive epochs, so N epochs give
//! the heading with σ ≈ σ_c/√N (jointly with the gyro bias, which the
//! filter estimates: a phone gyro's turn-on bias of 0.5°/s would otherwise
//! turn 5 s of carrying into 2.5° of yaw). This is the "course σ ≈ σ_v /
//! speed" rule of issue 13 applied to a sequence of epochs instead of one.
//!
//! Model (Groves 2nd ed. §3.2 Kalman filter; small tilt):
//! - propagation over Δt with the z-gyro increment Δθ:
//!   `ψ⁺ = ψ + Δθ − b Δt`, `b⁺ = b`; process noise on ψ: ARW² Δt plus the
//!   unmodelled share of the turn `(k Δθ)²` (k: the gyro scale-factor σ
//!   ⊕ the tilt term 1 − cos 10° ≈ 1.5 % that the z-only integration
//!   neglects on slopes up to 10°);
//! - measurement: the course with
//!   `σ_c² = (v_E² σ_N² + v_N² σ_E²) / |v|⁴` (the linearised atan2), used
//!   only where |v| ≥ [`MIN_SNR`] σ_⊥ (course σ ≤ 14°, where the atan2 of a
//!   noisy vector is close to Gaussian), with a χ² gate so a skid or a
//!   reversal is not averaged in.
//!
//! The course is the heading only up to the IMU's yaw mounting and the
//! tyres' sideslip, a bias that does not average down: the caller adds
//! [`crate::align::COURSE_MOUNT_STD`] to the σ it hands over.
//!
//! Angles in rad, rates in rad/s, time in s.

use navfuse_core::attitude::wrap_pi;
use navfuse_core::Vec3;

/// Lowest speed over cross-track velocity σ at which an epoch's course is
/// used (4: course σ ≤ 1/4 rad ≈ 14°, within the atan2's near-linear region).
pub const MIN_SNR: f64 = 4.0;
/// Innovation gate (χ²₁ at 99.9 %, 3.29σ): a course this far from the
/// carried heading is a skid, a reversal or a bad Doppler, not evidence.
const GATE_CHI2: f64 = 10.83;
/// Share of a turn the z-only integration may get wrong: 1 − cos 10° (tilt
/// up to 10° ignored, as in the alignment's straightness test).
const TILT_SCALE: f64 = 0.015;

/// The two-state course filter (see the module doc).
#[derive(Clone, Copy, Debug)]
pub struct CourseFilter {
    /// Yaw [rad] and z-gyro bias [rad/s].
    yaw: f64,
    bias: f64,
    /// Covariance [[ψψ, ψb], [ψb, bb]].
    p: [[f64; 2]; 2],
    /// GPS time [s] of the state; NaN before the first course.
    t: f64,
    arw: f64,
    turn_scale: f64,
    /// Prior bias and its σ (until the first course).
    bias0: f64,
    bias0_std: f64,
}

impl CourseFilter {
    /// A filter with the z-gyro bias prior `bias0 ± bias0_std` [rad/s], the
    /// gyro's angle random walk `arw` [rad/√s] and scale-factor σ `scale_std`.
    pub fn new(bias0: f64, bias0_std: f64, arw: f64, scale_std: f64) -> Self {
        CourseFilter {
            yaw: 0.0,
            bias: bias0,
            p: [[f64::INFINITY, 0.0], [0.0, bias0_std * bias0_std]],
            t: f64::NAN,
            arw,
            turn_scale: scale_std.hypot(TILT_SCALE),
            bias0,
            bias0_std,
        }
    }

    /// Whether a course has been taken in.
    pub fn started(&self) -> bool {
        self.t.is_finite()
    }

    /// Carry the state to `t` with the z-gyro increment `dtheta_z` [rad]
    /// integrated since the state's time.
    pub fn propagate(&mut self, t: f64, dtheta_z: f64) {
        if !self.started() {
            return;
        }
        let dt = t - self.t;
        if dt <= 0.0 {
            return;
        }
        self.yaw = wrap_pi(self.yaw + dtheta_z - self.bias * dt);
        // P ← F P Fᵀ + Q, F = [[1, −Δt], [0, 1]].
        let [[a, c], [_, b]] = self.p;
        let a = a - 2.0 * dt * c + dt * dt * b;
        let c = c - dt * b;
        let q = self.arw * self.arw * dt + (self.turn_scale * dtheta_z).powi(2);
        self.p = [[a + q, c], [c, b]];
        self.t = t;
    }

    /// Take in the GNSS velocity `v_n` (NED) with per-axis σ `sv` at `t`
    /// (after [`Self::propagate`] to `t`). Returns whether it was used.
    pub fn update(&mut self, t: f64, v_n: &Vec3, sv: &Vec3) -> bool {
        let v2 = v_n.x * v_n.x + v_n.y * v_n.y;
        let var = (v_n.y * v_n.y * sv.x * sv.x + v_n.x * v_n.x * sv.y * sv.y) / (v2 * v2);
        if !(v2 > 0.0 && var.is_finite() && var * MIN_SNR * MIN_SNR <= 1.0) {
            return false;
        }
        let course = v_n.y.atan2(v_n.x);
        if !self.started() {
            self.yaw = course;
            self.bias = self.bias0;
            self.p = [[var, 0.0], [0.0, self.bias0_std * self.bias0_std]];
            self.t = t;
            return true;
        }
        let nu = wrap_pi(course - self.yaw);
        let [[a, c], [_, b]] = self.p;
        let s = a + var;
        if nu * nu > GATE_CHI2 * s {
            return false;
        }
        let (ky, kb) = (a / s, c / s);
        self.yaw = wrap_pi(self.yaw + ky * nu);
        self.bias += kb * nu;
        // P ← (I − K H) P, H = [1, 0].
        self.p = [[a - ky * a, c - ky * c], [c - ky * c, b - kb * c]];
        true
    }

    /// Yaw [rad] and its σ [rad] (σ = ∞ before the first course).
    pub fn yaw(&self) -> (f64, f64) {
        (self.yaw, self.p[0][0].max(0.0).sqrt())
    }

    /// z-gyro bias [rad/s] and its σ.
    pub fn bias(&self) -> (f64, f64) {
        (self.bias, self.p[1][1].max(0.0).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A standard normal draw (Box–Muller).
    fn gauss(r: &mut impl Rng) -> f64 {
        let (u, v): (f64, f64) = (r.gen_range(1e-12..1.0), r.gen());
        (-2.0 * u.ln()).sqrt() * (core::f64::consts::TAU * v).cos()
    }

    /// A slow straight-and-turning vehicle at 1 m/s with 0.1 m/s Doppler σ
    /// (one epoch: 5.7°) and a 0.5°/s gyro bias: the filter's yaw error is
    /// inside its 3σ in ≥ 99 % of the checks over 200 runs (99.7 % for a
    /// Gaussian), its σ falls below 3° within 30 epochs, and the bias
    /// estimate ends within its 3σ in ≥ 97 % of the runs.
    #[test]
    fn course_over_epochs_is_consistent_and_converges_at_walking_speed() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (arw, bias_true, bias_std) = (
            0.42f64.to_radians() / 60.0,
            0.5f64.to_radians(),
            0.5f64.to_radians(),
        );
        let (mut inside, mut checks, mut converged, mut bias_inside) = (0, 0, 0, 0);
        for _ in 0..200 {
            let mut yaw_true: f64 = rng.gen_range(-3.0..3.0);
            let mut f = CourseFilter::new(0.0, bias_std, arw, 0.005);
            let mut t = 0.0;
            let mut conv = false;
            for k in 0..60 {
                // Turn at 10°/s during 9 of each 20 s.
                let rate = if k % 20 < 9 { 0.0 } else { 10f64.to_radians() };
                let nsub = 100;
                let mut dth = 0.0;
                for _ in 0..nsub {
                    let dt = 1.0 / nsub as f64;
                    dth += (rate + bias_true) * dt + arw * dt.sqrt() * gauss(&mut rng);
                    yaw_true += rate * dt;
                }
                t += 1.0;
                f.propagate(t, dth);
                let v = Vec3::new(yaw_true.cos(), yaw_true.sin(), 0.0)
                    + 0.1 * Vec3::new(gauss(&mut rng), gauss(&mut rng), 0.0);
                f.update(t, &v, &Vec3::new(0.1, 0.1, 0.1));
                let (y, s) = f.yaw();
                if s.is_finite() {
                    checks += 1;
                    if wrap_pi(y - yaw_true).abs() <= 3.0 * s {
                        inside += 1;
                    }
                }
                if k < 30 && s <= 3f64.to_radians() {
                    conv = true;
                }
            }
            converged += conv as usize;
            bias_inside += ((f.bias().0 - bias_true).abs() < 3.0 * f.bias().1) as usize;
        }
        assert!(bias_inside >= 194, "bias inside 3σ: {bias_inside}/200");
        let share = inside as f64 / checks as f64;
        assert!(share >= 0.99, "inside 3σ: {share}");
        assert_eq!(converged, 200);
    }

    #[test]
    fn slow_or_uncertain_velocity_is_not_a_course() {
        let mut f = CourseFilter::new(0.0, 0.01, 1e-4, 0.005);
        // 0.3 m/s with 0.1 m/s σ: SNR 3 < 4.
        assert!(!f.update(0.0, &Vec3::new(0.3, 0.0, 0.0), &Vec3::repeat(0.1)));
        assert!(!f.started());
        assert!(f.update(1.0, &Vec3::new(0.0, 1.0, 0.0), &Vec3::repeat(0.1)));
        let (y, s) = f.yaw();
        assert!((y - core::f64::consts::FRAC_PI_2).abs() < 1e-12 && (s - 0.1).abs() < 1e-12);
    }
}
