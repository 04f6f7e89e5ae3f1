//! Proves that the per-step code never touches the heap: a counting global
//! allocator records allocations made on the test's own thread while the
//! Kalman step and every streaming estimator (ESKF, PF-LC, GPS-ACC, GPS hold,
//! CP-ATT) process a synthetic drive.

use nalgebra::{SMatrix, SVector};
use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig, GpsHold};
use navfuse_core::estimators::adaptive::{AdaptiveConstraints, AdaptiveNoise, GnssQualityScale};
use navfuse_core::estimators::eskf::{Eskf, EskfConfig, ImuErrors, InitStd, NhcConfig, ZuptConfig};
use navfuse_core::estimators::pf_lc::{PfLc, PfLcConfig};
use navfuse_core::ins::mech::NavState;
use navfuse_core::kalman::{chi2_quantile, predict, predict_sparse, update_joseph};
use navfuse_core::{Estimator, Event, GnssFix, ImuSample, Vec3};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: delegates every call unchanged to the system allocator.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocs() -> usize {
    ALLOCS.with(|c| c.get())
}

#[test]
fn predict_and_update_do_not_allocate() {
    // The counter works: a Vec on this thread is seen.
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(64);
    assert!(allocs() > before, "counting allocator is not active");
    drop(v);

    let dt = 0.01;
    let mut f = SMatrix::<f64, 15, 15>::identity();
    for i in 0..3 {
        f[(i, i + 3)] = dt;
        f[(3 + i, 6 + (i + 1) % 3)] = 9.8 * dt;
        f[(6 + i, 12 + i)] = -dt;
        f[(3 + i, 9 + i)] = dt;
    }
    let q = SMatrix::<f64, 15, 15>::identity() * 1e-6;
    let mut h = SMatrix::<f64, 6, 15>::zeros();
    for i in 0..6 {
        h[(i, i)] = 1.0;
    }
    let r = SMatrix::<f64, 6, 6>::identity() * 0.25;
    let mut x = SVector::<f64, 15>::zeros();
    let mut p = SMatrix::<f64, 15, 15>::identity();

    let start = allocs();
    let gate = chi2_quantile(6, 0.999);
    let mut accepted = 0;
    for k in 0..1000 {
        if k % 2 == 0 {
            predict(&mut p, &f, &q);
        } else {
            predict_sparse(&mut p, &f, &q);
        }
        if k % 100 == 99 {
            let nu = SVector::<f64, 6>::from_fn(|i, _| ((k + i) % 5) as f64 * 0.1 - 0.2);
            accepted += update_joseph(&mut x, &mut p, &h, &r, &nu, Some(gate)).accepted as usize;
        }
    }
    let used = allocs() - start;
    assert_eq!(used, 0, "{used} heap allocations in the Kalman loop");
    assert_eq!(accepted, 10);
    assert!(p.iter().all(|v| v.is_finite()));
}

#[test]
fn push_does_not_allocate() {
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(64);
    assert!(allocs() > before, "counting allocator is not active");
    drop(v);

    let mut dr = AccelDr::new(AccelDrConfig::rate_scaled());
    let mut lit = AccelDr::new(AccelDrConfig::paper_literal());
    let mut hold = GpsHold::new();
    let (mut lat, lon) = (0.6f64, 2.1f64);
    let before = allocs();
    let mut outputs = 0usize;
    for k in 1..=3000u32 {
        let t = k as f64 * 0.01;
        // 2 m/s² forward then a right turn, readings in FRD.
        let f_b = Vec3::new(2.0, if t > 10.0 { 1.0 } else { 0.0 }, -9.8);
        let imu = Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: f_b * 0.01,
        });
        for e in [&mut dr as &mut dyn Estimator, &mut lit, &mut hold] {
            outputs += e.push(&imu).is_some() as usize;
        }
        if k % 100 == 0 {
            lat += t * 2.0 / 6.4e6;
            let fix = Event::Gnss(GnssFix {
                t,
                lat,
                lon,
                ..Default::default()
            });
            for e in [&mut dr as &mut dyn Estimator, &mut lit, &mut hold] {
                outputs += e.push(&fix).is_some() as usize;
            }
        }
    }
    assert_eq!(allocs(), before, "push allocated");
    assert!(outputs > 8000);
}

/// Initial σ of the ESKF in these tests.
fn init_std() -> InitStd {
    InitStd {
        pos: Vec3::repeat(1.0),
        vel: Vec3::repeat(0.1),
        att: Vec3::repeat(0.01),
        bg: Vec3::repeat(1e-4),
        ba: Vec3::repeat(0.01),
        sg: Vec3::repeat(1e-3),
        sa: Vec3::repeat(1e-3),
    }
}

