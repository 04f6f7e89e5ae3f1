//! RTK/INS on a static rover 2 km from its base with noise-free synthetic
//! satellites static in ECEF: whitening, slot bookkeeping, slip detection,
//! fixing.

use super::rtk::{dd_update_both, NJ_TEST};
use super::*;
use crate::geodesy::{c_en, geodetic_to_ecef, Geodetic};
use crate::gnss::raw::{
    geometric_range, GnssSystem, RawEpoch, RawObs, RawSat, SatState, Signal, FLAG_LOSS_OF_LOCK,
};
use crate::gnss::tropo::{day_of_year, slant_delay};
use crate::gnss::LAMBDA_L1;
use crate::types::ImuSample;
use nalgebra::{SMatrix, SVector};

const LAT: f64 = 0.6;
const LON: f64 = 2.0;
const H: f64 = 50.0;
const T0: f64 = 1.4e9;

fn rover() -> Vec3 {
    geodetic_to_ecef(&Geodetic {
        lat: LAT,
        lon: LON,
        h: H,
    })
}

fn base() -> Vec3 {
    geodetic_to_ecef(&Geodetic {
        lat: LAT + 2000.0 / 6.37e6,
        lon: LON,
        h: H + 10.0,
    })
}

/// `n` satellites 20 000 km away, spread in azimuth and elevation (≥ 20°),
/// static in ECEF.
fn sats(n: usize) -> Vec<Vec3> {
    let cne = c_en(LAT, LON).transpose();
    (0..n)
        .map(|k| {
            let az = (k as f64 * 137.5).to_radians();
            let el = (20.0 + (k as f64 * 23.0) % 65.0).to_radians();
            let u_n = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), -el.sin());
            rover() + cne * u_n * 2.0e7
        })
        .collect()
}

/// Truth SD integer of satellite `k`: rover and base integers.
fn n_rover(k: usize) -> f64 {
    1000.0 + 37.0 * k as f64
}
fn n_base(k: usize) -> f64 {
    -500.0 + 11.0 * (k * k) as f64
}

/// One receiver's epoch at `rx`; `slip[k]` cycles added to satellite k's
/// phase; `lli` flags set; satellites `skip` left out.
#[allow(clippy::too_many_arguments)]
fn epoch(
    t: f64,
    rx: &Vec3,
    nsat: usize,
    n_of: fn(usize) -> f64,
    slip: &[(usize, f64)],
    lli: &[usize],
    skip: &[usize],
    clock_m: f64,
) -> RawEpoch {
    let g = crate::geodesy::ecef_to_geodetic(rx);
    let cen = c_en(g.lat, g.lon);
    let mut ep = RawEpoch::new(t);
    for (k, p) in sats(nsat).iter().enumerate() {
        if skip.contains(&k) {
            continue;
        }
        let (rho, los) = geometric_range(p, rx);
        let el = (-(cen * los).z).asin();
        let trop = slant_delay(el, g.lat, g.h, day_of_year(t), 0.0);
        let s: f64 = slip.iter().filter(|x| x.0 == k).map(|x| x.1).sum();
        let (system, prn) = if k < 30 {
            (GnssSystem::Gps, k as u8 + 1)
        } else {
            (GnssSystem::Galileo, k as u8 - 29)
        };
        let signal = if k < 30 {
            Signal::GpsL1Ca
        } else {
            Signal::GalE1
        };
        ep.push(RawSat {
            obs: RawObs {
                t,
                pseudorange_m: rho + trop + clock_m,
                carrier_m: rho + trop + clock_m + LAMBDA_L1 * (n_of(k) + s),
                cn0_dbhz: 45.0,
                system,
                prn,
                signal,
                flags: if lli.contains(&k) {
                    FLAG_LOSS_OF_LOCK
                } else {
                    0
                },
                ..Default::default()
            },
            sat: SatState {
                pos_e: *p,
                valid: true,
                ..Default::default()
            },
        });
    }
    ep
}

fn filter() -> Eskf {
    filter_with(RtkConfig::rtklib())
}

fn filter_with(rc: RtkConfig) -> Eskf {
    filter_at(rc, LAT + 0.5 / 6.37e6, LON, H) // 0.5 m north
}

