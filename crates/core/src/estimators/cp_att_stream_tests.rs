#![allow(clippy::needless_range_loop)] // index loops mirror the epoch layout

use super::*;
use crate::attitude::{dcm_from_euler, dcm_from_rotvec};
use crate::estimators::cp_attitude::{paper_dcm_nb, paper_euler};

const LAM: f64 = 0.190293673;

/// A deterministic pseudo-random rotation (no RNG dependency in core).
fn rot(k: f64) -> Mat3 {
    dcm_from_rotvec(&Vec3::new(
        0.7 * k.sin(),
        1.3 * (2.0 * k).cos(),
        -0.9 * (0.5 * k).sin(),
    ))
}

fn est(c_nb: Mat3, cov_n: Mat3) -> AttEstimate {
    AttEstimate { c_nb, cov_n }
}

/// Default mounting: the NED angles are the paper's, bit for bit
/// (roll = φ, pitch = θ, yaw = −ψ, equal as values), also for eq. 4's non-orthonormal matrix.
#[test]
fn default_mounting_gives_the_papers_angles_exactly() {
    for k in 0..50 {
        let x = k as f64 * 0.37;
        let (r, p, y) = (0.4 * x.sin(), 0.3 * (1.7 * x).cos(), 3.0 * (0.9 * x).sin());
        let mut c = paper_dcm_nb(r, p, y);
        if k % 2 == 1 {
            c[(0, 1)] += 1e-3; // not orthonormal, as eq. 4's LS matrix
            c[(2, 0)] -= 2e-3;
        }
        let paper = paper_euler(&c);
        let (rpy, _) = body_rpy_ned(&est(c, Mat3::identity()), &T_ENU_NED);
        // `==`: equal values (±0 compare equal), no rounding difference.
        assert_eq!(rpy.x, paper.x, "{k}");
        assert_eq!(rpy.y, paper.y, "{k}");
        assert_eq!(rpy.z, -paper.z, "{k}");
    }
}

/// Any mounting: the reported ZYX angles rebuild `c_bn = T C_naᵀ c_baᵀ`, and
/// a vehicle heading east, level, with the paper's frame (y forward) reports
/// yaw +90° (clockwise from north).
#[test]
fn any_mounting_rebuilds_the_body_to_ned_dcm() {
    for k in 0..20 {
        let c_na = rot(k as f64);
        let c_ba = rot(10.0 + k as f64);
        let (rpy, _) = body_rpy_ned(&est(c_na, Mat3::identity()), &c_ba);
        let want = T_ENU_NED * c_na.transpose() * c_ba.transpose();
        assert!((dcm_from_euler(&rpy) - want).abs().max() < 1e-12, "{k}");
    }
    // Heading east: the antenna y axis (forward) points east in ENU.
    // c_na rows are the antenna axes in ENU: x = south (right), y = east, z = up.
    let c_na = Mat3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let (rpy, _) = body_rpy_ned(&est(c_na, Mat3::identity()), &T_ENU_NED);
    assert!(
        (rpy - Vec3::new(0.0, 0.0, core::f64::consts::FRAC_PI_2)).norm() < 1e-15,
        "{rpy}"
    );
}

