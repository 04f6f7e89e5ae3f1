use super::*;
use core::f64::consts::FRAC_PI_2;
use proptest::prelude::*;

fn rot_err(a: &Mat3, b: &Mat3) -> f64 {
    (a - b).abs().max()
}

fn angle_diff(a: f64, b: f64) -> f64 {
    wrap_pi(a - b).abs()
}

fn is_rotation(c: &Mat3, tol: f64) -> bool {
    (c.transpose() * c - Mat3::identity()).abs().max() < tol && (c.determinant() - 1.0).abs() < tol
}

/// Random unit quaternion from 4 components (rejecting tiny norms).
fn quat_strategy() -> impl Strategy<Value = Quaternion<f64>> {
    proptest::array::uniform4(-1.0f64..1.0)
        .prop_filter("non-degenerate", |a| {
            a.iter().map(|x| x * x).sum::<f64>() > 0.01
        })
        .prop_map(|a| quat_normalize(&Quaternion::new(a[0], a[1], a[2], a[3])))
}

fn euler_strategy() -> impl Strategy<Value = Vec3> {
    (-PI..PI, -FRAC_PI_2 + 1e-3..FRAC_PI_2 - 1e-3, -PI..PI).prop_map(|(r, p, y)| Vec3::new(r, p, y))
}

fn vec_strategy(r: f64) -> impl Strategy<Value = Vec3> {
    proptest::array::uniform3(-r..r).prop_map(Vec3::from)
}

#[test]
fn yaw_90_rotates_north_to_east() {
    let c = dcm_from_euler(&Vec3::new(0.0, 0.0, FRAC_PI_2));
    assert!((c * Vec3::x() - Vec3::y()).norm() < 1e-15);
    let q = quat_from_euler(&Vec3::new(0.0, 0.0, FRAC_PI_2));
    assert!((quat_rotate(&q, &Vec3::x()) - Vec3::y()).norm() < 1e-15);
}

#[test]
fn roll_and_pitch_signs() {
    // Roll +90°: right wing down, body y → nav down.
    let c = dcm_from_euler(&Vec3::new(FRAC_PI_2, 0.0, 0.0));
    assert!((c * Vec3::y() - Vec3::z()).norm() < 1e-15);
    // Pitch +90°: nose up, body x → nav up (−down).
    let c = dcm_from_euler(&Vec3::new(0.0, FRAC_PI_2, 0.0));
    assert!((c * Vec3::x() + Vec3::z()).norm() < 1e-15);
    // Composite: ZYX order, c_bn = Rz Ry Rx.
    let rpy = Vec3::new(0.3, -0.2, 1.1);
    let rx = dcm_from_euler(&Vec3::new(rpy.x, 0.0, 0.0));
    let ry = dcm_from_euler(&Vec3::new(0.0, rpy.y, 0.0));
    let rz = dcm_from_euler(&Vec3::new(0.0, 0.0, rpy.z));
    assert!(rot_err(&dcm_from_euler(&rpy), &(rz * ry * rx)) < 1e-15);
}

#[test]
fn wrap_pi_range() {
    assert_eq!(wrap_pi(PI), PI);
    assert_eq!(wrap_pi(-PI), PI);
    assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
    assert!((wrap_pi(-1.5 * PI) - FRAC_PI_2).abs() < 1e-12);
    assert!((wrap_pi(2.0 * PI + 0.1) - 0.1).abs() < 1e-12);
    assert!((wrap_pi(-2.0 * PI - 0.1) + 0.1).abs() < 1e-12);
    assert_eq!(wrap_pi(0.5), 0.5);
    assert!(wrap_pi(f64::INFINITY).is_nan());
    for k in -50..50 {
        let w = wrap_pi(k as f64 * 0.77);
        assert!(w > -PI && w <= PI, "{k}: {w}");
    }
}

#[test]
fn gimbal_lock_puts_rotation_in_yaw() {
    for &pitch in &[FRAC_PI_2, -FRAC_PI_2] {
        for &(roll, yaw) in &[(0.3, 1.0), (-2.0, 2.5), (1.0, -3.0)] {
            let c = dcm_from_euler(&Vec3::new(roll, pitch, yaw));
            let e = euler_from_dcm(&c);
            assert_eq!(e.x, 0.0, "roll must be 0 at gimbal lock");
            assert!((e.y - pitch).abs() < 1e-7);
            assert!(rot_err(&dcm_from_euler(&e), &c) < 1e-7);
            // At +90° only ψ − φ is observable, at −90° only ψ + φ.
            let expect = if pitch > 0.0 { yaw - roll } else { yaw + roll };
            assert!(angle_diff(e.z, expect) < 1e-7, "{e} {expect}");
        }
    }
}

