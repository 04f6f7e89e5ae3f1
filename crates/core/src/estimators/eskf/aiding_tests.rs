//! Filter-level tests of the issue 17 aiding (models: `crate::measurements`).

use super::tests::{config, fix_at, start, static_sample, std0};
use super::*;
use crate::measurements::heading::HeadingConfig;
use crate::measurements::magnetometer::MagConfig;
use crate::measurements::odometer::OdometerConfig;
use crate::measurements::wmm;
use crate::types::{HeadingFix, HeadingSource, MagSample, OdometerSample};

const DT: f64 = 0.01;

fn odo(t: f64) -> Event {
    Event::Odometer(OdometerSample {
        t,
        dt: 0.1,
        speed_mps: 0.0,
        std_mps: 0.0,
        wheel: 0,
    })
}

fn heading(t: f64, psi: f64) -> Event {
    Event::Heading(HeadingFix {
        t,
        heading_rad: psi,
        pitch_rad: f64::NAN,
        std_heading_rad: 0.2f64.to_radians(),
        std_pitch_rad: f64::NAN,
        baseline_m: 1.0,
        source: HeadingSource::DualAntenna,
    })
}

/// Static run of `secs`; `aid(k, t)` gives extra events after IMU sample k;
/// GNSS fixes at 1 Hz when `gnss`.
fn run(
    f: &mut Eskf,
    secs: u64,
    gnss: bool,
    mut aid: impl FnMut(u64, f64) -> Option<Event>,
) -> Vec<NavSolution> {
    let s = start();
    let lever = f.config().lever_arm_b;
    let mut out = Vec::new();
    for k in 1..=secs * 100 {
        let imu = static_sample(k, DT, &Vec3::zeros(), &Vec3::zeros());
        if let Some(sol) = f.push(&Event::Imu(imu)) {
            out.push(sol);
        }
        if gnss && k % 100 == 0 {
            f.push(&Event::Gnss(fix_at(&s, imu.t, &lever, Vec3::zeros())));
        }
        if let Some(e) = aid(k, imu.t) {
            f.push(&e);
        }
    }
    out
}

fn filter(aiding: AidingConfig, yaw_err: f64) -> Eskf {
    let mut nav = start();
    nav.q_bn = crate::ins::mech::q_bn_from_rpy(&(nav.rpy() + Vec3::new(0.0, 0.0, yaw_err)));
    let cfg = EskfConfig { aiding, ..config() };
    Eskf::new(cfg, nav, ImuErrors::default(), &std0())
}

#[test]
fn unconfigured_aiding_events_change_nothing() {
    let mut a = filter(AidingConfig::default(), 0.0);
    let mut b = filter(AidingConfig::default(), 0.0);
    let sa = run(&mut a, 20, true, |_, _| None);
    let sb = run(&mut b, 20, true, |k, t| match k % 3 {
        0 => Some(odo(t)),
        1 => Some(heading(t, 0.3)),
        _ => Some(Event::Mag(MagSample {
            t,
            m_b: Vec3::new(2e-5, 0.0, 4e-5),
        })),
    });
    assert_eq!(sa, sb);
    assert_eq!(a.stats(), b.stats());
    assert_eq!(a.covariance(), b.covariance());
}

#[test]
fn heading_fixes_correct_and_hold_the_yaw_at_rest() {
    let yaw_true = start().rpy().z;
    let err0 = 2f64.to_radians();
    let hcfg = HeadingConfig {
        mount_yaw_rad: 0.0,
        mount_pitch_rad: 0.0,
        std_floor_rad: 0.0,
        use_pitch: false,
    };
    let aid = AidingConfig {
        heading: Some(hcfg),
        ..Default::default()
    };
    let mut f = filter(aid, err0);
    run(&mut f, 120, true, |k, t| {
        (k % 100 == 0).then(|| heading(t, yaw_true))
    });
    let e = crate::measurements::wrap_pi(f.nav().rpy().z - yaw_true)
        .abs()
        .to_degrees();
    let sd = f.covariance()[(I_ATT + 2, I_ATT + 2)].sqrt().to_degrees();
    assert!(e < 0.1 && sd < 0.1, "yaw error {e}°, σ {sd}°");
    assert_eq!(f.stats().aiding.heading_used, 120);
    // Without: GNSS at rest does not see the yaw, the 2° stay.
    let mut g = filter(AidingConfig::default(), err0);
    run(&mut g, 120, true, |_, _| None);
    let e = crate::measurements::wrap_pi(g.nav().rpy().z - yaw_true)
        .abs()
        .to_degrees();
    assert!(e > 1.5, "{e}");
}

#[test]
fn odometer_with_nhc_rows_holds_the_velocity_without_gnss() {
    let o = OdometerConfig {
        lever_arm_b: Vec3::new(-1.2, 0.0, 0.4),
        std_mps: 0.05,
        scale_std: 0.03,
        scale_rw_psd: 0.0,
        nhc_std: Some(0.1),
        max_age_s: 0.02,
    };
    let aid = AidingConfig {
        odometer: Some(o),
        ..Default::default()
    };
    let mut f = filter(aid, 0.0);
    run(&mut f, 60, false, |k, t| (k % 10 == 0).then(|| odo(t)));
    assert!(f.nav().v_n.norm() < 0.05, "{:?}", f.nav().v_n);
    let a = f.augmented().expect("scale state");
    // At rest the scale is unobservable: its σ stays at the initial 3 %.
    assert!((a.odometer_scale_std - 0.03).abs() < 1e-3, "{a:?}");
    assert_eq!(f.stats().aiding.odometer_used, 600);
    // Stale samples are refused and counted.
    f.push(&odo(f.time() - 1.0));
    assert_eq!(f.stats().aiding.odometer_rejected_bad, 1);
    // Without any aiding the free INS drifts faster.
    let mut g = filter(AidingConfig::default(), 0.0);
    run(&mut g, 60, false, |_, _| None);
    assert!(g.nav().v_n.norm() > f.nav().v_n.norm());
}

#[test]
fn magnetometer_corrects_the_yaw_and_gates_disturbances() {
    let s = start();
    let year = 2026.9;
    let w = wmm::field(s.lat, s.lon, s.h, year).unwrap();
    let m_b = s.c_bn().transpose() * w.b_n;
    let mcfg = MagConfig {
        std_t: 0.3e-6,
        decimal_year: year,
        calib_residual: 0.02,
        interval_s: 0.1,
    };
    let aid = AidingConfig {
        mag: Some(mcfg),
        ..Default::default()
    };
    let mut f = filter(aid, 3f64.to_radians());
    run(&mut f, 60, true, |k, t| {
        // The last 10 s: a disturbance adding 30 % of the field.
        let m = if t > 50.0 { m_b * 1.3 } else { m_b };
        (k % 10 == 0).then_some(Event::Mag(MagSample { t, m_b: m }))
    });
    let e = crate::measurements::wrap_pi(f.nav().rpy().z - s.rpy().z)
        .abs()
        .to_degrees();
    // R includes the WMM declination uncertainty (~0.3°+): not better than that.
    assert!(e < 0.5, "yaw error {e}°");
    let st = f.stats().aiding;
    assert!(st.mag_disturbed >= 99 && st.mag_used >= 490, "{st:?}");
}
