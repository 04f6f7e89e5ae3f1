//! Criterion benches: one strapdown mechanization step, one ESKF IMU sample
//! (mechanization + 21-state covariance propagation), and one IMU sample
//! with a GNSS position update.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use navfuse_core::earth;
use navfuse_core::estimators::eskf::{Eskf, EskfConfig, ImuErrors, ImuNoise, InitStd};
use navfuse_core::ins::mech::{mechanize, q_bn_from_rpy, NavState};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample};
use navfuse_core::Vec3;

fn start() -> NavState {
    NavState {
        lat: 0.7,
        lon: -1.8,
        h: 1600.0,
        v_n: Vec3::new(10.0, 2.0, 0.1),
        q_bn: q_bn_from_rpy(&Vec3::new(0.01, -0.02, 0.5)),
    }
}

fn filter() -> Eskf {
    let cfg = EskfConfig {
        noise: ImuNoise {
            arw: Vec3::repeat(8.0f64.to_radians() / 60.0),
            vrw: Vec3::repeat(1.0 / 60.0),
            bg_std: Vec3::repeat(5.8f64.to_radians() / 3600.0),
            ba_std: Vec3::repeat(2.9e-3),
            sg_std: Vec3::repeat(1e-3),
            sa_std: Vec3::repeat(1e-3),
            corr_time: 3600.0,
        },
        lever_arm_b: Vec3::new(0.0, -0.05, 0.0),
        scale_factors: true,
        ..EskfConfig::seed001()
    };
    let std = InitStd {
        pos: Vec3::repeat(0.05),
        vel: Vec3::repeat(0.05),
        att: Vec3::repeat(0.02),
        bg: Vec3::repeat(5e-4),
        ba: Vec3::repeat(0.2),
        sg: Vec3::repeat(1e-3),
        sa: Vec3::repeat(1e-3),
    };
    Eskf::new(cfg, start(), ImuErrors::default(), &std)
}

fn sample(k: u64) -> ImuSample {
    let dt = 0.01;
    let g = earth::gravity(0.7, 1600.0);
    ImuSample {
        t: k as f64 * dt,
        dt,
        dtheta_b: Vec3::new(1e-4, -2e-4, 3e-3),
        dvel_b: Vec3::new(0.01, 0.002, -g * dt),
    }
}

fn benches(c: &mut Criterion) {
    let s = start();
    let dth = Vec3::new(1e-4, -2e-4, 3e-3);
    let dv = Vec3::new(0.01, 0.002, -0.098);
    c.bench_function("mechanize (one 100 Hz step)", |b| {
        b.iter(|| mechanize(black_box(&s), &dth, &dv, &dth, &dv, 0.01))
    });

    let mut f = filter();
    let mut k = 0u64;
    c.bench_function("eskf predict (mechanize + 21-state P propagation)", |b| {
        b.iter(|| {
            k += 1;
            // Restart every 10 min of data so P stays in its normal range.
            if k.is_multiple_of(60_000) {
                f = filter();
            }
            black_box(f.push(&Event::Imu(sample(k))))
        })
    });

    let mut f = filter();
    let mut k = 0u64;
    c.bench_function("eskf predict + GNSS position update", |b| {
        b.iter(|| {
            k += 1;
            let s = sample(k);
            let n = f.nav();
            f.push(&Event::Gnss(GnssFix {
                t: s.t - 0.004,
                lat: n.lat,
                lon: n.lon,
                h: n.h,
                std_ned: Vec3::repeat(0.02),
                ..Default::default()
            }));
            black_box(f.push(&Event::Imu(s)))
        })
    });
}

criterion_group!(ins, benches);
criterion_main!(ins);
