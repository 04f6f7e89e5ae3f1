//! Magnetometer heading with the World Magnetic Model declination and a
//! disturbance gate (issue 17).
//!
//! **Model.** The calibrated body field `m_b` rotated with the filter's
//! attitude, `m̂_n = Ĉ_bn m_b`, points (horizontally) at the declination `D`
//! of [`super::wmm`] when the attitude is right; with an attitude error it
//! is rotated by it exactly as any body direction ([`super::heading`]):
//! innovation `dz = wrap(atan2(m̂_E, m̂_N) − D)`, `H = ∂ψ/∂φ` of `m̂_n`.
//! Using the full `Ĉ_bn` is the levelling with the filter's roll and pitch;
//! their errors enter through the x/y terms of `H` (∝ tan I), as they must.
//! `R = (σ_m/|m̂_h|)² + σ_D²`: the sensor noise across the horizontal field,
//! plus the WMM declination uncertainty (crustal fields, `wmm::declination_std`).
//!
//! **Disturbance gate.** Iron nearby, currents or a bad calibration change
//! the field's magnitude and its dip before anything else. A sample is
//! rejected (counted as disturbed, not an innovation) when
//! `| |m_b| − F | > k σ_F` or `|I_meas − I| > k σ_I`, with
//! `σ_F = √(σ_m² + (ε F)²)`, `σ_I = √((σ_m/F)² + ε²)`: `σ_m` the per-axis
//! noise, `ε` the relative residual of the hard/soft-iron calibration
//! (a relative error ε of the vector changes its norm by ≤ εF and its
//! direction by ≤ ε rad), `k = √χ²₁(p)` with the filter's gate probability.
//! A distorted field that keeps magnitude and dip is left to the χ² gate.

use super::heading::angles_and_rows;
use super::wmm::Field;
use crate::estimators::eskf::{I_ATT, NX};
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::SMatrix;

/// Magnetometer aiding configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagConfig {
    /// Per-axis white noise 1-σ of the calibrated field [T].
    pub std_t: f64,
    /// Date of the run for the WMM [decimal year] (GPS seconds of week do
    /// not carry the date).
    pub decimal_year: f64,
    /// Relative residual of the hard/soft-iron calibration ε (0.02 = 2 %).
    pub calib_residual: f64,
    /// Minimum time between updates [s] (the field noise is white, the
    /// disturbances are not: 10 Hz of a 100 Hz sensor is plenty).
    pub interval_s: f64,
}

impl MagConfig {
    /// Valid: σ > 0, finite year, ε ≥ 0, interval ≥ 0.
    pub fn is_valid(&self) -> bool {
        self.std_t.is_finite()
            && self.std_t > 0.0
            && self.decimal_year.is_finite()
            && self.calib_residual.is_finite()
            && self.calib_residual >= 0.0
            && self.interval_s >= 0.0
    }
}

/// Why a magnetometer sample was not used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MagReject {
    /// Magnitude or dip differs from the WMM beyond the gate.
    Disturbed,
    /// Horizontal field too weak to give a heading (near the magnetic poles).
    NoHorizontal,
}

/// The heading update of one sample: `(dz, H row, R)` or why not.
/// `k` is the disturbance gate in σ (`√χ²₁(p)`).
pub fn heading_row(
    c_bn: &Mat3,
    m_b: &Vec3,
    wmm: &Field,
    cfg: &MagConfig,
    decl_std: f64,
    k: f64,
) -> Result<(f64, SMatrix<f64, 1, NX>, f64), MagReject> {
    let f = wmm.total;
    let eps = cfg.calib_residual;
    let s_f = (cfg.std_t * cfg.std_t + (eps * f) * (eps * f)).sqrt();
    let s_i = ((cfg.std_t / f) * (cfg.std_t / f) + eps * eps).sqrt();
    let m_n = c_bn * m_b;
    let m_h = m_n.xy().norm();
    let incl = m_n.z.atan2(m_h);
    if (m_b.norm() - f).abs() > k * s_f || (incl - wmm.inclination).abs() > k * s_i {
        return Err(MagReject::Disturbed);
    }
    if m_h < 5.0 * cfg.std_t {
        return Err(MagReject::NoHorizontal);
    }
    let (psi, _, hp, _) = angles_and_rows(&m_n);
    let mut h = SMatrix::<f64, 1, NX>::zeros();
    for j in 0..3 {
        h[(0, I_ATT + j)] = hp[j];
    }
    let s_psi = cfg.std_t / m_h;
    Ok((
        super::wrap_pi(psi - wmm.declination),
        h,
        s_psi * s_psi + decl_std * decl_std,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins::mech::quat_from_rotvec;
    use crate::measurements::wmm;

    fn cfg() -> MagConfig {
        MagConfig {
            std_t: 0.3e-6,
            decimal_year: 2026.9,
            calib_residual: 0.02,
            interval_s: 0.1,
        }
    }

    #[test]
    fn heading_error_shows_as_the_innovation_and_disturbances_are_gated() {
        let w = wmm::field(0.53, 1.99, 25.0, 2026.9).unwrap();
        let c_true = quat_from_rotvec(&Vec3::new(0.05, 0.02, 1.0))
            .to_rotation_matrix()
            .into_inner();
        let m_b = c_true.transpose() * w.b_n;
        // Filter yaw 2° too large: Ĉ = R_z(2°) C.
        let c_hat = quat_from_rotvec(&Vec3::new(0.0, 0.0, 2f64.to_radians()))
            .to_rotation_matrix()
            .into_inner()
            * c_true;
        let (dz, h, r) = heading_row(&c_hat, &m_b, &w, &cfg(), 0.0, 4.0).unwrap();
        assert!((dz - 2f64.to_radians()).abs() < 1e-9, "{dz}");
        assert!((h[(0, I_ATT + 2)] + 1.0).abs() < 1e-9);
        assert!(r > 0.0);
        // 10 % stronger field: a disturbance.
        let e = heading_row(&c_true, &(m_b * 1.1), &w, &cfg(), 0.0, 4.0);
        assert_eq!(e.unwrap_err(), MagReject::Disturbed);
    }
}
