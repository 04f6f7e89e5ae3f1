//! Tests of the evaluator on synthetic trajectories with known injected errors.

use super::*;
use navfuse_core::attitude::{dcm_from_euler, wrap_pi};
use navfuse_core::earth::{WGS84_A, WGS84_E2};
use navfuse_core::Mat3;
use proptest::prelude::*;
use std::f64::consts::PI;

const DEG: f64 = PI / 180.0;

/// Test-only exact geodetic → ECEF (Groves eq. 2.112), independent of `ned_offset`.
fn ecef(lat: f64, lon: f64, h: f64) -> Vec3 {
    let rn = WGS84_A / (1.0 - WGS84_E2 * lat.sin().powi(2)).sqrt();
    Vec3::new(
        (rn + h) * lat.cos() * lon.cos(),
        (rn + h) * lat.cos() * lon.sin(),
        ((1.0 - WGS84_E2) * rn + h) * lat.sin(),
    )
}

/// Test-only ECEF → geodetic by fixed-point iteration (converges to < 1e-12 rad).
fn geodetic(r: &Vec3) -> (f64, f64, f64) {
    let lon = r.y.atan2(r.x);
    let p = r.x.hypot(r.y);
    let mut lat = r.z.atan2(p * (1.0 - WGS84_E2));
    let mut h = 0.0;
    for _ in 0..20 {
        let rn = WGS84_A / (1.0 - WGS84_E2 * lat.sin().powi(2)).sqrt();
        h = p / lat.cos() - rn;
        lat = r.z.atan2(p * (1.0 - WGS84_E2 * rn / (rn + h)));
    }
    (lat, lon, h)
}

/// The point at exact NED offset `d_n` from (lat, lon, h), through ECEF.
fn offset_exact(lat: f64, lon: f64, h: f64, d_n: Vec3) -> (f64, f64, f64) {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    // c_ne = c_en^T, columns: north, east, down unit vectors in ECEF.
    let n = Vec3::new(-sl * co, -sl * so, cl);
    let e = Vec3::new(-so, co, 0.0);
    let d = Vec3::new(-cl * co, -cl * so, -sl);
    geodetic(&(ecef(lat, lon, h) + n * d_n.x + e * d_n.y + d * d_n.z))
}

fn sol(t: f64, lat: f64, lon: f64, h: f64) -> NavSolution {
    NavSolution {
        t,
        lat,
        lon,
        h,
        ..NavSolution::unknown_at(t)
    }
}

/// A 4 Hz reference driving north-east at ~10 m/s near Longmont, with velocity.
fn reference(t0: f64, n: usize) -> Vec<NavSolution> {
    let lat0 = 40.1 * DEG;
    let lon0 = -105.15 * DEG;
    (0..n)
        .map(|i| {
            let dt = i as f64 * 0.25;
            let mut s = sol(
                t0 + dt,
                lat0 + 1e-6 * dt,
                lon0 + 1.2e-6 * dt,
                1600.0 + 0.1 * dt,
            );
            s.v_n = Vec3::new(11.1, 10.2, -0.1);
            s.rpy = Vec3::new(0.01, -0.02, 0.7);
            s
        })
        .collect()
}

#[test]
fn constant_offset_rms_equals_offset() {
    let r = reference(1000.0, 400);
    let d_n = Vec3::new(3.0, -4.0, 2.0);
    // Solutions at the reference epochs, displaced by an exact NED offset.
    let s: Vec<NavSolution> = r
        .iter()
        .map(|x| {
            let (lat, lon, h) = offset_exact(x.lat, x.lon, x.h, d_n);
            let mut y = sol(x.t, lat, lon, h);
            y.v_n = x.v_n + Vec3::new(0.1, 0.2, -0.3);
            y.rpy = x.rpy + Vec3::new(0.0, 0.0, 0.05);
            y
        })
        .collect();
    let ev = evaluate(&s, &r, &EvalConfig::default(), None, None).unwrap();
    assert_eq!(ev.counts.evaluated, 400);
    let sm = &ev.summary;
    let tol = 1e-8; // exact ECEF route both ways.
    assert!((sm.horizontal.unwrap().rms - 5.0).abs() < tol, "{sm:?}");
    assert!((sm.horizontal.unwrap().max_abs - 5.0).abs() < tol);
    assert!((sm.horizontal.unwrap().p95_abs - 5.0).abs() < tol);
    assert!((sm.north.unwrap().mean - 3.0).abs() < tol);
    assert!((sm.east.unwrap().mean + 4.0).abs() < tol);
    assert!((sm.down.unwrap().mean - 2.0).abs() < tol);
    assert!((sm.vertical.unwrap().rms - 2.0).abs() < tol);
    assert!((sm.vel_north.unwrap().mean - 0.1).abs() < 1e-12);
    assert!((sm.vel_down.unwrap().rms - 0.3).abs() < 1e-12);
    assert!((sm.yaw.unwrap().rms - 0.05).abs() < 1e-12);
    assert!(sm.roll.unwrap().rms < 1e-12);
}