/// [`filter_with`] started at (`lat`, `lon`, `h`) with its position σ 1 m.
fn filter_at(rc: RtkConfig, lat: f64, lon: f64, h: f64) -> Eskf {
    let nav = NavState {
        lat,
        lon,
        h,
        ..Default::default()
    };
    let std = InitStd {
        pos: Vec3::repeat(1.0),
        vel: Vec3::repeat(0.1),
        att: Vec3::repeat(0.01),
        bg: Vec3::zeros(),
        ba: Vec3::zeros(),
        sg: Vec3::zeros(),
        sa: Vec3::zeros(),
    };
    // An industrial MEMS IMU (ARW 0.34°/√h, VRW 0.06 m/s/√h): over 1 s its
    // position change is known to ~mm, so a 1-cycle slip stands out. (The
    // seed 001 preset's ARW, 34°/√h, tilts the platform by ~0.01 rad per
    // second: a ~5 cm position-change σ, and a 19 cm slip is < 4σ.)
    let cfg = EskfConfig {
        noise: ImuNoise {
            arw: Vec3::repeat(1e-4),
            vrw: Vec3::repeat(1e-3),
            ..EskfConfig::seed001().noise
        },
        ..EskfConfig::seed001()
    };
    Eskf::new(cfg, nav, ImuErrors::default(), &std)
        .with_rtk(rc)
        .unwrap()
}

/// Run `secs` epochs at 1 Hz (IMU 100 Hz at rest); `ep(s)` gives the
/// rover and base epochs of second `s`. Returns the solutions.
fn run(f: &mut Eskf, secs: u32, ep: &dyn Fn(u32, f64) -> (RawEpoch, RawEpoch)) -> Vec<RtkSolution> {
    let g = crate::earth::gravity(LAT, H);
    let mut out = Vec::new();
    for k in 1..=secs * 100 {
        let t = T0 + k as f64 * 0.01;
        f.push(&Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: Vec3::new(0.0, 0.0, -g * 0.01),
        }));
        if k % 100 == 0 {
            let (r, b) = ep(k / 100, t);
            out.push(f.rtk_update(&r, &b, &base()).unwrap());
        }
    }
    out
}

fn clean(_s: u32, t: f64) -> (RawEpoch, RawEpoch) {
    (
        epoch(
            t,
            &rover(),
            8,
            n_rover,
            &[],
            &[],
            &[],
            1.0e4 + 30.0 * (t - T0),
        ),
        epoch(t, &base(), 8, n_base, &[], &[], &[], -2.0e3),
    )
}

/// Whitened sequential scalar updates equal the vector update with the
/// exact (correlated) DD covariance.
#[test]
fn whitened_equals_vector_update() {
    let m = 5;
    // A positive definite prior: A Aᵀ + I.
    let a = SMatrix::<f64, NJ_TEST, NJ_TEST>::from_fn(|i, j| {
        ((i * 7 + j * 13) % 11) as f64 * 0.1 - 0.5
    });
    let p0 = a * a.transpose() + SMatrix::<f64, NJ_TEST, NJ_TEST>::identity();
    let h: Vec<SVector<f64, NJ_TEST>> = (0..m)
        .map(|r| SVector::<f64, NJ_TEST>::from_fn(|i, _| ((r * 5 + i * 3) % 7) as f64 - 3.0))
        .collect();
    let dz = [0.3, -0.1, 0.05, 0.2, -0.4];
    let v = [1e-4, 2e-4, 5e-5, 3e-4, 1e-4];
    let ((dx1, p1), (dx2, p2)) = dd_update_both(&p0, &h, &dz, &v, 7e-5);
    assert!(
        (dx1 - dx2).amax() < 1e-9 * dx2.amax().max(1.0),
        "{}",
        (dx1 - dx2).amax()
    );
    assert!((p1 - p2).amax() < 1e-8 * p2.amax(), "{}", (p1 - p2).amax());
}

/// Clean data: floats converge, LAMBDA fixes with the true DD integers,
/// the fixed position is at the truth, no slip detected, no gating.
#[test]
fn fixes_clean_static_baseline_with_true_integers() {
    let mut f = filter();
    let sols = run(&mut f, 30, &clean);
    let st = *f.rtk_stats().unwrap();
    let tot = st.total();
    assert_eq!(tot.slips, 0, "{tot:?}");
    assert_eq!(tot.phase_gated, 0, "{tot:?}");
    assert_eq!(tot.rises, 8);
    let last = sols.last().unwrap();
    assert!(last.fixed, "{last:?}");
    assert_eq!(last.n_fixed, 7);
    for d in &last.fixed_dd[..last.n_fixed] {
        let (i, r) = (d.prn as usize - 1, d.ref_prn as usize - 1);
        let truth = (n_rover(i) - n_base(i)) - (n_rover(r) - n_base(r));
        assert_eq!(d.n as f64, truth, "{d:?}");
    }
    let fx = geodetic_to_ecef(&last.pos);
    // The IMU is the antenna (no lever arm).
    assert!((fx - rover()).norm() < 0.01, "{}", (fx - rover()).norm());
    assert_eq!(st.fix_attempts, 30);
    assert!(st.fixed >= 1);
}