/// A level drive north at 10 m/s, 100 Hz IMU and 1 Hz fixes with velocity,
/// through the ESKF (GNSS position + velocity updates, NHC/ZUPT as in the
/// seed 001 preset) and PF-LC.
#[test]
fn eskf_and_pf_lc_push_do_not_allocate() {
    let (lat0, lon0, h) = (0.7f64, -1.8f64, 100.0);
    let (rm, _) = navfuse_core::earth::radii(lat0);
    let v = 10.0;
    let nav = NavState {
        lat: lat0,
        lon: lon0,
        h,
        v_n: Vec3::new(v, 0.0, 0.0),
        ..Default::default()
    };
    let std = init_std();
    let mut eskf = Eskf::new(EskfConfig::seed001(), nav, ImuErrors::default(), &std);
    let mut pflc = PfLc::new(PfLcConfig::default());
    let g = navfuse_core::earth::gravity(lat0, h);
    let mut outputs = 0usize;
    // Warm up: first fixes initialise PF-LC's plane and filters.
    let mut events = Vec::with_capacity(6100);
    for k in 1..=6000u32 {
        let t = k as f64 * 0.01;
        events.push(Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: Vec3::new(0.0, 0.0, -g * 0.01),
        }));
        if k % 100 == 0 {
            events.push(Event::Gnss(GnssFix {
                t,
                lat: lat0 + v * t / (rm + h),
                lon: lon0,
                h,
                std_ned: Vec3::repeat(0.5),
                v_n: Some(Vec3::new(v, 0.0, 0.0)),
                std_v_n: Some(Vec3::repeat(0.05)),
                quality: 1,
                num_sats: 10,
            }));
        }
    }
    let (warm, rest) = events.split_at(1020);
    for e in warm {
        outputs += eskf.push(e).is_some() as usize + pflc.push(e).is_some() as usize;
    }
    let before = allocs();
    for e in rest {
        outputs += eskf.push(e).is_some() as usize + pflc.push(e).is_some() as usize;
    }
    assert_eq!(allocs(), before, "push allocated");
    assert!(outputs > 10_000, "{outputs} solutions");
    assert!(eskf.solution().lat.is_finite());
}

/// The ESKF with adaptive NHC, ZUPT and ZARU noise and the GNSS quality
/// scale: 20 s parked (standstill, ZUPT/ZARU), then 1 m/s² north to 10 m/s
/// (NHC), fixes at 1 Hz.
#[test]
fn adaptive_eskf_push_does_not_allocate() {
    let (lat0, lon0, h) = (0.7f64, -1.8f64, 100.0);
    let (rm, _) = navfuse_core::earth::radii(lat0);
    let g = navfuse_core::earth::gravity(lat0, h);
    let std = init_std();
    let mut cfg = EskfConfig::seed001();
    cfg.gate_probability = Some(0.9999);
    cfg.nhc = Some(NhcConfig {
        std: 0.5,
        interval: 0.1,
        min_speed: 0.5,
    });
    cfg.zupt = Some(ZuptConfig {
        window: 50,
        max_accel_std: 0.1,
        max_gyro_std: 0.03,
        max_accel_dev: 0.2,
        max_speed: 1.0,
        vel_std: 0.02,
        zaru_std: Some(1e-3),
        interval: 0.1,
    });
    let nav = NavState {
        lat: lat0,
        lon: lon0,
        h,
        ..Default::default()
    };
    let mut eskf = Eskf::new(cfg, nav, ImuErrors::default(), &std)
        .with_adaptive_noise(AdaptiveConstraints {
            nhc: Some(AdaptiveNoise::nhc_ground_vehicle()),
            zupt: Some(AdaptiveNoise::zupt()),
            zaru: Some(AdaptiveNoise::zaru()),
        })
        .unwrap()
        .with_gnss_quality_scale(GnssQualityScale([1.0, 1.0, 3.0, 1.0, 2.0, 5.0, 1.0]));
    let accel = |t: f64| if (20.0..30.0).contains(&t) { 1.0 } else { 0.0 };
    let (mut north, mut v) = (0.0, 0.0);
    let mut events = Vec::with_capacity(6100);
    for k in 1..=6000u32 {
        let t = k as f64 * 0.01;
        let a = accel(t);
        north += (v + 0.5 * a * 0.01) * 0.01;
        v += a * 0.01;
        events.push(Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: Vec3::new(a * 0.01, 0.0, -g * 0.01),
        }));
        if k % 100 == 0 {
            events.push(Event::Gnss(GnssFix {
                t,
                lat: lat0 + north / (rm + h),
                lon: lon0,
                h,
                std_ned: Vec3::repeat(0.05),
                quality: 1 + (k / 100 % 2) as u8,
                ..Default::default()
            }));
        }
    }
    let (warm, rest) = events.split_at(100);
    for e in warm {
        eskf.push(e);
    }
    let before = allocs();
    for e in rest {
        eskf.push(e);
    }
    assert_eq!(allocs(), before, "push allocated");
    let a = eskf.adapted_noise();
    assert!(
        a.nhc_counts.0 > 100 && a.zupt_counts.0 > 50 && a.zaru_counts.0 > 3,
        "{a:?}"
    );
    assert!(eskf.solution().lat.is_finite());
}

