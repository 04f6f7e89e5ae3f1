//! Kalman core timings: 15-state covariance predict with an INS-like
//! transition (NED psi-angle error model blocks, Groves 2nd ed. ch. 14,
//! F = I + F_c·dt at 100 Hz) and a 6-measurement (position + velocity) Joseph
//! update. Run: `cargo bench -p navfuse-core --bench kalman`.

use criterion::{black_box, criterion_group, Criterion};
use nalgebra::{SMatrix, SVector};
use navfuse_core::attitude::{dcm_from_euler, skew};
use navfuse_core::kalman::{predict, predict_sparse, update_joseph};
use navfuse_core::Vec3;

const N: usize = 15;

fn ins_f(dt: f64) -> SMatrix<f64, N, N> {
    let mut fc = SMatrix::<f64, N, N>::zeros();
    let c_bn = dcm_from_euler(&Vec3::new(0.02, -0.01, 1.2));
    let f_n = Vec3::new(0.3, -0.2, -9.8);
    let w_ie = Vec3::new(5.3e-5, 0.0, -5.3e-5);
    let w_en = Vec3::new(1e-6, -2e-6, -1e-6);
    // Position (N, E, D metres) ← velocity.
    for i in 0..3 {
        fc[(i, 3 + i)] = 1.0;
    }
    // Velocity ← velocity (Coriolis), attitude ([f_n×]), accel bias (C_bn).
    fc.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(-skew(&(w_ie * 2.0 + w_en))));
    fc.fixed_view_mut::<3, 3>(3, 6).copy_from(&skew(&f_n));
    fc.fixed_view_mut::<3, 3>(3, 9).copy_from(&c_bn);
    // Attitude ← attitude (−[ω_in×]), gyro bias (−C_bn).
    fc.fixed_view_mut::<3, 3>(6, 6)
        .copy_from(&(-skew(&(w_ie + w_en))));
    fc.fixed_view_mut::<3, 3>(6, 12).copy_from(&(-c_bn));
    // Bias Gauss–Markov, 1 h correlation time.
    for i in 9..15 {
        fc[(i, i)] = -1.0 / 3600.0;
    }
    SMatrix::identity() + fc * dt
}

fn initial_p() -> SMatrix<f64, N, N> {
    let d = [
        1.0, 1.0, 2.0, 0.01, 0.01, 0.02, 1e-4, 1e-4, 1e-3, 1e-4, 1e-4, 1e-4, 1e-8, 1e-8, 1e-8,
    ];
    let mut p = SMatrix::<f64, N, N>::from_diagonal(&SVector::from_row_slice(&d));
    // Some correlation, as after a few updates.
    for i in 0..3 {
        p[(i, i + 3)] = 0.05 * (d[i] * d[i + 3]).sqrt();
        p[(i + 3, i)] = p[(i, i + 3)];
    }
    p
}

fn bench(c: &mut Criterion) {
    let dt = 0.01;
    let f = ins_f(dt);
    let q = SMatrix::<f64, N, N>::from_diagonal(&SVector::from_row_slice(&[
        0.0, 0.0, 0.0, 2.5e-5, 2.5e-5, 2.5e-5, 1e-6, 1e-6, 1e-6, 1e-10, 1e-10, 1e-10, 1e-14, 1e-14,
        1e-14,
    ]));
    let p0 = initial_p();

    c.bench_function("predict_15_dense", |b| {
        let mut p = p0;
        b.iter(|| {
            predict(&mut p, black_box(&f), black_box(&q));
        })
    });
    c.bench_function("predict_15_sparse", |b| {
        let mut p = p0;
        b.iter(|| {
            predict_sparse(&mut p, black_box(&f), black_box(&q));
        })
    });

    let mut h = SMatrix::<f64, 6, N>::zeros();
    for i in 0..6 {
        h[(i, i)] = 1.0;
    }
    let r = SMatrix::<f64, 6, 6>::from_diagonal(&SVector::from_row_slice(&[
        1.0, 1.0, 2.25, 0.01, 0.01, 0.0225,
    ]));
    let nu = SVector::<f64, 6>::new(0.5, -0.3, 1.0, 0.02, -0.01, 0.03);
    c.bench_function("update_joseph_15x6", |b| {
        b.iter(|| {
            // Fresh copies each iteration so P does not collapse; the copy
            // (~2 kB) is included in the timing.
            let mut x = SVector::<f64, N>::zeros();
            let mut p = p0;
            let info = update_joseph(&mut x, &mut p, &h, &r, black_box(&nu), None);
            black_box((x, p, info))
        })
    });
}

/// On-CPU nanoseconds of this thread (Linux `schedstat`), so the per-step
/// cost can be reported even when other processes load the machine and
/// inflate criterion's wall-clock times.
fn thread_cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

fn cpu_time_per_call(name: &str, iters: u32, mut step: impl FnMut()) {
    for _ in 0..iters / 10 {
        step();
    }
    let (Some(t0), w0) = (thread_cpu_ns(), std::time::Instant::now()) else {
        return;
    };
    for _ in 0..iters {
        step();
    }
    let wall = w0.elapsed().as_nanos() as f64 / iters as f64;
    if let Some(t1) = thread_cpu_ns() {
        let cpu = (t1 - t0) as f64 / iters as f64;
        println!("{name:<24} on-CPU {cpu:8.0} ns/call   (wall {wall:8.0} ns/call, {iters} calls)");
    }
}

fn cpu_time_report() {
    let f = ins_f(0.01);
    let q = SMatrix::<f64, N, N>::identity() * 1e-9;
    let p0 = initial_p();
    let mut h = SMatrix::<f64, 6, N>::zeros();
    for i in 0..6 {
        h[(i, i)] = 1.0;
    }
    let r = SMatrix::<f64, 6, 6>::identity();
    let nu = SVector::<f64, 6>::new(0.5, -0.3, 1.0, 0.02, -0.01, 0.03);
    let n = 200_000;
    let mut p = p0;
    cpu_time_per_call("predict_15_dense", n, || {
        predict(&mut p, black_box(&f), black_box(&q))
    });
    let mut p = p0;
    cpu_time_per_call("predict_15_sparse", n, || {
        predict_sparse(&mut p, black_box(&f), black_box(&q))
    });
    cpu_time_per_call("update_joseph_15x6", n, || {
        let mut x = SVector::<f64, N>::zeros();
        let mut p = p0;
        black_box(update_joseph(&mut x, &mut p, &h, &r, black_box(&nu), None));
        black_box((x, p));
    });
}

criterion_group!(benches, bench);

fn main() {
    benches();
    cpu_time_report();
    Criterion::default().configure_from_args().final_summary();
}