/// Rise, set, loss of lock and a full capacity are counted; no panic.
#[test]
fn slot_bookkeeping() {
    let mut f = filter();
    let ep = |s: u32, t: f64| {
        // Satellite 7 rises at s = 10, satellite 2 sets at s = 20,
        // satellite 4 loses lock at s = 15 (rover).
        let skip: &[usize] = match s {
            0..=9 => &[7],
            20.. => &[2],
            _ => &[],
        };
        let lli: &[usize] = if s == 15 { &[4] } else { &[] };
        (
            epoch(t, &rover(), 8, n_rover, &[], lli, skip, 0.0),
            epoch(t, &base(), 8, n_base, &[], &[], skip, 0.0),
        )
    };
    run(&mut f, 25, &ep);
    let st = f.rtk_stats().unwrap();
    assert_eq!(st.sat(GnssSystem::Gps, 8).rises, 1);
    assert_eq!(st.sat(GnssSystem::Gps, 3).sets, 1);
    assert_eq!(st.sat(GnssSystem::Gps, 5).lli_resets, 1);
    assert_eq!(f.rtk_slots_used(), 7);
    // 40 satellites: all get a slot (48), none beyond the capacity.
    let mut f = filter();
    let many = |_s: u32, t: f64| {
        (
            epoch(t, &rover(), 40, n_rover, &[], &[], &[], 0.0),
            epoch(t, &base(), 40, n_base, &[], &[], &[], 0.0),
        )
    };
    let sols = run(&mut f, 3, &many);
    let tot = f.rtk_stats().unwrap().total();
    assert_eq!(f.rtk_slots_used(), 40.min(NAMB));
    assert_eq!(
        tot.capacity,
        3 * (40u32.saturating_sub(NAMB as u32)),
        "{tot:?}"
    );
    assert!(sols.iter().all(|s| s.n_phase > 0));
}

/// A 1-cycle slip on one satellite is detected by the INS prediction
/// (and only that one); clean data has none (previous test).
#[test]
fn detects_one_cycle_slip() {
    let mut f = filter();
    let ep = |s: u32, t: f64| {
        let slip: &[(usize, f64)] = if s >= 20 { &[(3, 1.0)] } else { &[] };
        (
            epoch(t, &rover(), 8, n_rover, slip, &[], &[], 5.0 * s as f64),
            epoch(t, &base(), 8, n_base, &[], &[], &[], 0.0),
        )
    };
    let sols = run(&mut f, 30, &ep);
    let st = f.rtk_stats().unwrap();
    assert_eq!(
        st.sat(GnssSystem::Gps, 4).slips,
        1,
        "{:?}",
        st.sat(GnssSystem::Gps, 4)
    );
    assert_eq!(st.total().slips, 1);
    assert_eq!(st.total().phase_gated, 0);
    // Fixed again with the new integer.
    let last = sols.last().unwrap();
    assert!(last.fixed, "{last:?}");
    let fx = geodetic_to_ecef(&last.pos);
    assert!((fx - rover()).norm() < 0.01);
}

#[test]
fn refuses_tight_coupling_and_bad_input() {
    let nav = NavState {
        lat: LAT,
        lon: LON,
        h: H,
        ..Default::default()
    };
    let std = InitStd {
        pos: Vec3::repeat(1.0),
        vel: Vec3::repeat(0.1),
        att: Vec3::repeat(0.01),
        bg: Vec3::zeros(),
        ba: Vec3::zeros(),
        sg: Vec3::zeros(),
        sa: Vec3::zeros(),
    };
    let f = Eskf::new(EskfConfig::seed001(), nav, ImuErrors::default(), &std)
        .with_tight_coupling(TightConfig::consumer())
        .unwrap();
    assert_eq!(
        f.with_rtk(RtkConfig::rtklib()).err(),
        Some(RtkConfigError::Incompatible)
    );
    let mut f = filter();
    let e = RawEpoch::new(T0);
    assert_eq!(
        f.rtk_update(&e, &e, &base()).err(),
        Some(RtkError::NotStarted)
    );
    let bad = RtkConfig {
        ratio_min: 0.5,
        ..RtkConfig::rtklib()
    };
    let nav2 = *filter().nav();
    let g = Eskf::new(EskfConfig::seed001(), nav2, ImuErrors::default(), &std);
    assert_eq!(g.with_rtk(bad).err(), Some(RtkConfigError::Invalid));
}