#[test]
fn near_gimbal_lock_roundtrip_is_exact() {
    for &dp in &[1e-3, 1e-6, 1e-9, 1e-11, 1e-13] {
        for &pitch in &[FRAC_PI_2 - dp, -FRAC_PI_2 + dp] {
            let c = dcm_from_euler(&Vec3::new(0.7, pitch, -2.2));
            let e = euler_from_dcm(&c);
            let err = rot_err(&dcm_from_euler(&e), &c);
            if dp.sin() >= GIMBAL_LOCK_COS {
                assert!(err < 1e-14, "dp={dp}: {err}");
            } else {
                // Inside the lock band roll is forced to 0: error O(cos θ · |φ|).
                assert_eq!(e.x, 0.0);
                assert!(err < 4.0 * dp, "dp={dp}: {err}");
            }
        }
    }
}

#[test]
fn quat_product_matches_nalgebra_and_dcm() {
    let p = quat_from_euler(&Vec3::new(0.1, 0.2, 0.3));
    let q = quat_from_euler(&Vec3::new(-0.5, 0.4, 2.0));
    let pq = quat_mul(&p, &q);
    assert!((pq - p * q).norm() < 1e-15);
    // q_ac = q_ab ⊗ q_bc  ⇔  C_ac = C_ab C_bc.
    assert!(
        rot_err(
            &dcm_from_quat(&pq),
            &(dcm_from_quat(&p) * dcm_from_quat(&q))
        ) < 1e-15
    );
}

#[test]
fn quat_update_integrates_constant_rate() {
    let axis = Vec3::new(1.0, -2.0, 0.5).normalize();
    let q0 = quat_from_euler(&Vec3::new(0.1, -0.3, 0.8));
    let mut q = q0;
    let dtheta = axis * 1e-3;
    for _ in 0..2000 {
        quat_update(&mut q, &dtheta);
    }
    let expect = quat_mul(&q0, &quat_from_rotvec(&(axis * 2.0)));
    assert!((q - expect).norm() < 1e-12 || (q + expect).norm() < 1e-12);
    assert!((q.norm() - 1.0).abs() < 1e-15);
}

#[test]
fn rotvec_small_and_near_pi() {
    // Small angles: exp/log exact to relative precision.
    for &a in &[0.0, 1e-300, 1e-12, 1e-8, 1e-5, 1e-4, 1e-3, 2e-3] {
        let phi = Vec3::new(0.6, -0.8, 0.0) * a;
        let back = rotvec_from_quat(&quat_from_rotvec(&phi));
        assert!(
            (back - phi).norm() <= 1e-15 * a.max(1e-300) + 1e-300,
            "a={a}"
        );
        let back = rotvec_from_dcm(&dcm_from_rotvec(&phi));
        assert!(
            (back - phi).norm() <= 4e-16 * a + 1e-300,
            "dcm a={a}: {}",
            (back - phi).norm()
        );
        // DCM from the series agrees with the closed form at the switch points.
        let direct = Mat3::identity()
            + skew(&phi) * (a.sin() / a.max(1e-300))
            + skew(&phi) * skew(&phi) * ((1.0 - a.cos()) / (a * a).max(1e-300));
        if a > 1e-6 {
            assert!(rot_err(&dcm_from_rotvec(&phi), &direct) < 1e-15);
        }
    }
    // Near π the log must still recover the angle.
    for &eps in &[1e-3, 1e-6, 1e-9, 0.0] {
        let axis = Vec3::new(1.0, 2.0, -2.0) / 3.0;
        let phi = axis * (PI - eps);
        // At exactly π, φ and −φ are the same rotation.
        let close =
            |b: Vec3, tol: f64| (b - phi).norm() < tol || (eps == 0.0 && (b + phi).norm() < tol);
        let back = rotvec_from_dcm(&dcm_from_rotvec(&phi));
        assert!(close(back, 1e-8), "eps={eps}: {back}");
        let back = rotvec_from_quat(&quat_from_rotvec(&phi));
        assert!(close(back, 1e-12), "eps={eps}");
    }
}

