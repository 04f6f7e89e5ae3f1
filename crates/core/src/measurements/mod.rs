//! Measurement models of the aiding sensors beyond GNSS (issue 17), one small
//! module each: prediction `h(x)`, Jacobian rows `H` over the ESKF error
//! state ([`crate::estimators::eskf`], psi-angle convention
//! `C_bn = (I + [φ×]) Ĉ_bn`, errors `δx = x̂ − x`), the measurement noise
//! `R` and, where the physics gives one, a plausibility gate beyond the
//! filter's χ² gate. The ESKF applies them from one dispatch
//! (`estimators/eskf/aiding.rs`).
//!
//! * [`odometer`]: wheel speed as the body-frame forward velocity at the
//!   wheel's lever arm, with a scale-factor state; NHC rows at the same point.
//! * [`heading`]: heading (and pitch) of a body-fixed baseline (dual-antenna
//!   GNSS, CP-ATT), with a configured mounting.
//! * [`magnetometer`]: heading from the levelled body field and the World
//!   Magnetic Model declination ([`wmm`]), with a disturbance gate.

pub mod heading;
pub mod magnetometer;
pub mod odometer;
pub mod wmm;

/// Wrap an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    #[allow(unused_imports)]
    use crate::prelude::*;
    let two_pi = 2.0 * core::f64::consts::PI;
    let mut w = a - two_pi * ((a + core::f64::consts::PI) / two_pi).floor();
    if w <= -core::f64::consts::PI {
        w += two_pi;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::wrap_pi;
    use core::f64::consts::PI;

    #[test]
    fn wrap_pi_lands_in_the_half_open_interval() {
        for (a, w) in [
            (0.0, 0.0),
            (PI, PI),
            (-PI, PI),
            (3.0 * PI, PI),
            (0.5 - 4.0 * PI, 0.5),
        ] {
            assert!((wrap_pi(a) - w).abs() < 1e-12, "{a} -> {}", wrap_pi(a));
        }
    }
}