/// Dual-frequency (GPS L1 + L2C) epochs of `nsat` satellites with a
/// single-difference slant ionosphere `iono_l1(k)` [m on 1575.42 MHz] at the
/// rover only (code `+γ_f I`, phase `−γ_f I`, first order).
fn epoch_df(
    t: f64,
    rx: &Vec3,
    nsat: usize,
    rover_side: bool,
    iono_l1: fn(usize) -> f64,
) -> RawEpoch {
    let g = crate::geodesy::ecef_to_geodetic(rx);
    let cen = c_en(g.lat, g.lon);
    let mut ep = RawEpoch::new(t);
    for (k, p) in sats(nsat).iter().enumerate() {
        let (rho, los) = geometric_range(p, rx);
        let el = (-(cen * los).z).asin();
        let trop = slant_delay(el, g.lat, g.h, day_of_year(t), 0.0);
        for (j, signal) in [Signal::GpsL1Ca, Signal::GpsL2C].into_iter().enumerate() {
            let lam = signal.wavelength_m(0);
            let gamma = (lam / LAMBDA_L1).powi(2);
            let i_f = if rover_side { gamma * iono_l1(k) } else { 0.0 };
            let n = if rover_side { n_rover(k) } else { n_base(k) } + 7.0 * j as f64;
            ep.push(RawSat {
                obs: RawObs {
                    t,
                    pseudorange_m: rho + trop + i_f,
                    carrier_m: rho + trop - i_f + lam * n,
                    cn0_dbhz: 45.0,
                    system: GnssSystem::Gps,
                    prn: k as u8 + 1,
                    signal,
                    ..Default::default()
                },
                sat: SatState {
                    pos_e: *p,
                    valid: true,
                    ..Default::default()
                },
            });
        }
    }
    ep
}

/// A differential ionosphere of 1–3 cm slant (what 5 ppm, a disturbed day
/// in the range of Springer Handbook of GNSS ch. 26, gives over this 2 km
/// baseline at low elevation), constant over the run: estimated
/// ([`RtkConfig::iono_estimate`]) the fixed position stays at the truth
/// within 5 mm with the true integers (measured 3.3 mm: the states are
/// ionosphere-weighted, their prior pulls toward 0 against the weak code);
/// weighted as white noise instead, it is averaged into a bias of the
/// position (measured 0.44 m; asserted only > 2× the estimated case).
#[test]
fn differential_ionosphere_estimated_not_averaged_into_the_fix() {
    fn iono(k: usize) -> f64 {
        0.01 + 0.02 * ((k * 5) % 7) as f64 / 6.0 * if k.is_multiple_of(2) { 1.0 } else { -1.0 }
    }
    let ep = |_s: u32, t: f64| {
        (
            epoch_df(t, &rover(), 8, true, iono),
            epoch_df(t, &base(), 8, false, iono),
        )
    };
    let mut err = [0.0; 2];
    for (i, est) in [true, false].into_iter().enumerate() {
        let rc = RtkConfig {
            iono_ppm: 5.0,
            iono_estimate: est,
            ..RtkConfig::rtklib()
        };
        let mut f = filter_with(rc);
        let sols = run(&mut f, 60, &ep);
        let last = sols.last().unwrap();
        assert!(last.fixed, "{last:?}");
        for d in &last.fixed_dd[..last.n_fixed] {
            let (a, r) = (d.prn as usize - 1, d.ref_prn as usize - 1);
            let truth = (n_rover(a) - n_base(a)) - (n_rover(r) - n_base(r));
            assert_eq!(d.n as f64, truth, "est {est}: {d:?}");
        }
        err[i] = (geodetic_to_ecef(&last.pos) - rover()).norm();
    }
    assert!(err[0] < 0.005, "{err:?}");
    assert!(err[1] > 2.0 * err[0], "{err:?}");
}