/// σ mapping: a perturbation `δθ_n = M e_i ε` of the attitude moves angle i
/// alone by ε (so `M` is the right Jacobian), and an isotropic covariance
/// at zero pitch gives equal σ.
#[test]
fn euler_sigma_from_rotation_covariance() {
    let rpy0 = Vec3::new(0.2, -0.3, 1.1);
    let c_bn = dcm_from_euler(&rpy0);
    let m = euler_rate_matrix(&rpy0);
    let eps = 1e-7;
    for i in 0..3 {
        let d = m.column(i) * eps;
        let rpy = crate::attitude::euler_from_dcm(&(dcm_from_rotvec(&d) * c_bn));
        let mut want = rpy0;
        want[i] += eps;
        assert!((rpy - want).norm() < 1e-12, "{i}: {}", rpy - want);
    }
    // Isotropic 1 mrad, level: σ = 1 mrad on every angle.
    let c_nb = (T_ENU_NED * dcm_from_euler(&Vec3::new(0.0, 0.0, 0.7)) * T_ENU_NED).transpose();
    let (_, std) = body_rpy_ned(&est(c_nb, Mat3::identity() * 1e-6), &T_ENU_NED);
    assert!((std - Vec3::repeat(1e-3)).norm() < 1e-12, "{std}");
    // Yaw-only uncertainty (ENU z) stays in yaw.
    let cov = Mat3::from_diagonal(&Vec3::new(0.0, 0.0, 4e-6));
    let (_, std) = body_rpy_ned(&est(c_nb, cov), &T_ENU_NED);
    assert!((std - Vec3::new(0.0, 0.0, 2e-3)).norm() < 1e-12, "{std}");
}

/// A noise-free scene: `n` satellites, three orthogonal 1 m baselines,
/// slowly turning body, fixed integer ambiguities.
fn scene(n_epochs: usize, n: usize) -> (Vec<CpEpoch>, Vec<Vec3>) {
    let b_a = vec![Vec3::x(), Vec3::y(), Vec3::z()];
    let mut out = Vec::new();
    for e in 0..n_epochs {
        let t = 1000.0 + e as f64;
        let c_na = paper_dcm_nb(0.05, -0.02, 0.3 + 0.01 * e as f64);
        let mut ep = CpEpoch {
            t,
            n_sats: n,
            n_baselines: 3,
            ..Default::default()
        };
        for i in 0..n {
            let el = 1.45 - 0.15 * i as f64;
            let az = 2.1 * i as f64;
            let s = Vec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin());
            ep.prn[i] = 3 + i as u8;
            ep.los_enu[i] = s;
            ep.sigma[i] = 0.002;
            for k in 0..3 {
                let b_n = c_na.transpose() * b_a[k];
                let n_amb = ((i * 7 + k * 3) % 11) as f64 - 5.0;
                // Deterministic mm-level "noise" so the filters are exercised.
                let noise = 1e-3 * ((e * 31 + i * 17 + k * 5) as f64).sin();
                ep.sd_phase[k][i] = s.dot(&b_n) + LAM * n_amb + noise;
            }
        }
        out.push(ep);
    }
    (out, b_a)
}

fn records(ep: &CpEpoch, flag_last: bool) -> impl Iterator<Item = Event> + '_ {
    epoch_records(ep).map(move |mut r| {
        r.last_in_epoch &= flag_last;
        Event::CarrierPhase(r)
    })
}

/// The stream reassembles epochs exactly: its solutions are the batch
/// estimator's, bit for bit, whether epochs end by the flag, by the next
/// epoch's first record, or by a later event of another kind.
#[test]
fn stream_equals_batch_however_epochs_end() {
    let (eps, b_a) = scene(40, 8);
    let cfg = CpAttStreamConfig::new(&b_a);
    let mut batch = CpAttitude::new(cfg.filter, &b_a).with_fixing(cfg.fix.unwrap());
    let want: Vec<CpAttSolution> = eps.iter().map(|e| batch.update(e)).collect();
    for mode in 0..3 {
        let mut s = CpAttStream::new(cfg).unwrap();
        let mut got = Vec::new();
        for ep in &eps {
            for ev in records(ep, mode == 0) {
                if let Some(sol) = s.push(&ev) {
                    got.push((sol, *s.last()));
                }
            }
            if mode == 2 {
                let imu = Event::Imu(crate::ImuSample {
                    t: ep.t + 0.01,
                    dt: 0.01,
                    ..Default::default()
                });
                if let Some(sol) = s.push(&imu) {
                    got.push((sol, *s.last()));
                }
            }
        }
        if let Some(sol) = s.flush() {
            got.push((sol, *s.last()));
        }
        assert_eq!(got.len(), eps.len(), "mode {mode}");
        for ((sol, last), w) in got.iter().zip(&want) {
            // Debug text: every float in shortest round-trip form, NaN == NaN.
            assert_eq!(format!("{last:?}"), format!("{w:?}"), "mode {mode}");
            assert_eq!(sol.t, w.t);
            assert!(sol.lat.is_nan() && sol.v_n.x.is_nan());
        }
        // Noise-free geometry: the fixed attitude is there and right.
        let (sol, last) = got.last().unwrap();
        let p = last.rpy_fixed.expect("fixed");
        assert_eq!(paper_rpy_from_ned_default(&sol.rpy), p);
        assert!((p - Vec3::new(0.05, -0.02, 0.69)).norm() < 2e-3, "{p}");
        assert!(sol
            .std_rpy
            .iter()
            .all(|x| x.is_finite() && *x > 0.0 && *x < 0.01));
        assert_eq!(s.stats().epochs, 40);
        assert_eq!(s.stats().records, 40 * 8);
    }
}

