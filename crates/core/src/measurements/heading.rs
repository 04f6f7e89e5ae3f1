//! Heading (and pitch) of a body-fixed baseline: dual-antenna GNSS
//! (NAV-RELPOSNED, NMEA HDT/THS), CP-ATT, or any [`HeadingFix`] (issue 17).
//!
//! The baseline (master → slave antenna) points along `u_b` in the body
//! frame FRD, from its mounting: azimuth `ψ_m` from body +x towards +y
//! (right) and elevation `θ_m` above the body x–y plane,
//! `u_b = (cos θ_m cos ψ_m, cos θ_m sin ψ_m, −sin θ_m)`. In NED
//! `u_n = C_bn u_b`; the measured angles are `ψ = atan2(u_E, u_N)` and
//! `θ = atan2(−u_D, √(u_N² + u_E²))` (pitch positive up, as `HeadingFix`).
//!
//! Jacobians with `C_bn = (I + [φ×]) Ĉ_bn`: `û_n = (I − [φ×]) u_n`, so
//! `∂û_n/∂φ = [û_n×]` and `∂ψ̂/∂φ = ∂ψ/∂u · [û_n×]` with
//! `∂ψ/∂u = (−u_E, u_N, 0)/ρ²`, `∂θ/∂u = (u_N u_D/ρ, u_E u_D/ρ, −ρ)/|u|²`,
//! `ρ = √(u_N² + u_E²)`. For a level body-x baseline `∂ψ̂/∂φ = (0, 0, −1)`.
//! The heading innovation is wrapped to (−π, π].
//!
//! The yaw of the vehicle (ZYX Euler) is the heading of `u_b = (1, 0, 0)`,
//! which the magnetometer model uses ([`super::magnetometer`]).

use crate::estimators::eskf::{I_ATT, NX};
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{HeadingFix, Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

/// Baseline-heading aiding configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadingConfig {
    /// Baseline azimuth in the body frame, from +x towards +y [rad]
    /// (0: antennas along the vehicle axis, slave ahead of master).
    pub mount_yaw_rad: f64,
    /// Baseline elevation above the body x–y plane [rad] (up positive).
    pub mount_pitch_rad: f64,
    /// Floor of the heading/pitch 1-σ [rad]: receivers report a formal σ
    /// that ignores multipath and the mounting calibration's own error.
    pub std_floor_rad: f64,
    /// Use the baseline pitch when the fix carries one.
    pub use_pitch: bool,
}

impl HeadingConfig {
    /// Valid: finite angles, floor ≥ 0.
    pub fn is_valid(&self) -> bool {
        self.mount_yaw_rad.is_finite()
            && self.mount_pitch_rad.is_finite()
            && self.std_floor_rad.is_finite()
            && self.std_floor_rad >= 0.0
    }
}

/// Body-frame unit baseline from its mounting angles (module docs).
pub fn baseline_b(mount_yaw: f64, mount_pitch: f64) -> Vec3 {
    let (sy, cy) = mount_yaw.sin_cos();
    let (sp, cp) = mount_pitch.sin_cos();
    Vec3::new(cp * cy, cp * sy, -sp)
}

/// Heading and pitch of the NED direction `u_n` [rad], and their
/// Jacobians over the attitude error φ.
pub fn angles_and_rows(u_n: &Vec3) -> (f64, f64, [f64; 3], [f64; 3]) {
    let rho2 = u_n.x * u_n.x + u_n.y * u_n.y;
    let rho = rho2.sqrt();
    let n2 = rho2 + u_n.z * u_n.z;
    let psi = u_n.y.atan2(u_n.x);
    let theta = (-u_n.z).atan2(rho);
    let d_psi = Vec3::new(-u_n.y / rho2, u_n.x / rho2, 0.0);
    let d_theta = Vec3::new(
        u_n.x * u_n.z / (rho * n2),
        u_n.y * u_n.z / (rho * n2),
        -rho / n2,
    );
    let s = skew(u_n);
    let hp = s.transpose() * d_psi;
    let ht = s.transpose() * d_theta;
    (psi, theta, [hp.x, hp.y, hp.z], [ht.x, ht.y, ht.z])
}

/// Heading (1 row) or heading + pitch (2 rows) update of a fix against the
/// filter's `c_bn`: `(dz, H, R diagonal)` with `dz = ẑ − z` wrapped.
pub fn rows<const M: usize>(
    c_bn: &Mat3,
    u_b: &Vec3,
    fix: &HeadingFix,
    std_floor: f64,
) -> (SVector<f64, M>, SMatrix<f64, M, NX>, SVector<f64, M>) {
    let u_n = c_bn * u_b;
    let (psi, theta, hp, ht) = angles_and_rows(&u_n);
    let mut dz = SVector::<f64, M>::zeros();
    let mut h = SMatrix::<f64, M, NX>::zeros();
    let mut r = SVector::<f64, M>::zeros();
    dz[0] = super::wrap_pi(psi - fix.heading_rad);
    let s = fix.std_heading_rad.max(std_floor);
    r[0] = s * s;
    for k in 0..3 {
        h[(0, I_ATT + k)] = hp[k];
    }
    if M > 1 {
        dz[1] = theta - fix.pitch_rad;
        let s = fix.std_pitch_rad.max(std_floor);
        r[1] = s * s;
        for k in 0..3 {
            h[(1, I_ATT + k)] = ht[k];
        }
    }
    (dz, h, r)
}

#[inline]
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins::mech::quat_from_rotvec;
    use crate::HeadingSource;

    fn fix(psi: f64, theta: f64) -> HeadingFix {
        HeadingFix {
            t: 0.0,
            heading_rad: psi,
            pitch_rad: theta,
            std_heading_rad: 0.01,
            std_pitch_rad: 0.02,
            baseline_m: 1.0,
            source: HeadingSource::DualAntenna,
        }
    }

    #[test]
    fn level_body_x_baseline_reads_the_yaw_and_its_row_is_minus_one() {
        let c = quat_from_rotvec(&Vec3::new(0.0, 0.0, 3.0))
            .to_rotation_matrix()
            .into_inner();
        let (dz, h, r) = rows::<1>(&c, &baseline_b(0.0, 0.0), &fix(-3.0, 0.0), 0.0);
        // 3 − (−3) = 6 wraps to 6 − 2π.
        assert!((dz[0] - (6.0 - 2.0 * core::f64::consts::PI)).abs() < 1e-12);
        assert!((h[(0, I_ATT + 2)] + 1.0).abs() < 1e-12 && h[(0, I_ATT)].abs() < 1e-12);
        assert!((r[0] - 1e-4).abs() < 1e-18);
    }

    #[test]
    fn jacobian_matches_numerical_differences() {
        let c = quat_from_rotvec(&Vec3::new(0.1, -0.2, 1.0))
            .to_rotation_matrix()
            .into_inner();
        let u_b = baseline_b(1.2, 0.3);
        let (dz0, h, _) = rows::<2>(&c, &u_b, &fix(0.0, 0.0), 0.0);
        let e = 1e-7;
        for k in 0..3 {
            let mut d = Vec3::zeros();
            d[k] = e;
            let c_hat = (Mat3::identity() - skew(&d)) * c;
            let (dz, _, _) = rows::<2>(&c_hat, &u_b, &fix(0.0, 0.0), 0.0);
            for r in 0..2 {
                let num = (dz[r] - dz0[r]) / e;
                assert!(
                    (num - h[(r, I_ATT + k)]).abs() < 1e-5,
                    "{r} {k}: {num} {}",
                    h[(r, I_ATT + k)]
                );
            }
        }
    }
}