/// GNSS-only mode ([`RtkConfig::gnss_only`]) does not use the INS: an IMU
/// with a 0.5 m/s² accelerometer bias (its free-inertial position drifts
/// 0.25 m per second and 225 m over 30 s) gives the same RTK positions,
/// to 1 mm, as a perfect one, and both fix the static baseline to 1 cm.
#[test]
fn gnss_only_mode_ignores_the_ins() {
    let g = crate::earth::gravity(LAT, H);
    let mk = || {
        let mut f = filter();
        let c = RtkConfig {
            gnss_only: true,
            ..f.rtk_config().unwrap()
        };
        f.rtk_set_config(c).unwrap();
        f
    };
    let (mut a, mut b) = (mk(), mk());
    let mut worst = 0.0f64;
    let mut last = None;
    for k in 1..=30 * 100 {
        let t = T0 + k as f64 * 0.01;
        for (f, bias) in [(&mut a, 0.0), (&mut b, 0.5)] {
            f.push(&Event::Imu(ImuSample {
                t,
                dt: 0.01,
                dtheta_b: Vec3::zeros(),
                dvel_b: Vec3::new(bias * 0.01, 0.0, -g * 0.01),
            }));
        }
        if k % 100 == 0 {
            let (r, bs) = clean(k / 100, t);
            let sa = a.rtk_update(&r, &bs, &base()).unwrap();
            let sb = b.rtk_update(&r, &bs, &base()).unwrap();
            let d = geodetic_to_ecef(&sa.float_pos) - geodetic_to_ecef(&sb.float_pos);
            worst = worst.max(d.norm());
            last = Some((sa, sb));
        }
    }
    assert!(worst < 1e-3, "{worst}");
    let (sa, sb) = last.unwrap();
    for s in [sa, sb] {
        assert!(s.fixed, "{s:?}");
        assert!((geodetic_to_ecef(&s.pos) - rover()).norm() < 0.01, "{s:?}");
    }
}

fn gnss_only() -> RtkConfig {
    RtkConfig {
        gnss_only: true,
        ..RtkConfig::rtklib()
    }
}

/// Float horizontal+vertical error [m] of each solution against `truth(s)`
/// (epoch `s` = index + 1).
fn float_errors(sols: &[RtkSolution], truth: impl Fn(u32) -> Vec3) -> Vec<f64> {
    sols.iter()
        .enumerate()
        .map(|(i, s)| (geodetic_to_ecef(&s.float_pos) - truth(i as u32 + 1)).norm())
        .collect()
}

/// GNSS-only mode restarts from a code solution computed independently of
/// its own state ([`RtkConfig::gnss_only`], `Eskf::recentre_on_code`):
/// started on the far side of the earth (σ 1 m), from where no satellite
/// is above the mask, its float is within 1 m of the rover from the first
/// epoch on. Before, the
/// code solution started at the filter's state, found no satellite there
/// and was refused; every DD was then gated and the filter coasted
/// 12 700 km off for good (the runaway of `experiment rtk` seed 19 with a
/// perturbed scene, which went 27 600 km off).
#[test]
fn gnss_only_restart_does_not_depend_on_a_lost_state() {
    let mut f = filter_at(gnss_only(), -LAT, LON + core::f64::consts::PI, H);
    let sols = run(&mut f, 10, &clean);
    let err = float_errors(&sols, |_| rover());
    assert!(err.iter().all(|e| *e < 1.0), "{err:?}");
}

/// A static rover whose data jump `east_m` east after epoch 10 (the IMU
/// does not move): the moved antenna, the antenna at epoch `s`, and the
/// epochs (8 satellites, clean).
#[allow(clippy::type_complexity)]
fn jump_east(
    east_m: f64,
) -> (
    Vec3,
    impl Fn(u32) -> Vec3 + Copy,
    impl Fn(u32, f64) -> (RawEpoch, RawEpoch),
) {
    let moved = rover() + c_en(LAT, LON).transpose() * Vec3::new(0.0, east_m, 0.0);
    let at = move |s: u32| if s <= 10 { rover() } else { moved };
    let ep = move |s: u32, t: f64| {
        (
            epoch(t, &at(s), 8, n_rover, &[], &[], &[], 1.0e4),
            epoch(t, &base(), 8, n_base, &[], &[], &[], -2.0e3),
        )
    };
    (moved, at, ep)
}

