//! Odometer (wheel speed) measurement model (issue 17).
//!
//! **Geometry.** The wheel reference point (rear-axle centre, or the wheel
//! of `OdometerSample::wheel`) sits at `l_b` from the IMU, body FRD. Its
//! velocity in the body frame is (Groves 2nd ed. §16.3.2, eq. 16.44)
//!
//! `v_w^b = C_nb v_n + ω_nb^b × l_b ≈ C_nb v_n + ω_ib^b × l_b`;
//!
//! the earth-rate and transport-rate parts of `ω_nb = ω_ib − C_nb(ω_ie + ω_en)`
//! are neglected: |ω_ie| = 7.3e-5 rad/s times a lever arm ≤ 3 m is < 0.25 mm/s.
//!
//! **Measurement** (sign convention: positive forward, along body +x):
//! `z = (1 + s) · v̄_w,x + v`, with `s` the odometer scale-factor error (a
//! wheel radius 1 % too small in the conversion gives `s = +0.01`) and
//! `v̄` the speed averaged over the sample's interval `dt`, predicted as
//! `v_w,x(t) − a_x dt/2` with `a_x` the forward acceleration
//! (`a_b = f_b + C_nb g_n`; body-rate and Coriolis terms of the derivative
//! neglected, second order for a car). `s` is an augmented ESKF state
//! (random walk, `eskf::aug`), error `δs = ŝ − s`.
//!
//! **NHC at the same point.** The wheel does not slip sideways nor leave
//! the road: `v_w,y = v_w,z = 0`, rows 2–3 of the same `v_w^b` (the filter's
//! plain NHC applies the constraint at the IMU instead, where a lever arm
//! to the axle makes it wrong by `ω × l`).
//!
//! **Jacobians** (`C_bn = (I + [φ×]) Ĉ_bn`, `δx = x̂ − x`):
//! `∂v̂_w/∂δv = Ĉ_nb`, `∂v̂_w/∂φ = −Ĉ_nb [v̂_n×]`, `∂v̂_w/∂δb_g = [l_b×]`
//! (ω̂ = ω̃ − b̂_g, so ω̂ × l = −[l×] ω̂), `∂ẑ/∂δs = v̂_w,x`.

use crate::estimators::eskf::{I_ATT, I_BG, I_VEL, NX};
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

/// Odometer aiding configuration (`None` in [`crate::estimators::eskf::AidingConfig`]: off).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometerConfig {
    /// Wheel reference point (wheel 0) from the IMU, body FRD [m].
    pub lever_arm_b: Vec3,
    /// 1-σ of one speed sample when the source gives none [m/s].
    pub std_mps: f64,
    /// Initial 1-σ of the scale-factor error (fraction, 0.01 = 1 %).
    pub scale_std: f64,
    /// Random-walk PSD of the scale factor [1/s] (tyre wear, pressure and
    /// temperature change it over hours; 0: a constant).
    pub scale_rw_psd: f64,
    /// 1-σ of the lateral and vertical wheel velocity for the NHC rows
    /// [m/s]; `None`: forward speed only.
    pub nhc_std: Option<f64>,
    /// Samples further than this from the filter time are dropped [s].
    pub max_age_s: f64,
}

impl OdometerConfig {
    /// Valid: finite lever arm, σ > 0, scale σ > 0, PSD ≥ 0, NHC σ > 0, age > 0.
    pub fn is_valid(&self) -> bool {
        self.lever_arm_b.iter().all(|v| v.is_finite())
            && self.std_mps.is_finite()
            && self.std_mps > 0.0
            && self.scale_std.is_finite()
            && self.scale_std > 0.0
            && self.scale_rw_psd.is_finite()
            && self.scale_rw_psd >= 0.0
            && self.nhc_std.is_none_or(|s| s.is_finite() && s > 0.0)
            && self.max_age_s > 0.0
    }
}

/// Predicted wheel velocity `v̂_w^b` [m/s] and its Jacobian over the
/// 21 error states (see the module documentation).
pub fn wheel_velocity(
    c_bn: &Mat3,
    v_n: &Vec3,
    w_ib_b: &Vec3,
    lever_b: &Vec3,
) -> (Vec3, SMatrix<f64, 3, NX>) {
    let c_nb = c_bn.transpose();
    let v_b = c_nb * v_n + w_ib_b.cross(lever_b);
    let mut h = SMatrix::<f64, 3, NX>::zeros();
    h.fixed_view_mut::<3, 3>(0, I_VEL).copy_from(&c_nb);
    h.fixed_view_mut::<3, 3>(0, I_ATT)
        .copy_from(&(-(c_nb * skew(v_n))));
    h.fixed_view_mut::<3, 3>(0, I_BG).copy_from(&skew(lever_b));
    (v_b, h)
}