/// Seed 003: float filters, integer fixing, joint fixed-DD attitude, the
/// rigid-body attitude filter and its smoother allocate nothing per epoch.
#[test]
fn cp_attitude_update_does_not_allocate() {
    use navfuse_core::estimators::cp_attitude::{
        paper_dcm_nb, CpAttConfig, CpAttitude, CpEpoch, FixConfig,
    };
    const LAM: f64 = 0.190293673;
    let b_b = [Vec3::x(), Vec3::y(), Vec3::z()];
    let mut fc = FixConfig::default();
    if let Some(a) = fc.att_filter.as_mut() {
        a.smoother_lag = 2;
    }
    let mut est = CpAttitude::new(CpAttConfig::default(), &b_b).with_fixing(fc);
    // Epochs prepared before counting: 8 satellites, slowly turning body.
    let epochs: Vec<CpEpoch> = (0..40)
        .map(|e| {
            let t = 10.0 * e as f64;
            let c_bn =
                paper_dcm_nb(0.1 * (0.02 * t).sin(), 0.05, 0.3 * (0.02 * t).cos()).transpose();
            let mut ep = CpEpoch {
                t,
                n_sats: 8,
                n_baselines: 3,
                ..Default::default()
            };
            let mut prng = 0x9E37_79B9_7F4A_7C15u64 ^ e as u64;
            for s in 0..8 {
                let el = 1.4 - 0.16 * s as f64;
                let az = 0.8 * s as f64 + 0.001 * e as f64;
                ep.prn[s] = s as u8 + 1;
                ep.los_enu[s] = Vec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin());
                ep.sigma[s] = 0.002;
                for (k, bk) in b_b.iter().enumerate() {
                    prng = prng
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let noise = ((prng >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.002;
                    let amb = ((s * 5 + k * 3) % 11) as f64 - 5.0;
                    ep.sd_phase[k][s] = ep.los_enu[s].dot(&(c_bn * bk)) + LAM * amb + noise;
                }
            }
            ep
        })
        .collect();
    let mut fixed = 0;
    let mut smoothed = 0;
    let before = allocs();
    for ep in &epochs {
        let sol = est.update(ep);
        fixed += sol.rpy_fixed.is_some() as usize;
        smoothed += sol.smoothed.is_some() as usize;
    }
    assert_eq!(allocs(), before, "CpAttitude::update allocated");
    assert!(
        fixed > 30 && smoothed > 25,
        "fixed {fixed}, smoothed {smoothed}"
    );
    // The same epochs as per-satellite events through the streaming estimator.
    use navfuse_core::estimators::cp_att_stream::{CpAttStream, CpAttStreamConfig};
    use navfuse_core::types::{CarrierPhaseSat, Estimator, Event};
    let events: Vec<Event> = epochs
        .iter()
        .flat_map(|ep| {
            (0..ep.n_sats).map(move |i| {
                let sd: [f64; 4] = core::array::from_fn(|k| ep.sd_phase[k][i]);
                Event::CarrierPhase(CarrierPhaseSat {
                    t: ep.t,
                    prn: ep.prn[i],
                    n_baselines: 3,
                    last_in_epoch: i + 1 == ep.n_sats,
                    los_enu: ep.los_enu[i],
                    sigma_m: ep.sigma[i],
                    sd_phase_m: sd,
                })
            })
        })
        .collect();
    let mut stream = CpAttStream::new(CpAttStreamConfig::new(&b_b)).unwrap();
    let before = allocs();
    let mut sols = 0;
    for ev in &events {
        sols += stream.push(ev).is_some() as usize;
    }
    assert_eq!(allocs(), before, "CpAttStream::push allocated");
    assert!(sols > 30, "{sols}");
}

#[test]
fn yaw_gsf_push_does_not_allocate() {
    use navfuse_core::ins::yaw_gsf::{GsfConfig, YawGsf};
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(64);
    assert!(allocs() > before, "counting allocator is not active");
    drop(v);

    let mut gsf = YawGsf::new(GsfConfig::default());
    let start = allocs();
    let mut estimates = 0usize;
    for k in 1..=3000u32 {
        let t = k as f64 * 0.01;
        // A 2 m/s² forward push then a right turn, FRD, level.
        let turning = t > 10.0;
        let imu = ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::new(0.0, 0.0, if turning { 0.002 } else { 0.0 }),
            dvel_b: Vec3::new(0.02, if turning { 0.01 } else { 0.0 }, -0.098),
        };
        gsf.push_imu(&imu).unwrap();
        if k % 100 == 0 {
            let v_n = Vec3::new(2.0 * t.min(10.0), 0.0, 0.0);
            gsf.push_gnss_velocity(t, &v_n, &Vec3::repeat(0.1)).unwrap();
            estimates += gsf.estimate().is_some() as usize;
            let _ = gsf.c_bn();
        }
    }
    let used = allocs() - start;
    assert_eq!(used, 0, "{used} heap allocations in the yaw GSF loop");
    assert_eq!(estimates, 30);
}