/// GNSS-only mode detects that it has lost itself — every code DD of an
/// epoch beyond its gate — and restarts from the code solution at the next
/// epoch: a rover whose data jump 2 km east after 10 s (a filter whose
/// state is suddenly 2 km off with a σ of metres) is back within 1 m at
/// the second epoch after the jump and fixed again. Before, it coasted on
/// its constant-velocity prediction with every DD gated until the
/// predicted σ had grown past 30 m (~7 epochs).
#[test]
fn gnss_only_restarts_when_every_code_dd_is_gated() {
    let (moved, at, ep) = jump_east(2000.0);
    let mut f = filter_with(gnss_only());
    let sols = run(&mut f, 20, &ep);
    let err = float_errors(&sols, at);
    assert!(err[..10].iter().all(|e| *e < 0.1), "{err:?}");
    assert!(err[10] > 1000.0, "{err:?}"); // the jump epoch: all gated
    assert!(err[11..].iter().all(|e| *e < 1.0), "{err:?}");
    let last = sols.last().unwrap();
    assert!(
        last.fixed && (geodetic_to_ecef(&last.pos) - moved).norm() < 0.01,
        "{last:?}"
    );
}

/// Dual-frequency epoch of satellites `ks` of [`sats`]`(8)`, GPS L1/L2 for
/// `k < 4`, Galileo E1/E5b otherwise; no ionosphere.
fn epoch_gal_gps(t: f64, rx: &Vec3, ks: &[usize], rover_side: bool) -> RawEpoch {
    let g = crate::geodesy::ecef_to_geodetic(rx);
    let cen = c_en(g.lat, g.lon);
    let mut ep = RawEpoch::new(t);
    for (k, p) in sats(8).iter().enumerate() {
        if !ks.contains(&k) {
            continue;
        }
        let (rho, los) = geometric_range(p, rx);
        let el = (-(cen * los).z).asin();
        let trop = slant_delay(el, g.lat, g.h, day_of_year(t), 0.0);
        let (system, sigs) = if k < 4 {
            (GnssSystem::Gps, [Signal::GpsL1Ca, Signal::GpsL2C])
        } else {
            (GnssSystem::Galileo, [Signal::GalE1, Signal::GalE5b])
        };
        for (j, signal) in sigs.into_iter().enumerate() {
            let lam = signal.wavelength_m(0);
            let n = if rover_side { n_rover(k) } else { n_base(k) } + 7.0 * j as f64;
            ep.push(RawSat {
                obs: RawObs {
                    t,
                    pseudorange_m: rho + trop,
                    carrier_m: rho + trop + lam * n,
                    cn0_dbhz: 45.0,
                    system,
                    prn: k as u8 + 1,
                    signal,
                    ..Default::default()
                },
                sat: SatState {
                    pos_e: *p,
                    valid: true,
                    ..Default::default()
                },
            });
        }
    }
    ep
}

/// The GNSS-only restart refuses a code solution of rank-deficient
/// geometry although it has "enough" DDs: 2 GPS + 2 Galileo satellites on
/// two frequencies give 4 code DDs along only 2 lines of sight (one DD per
/// system and signal), so the position along the third direction is not
/// observed (its DOP is infinite, `MAX_DD_PDOP`). Static rover: 10 s
/// with 8 satellites, 60 s with those 4 (the unobserved direction's σ
/// grows past the 30 m restart threshold), 20 s with 8 again: no restart
/// in the window (the σ keeps growing, the prediction is kept), the float
/// within 5 m throughout, fixed on the rover at the end. Before, each
/// restart took the singular "solution" (σ back to 30 m every 3–6
/// epochs); with noise-free code it stayed on the rover here, but in seed
/// 19 of `experiment rtk` (GPS + BeiDou in its 4-satellite window, a
/// perturbed scene) it went to a false root 27 600 km off.
#[test]
fn gnss_only_refuses_a_rank_deficient_code_restart() {
    let ks = |s: u32| -> &'static [usize] {
        if (11..=70).contains(&s) {
            &[0, 1, 4, 5]
        } else {
            &[0, 1, 2, 3, 4, 5, 6, 7]
        }
    };
    let ep = move |s: u32, t: f64| {
        (
            epoch_gal_gps(t, &rover(), ks(s), true),
            epoch_gal_gps(t, &base(), ks(s), false),
        )
    };
    let mut f = filter_with(gnss_only());
    let sols = run(&mut f, 90, &ep);
    let err = float_errors(&sols, |_| rover());
    let worst = err.iter().cloned().fold(0.0, f64::max);
    // No restart in the window: the σ of the unobserved direction keeps
    // growing (an accepted restart would set it back to 30 m).
    let sd: Vec<f64> = sols.iter().map(|s| s.float_std_ned.norm()).collect();
    assert!(sd[69] > 100.0, "{sd:?}");
    assert!(sd[10..70].windows(2).all(|w| w[1] >= 0.99 * w[0]), "{sd:?}");
    assert!(worst < 5.0, "{worst} {err:?}");
    let last = sols.last().unwrap();
    assert!(
        last.fixed && (geodetic_to_ecef(&last.pos) - rover()).norm() < 0.01,
        "{last:?}"
    );
}