/// One odometer update, ready for the filter: innovation `dz = ẑ − z`,
/// Jacobian over the 21 states, over the scale state, and `R` (diagonal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometerRows<const M: usize> {
    pub dz: SVector<f64, M>,
    pub h: SMatrix<f64, M, NX>,
    pub h_scale: SVector<f64, M>,
    pub r_diag: SVector<f64, M>,
}

/// Rows of the odometer update: forward speed (row 0) and, for `M = 3`,
/// the NHC rows at the wheel. `speed` measured [m/s] with 1-σ `std`,
/// `scale` the current `ŝ`, `a_fwd` the forward acceleration [m/s²] and
/// `dt` the sample's averaging interval [s].
#[allow(clippy::too_many_arguments)]
pub fn rows<const M: usize>(
    v_b: &Vec3,
    h_v: &SMatrix<f64, 3, NX>,
    scale: f64,
    speed: f64,
    std: f64,
    nhc_std: f64,
    a_fwd: f64,
    dt: f64,
) -> OdometerRows<M> {
    let v_fwd = v_b.x - a_fwd * 0.5 * dt.max(0.0);
    let mut dz = SVector::<f64, M>::zeros();
    let mut h = SMatrix::<f64, M, NX>::zeros();
    let mut h_scale = SVector::<f64, M>::zeros();
    let mut r_diag = SVector::<f64, M>::repeat(nhc_std * nhc_std);
    dz[0] = (1.0 + scale) * v_fwd - speed;
    h.set_row(0, &(h_v.row(0) * (1.0 + scale)));
    h_scale[0] = v_fwd;
    r_diag[0] = std * std;
    for k in 1..M {
        dz[k] = v_b[k];
        h.set_row(k, &h_v.row(k));
    }
    OdometerRows {
        dz,
        h,
        h_scale,
        r_diag,
    }
}

#[inline]
fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins::mech::quat_from_rotvec;

    /// The analytic Jacobian against central differences of the prediction,
    /// perturbing the true state the way the error state is defined.
    #[test]
    fn jacobian_matches_numerical_differences() {
        let q = quat_from_rotvec(&Vec3::new(0.05, -0.1, 2.0));
        let c_bn = q.to_rotation_matrix().into_inner();
        let v_n = Vec3::new(12.0, -7.0, 0.4);
        let w = Vec3::new(0.02, -0.03, 0.25);
        let l = Vec3::new(-1.4, 0.3, 0.5);
        let (v0, h) = wheel_velocity(&c_bn, &v_n, &w, &l);
        let e = 1e-6;
        for k in 0..3 {
            let mut d = Vec3::zeros();
            d[k] = e;
            // δv: v̂ = v + δv.
            let (vp, _) = wheel_velocity(&c_bn, &(v_n + d), &w, &l);
            let num = (vp - v0) / e;
            for r in 0..3 {
                assert!((num[r] - h[(r, I_VEL + k)]).abs() < 1e-6);
            }
            // φ: Ĉ_bn = (I − [φ×]) C_bn.
            let c_hat = (Mat3::identity() - skew(&d)) * c_bn;
            let (vp, _) = wheel_velocity(&c_hat, &v_n, &w, &l);
            let num = (vp - v0) / e;
            for r in 0..3 {
                assert!((num[r] - h[(r, I_ATT + k)]).abs() < 1e-4, "att {r} {k}");
            }
            // δb_g: ω̂ = ω − δb_g.
            let (vp, _) = wheel_velocity(&c_bn, &v_n, &(w - d), &l);
            let num = (vp - v0) / e;
            for r in 0..3 {
                assert!((num[r] - h[(r, I_BG + k)]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn scale_and_averaging_enter_the_forward_row_only() {
        let v_b = Vec3::new(10.0, 0.2, -0.1);
        let h_v = SMatrix::<f64, 3, NX>::from_fn(|r, c| (r * NX + c) as f64);
        let o = rows::<3>(&v_b, &h_v, 0.02, 10.0, 0.1, 0.3, 2.0, 0.1);
        // ẑ = 1.02 · (10 − 2·0.05) = 10.098.
        assert!((o.dz[0] - 0.098).abs() < 1e-12);
        assert!((o.h_scale[0] - 9.9).abs() < 1e-12);
        assert_eq!(o.h_scale[1], 0.0);
        assert_eq!((o.dz[1], o.dz[2]), (0.2, -0.1));
        assert!((o.h[(0, 5)] - 1.02 * 5.0).abs() < 1e-12);
        assert_eq!(o.h[(2, 5)], h_v[(2, 5)]);
        assert!((o.r_diag[0] - 0.01).abs() < 1e-15 && (o.r_diag[2] - 0.09).abs() < 1e-15);
    }
}