/// The tightly coupled ESKF (issue 14): raw pseudorange/Doppler records of
/// 6 static synthetic satellites at 1 Hz, 100 Hz IMU at rest, with the car
/// constraints of the seed 001 preset's ZUPT — no heap use per event.
#[test]
fn tight_eskf_push_does_not_allocate() {
    use navfuse_core::estimators::eskf::TightConfig;
    use navfuse_core::geodesy::{c_en, geodetic_to_ecef, Geodetic};
    use navfuse_core::gnss::raw::{geometric_range, RawEpoch, RawObs, RawSat, SatState};
    let (lat0, lon0, h) = (0.7f64, -1.8f64, 100.0);
    let g = navfuse_core::earth::gravity(lat0, h);
    let rx = geodetic_to_ecef(&Geodetic {
        lat: lat0,
        lon: lon0,
        h,
    });
    let cne = c_en(lat0, lon0).transpose();
    let sats: Vec<(Vec3, f64)> = (0..6)
        .map(|k| {
            let (az, el) = (k as f64 * 1.0, 0.4 + 0.15 * k as f64);
            let u_n = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), -el.sin());
            (rx + cne * u_n * 2.0e7, el)
        })
        .collect();
    let nav = NavState {
        lat: lat0,
        lon: lon0,
        h,
        ..Default::default()
    };
    let mut eskf = Eskf::new(
        EskfConfig::seed001(),
        nav,
        ImuErrors::default(),
        &init_std(),
    )
    .with_tight_coupling(TightConfig::consumer())
    .unwrap();
    let mut events = Vec::with_capacity(7000);
    for k in 1..=6000u32 {
        let t = 1.4e9 + k as f64 * 0.01;
        events.push(Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: Vec3::zeros(),
            dvel_b: Vec3::new(0.0, 0.0, -g * 0.01),
        }));
        if k % 100 == 0 {
            let mut ep = RawEpoch::new(t);
            for (i, (p, el)) in sats.iter().enumerate() {
                let trop = navfuse_core::gnss::tropo::slant_delay(
                    *el,
                    lat0,
                    h,
                    navfuse_core::gnss::tropo::day_of_year(t),
                    navfuse_core::estimators::eskf::REL_HUMIDITY,
                );
                ep.push(RawSat {
                    obs: RawObs {
                        pseudorange_m: geometric_range(p, &rx).0 + 1.0e5 + trop,
                        doppler_hz: 0.0,
                        cn0_dbhz: 45.0,
                        prn: i as u8 + 1,
                        ..Default::default()
                    },
                    sat: SatState {
                        pos_e: *p,
                        valid: true,
                        ..Default::default()
                    },
                });
            }
            events.extend(ep.events());
        }
    }
    let (warm, rest) = events.split_at(1000);
    for e in warm {
        eskf.push(e);
    }
    let before = allocs();
    for e in rest {
        eskf.push(e);
    }
    assert_eq!(allocs(), before, "push allocated");
    // 60 epochs × 6; the last one waits for an IMU sample after it.
    assert_eq!(eskf.tight_stats().unwrap().total().pr_used, 354);
    assert!(eskf.solution().lat.is_finite());
}