/// INS-aided RTK resets a position that the code DDs contradict
/// ([`Eskf::rtk_test_position_on_code`]): the rover's data jump 20 m east
/// after 10 s while the (static) IMU does not, i.e. an INS position 20 m
/// off with a σ of decimetres. Before, the filter stayed 20 m off to the
/// end with σ 0.1–0.2 m: 5 of 7 code DDs gated at every epoch, the phase
/// DDs all used, their float ambiguities having taken up the error. Now
/// the epoch after the jump tests the position against the code
/// solution, resets it and the ambiguities, and the filter is within 1 m
/// (σ covering it) from then on and fixed again on the moved antenna; a
/// consistent run never resets.
#[test]
fn ins_aided_rtk_resets_a_position_inconsistent_with_code() {
    let (moved, at, ep) = jump_east(20.0);
    let mut f = filter_with(RtkConfig::rtklib());
    let sols = run(&mut f, 40, &ep);
    let err = float_errors(&sols, at);
    // Before the jump: within the start's 0.5 m offset.
    assert!(err[..10].iter().all(|e| *e < 0.5), "{err:?}");
    assert!(err[10] > 19.0, "{err:?}"); // the jump epoch itself
    for (e, s) in err[11..].iter().zip(&sols[11..]) {
        assert!(*e < 1.0 && *e < 3.0 * s.float_std_ned.norm(), "{err:?}");
    }
    let last = sols.last().unwrap();
    assert!(
        last.fixed && (geodetic_to_ecef(&last.pos) - moved).norm() < 0.01,
        "{last:?}"
    );
    assert_eq!(f.rtk_stats().unwrap().position_resets, 1);
    let mut g = filter_with(RtkConfig::rtklib());
    run(&mut g, 40, &clean);
    assert_eq!(g.rtk_stats().unwrap().position_resets, 0);
}

/// A fixed solution is reported as fixed only when the fixed DDs alone
/// determine the position ([`RtkSolution::position_fixed`]). INS-aided,
/// static rover: 10 s with 8 satellites (GPS and Galileo, two signals
/// each), 30 s with 2 GPS + 2 Galileo — one DD per system and signal, L1
/// and L2 along the same line of sight: 4 phase DDs of rank 2 — then 10 s
/// with 8 again. The integers are validated in most window epochs (the
/// INS carries the third direction), but there the fixed DDs' position DOP is
/// unbounded and the epoch is not a fixed position; outside it the DOP is
/// that of 8 satellites and the position fixed to the centimetre.
#[test]
fn fix_on_rank_deficient_dds_is_not_a_fixed_position() {
    let window = |s: u32| (11..=40).contains(&s);
    let ep = move |s: u32, t: f64| {
        let ks: &[usize] = if window(s) {
            &[0, 1, 4, 5]
        } else {
            &[0, 1, 2, 3, 4, 5, 6, 7]
        };
        (
            epoch_gal_gps(t, &rover(), ks, true),
            epoch_gal_gps(t, &base(), ks, false),
        )
    };
    let mut f = filter_with(RtkConfig::rtklib());
    let sols = run(&mut f, 50, &ep);
    let mut weak = 0u64;
    for (k, s) in sols.iter().enumerate() {
        let sec = k as u32 + 1;
        if window(sec) {
            assert!(!s.position_fixed(), "{sec}: {s:?}");
            // Rank 2: ∞, or round-off's 10⁷ (the exact Cholesky pivot is 0).
            assert!(s.fix_pdop > 1e3, "{sec}: {}", s.fix_pdop);
            weak += u64::from(s.fixed);
        } else if sec > 3 {
            assert!(s.position_fixed(), "{sec}: {s:?}");
            assert!(s.fix_pdop < 5.0, "{sec}: {}", s.fix_pdop);
            assert!((geodetic_to_ecef(&s.pos) - rover()).norm() < 0.01, "{sec}");
        }
    }
    // The integers themselves were validated in most of the window.
    assert!(weak >= 15, "{weak}");
    assert_eq!(f.rtk_stats().unwrap().fixed_weak_geometry, weak);
}