#[test]
fn orthonormalize_special_cases() {
    // A reflection is mapped to a proper rotation (det +1).
    let refl = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0));
    let r = orthonormalize(&refl);
    assert!(is_rotation(&r, 1e-14));
    // Scaled rotation → the rotation.
    let c = dcm_from_euler(&Vec3::new(0.2, 0.3, -1.0));
    assert!(rot_err(&orthonormalize(&(c * 3.0)), &c) < 1e-15);
    // NaN stays visible.
    assert!(orthonormalize(&Mat3::repeat(f64::NAN))[(0, 0)].is_nan());
}

#[test]
fn wahba_degenerate_inputs() {
    let a = Vec3::x();
    let b = Vec3::y();
    assert!(wahba_svd(&[a], &[a], &[1.0]).is_none());
    assert!(wahba_svd(&[a, b], &[a], &[1.0, 1.0]).is_none());
    assert!(wahba_svd(&[a, b], &[a, b], &[1.0]).is_none());
    assert!(wahba_svd(&[a, a * 2.0, -a], &[a, a * 2.0, -a], &[1.0, 1.0, 1.0]).is_none());
    assert!(wahba_svd(&[a, b], &[a, b], &[1.0, -1.0]).is_none());
    assert!(wahba_svd(&[a, b], &[a, b], &[1.0, f64::NAN]).is_none());
    assert!(wahba_svd(&[a, b], &[a, b], &[0.0, 0.0]).is_none());
    // Two non-parallel vectors determine the rotation.
    let c = dcm_from_euler(&Vec3::new(0.5, -0.4, 2.9));
    let est = wahba_svd(&[a, b], &[c * a, c * b], &[1.0, 1.0]).unwrap();
    assert!(rot_err(&est, &c) < 1e-14);
}

#[test]
fn baselines_ls_seed003() {
    // Three orthogonal 1 m baselines (seed 003 geometry); C maps nav → body.
    let c_bn = dcm_from_euler(&Vec3::new(0.05, -0.1, 0.7));
    let r_b = Mat3::identity();
    let r_n = c_bn * r_b;
    let c_nb = dcm_from_baselines_ls(&r_b, &r_n).unwrap();
    assert!(rot_err(&c_nb, &c_bn.transpose()) < 1e-15);
    // Non-orthogonal, non-unit baselines and 4 of them.
    let r_b4 =
        nalgebra::Matrix3x4::new(1.0, 0.0, 0.3, -1.0, 0.2, 2.0, 0.0, 1.0, 0.0, 0.1, 1.5, 0.5);
    let c_nb = dcm_from_baselines_ls(&r_b4, &(c_bn * r_b4)).unwrap();
    assert!(rot_err(&c_nb, &c_bn.transpose()) < 1e-14);
    // Coplanar baselines: singular.
    let flat = Mat3::new(1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0);
    assert!(dcm_from_baselines_ls(&flat, &(c_bn * flat)).is_none());
    assert!(dcm_from_baselines_ls(&Mat3::zeros(), &Mat3::zeros()).is_none());
}

