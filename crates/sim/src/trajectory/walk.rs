//! Walking: a body-frame phase with step-periodic velocity and attitude.
//!
//! Over a phase of duration T holding N whole strides (2N steps), the step
//! angular frequency is ω = 2π·2N/T and
//!
//! ```text
//! v_b(τ) = v_b0 + a τ + u₁ sin(ωτ) + u₂ sin(ωτ/2)
//! rpy(τ) = rpy₀ + ψ̇ τ + α₁ sin(ωτ) + α₂ sin(ωτ/2)
//! ```
//!
//! with u₁ = (A_fwd d + A_vert z)/ω + s̄ d_x θ_s z (forward and vertical
//! bounce at the cadence), u₂ = (A_lat/(ω/2) − s̄ ψ_s) p (side-to-side sway
//! at the stride frequency), α₁ = pitch sway θ_s, α₂ = roll and yaw sway
//! (d walking direction, p its right normal, both in the body frame; s̄ the
//! mean forward speed of the phase). The s̄ terms cancel, to first order,
//! what the sway does to the velocity in NED (pitching a forward velocity
//! tilts it vertically, yawing it sideways), so the NED bounce and side
//! sway keep the amplitudes A_vert, A_lat whatever the sway. All sinusoids vanish at τ = 0 and τ = T,
//! so phases join continuously in position, velocity and attitude, and the
//! derivatives are analytic: truth and IMU increments stay exact (the
//! generator integrates these closed forms like every other phase).
//!
//! Default amplitudes are typical of trunk-worn sensors in level walking
//! (vertical ≈ 2 m/s², forward ≈ 1.5 m/s², lateral ≈ 0.5 m/s² at 1.9 steps/s;
//! order of magnitude as reported e.g. by Zijlstra & Hof, Gait & Posture
//! 2003 — recalled, not re-derived here).

use super::{Compiler, Phase, Segment, DEG};
use crate::SimError;
use navfuse_core::Vec3;

/// Typical free walking cadence [steps/s] (≈ 110–120 steps/min).
pub(crate) fn default_cadence() -> f64 {
    1.9
}
/// Step-induced acceleration amplitudes [fwd, lat, vert] [m/s²].
pub(crate) fn default_step_accel() -> [f64; 3] {
    [1.5, 0.5, 2.0]
}
/// Attitude sway amplitudes [roll, pitch, yaw] [deg].
pub(crate) fn default_sway() -> [f64; 3] {
    [2.0, 2.0, 2.0]
}

/// Step-periodic part of a walking phase (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gait {
    /// Step angular frequency ω [rad/s].
    pub omega: f64,
    /// Body-velocity amplitudes [m/s] at ω and at ω/2.
    pub v_amp: [Vec3; 2],
    /// Euler-angle amplitudes [rad] at ω and at ω/2.
    pub att_amp: [Vec3; 2],
}

impl Gait {
    /// Add the sinusoids at `tau` to the angles, their rates, the body
    /// velocity and its derivative.
    pub(super) fn add(
        &self,
        tau: f64,
        rpy: &mut Vec3,
        rpy_dot: &mut Vec3,
        dv: &mut Vec3,
        dv_dot: &mut Vec3,
    ) {
        for (k, m) in [(0usize, 1.0), (1, 0.5)] {
            let w = self.omega * m;
            let (s, c) = (w * tau).sin_cos();
            *rpy += self.att_amp[k] * s;
            *rpy_dot += self.att_amp[k] * (w * c);
            *dv += self.v_amp[k] * s;
            *dv_dot += self.v_amp[k] * (w * c);
        }
    }
}

/// Whole strides in `duration_s` at `cadence_hz` (at least one).
pub fn strides(duration_s: f64, cadence_hz: f64) -> u64 {
    ((duration_s * cadence_hz / 2.0).round() as u64).max(1)
}

impl Compiler {
    /// Compile a [`Segment::Walk`] (any other segment is an error).
    pub(super) fn walk(&mut self, seg: &Segment, what: &str) -> Result<(), SimError> {
        let Segment::Walk {
            duration_s,
            speed_mps,
            turn_deg,
            cadence_hz,
            step_accel_mps2,
            sway_deg,
            yaw_offset_deg,
        } = *seg
        else {
            return Err(SimError::Scenario(format!("{what}: not a walk segment")));
        };
        let finite = [duration_s, turn_deg, cadence_hz]
            .iter()
            .chain(&step_accel_mps2)
            .chain(&sway_deg)
            .chain(speed_mps.iter())
            .chain(yaw_offset_deg.iter())
            .all(|x| x.is_finite());
        if !finite || cadence_hz <= 0.0 || duration_s < 0.0 {
            return Err(SimError::Scenario(format!(
                "{what}: numbers must be finite, cadence_hz > 0, duration_s ≥ 0"
            )));
        }
        if speed_mps.is_some_and(|s| s < 0.0) {
            return Err(SimError::Scenario(format!("{what}: speed_mps must be ≥ 0")));
        }
        let n = strides(duration_s, cadence_hz);
        let steps = self.steps(2.0 * n as f64 / cadence_hz, what)?.max(1);
        let t = steps as f64 * self.h;
        // Exactly n strides in the rounded duration.
        let omega = 2.0 * core::f64::consts::PI * 2.0 * n as f64 / t;
        let vh = Vec3::new(self.v_b.x, self.v_b.y, 0.0);
        let d = match yaw_offset_deg {
            // Course = yaw − offset: the direction is at −offset in the body frame.
            Some(o) => Vec3::new((o * DEG).cos(), -(o * DEG).sin(), 0.0),
            None if vh.norm() > 1e-9 => vh / vh.norm(),
            None => Vec3::x(),
        };
        let p = Vec3::new(-d.y, d.x, 0.0);
        let speed = speed_mps.unwrap_or(vh.norm());
        let acc = (d * speed - self.v_b) / t;
        let s_mean = 0.5 * (self.v_b.dot(&d) + speed);
        let [af, al, av] = step_accel_mps2;
        let [sr, sp, sy] = sway_deg;
        let gait = Gait {
            omega,
            v_amp: [
                (d * af + Vec3::z() * av) / omega + Vec3::z() * (s_mean * d.x * sp * DEG),
                p * (al / (0.5 * omega) - s_mean * sy * DEG),
            ],
            att_amp: [Vec3::new(0.0, sp, 0.0) * DEG, Vec3::new(sr, 0.0, sy) * DEG],
        };
        self.push(Phase {
            gait: Some(gait),
            ..Phase::body(steps, Vec3::new(0.0, 0.0, turn_deg * DEG / t), acc)
        });
        Ok(())
    }
}