/// [`epoch_gal_gps`] at the rover with between-receiver hardware biases a
/// real receiver pair of different types has: per Galileo signal a phase
/// bias (not a whole number of cycles) and a code bias of metres, on top of
/// a receiver clock common to everything.
fn epoch_gal_gps_biased(t: f64, ks: &[usize]) -> RawEpoch {
    let src = epoch_gal_gps(t, &rover(), ks, true);
    let mut ep = RawEpoch::new(t);
    for s in src.sats() {
        let mut s = *s;
        let (phase_m, code_m) = match s.obs.signal {
            Signal::GalE1 => (0.231, 2.5),
            Signal::GalE5b => (-0.413, -1.7),
            _ => (0.0, 0.0),
        };
        let clock_m = 3.0e3 + 25.0 * (t - T0);
        s.obs.carrier_m += phase_m + clock_m;
        s.obs.pseudorange_m += code_m + clock_m;
        ep.push(s);
    }
    ep
}

/// Float links between the DD groups (`RtkConfig::float_links`): 20 s with
/// 8 satellites (4 GPS L1/L2, 4 Galileo E1/E5b, separate groups, inter-
/// system biases at the rover), then 60 s with 2 GPS + 2 Galileo, whose
/// DDs within groups have rank 2 (`fix_on_rank_deficient_dds_is_not_a_
/// fixed_position`). Without links the position along the third direction
/// is the INS's alone: its σ grows (to ≥ 0.1 m by the end, the test IMU's
/// VRW over 60 s). With links the Galileo group's reference is a DD
/// against GPS whose float part (ambiguities plus the biases, which are
/// not whole cycles) was learnt with 8 satellites: the largest position σ
/// stays ≤ 2 cm, the float within 3σ of the truth in every direction, and
/// no phase DD is gated (the biases are absorbed, not rejected). Bars
/// written before the first run. Both filters hold the fixed DDs
/// (fix-and-hold): a float link is only as precise as the float position
/// it was learnt with, and in this scene (static satellites, static rover)
/// the float alone never gets beyond code averaging — the first run,
/// without hold, ended at 0.21 m with links, the bar failed — while the
/// moving sky of `experiment rtk` separates the floats over minutes.
#[test]
fn float_links_keep_the_third_direction_with_two_systems() {
    let window = |s: u32| s > 20;
    let ep = move |s: u32, t: f64| {
        let ks: &[usize] = if window(s) {
            &[0, 1, 4, 5]
        } else {
            &[0, 1, 2, 3, 4, 5, 6, 7]
        };
        (
            epoch_gal_gps_biased(t, ks),
            epoch_gal_gps(t, &base(), ks, false),
        )
    };
    let worst_std = |f: &Eskf| {
        let p: Mat3 = f.covariance().fixed_view::<3, 3>(0, 0).into_owned();
        p.symmetric_eigenvalues().max().max(0.0).sqrt()
    };
    let hold = RtkConfig {
        fix_and_hold: true,
        ..RtkConfig::rtklib()
    };
    let mut without = filter_with(hold);
    run(&mut without, 80, &ep);
    let s_without = worst_std(&without);
    assert!(s_without >= 0.1, "without links: {s_without}");

    let mut f = filter_with(RtkConfig {
        float_links: true,
        ..hold
    });
    let sols = run(&mut f, 80, &ep);
    let s_with = worst_std(&f);
    assert!(s_with <= 0.02, "with links: {s_with}");
    for (k, s) in sols.iter().enumerate().skip(5) {
        let g = crate::geodesy::ecef_to_geodetic(&rover());
        let d = c_en(g.lat, g.lon) * (geodetic_to_ecef(&s.float_pos) - rover());
        for i in 0..3 {
            let sd = s.float_std_ned[i];
            assert!(
                d[i].abs() <= 3.0 * sd,
                "{}: axis {i} {} > 3 × {sd}",
                k + 1,
                d[i]
            );
        }
    }
    assert_eq!(f.rtk_stats().unwrap().total().phase_gated, 0);
}