#[test]
fn interpolation_is_exact_on_a_linear_reference() {
    let r = reference(1000.0, 100);
    // 10 Hz solution at times between the 4 Hz reference epochs, on the same line.
    let s: Vec<NavSolution> = (0..240)
        .map(|i| {
            let t = 1000.0 + 0.013 + i as f64 * 0.1;
            let dt = t - 1000.0;
            let mut y = sol(
                t,
                r[0].lat + 1e-6 * dt,
                r[0].lon + 1.2e-6 * dt,
                1600.0 + 0.1 * dt,
            );
            y.v_n = r[0].v_n;
            y.rpy = r[0].rpy;
            y
        })
        .collect();
    let ev = evaluate(&s, &r, &EvalConfig::default(), None, None).unwrap();
    assert_eq!(ev.counts.evaluated, 240);
    assert!(ev.summary.horizontal.unwrap().max_abs < 1e-6);
    assert!(ev.summary.vertical.unwrap().max_abs < 1e-7);
    assert!(ev.summary.vel_horizontal.unwrap().max_abs < 1e-12);
    assert!(ev.summary.yaw.unwrap().max_abs < 1e-12);
}

#[test]
fn interpolation_weights_are_linear() {
    // Reference height 0 m at t = 0, 10 m at t = 1: a solution at 0 m and
    // t = 0.3 is 3 m above the reference (down error +3 m).
    let lat = 0.7;
    let r = vec![sol(0.0, lat, 0.1, 0.0), sol(1.0, lat, 0.1, 10.0)];
    let ev = evaluate(
        &[sol(0.3, lat, 0.1, 0.0)],
        &r,
        &EvalConfig::default(),
        None,
        None,
    )
    .unwrap();
    assert!((ev.errors[0].pos_ned[2] - 3.0).abs() < 1e-7); // ECEF round-off ~1e-9 m
}

#[test]
fn excluded_epochs_are_counted() {
    // Reference 10 … 20 s at 4 Hz with the epochs in (14, 16) removed: a 2 s gap.
    let r: Vec<NavSolution> = reference(10.0, 41)
        .into_iter()
        .filter(|x| !(x.t > 14.0 && x.t < 16.0))
        .collect();
    // Solution 5 … 25 s every 0.5 s, one with a NaN latitude.
    let mut s: Vec<NavSolution> = (0..=40)
        .map(|i| {
            let t = 5.0 + 0.5 * i as f64;
            sol(t, r[0].lat, r[0].lon, r[0].h)
        })
        .collect();
    s[22].lat = f64::NAN; // t = 16.0
    let ev = evaluate(&s, &r, &EvalConfig::default(), None, None).unwrap();
    let c = ev.counts;
    assert_eq!(c.epochs, 41);
    assert_eq!(c.before_span, 10); // 5.0 … 9.5
    assert_eq!(c.after_span, 10); // 20.5 … 25.0
    assert_eq!(c.in_gap, 3); // 14.5, 15.0, 15.5 (14.0 and 16.0 are exact epochs)
    assert_eq!(c.invalid, 1); // 16.0
    assert_eq!(c.evaluated, 41 - 10 - 10 - 3 - 1);
    assert_eq!(ev.errors.len(), c.evaluated);
    // With a larger max_gap the gap is bridged.
    let cfg = EvalConfig {
        max_gap: 2.5,
        ..EvalConfig::default()
    };
    let ev = evaluate(&s, &r, &cfg, None, None).unwrap();
    assert_eq!(ev.counts.in_gap, 0);
    assert_eq!(ev.counts.evaluated, 41 - 10 - 10 - 1);
}

