//! Attitude representations and conversions.
//!
//! Conventions: `c_bn` is the body→navigation DCM (`v_n = c_bn · v_b`);
//! `q_bn` the equivalent unit quaternion (Hamilton, scalar first:
//! `Quaternion::new(w, x, y, z)`, `v_n = q_bn ⊗ v_b ⊗ q_bn*`);
//! Euler angles `rpy = (roll φ, pitch θ, yaw ψ)` in the ZYX sequence,
//! `c_bn = Rz(ψ) Ry(θ) Rx(φ)` (`SEEDS.md §1` eq. 3–4; Groves 2nd ed. §2.2).
//! Yaw is wrapped to (−π, π]. Rotation vectors `phi` [rad]
//! are axis·angle with `c = exp([phi×])` (Groves §2.2.4).
//!
//! Gimbal lock: where `cos θ` is below [`GIMBAL_LOCK_COS`], roll and yaw are not
//! separable; [`euler_from_dcm`] then returns roll = 0 and puts the whole
//! rotation about the vertical into yaw.

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use core::f64::consts::PI;
use nalgebra::{Quaternion, SMatrix};

mod svd3;
pub use svd3::{proper_svd3, ProperSvd3};

/// `cos θ` below which [`euler_from_dcm`] treats the pitch as ±90° (roll set to 0).
pub const GIMBAL_LOCK_COS: f64 = 1e-10;

/// Skew-symmetric (cross-product) matrix: `skew(a) · b = a × b`.
pub fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// DCM `c_bn` from roll, pitch, yaw (ZYX) [rad] (`SEEDS.md §1` eq. 3; Groves 2nd ed. §2.2.2).
pub fn dcm_from_euler(rpy: &Vec3) -> Mat3 {
    let (sr, cr) = rpy.x.sin_cos();
    let (sp, cp) = rpy.y.sin_cos();
    let (sy, cy) = rpy.z.sin_cos();
    Mat3::new(
        cp * cy,
        -cr * sy + sr * sp * cy,
        sr * sy + cr * sp * cy,
        cp * sy,
        cr * cy + sr * sp * sy,
        -sr * cy + cr * sp * sy,
        -sp,
        sr * cp,
        cr * cp,
    )
}

/// Roll, pitch, yaw (ZYX) [rad] from `c_bn` (`SEEDS.md §1` eq. 4; Groves §2.2.2),
/// robust near ±90° pitch.
///
/// θ = atan2(−C31, √(C11² + C21²)), ψ = atan2(C21, C11), and roll from the
/// yaw-compensated second/third columns,
/// φ = atan2(sψ C13 − cψ C23, cψ C22 − sψ C12), which is exact for any ψ and
/// so stays consistent when ψ itself is poorly conditioned. At gimbal lock
/// (`cos θ <` [`GIMBAL_LOCK_COS`]) roll is 0 and ψ = atan2(−C12, C22).
pub fn euler_from_dcm(c_bn: &Mat3) -> Vec3 {
    let c = c_bn;
    let cos_pitch = c[(0, 0)].hypot(c[(1, 0)]);
    let pitch = (-c[(2, 0)]).atan2(cos_pitch);
    let (roll, yaw) = if cos_pitch < GIMBAL_LOCK_COS {
        (0.0, (-c[(0, 1)]).atan2(c[(1, 1)]))
    } else {
        let yaw = c[(1, 0)].atan2(c[(0, 0)]);
        let (sy, cy) = yaw.sin_cos();
        let roll = (sy * c[(0, 2)] - cy * c[(1, 2)]).atan2(cy * c[(1, 1)] - sy * c[(0, 1)]);
        (roll, yaw)
    };
    Vec3::new(wrap_pi(roll), pitch, wrap_pi(yaw))
}

/// Quaternion `q_bn` from roll, pitch, yaw [rad]: `q = q_z(ψ) ⊗ q_y(θ) ⊗ q_x(φ)`
/// (Groves §2.2.3).
pub fn quat_from_euler(rpy: &Vec3) -> Quaternion<f64> {
    let (sr, cr) = (0.5 * rpy.x).sin_cos();
    let (sp, cp) = (0.5 * rpy.y).sin_cos();
    let (sy, cy) = (0.5 * rpy.z).sin_cos();
    Quaternion::new(
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )
}

