//! Rotation helpers: the core attitude functions plus the Euler-rate
//! kinematics the trajectory generator needs (conventions of
//! `navfuse_core::attitude`: `c_bn` body→NED, FRD/NED, roll/pitch/yaw ZYX).

pub use navfuse_core::attitude::{dcm_from_euler, dcm_from_rotvec, euler_from_dcm, skew, wrap_pi};
use navfuse_core::Vec3;

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
    use navfuse_core::Mat3;

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