/// Bad records are rejected and counted, never processed.
#[test]
fn duplicate_out_of_order_and_invalid_records_are_counted() {
    let (eps, b_a) = scene(3, 7);
    let mut s = CpAttStream::new(CpAttStreamConfig::new(&b_a)).unwrap();
    let evs: Vec<Event> = records(&eps[1], false).collect();
    s.push(&evs[0]);
    s.push(&evs[0]); // duplicate PRN
    let old: Vec<Event> = records(&eps[0], false).collect();
    s.push(&old[2]); // earlier epoch
    let Event::CarrierPhase(mut bad) = evs[1] else {
        unreachable!()
    };
    bad.sd_phase_m[1] = f64::NAN;
    s.push(&Event::CarrierPhase(bad));
    bad.sd_phase_m[1] = 0.0;
    bad.n_baselines = 2; // fewer than configured
    s.push(&Event::CarrierPhase(bad));
    let st = *s.stats();
    assert_eq!(
        (
            st.records,
            st.rejected_duplicate,
            st.rejected_out_of_order,
            st.rejected_invalid
        ),
        (1, 1, 1, 2)
    );
    assert!(s.push(&Event::Gnss(Default::default())).is_none());
    assert_eq!(s.stats().ignored, 1);
}

#[test]
fn config_is_checked() {
    let b = [Vec3::x(), Vec3::y(), Vec3::z()];
    assert_eq!(
        CpAttStream::new(CpAttStreamConfig::new(&b[..1])).err(),
        Some(CpAttStreamError::Baselines(1))
    );
    let mut c = CpAttStreamConfig::new(&b);
    c.b_a[1] = Vec3::zeros();
    assert_eq!(
        CpAttStream::new(c).err(),
        Some(CpAttStreamError::BadBaseline(1))
    );
    let mut c = CpAttStreamConfig::new(&b);
    c.c_ba = Mat3::identity() * 2.0;
    assert_eq!(
        CpAttStream::new(c).err(),
        Some(CpAttStreamError::NotRotation)
    );
    c.c_ba = -Mat3::identity();
    assert_eq!(
        CpAttStream::new(c).err(),
        Some(CpAttStreamError::NotRotation)
    );
}

#[test]
fn heading_fix_from_a_solution() {
    let mut sol = NavSolution::unknown_at(5.0);
    assert!(heading_fix(&sol).is_none());
    sol.rpy = Vec3::new(0.01, 0.02, -2.0);
    sol.std_rpy = Vec3::new(1e-3, 2e-3, 3e-3);
    let h = heading_fix(&sol).unwrap();
    assert_eq!((h.t, h.heading_rad, h.pitch_rad), (5.0, -2.0, 0.02));
    assert_eq!((h.std_heading_rad, h.std_pitch_rad), (3e-3, 2e-3));
    assert_eq!(h.source, HeadingSource::CpAtt);
    sol.rpy.y = 1.5; // near the vertical: no heading
    assert!(heading_fix(&sol).is_none());
}