/// Roll, pitch, yaw [rad] from `q_bn` (via the DCM, same gimbal-lock rule as
/// [`euler_from_dcm`]).
pub fn euler_from_quat(q_bn: &Quaternion<f64>) -> Vec3 {
    euler_from_dcm(&dcm_from_quat(q_bn))
}

/// DCM from a quaternion (Groves §2.2.3). Non-unit input is treated as its
/// normalised direction (the formula divides by |q|²).
pub fn dcm_from_quat(q: &Quaternion<f64>) -> Mat3 {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let n2 = w * w + x * x + y * y + z * z;
    let s = 2.0 / n2;
    let (wx, wy, wz) = (s * w * x, s * w * y, s * w * z);
    let (xx, xy, xz) = (s * x * x, s * x * y, s * x * z);
    let (yy, yz, zz) = (s * y * y, s * y * z, s * z * z);
    Mat3::new(
        1.0 - yy - zz,
        xy - wz,
        xz + wy,
        xy + wz,
        1.0 - xx - zz,
        yz - wx,
        xz - wy,
        yz + wx,
        1.0 - xx - yy,
    )
}

/// Unit quaternion from a DCM (Shepperd's method), scalar part ≥ 0.
///
/// Picks the largest of 4w², 4x², 4y², 4z² (from the trace and diagonal) as
/// the pivot, so it is accurate for every rotation including 180°.
pub fn quat_from_dcm(c: &Mat3) -> Quaternion<f64> {
    let tr = c.trace();
    let d = [tr, c[(0, 0)], c[(1, 1)], c[(2, 2)]];
    let mut k = 0;
    for i in 1..4 {
        if d[i] > d[k] {
            k = i;
        }
    }
    let q = match k {
        0 => {
            let r = (1.0 + tr).sqrt();
            let s = 0.5 / r;
            Quaternion::new(
                0.5 * r,
                (c[(2, 1)] - c[(1, 2)]) * s,
                (c[(0, 2)] - c[(2, 0)]) * s,
                (c[(1, 0)] - c[(0, 1)]) * s,
            )
        }
        1 => {
            let r = (1.0 + 2.0 * c[(0, 0)] - tr).sqrt();
            let s = 0.5 / r;
            Quaternion::new(
                (c[(2, 1)] - c[(1, 2)]) * s,
                0.5 * r,
                (c[(0, 1)] + c[(1, 0)]) * s,
                (c[(0, 2)] + c[(2, 0)]) * s,
            )
        }
        2 => {
            let r = (1.0 + 2.0 * c[(1, 1)] - tr).sqrt();
            let s = 0.5 / r;
            Quaternion::new(
                (c[(0, 2)] - c[(2, 0)]) * s,
                (c[(0, 1)] + c[(1, 0)]) * s,
                0.5 * r,
                (c[(1, 2)] + c[(2, 1)]) * s,
            )
        }
        _ => {
            let r = (1.0 + 2.0 * c[(2, 2)] - tr).sqrt();
            let s = 0.5 / r;
            Quaternion::new(
                (c[(1, 0)] - c[(0, 1)]) * s,
                (c[(0, 2)] + c[(2, 0)]) * s,
                (c[(1, 2)] + c[(2, 1)]) * s,
                0.5 * r,
            )
        }
    };
    let q = quat_normalize(&q);
    if q.w < 0.0 {
        -q
    } else {
        q
    }
}

/// Quaternion of the rotation vector `phi` [rad] (exponential map, Groves §2.2.4):
/// `q = (cos(|φ|/2), sin(|φ|/2)/|φ| · φ)`, with a Taylor series for small |φ|.
pub fn quat_from_rotvec(phi: &Vec3) -> Quaternion<f64> {
    let a2 = phi.norm_squared();
    let a = a2.sqrt();
    // sin(a/2)/a = 1/2 − a²/48 + a⁴/3840 − …; truncation < 1e-20 for a < 1e-3.
    let k = if a < 1e-3 {
        0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    } else {
        (0.5 * a).sin() / a
    };
    Quaternion::from_parts((0.5 * a).cos(), phi * k)
}