#[test]
fn yaw_error_wraps_at_180() {
    let lat = 0.7;
    let mut a = sol(0.0, lat, 0.1, 0.0);
    a.rpy = Vec3::new(0.0, 0.0, 179.0 * DEG);
    let mut b = sol(1.0, lat, 0.1, 0.0);
    b.rpy = Vec3::new(0.0, 0.0, -179.0 * DEG);
    let r = vec![a, b];
    // At t = 0: solution −179°, reference 179° → error +2°, not −358°.
    let mut s0 = sol(0.0, lat, 0.1, 0.0);
    s0.rpy = Vec3::new(0.0, 0.0, -179.0 * DEG);
    // At t = 0.5 the reference passes through ±180° (shorter arc); solution 180°.
    let mut s1 = sol(0.5, lat, 0.1, 0.0);
    s1.rpy = Vec3::new(0.0, 0.0, 180.0 * DEG);
    // At t = 1: solution 178° vs reference −179° → −3°.
    let mut s2 = sol(1.0, lat, 0.1, 0.0);
    s2.rpy = Vec3::new(0.0, 0.0, 178.0 * DEG);
    let ev = evaluate(&[s0, s1, s2], &r, &EvalConfig::default(), None, None).unwrap();
    let yaw: Vec<f64> = ev
        .errors
        .iter()
        .map(|e| e.att_rpy.unwrap()[2] / DEG)
        .collect();
    assert!((yaw[0] - 2.0).abs() < 1e-9, "{yaw:?}");
    assert!(yaw[1].abs() < 1e-9, "{yaw:?}");
    assert!((yaw[2] + 3.0).abs() < 1e-9, "{yaw:?}");
}

#[test]
fn unknown_reference_velocity_and_attitude_give_none() {
    let r = vec![sol(0.0, 0.7, 0.1, 0.0), sol(1.0, 0.7, 0.1, 0.0)]; // rpy NaN
    let mut r2 = r.clone();
    r2[1].v_n = Vec3::new(f64::NAN, 0.0, 0.0);
    let mut s = sol(0.5, 0.7, 0.1, 0.0);
    s.rpy = Vec3::zeros();
    let ev = evaluate(&[s], &r2, &EvalConfig::default(), None, None).unwrap();
    assert_eq!(ev.errors[0].vel_ned, None);
    assert_eq!(ev.errors[0].att_rpy, None);
    assert!(ev.summary.yaw.is_none() && ev.summary.vel_north.is_none());
    let ev = evaluate(&[s], &r, &EvalConfig::default(), None, None).unwrap();
    assert!(ev.errors[0].vel_ned.is_some());
}

#[test]
fn lever_arm_moves_the_solution_point() {
    // Vehicle heading east (yaw 90°), antenna 1 m forward and 0.5 m right of
    // the IMU: the antenna is 1 m east and 0.5 m south of the IMU.
    let (lat, lon, h) = (40.0 * DEG, -105.0 * DEG, 1600.0);
    let r = vec![sol(0.0, lat, lon, h), sol(1.0, lat, lon, h)];
    let (ilat, ilon, ih) = offset_exact(lat, lon, h, Vec3::new(0.5, -1.0, 0.3));
    let mut s = sol(0.5, ilat, ilon, ih);
    s.rpy = Vec3::new(0.0, 0.0, 90.0 * DEG);
    let cfg = EvalConfig {
        lever_arm_b: Some([1.0, 0.5, -0.3]),
        ..EvalConfig::default()
    };
    let ev = evaluate(&[s], &r, &cfg, None, None).unwrap();
    let e = ev.errors[0].pos_ned;
    assert!(e.iter().all(|x| x.abs() < 1e-6), "{e:?}");
    // Without the lever arm the IMU offset shows.
    let ev = evaluate(&[s], &r, &EvalConfig::default(), None, None).unwrap();
    assert!((ev.errors[0].horizontal - 1.25f64.sqrt()).abs() < 1e-6);
    // A lever arm needs the solution attitude: NaN attitude → invalid, counted.
    let mut s_nan = s;
    s_nan.rpy.x = f64::NAN;
    let ev = evaluate(&[s_nan], &r, &cfg, None, None).unwrap();
    assert_eq!(ev.counts.invalid, 1);
}