proptest! {
    #[test]
    fn euler_dcm_roundtrip(rpy in euler_strategy()) {
        let c = dcm_from_euler(&rpy);
        prop_assert!(is_rotation(&c, 1e-14));
        let e = euler_from_dcm(&c);
        prop_assert!(angle_diff(e.x, rpy.x) < 1e-11);
        prop_assert!((e.y - rpy.y).abs() < 1e-11);
        prop_assert!(angle_diff(e.z, rpy.z) < 1e-11);
        prop_assert!(e.z > -PI && e.z <= PI && e.x > -PI && e.x <= PI);
    }

    #[test]
    fn euler_quat_roundtrip(rpy in euler_strategy()) {
        let q = quat_from_euler(&rpy);
        prop_assert!(rot_err(&dcm_from_quat(&q), &dcm_from_euler(&rpy)) < 1e-15);
        let e = euler_from_quat(&q);
        prop_assert!(angle_diff(e.x, rpy.x) < 1e-11);
        prop_assert!((e.y - rpy.y).abs() < 1e-11);
        prop_assert!(angle_diff(e.z, rpy.z) < 1e-11);
    }

    #[test]
    fn any_dcm_euler_dcm(q in quat_strategy()) {
        // Every rotation, including the gimbal-lock neighbourhood, survives DCM → Euler → DCM.
        let c = dcm_from_quat(&q);
        prop_assert!(rot_err(&dcm_from_euler(&euler_from_dcm(&c)), &c) < 1e-14);
    }

    #[test]
    fn dcm_quat_roundtrip(q in quat_strategy()) {
        let c = dcm_from_quat(&q);
        prop_assert!(is_rotation(&c, 1e-14));
        let q2 = quat_from_dcm(&c);
        prop_assert!(q2.w >= 0.0);
        prop_assert!((q2 - q).norm() < 1e-14 || (q2 + q).norm() < 1e-14);
        // Rotating with the quaternion equals multiplying by the DCM.
        let v = Vec3::new(0.3, -1.2, 2.0);
        prop_assert!((quat_rotate(&q, &v) - c * v).norm() < 1e-14);
    }

    #[test]
    fn rotvec_roundtrip(phi in vec_strategy(1.8)
        .prop_filter("|phi| < pi - 1e-6", |p| p.norm() < PI - 1e-6)) {
        let q = quat_from_rotvec(&phi);
        prop_assert!((q.norm() - 1.0).abs() < 1e-15);
        prop_assert!((rotvec_from_quat(&q) - phi).norm() < 1e-13);
        let c = dcm_from_rotvec(&phi);
        prop_assert!(rot_err(&c, &dcm_from_quat(&q)) < 1e-15);
        prop_assert!((rotvec_from_dcm(&c) - phi).norm() < 1e-9);
        // The rotation axis is invariant.
        prop_assert!((c * phi - phi).norm() < 1e-14);
    }

    #[test]
    fn orthonormalize_perturbed(q in quat_strategy(), e in proptest::array::uniform9(-1e-3f64..1e-3)) {
        let r = dcm_from_quat(&q);
        let pert = Mat3::from_row_slice(&e);
        // A symmetric stretch R (I + S) has polar factor exactly R.
        let s = (pert + pert.transpose()) * 0.5;
        let o = orthonormalize(&(r * (Mat3::identity() + s)));
        prop_assert!(is_rotation(&o, 1e-14));
        prop_assert!(rot_err(&o, &r) < 1e-13);
        // A general perturbation: still a rotation, and closer to the input than R is.
        let c = r + pert;
        let o = orthonormalize(&c);
        prop_assert!(is_rotation(&o, 1e-14));
        prop_assert!((o - c).norm() <= (r - c).norm() + 1e-15);
    }

    #[test]
    fn wahba_recovers_rotation(q in quat_strategy(), seed in proptest::array::uniform32(-1.0f64..1.0)) {
        let c_bn = dcm_from_quat(&q);
        let mut v_b = [Vec3::zeros(); 8];
        let mut v_n = [Vec3::zeros(); 8];
        let w = [1.0, 2.0, 0.5, 1.0, 1.5, 1.0, 3.0, 1.0];
        for i in 0..8 {
            v_b[i] = Vec3::new(seed[3 * i], seed[3 * i + 1], seed[3 * i + 2] + 0.05 * (i as f64 - 3.5));
            // Deterministic 1e-4-level "noise" drawn from the remaining seed entries.
            let noise = Vec3::new(seed[(i + 24) % 32], seed[(i + 27) % 32], seed[(i + 29) % 32]) * 1e-4;
            v_n[i] = c_bn * v_b[i] + noise;
        }
        let est = wahba_svd(&v_b, &v_n, &w).unwrap();
        prop_assert!(is_rotation(&est, 1e-14));
        let err = rotvec_from_dcm(&(est * c_bn.transpose())).norm();
        prop_assert!(err < 2e-3, "attitude error {err} rad");
        // Noise-free: exact.
        let exact: [Vec3; 8] = core::array::from_fn(|i| c_bn * v_b[i]);
        let est = wahba_svd(&v_b, &exact, &w).unwrap();
        prop_assert!(rot_err(&est, &c_bn) < 1e-13);
        // It is the optimum: no worse than the true rotation on the noisy data.
        let loss = |c: &Mat3| -> f64 { (0..8).map(|i| w[i] * (v_n[i] - c * v_b[i]).norm_squared()).sum() };
        let est = wahba_svd(&v_b, &v_n, &w).unwrap();
        prop_assert!(loss(&est) <= loss(&c_bn) + 1e-15);
    }
}