/// Rotation vector [rad] of a unit quaternion (logarithm map), |φ| ≤ π.
///
/// Uses `θ = 2·atan2(|v|, |w|)` (accurate near 0 and near π) with the sign of `q`
/// chosen so that `w ≥ 0`; the scale of `q` cancels.
pub fn rotvec_from_quat(q: &Quaternion<f64>) -> Vec3 {
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    if s == 0.0 {
        return Vec3::zeros();
    }
    // atan2 keeps full relative precision for small s, so θ/s is accurate.
    let theta = 2.0 * s.atan2(w);
    v * (theta / s)
}

/// DCM of the rotation vector `phi` [rad] (Rodrigues, Groves §2.2.4):
/// `C = I + (sin a / a) [φ×] + ((1 − cos a)/a²) [φ×]²`, a = |φ|.
pub fn dcm_from_rotvec(phi: &Vec3) -> Mat3 {
    let a2 = phi.norm_squared();
    let a = a2.sqrt();
    let (ka, kb) = if a < 1e-4 {
        // sin a / a and (1 − cos a)/a² series; truncation < 1e-21.
        (
            1.0 - a2 / 6.0 + a2 * a2 / 120.0,
            0.5 - a2 / 24.0 + a2 * a2 / 720.0,
        )
    } else {
        let h = (0.5 * a).sin() / a;
        // 1 − cos a = 2 sin²(a/2): no cancellation.
        (a.sin() / a, 2.0 * h * h)
    };
    let k = skew(phi);
    Mat3::identity() + k * ka + k * k * kb
}

/// Rotation vector [rad] of a DCM (via Shepperd's quaternion, accurate up to |φ| = π).
pub fn rotvec_from_dcm(c: &Mat3) -> Vec3 {
    rotvec_from_quat(&quat_from_dcm(c))
}

/// Hamilton product `p ⊗ q` (Groves §2.2.3 convention: `q_ac = q_ab ⊗ q_bc`).
#[inline]
pub fn quat_mul(p: &Quaternion<f64>, q: &Quaternion<f64>) -> Quaternion<f64> {
    Quaternion::new(
        p.w * q.w - p.i * q.i - p.j * q.j - p.k * q.k,
        p.w * q.i + p.i * q.w + p.j * q.k - p.k * q.j,
        p.w * q.j - p.i * q.k + p.j * q.w + p.k * q.i,
        p.w * q.k + p.i * q.j - p.j * q.i + p.k * q.w,
    )
}

/// Rotate `v` by the unit quaternion `q`: `q ⊗ (0, v) ⊗ q*`
/// (e.g. `v_n = quat_rotate(q_bn, v_b)`).
#[inline]
pub fn quat_rotate(q: &Quaternion<f64>, v: &Vec3) -> Vec3 {
    let u = q.imag();
    let t = u.cross(v) * 2.0;
    v + t * q.w + u.cross(&t)
}

/// `q / |q|`. A zero or non-finite quaternion is returned unchanged (callers
/// that can produce one should check [`quat_is_finite_unit`]).
#[inline]
pub fn quat_normalize(q: &Quaternion<f64>) -> Quaternion<f64> {
    let n = q.norm();
    if n > 0.0 && n.is_finite() {
        q / n
    } else {
        *q
    }
}

/// True when every component is finite and |q| = 1 within `1e-9`.
pub fn quat_is_finite_unit(q: &Quaternion<f64>) -> bool {
    q.coords.iter().all(|x| x.is_finite()) && (q.norm() - 1.0).abs() < 1e-9
}

/// Body-frame attitude update `q_bn ← q_bn ⊗ q(Δθ_b)`, then renormalised
/// (Groves ch. 5 attitude update, without the nav-frame rotation term, which the caller
/// applies as `q_nn ⊗ q_bn` if needed). `dtheta_b` is the body rotation
/// increment [rad] over the step (coning-corrected by the caller).
#[inline]
pub fn quat_update(q_bn: &mut Quaternion<f64>, dtheta_b: &Vec3) {
    *q_bn = quat_normalize(&quat_mul(q_bn, &quat_from_rotvec(dtheta_b)));
}

