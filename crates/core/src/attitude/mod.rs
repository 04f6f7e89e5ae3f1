//! Attitude representations and conversions (CONTRACT STUB — being filled in).
//!
//! Conventions: `c_bn` is the body→navigation DCM (`v_n = c_bn · v_b`);
//! `q_bn` the equivalent unit quaternion (Hamilton, scalar first);
//! Euler angles `rpy = (roll φ, pitch θ, yaw ψ)` in the ZYX sequence
//! (`SEEDS.md §1` eq. 3–4; Groves §2.2). Yaw is wrapped to (−π, π].

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::Quaternion;

/// Skew-symmetric (cross-product) matrix: `skew(a) · b = a × b`.
pub fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// DCM `c_bn` from roll, pitch, yaw (ZYX) [rad] (`SEEDS.md §1` eq. 3).
pub fn dcm_from_euler(rpy: &Vec3) -> Mat3 {
    let _ = rpy;
    unimplemented!()
}

/// Roll, pitch, yaw (ZYX) [rad] from `c_bn` (`SEEDS.md §1` eq. 4), robust near ±90° pitch.
pub fn euler_from_dcm(c_bn: &Mat3) -> Vec3 {
    let _ = c_bn;
    unimplemented!()
}

/// Quaternion `q_bn` from roll, pitch, yaw [rad].
pub fn quat_from_euler(rpy: &Vec3) -> Quaternion<f64> {
    let _ = rpy;
    unimplemented!()
}

/// Roll, pitch, yaw [rad] from `q_bn`.
pub fn euler_from_quat(q_bn: &Quaternion<f64>) -> Vec3 {
    let _ = q_bn;
    unimplemented!()
}

/// DCM from a unit quaternion.
pub fn dcm_from_quat(q: &Quaternion<f64>) -> Mat3 {
    let _ = q;
    unimplemented!()
}

/// Unit quaternion from a DCM (Shepperd's method), scalar part ≥ 0.
pub fn quat_from_dcm(c: &Mat3) -> Quaternion<f64> {
    let _ = c;
    unimplemented!()
}

/// Quaternion of the rotation vector `phi` [rad] (exponential map).
pub fn quat_from_rotvec(phi: &Vec3) -> Quaternion<f64> {
    let _ = phi;
    unimplemented!()
}

/// Rotation vector [rad] of a unit quaternion (logarithm map), |φ| ≤ π.
pub fn rotvec_from_quat(q: &Quaternion<f64>) -> Vec3 {
    let _ = q;
    unimplemented!()
}

/// DCM of the rotation vector `phi` [rad] (Rodrigues).
pub fn dcm_from_rotvec(phi: &Vec3) -> Mat3 {
    let _ = phi;
    unimplemented!()
}

/// Rotation vector [rad] of a DCM.
pub fn rotvec_from_dcm(c: &Mat3) -> Vec3 {
    let _ = c;
    unimplemented!()
}

/// Nearest rotation matrix (SVD polar factor, singular values set to 1; seed 002).
pub fn orthonormalize(c: &Mat3) -> Mat3 {
    let _ = c;
    unimplemented!()
}

/// Wahba's problem by SVD: the `c_bn` minimising Σ wᵢ |v_n,i − c_bn v_b,i|².
/// Returns `None` when the observations do not determine a rotation.
pub fn wahba_svd(v_b: &[Vec3], v_n: &[Vec3], weights: &[f64]) -> Option<Mat3> {
    let _ = (v_b, v_n, weights);
    unimplemented!()
}

/// Wrap an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let _ = a;
    unimplemented!()
}