#[test]
fn dcm_from_euler_rotates_frd_to_ned() {
    // Pitch up 90°: body forward points up (−down).
    let c = dcm_from_euler(&Vec3::new(0.0, 90.0 * DEG, 0.0));
    assert!((c * Vec3::x() - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    // Roll right 90°: body right points down.
    let c = dcm_from_euler(&Vec3::new(90.0 * DEG, 0.0, 0.0));
    assert!((c * Vec3::y() - Vec3::z()).norm() < 1e-12);
    let c = dcm_from_euler(&Vec3::new(0.3, -0.4, 2.5));
    assert!((c.transpose() * c - Mat3::identity()).norm() < 1e-12);
    assert!((c.determinant() - 1.0).abs() < 1e-12);
}

#[test]
fn bad_reference_is_rejected() {
    let cfg = EvalConfig::default();
    assert_eq!(
        evaluate(&[], &[], &cfg, None, None),
        Err(EvalError::Empty(Series::Reference))
    );
    let r = vec![sol(1.0, 0.7, 0.1, 0.0), sol(1.0, 0.7, 0.1, 0.0)];
    assert!(matches!(
        evaluate(&[], &r, &cfg, None, None),
        Err(EvalError::NotIncreasing {
            series: Series::Reference,
            index: 1,
            ..
        })
    ));
    let r = vec![sol(1.0, 0.7, 0.1, 0.0), sol(2.0, f64::NAN, 0.1, 0.0)];
    assert_eq!(
        evaluate(&[], &r, &cfg, None, None),
        Err(EvalError::NonFinite {
            series: Series::Reference,
            index: 1
        })
    );
    let bad = EvalConfig {
        max_gap: 0.0,
        ..cfg
    };
    assert!(matches!(
        evaluate(&[], &r[..1], &bad, None, None),
        Err(EvalError::BadConfig(_))
    ));
}

#[test]
fn outage_drift_end_to_end() {
    // Reference static for 300 s at 4 Hz; the solution drifts north at
    // 0.5 m/s inside each outage until the next fix (1 Hz fixes at x.0),
    // then is back on the reference. 10 Hz solution.
    let (lat, lon, h) = (40.1 * DEG, -105.15 * DEG, 1600.0);
    let r: Vec<NavSolution> = (0..1200)
        .map(|i| sol(i as f64 * 0.25, lat, lon, h))
        .collect();
    let sched = OutageSchedule::periodic(0.0, 50.0, 90.0, 30.0, None).unwrap();
    let fixes: Vec<f64> = (0..300)
        .map(f64::from)
        .filter(|&t| !sched.contains(t))
        .collect();
    let s: Vec<NavSolution> = (0..2990)
        .map(|i| {
            let t = i as f64 * 0.1;
            let k = ((t - 50.0) / 90.0).floor();
            let start = 50.0 + 90.0 * k;
            let drift = if k >= 0.0 && t >= start && t < start + 30.0 {
                0.5 * (t - start)
            } else {
                0.0
            };
            let (la, lo, hh) = offset_exact(lat, lon, h, Vec3::new(drift, 0.0, 0.0));
            sol(t, la, lo, hh)
        })
        .collect();
    let ev = evaluate(&s, &r, &EvalConfig::default(), Some(&sched), Some(&fixes)).unwrap();
    let rep = ev.outages.unwrap();
    // Outages at 50, 140, 230 (320 is past the data).
    assert_eq!(rep.outages.len(), 3);
    for o in &rep.outages {
        assert_eq!(o.window_end, o.end);
        // Last epoch inside: start + 29.9 s → 14.95 m.
        assert!((o.max_horizontal.unwrap() - 14.95).abs() < 1e-4, "{o:?}");
    }
    assert!((rep.rms_of_max.unwrap() - 14.95).abs() < 1e-4);
}

#[test]
fn evaluation_serialises_to_json() {
    let r = reference(0.0, 10);
    let ev = evaluate(&r, &r, &EvalConfig::default(), None, None).unwrap();
    let js = serde_json::to_string(&ev).unwrap();
    assert!(js.contains("\"horizontal\""));
    let back: Evaluation = serde_json::from_str(&js).unwrap();
    assert_eq!(back.counts, ev.counts);
    assert_eq!(back.errors.len(), 10);
}

#[test]
fn wrap_pi_range() {
    assert_eq!(wrap_pi(PI), PI);
    assert_eq!(wrap_pi(-PI), PI);
    assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
    assert!((wrap_pi(-190.0 * DEG) - 170.0 * DEG).abs() < 1e-12);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn recovers_injected_offset_with_lever_arm(
        dn in -50f64..50.0, de in -50f64..50.0, dd in -10f64..10.0,
        roll in -0.5f64..0.5, pitch in -0.5f64..0.5, yaw in -PI..PI,
        lx in -2f64..2.0, ly in -2f64..2.0, lz in -2f64..2.0,
        lat_deg in -80f64..80.0, t in 0.0f64..1.0,
    ) {
        let (lat, lon, h) = (lat_deg * DEG, 2.0, 100.0);
        let r = vec![sol(0.0, lat, lon, h), sol(1.0, lat, lon, h)];
        let rpy = Vec3::new(roll, pitch, yaw);
        let l_b = Vec3::new(lx, ly, lz);
        // IMU position = truth antenna + injected error − c_bn·l_b.
        let d_imu = Vec3::new(dn, de, dd) - dcm_from_euler(&rpy) * l_b;
        let (a, b, c) = offset_exact(lat, lon, h, d_imu);
        let mut s = sol(t, a, b, c);
        s.rpy = rpy;
        let cfg = EvalConfig { lever_arm_b: Some([lx, ly, lz]), ..EvalConfig::default() };
        let ev = evaluate(&[s], &r, &cfg, None, None).unwrap();
        let e = ev.errors[0].pos_ned;
        prop_assert!((e[0] - dn).abs() < 1e-6 && (e[1] - de).abs() < 1e-6 && (e[2] - dd).abs() < 1e-6,
            "{:?} vs {:?}", e, (dn, de, dd));
    }
}

fn at_reference() -> EvalConfig {
    EvalConfig {
        align: Align::AtReference,
        ..EvalConfig::default()
    }
}

#[test]
fn at_reference_interpolates_the_solution() {
    // 4 Hz reference on a line; 10 Hz solution on the same line shifted by a
    // constant 2 m north, with the lever arm undone through the attitude.
    let r = reference(1000.0, 100);
    let l_b = Vec3::new(0.3, -0.05, -0.6);
    let s: Vec<NavSolution> = (0..260)
        .map(|i| {
            let t = 999.0 + 0.013 + i as f64 * 0.1;
            let dt = t - 1000.0;
            let rpy = Vec3::new(0.01, -0.02, 0.7 + 0.01 * dt);
            let d = Vec3::new(2.0, 0.0, 0.0) - dcm_from_euler(&rpy) * l_b;
            let (lat, lon, h) = offset_exact(
                r[0].lat + 1e-6 * dt,
                r[0].lon + 1.2e-6 * dt,
                1600.0 + 0.1 * dt,
                d,
            );
            let mut y = sol(t, lat, lon, h);
            y.v_n = r[0].v_n;
            y.rpy = rpy;
            y
        })
        .collect();
    let cfg = EvalConfig {
        lever_arm_b: Some([l_b.x, l_b.y, l_b.z]),
        ..at_reference()
    };
    let ev = evaluate(&s, &r, &cfg, None, None).unwrap();
    // Reference epochs 1000 … 1024.75; the solution spans 999.013 … 1024.913.
    assert_eq!(ev.counts.epochs, 100);
    assert_eq!(ev.counts.evaluated, 100);
    assert_eq!(ev.errors[1].t, 1000.25);
    let h = ev.summary.horizontal.unwrap();
    // The solution's offset is exact at its own epochs; between them the
    // yaw-dependent lever-arm term is interpolated linearly: error ≪ 1 mm.
    assert!(
        (h.rms - 2.0).abs() < 1e-4 && (h.max_abs - 2.0).abs() < 1e-4,
        "{h:?}"
    );
    assert!(ev.summary.vertical.unwrap().max_abs < 1e-4);
}

#[test]
fn at_reference_counts_solution_gaps_and_span() {
    let r = reference(10.0, 41); // 10 … 20 s
    let s: Vec<NavSolution> = (0..=100)
        .map(|i| 12.0 + 0.1 * i as f64) // 12 … 22 s
        .filter(|&t| !(t > 15.05 && t < 16.95)) // gap 15.0 → 17.0
        .map(|t| sol(t, r[0].lat, r[0].lon, r[0].h))
        .collect();
    let ev = evaluate(&s, &r, &at_reference(), None, None).unwrap();
    let c = ev.counts;
    assert_eq!(c.epochs, 41);
    assert_eq!(c.before_span, 8); // 10.0 … 11.75
    assert_eq!(c.after_span, 0);
    assert_eq!(c.in_gap, 7); // 15.25 … 16.75
    assert_eq!(c.evaluated, 41 - 8 - 7);
    // A solution out of time order cannot be interpolated.
    let mut bad = s.clone();
    bad.swap(3, 4);
    assert!(matches!(
        evaluate(&bad, &r, &at_reference(), None, None),
        Err(EvalError::NotIncreasing {
            series: Series::Solution,
            index: 4,
            ..
        })
    ));
    // The streaming evaluator only aligns at solution epochs.
    assert!(Evaluator::new(&r, at_reference()).is_err());
}