/// Nearest rotation matrix (SVD polar factor, singular values set to 1; seed 002,
/// `SEEDS.md §2`).
///
/// `C = U Σ Vᵀ ⇒ C ← U diag(1, 1, d) Vᵀ` with `d = det(U Vᵀ)`, so a result with
/// det −1 (reflection) is never returned: for det C < 0 the axis of the smallest
/// singular value is flipped, the nearest proper rotation in Frobenius norm.
/// A matrix with a non-finite entry is returned unchanged (NaN stays visible).
pub fn orthonormalize(c: &Mat3) -> Mat3 {
    match proper_svd3(c) {
        // U and V are proper rotations, so U Vᵀ already has det +1.
        Some(d) => d.u * d.v.transpose(),
        None => *c,
    }
}

/// Wahba's problem by SVD (Markley 1988): the `c_bn` minimising
/// Σ wᵢ |v_n,i − c_bn v_b,i|².
///
/// `B = Σ wᵢ v_n,i v_b,iᵀ = U S Vᵀ`, `c_bn = U diag(1, 1, det U det V) Vᵀ`.
/// Returns `None` when the observations do not determine a rotation: slice
/// lengths differ, fewer than 2 observations, a weight negative or non-finite,
/// a non-finite vector, or all vectors (nearly) parallel (`s2 + d·s3 ≤ 1e-10 s1`,
/// Markley's uniqueness condition).
pub fn wahba_svd(v_b: &[Vec3], v_n: &[Vec3], weights: &[f64]) -> Option<Mat3> {
    if v_b.len() != v_n.len() || v_b.len() != weights.len() || v_b.len() < 2 {
        return None;
    }
    let mut b = Mat3::zeros();
    for ((vb, vn), &w) in v_b.iter().zip(v_n).zip(weights) {
        if !w.is_finite() || w < 0.0 {
            return None;
        }
        b += vn * vb.transpose() * w;
    }
    let d = proper_svd3(&b)?;
    // With proper U, V the signed s3 already includes det U det V.
    if d.s[0] <= 0.0 || d.s[1] + d.s[2] <= 1e-10 * d.s[0] {
        return None;
    }
    Some(d.u * d.v.transpose())
}

/// Least-squares attitude from baselines (seed 003, `SEEDS.md §3` eq. 3–4):
/// `R_b = C R_n ⇒ C = R_b R_nᵀ (R_n R_nᵀ)⁻¹`.
///
/// Columns of `r_b` / `r_n` are the same K baselines in the body and the
/// navigation frame, so `C` maps nav→body (`c_bn = Cᵀ`). The result is the
/// unconstrained LS matrix, not exactly orthonormal with noisy baselines;
/// pass it through [`orthonormalize`] or use [`wahba_svd`] for the optimal
/// rotation. `None` when the baselines are coplanar / rank-deficient
/// (det(R_n R_nᵀ) ≤ 1e-12 · (tr/3)³) or non-finite.
pub fn dcm_from_baselines_ls<const K: usize>(
    r_b: &SMatrix<f64, 3, K>,
    r_n: &SMatrix<f64, 3, K>,
) -> Option<Mat3> {
    if !r_b.iter().chain(r_n.iter()).all(|x| x.is_finite()) {
        return None;
    }
    let nnt: Mat3 = r_n * r_n.transpose();
    let tr = nnt.trace() / 3.0;
    let det = nnt.determinant();
    if tr <= 0.0 || det <= 1e-12 * tr * tr * tr {
        return None;
    }
    let inv = nnt.try_inverse()?;
    Some(r_b * r_n.transpose() * inv)
}

/// Wrap an angle to (−π, π]. Non-finite input gives NaN.
pub fn wrap_pi(a: f64) -> f64 {
    if a > -PI && a <= PI {
        return a;
    }
    if !a.is_finite() {
        return f64::NAN;
    }
    let two_pi = 2.0 * PI;
    // r ∈ [0, 2π) ⇒ π − r ∈ (−π, π].
    let x = PI - a;
    let mut r = x - two_pi * (x / two_pi).floor();
    if r >= two_pi {
        r -= two_pi;
    }
    if r < 0.0 {
        r += two_pi;
    }
    PI - r
}

#[cfg(test)]
mod tests;
