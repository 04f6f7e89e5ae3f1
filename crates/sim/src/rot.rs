//! Private rotation helpers (ZYX Euler ↔ DCM, rotation vector).
//!
//! `navfuse_core::attitude` is still a contract stub on `main`; these few
//! functions are written here so the simulator can work today. Switch to the
//! core versions once they land (same conventions: `c_bn` body→NED, FRD/NED,
//! roll/pitch/yaw ZYX; Groves 2nd ed. eq. 2.22, 2.24).

use navfuse_core::{Mat3, Vec3};

/// `c_bn` from roll, pitch, yaw (ZYX) [rad] (Groves eq. 2.22, transposed).
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

/// Roll, pitch, yaw (ZYX) [rad] from `c_bn` (Groves eq. 2.24); yaw in (−π, π].
pub fn euler_from_dcm(c: &Mat3) -> Vec3 {
    let pitch = (-c[(2, 0)]).clamp(-1.0, 1.0).asin();
    Vec3::new(
        c[(2, 1)].atan2(c[(2, 2)]),
        pitch,
        wrap_pi(c[(1, 0)].atan2(c[(0, 0)])),
    )
}

/// Skew-symmetric matrix: `skew(a)·b = a × b`.
pub fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// DCM of a rotation vector (Rodrigues; Groves eq. 2.39).
pub fn dcm_from_rotvec(phi: &Vec3) -> Mat3 {
    let a = phi.norm();
    let k = skew(phi);
    if a < 1e-8 {
        return Mat3::identity() + k + 0.5 * k * k;
    }
    Mat3::identity() + (a.sin() / a) * k + ((1.0 - a.cos()) / (a * a)) * k * k
}

/// Wrap an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let mut x = a % (2.0 * core::f64::consts::PI);
    if x > core::f64::consts::PI {
        x -= 2.0 * core::f64::consts::PI;
    } else if x <= -core::f64::consts::PI {
        x += 2.0 * core::f64::consts::PI;
    }
    x
}

/// Euler-angle rates → body angular rate ω_nb^b (ZYX; Groves eq. 2.58 inverse).
pub fn omega_nb_b_from_euler_rates(rpy: &Vec3, rpy_dot: &Vec3) -> Vec3 {
    let (sr, cr) = rpy.x.sin_cos();
    let (sp, cp) = rpy.y.sin_cos();
    Vec3::new(
        rpy_dot.x - rpy_dot.z * sp,
        rpy_dot.y * cr + rpy_dot.z * sr * cp,
        -rpy_dot.y * sr + rpy_dot.z * cr * cp,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_round_trip_and_orthonormal() {
        let rpy = Vec3::new(0.3, -0.4, 2.9);
        let c = dcm_from_euler(&rpy);
        assert!((c * c.transpose() - Mat3::identity()).norm() < 1e-14);
        assert!((euler_from_dcm(&c) - rpy).norm() < 1e-12);
        // Yaw only: body x axis points along (cos ψ, sin ψ, 0) in NED.
        let c = dcm_from_euler(&Vec3::new(0.0, 0.0, 0.5));
        assert!((c * Vec3::x() - Vec3::new(0.5f64.cos(), 0.5f64.sin(), 0.0)).norm() < 1e-15);
    }

    #[test]
    fn euler_rates_match_dcm_derivative() {
        // Ċ_bn = C_bn [ω_nb^b ×], checked by finite differences.
        let rpy = Vec3::new(0.2, 0.1, -1.0);
        let rate = Vec3::new(0.05, -0.03, 0.2);
        let dt = 1e-6;
        let c0 = dcm_from_euler(&(rpy - rate * dt));
        let c1 = dcm_from_euler(&(rpy + rate * dt));
        let cdot = (c1 - c0) / (2.0 * dt);
        let w = omega_nb_b_from_euler_rates(&rpy, &rate);
        let expect = dcm_from_euler(&rpy) * skew(&w);
        assert!((cdot - expect).norm() < 1e-8);
    }
}
