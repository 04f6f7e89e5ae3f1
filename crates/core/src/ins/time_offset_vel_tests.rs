//! Synthetic platforms with an exact INS trajectory: speed changes, turns and
//! climbs (raised cosines), GNSS velocity with white noise; the INS carries a
//! constant acceleration error (filter tilt/bias) that the model must absorb.
use super::*;
use crate::attitude::{dcm_from_euler, skew};

use crate::ins::time_offset::tests::Rng;

/// Sum of raised-cosine bumps: (centre, half-width, amplitude).
fn bumps(b: &[(f64, f64, f64)], t: f64) -> f64 {
    b.iter()
        .filter(|(c, h, _)| (t - c).abs() < *h)
        .map(|(c, h, a)| a * 0.5 * (1.0 + (core::f64::consts::PI * (t - c) / h).cos()))
        .sum()
}

struct Motion {
    /// Yaw rate and climb rate bumps; course and speed tabulated.
    yaw_rate: Vec<(f64, f64, f64)>,
    table: Vec<(f64, f64)>,
    climb: Vec<(f64, f64, f64)>,
    /// Body heading − course [rad] (sideways flight when ≠ 0).
    crab: f64,
}

impl Motion {
    fn new(seed: u64, crab: f64) -> Self {
        let mut r = Rng::new(seed);
        let mut m = |n: usize, amp: f64| -> Vec<(f64, f64, f64)> {
            (0..n)
                .map(|_| {
                    let c = 20.0 + 560.0 * r.uni();
                    (c, 2.0 + 4.0 * r.uni(), amp * (2.0 * r.uni() - 1.0))
                })
                .collect()
        };
        let yaw_rate = m(40, 0.4);
        let accel = m(40, 1.5);
        let climb = m(20, 1.0);
        Motion {
            table: table(&yaw_rate, &accel),
            yaw_rate,
            climb,
            crab,
        }
    }
    /// (course, speed, v_down): table lookup (linear between 1 ms nodes).
    fn state(&self, t: f64) -> (f64, f64, f64) {
        let x = (t / TABLE_H).clamp(0.0, (self.table.len() - 2) as f64);
        let i = x.floor() as usize;
        let w = x - i as f64;
        let (a, b) = (self.table[i], self.table[i + 1]);
        (
            a.0 * (1.0 - w) + b.0 * w,
            (a.1 * (1.0 - w) + b.1 * w).max(0.5),
            -bumps(&self.climb, t),
        )
    }
}

const TABLE_H: f64 = 0.001;

/// Course and speed at 1 ms nodes (midpoint rule) over 0…601 s.
fn table(yaw_rate: &[(f64, f64, f64)], accel: &[(f64, f64, f64)]) -> Vec<(f64, f64)> {
    let n = (601.0 / TABLE_H) as usize;
    let mut out = Vec::with_capacity(n + 1);
    let (mut psi, mut v) = (0.0, 8.0);
    out.push((psi, v));
    for i in 0..n {
        let tm = (i as f64 + 0.5) * TABLE_H;
        psi += bumps(yaw_rate, tm) * TABLE_H;
        v += bumps(accel, tm) * TABLE_H;
        out.push((psi, v));
    }
    out
}

/// INS samples at 100 Hz stamped `s` = true time − τ (with a constant
/// acceleration error `a_err`), and 1 Hz GNSS velocities of the antenna
/// (IMU velocity + C_bn(ω × lever)) with σ `sv`.
fn drive(m: &Motion, tau: f64, lever: Vec3, sv: f64, seed: u64) -> (Vec<InsSample>, Vec<GnssFix>) {
    let dt = 0.01;
    let n = 60_000;
    let mut states = Vec::with_capacity(n + 1);
    for i in 0..=n {
        states.push(m.state(i as f64 * dt + tau));
    }
    let vel = |st: (f64, f64, f64)| Vec3::new(st.1 * st.0.cos(), st.1 * st.0.sin(), st.2);
    let a_err = Vec3::new(0.01, -0.008, 0.005);
    let mut ins = Vec::with_capacity(n);
    for i in 1..=n {
        let s = i as f64 * dt;
        let (st0, st1) = (states[i - 1], states[i]);
        let a_n = (vel(st1) - vel(st0)) / dt + a_err;
        let c = dcm_from_euler(&Vec3::new(0.0, 0.0, st1.0 + m.crab));
        let w = Vec3::new(0.0, 0.0, bumps(&m.yaw_rate, s + tau));
        ins.push(InsSample {
            t: s,
            a_n,
            lever_map: c * skew(&w),
        });
    }
    let mut r = Rng::new(seed ^ 0xabc);
    let mut gnss = Vec::new();
    for k in 1..600 {
        let t = k as f64;
        let st = m.state(t);
        let c = dcm_from_euler(&Vec3::new(0.0, 0.0, st.0 + m.crab));
        let w = Vec3::new(0.0, 0.0, bumps(&m.yaw_rate, t));
        let noise = Vec3::new(r.gauss(), r.gauss(), r.gauss()) * sv;
        gnss.push(GnssFix {
            t,
            lat: 0.5,
            lon: 2.0,
            h: 30.0,
            std_ned: Vec3::repeat(0.02),
            v_n: Some(vel(st) + c * w.cross(&lever) + noise),
            std_v_n: Some(Vec3::repeat(sv)),
            quality: 1,
            num_sats: 10,
        });
    }
    (ins, gnss)
}

#[test]
fn recovers_injected_offsets_within_5_ms_and_ignores_zero() {
    let cfg = VelOffsetConfig::default();
    for (seed, crab, lever) in [
        (1u64, 0.0, Vec3::zeros()),
        (2, 0.7, Vec3::new(1.0, 0.2, -0.5)),
        (3, -1.2, Vec3::zeros()),
    ] {
        let m = Motion::new(seed, crab);
        for tau in [0.0, 0.05, -0.05, 0.2, -0.2] {
            let (ins, gnss) = drive(&m, tau, lever, 0.03, seed);
            let e = estimate_from_velocity(&ins, &gnss, &cfg);
            let t = e.tau_s.expect("an estimate");
            assert!(
                (t - tau).abs() < 0.005,
                "seed {seed} τ {tau}: {t} ± {} ({:?})",
                e.std_s,
                e.reason
            );
            assert!(e.std_s < 0.005, "σ {} too large", e.std_s);
            assert!(
                (t - tau).abs() < 4.0 * e.std_s.max(1e-3),
                "σ {} overconfident for error {}",
                e.std_s,
                t - tau
            );
            assert_eq!(e.significant(), tau != 0.0, "seed {seed} τ {tau}: {e:?}");
        }
    }
}

#[test]
fn too_few_velocity_epochs_give_no_estimate() {
    let m = Motion::new(4, 0.0);
    let (ins, mut gnss) = drive(&m, 0.1, Vec3::zeros(), 0.03, 4);
    for g in gnss.iter_mut().skip(20) {
        g.v_n = None;
    }
    let e = estimate_from_velocity(&ins, &gnss, &VelOffsetConfig::default());
    assert_eq!(e.tau_s, None);
    assert_eq!(e.reason, TimeOffsetReason::TooFewPairs);
}

/// A heading error that decays through the record (a filter converging from
/// an in-motion start: 3° falling with a 40 s time constant) at τ = 0: the
/// INS acceleration is rotated by it, a misfit the residual σ does not see.
/// The split-half check must keep it from being applied as an offset.
#[test]
fn a_decaying_heading_error_is_not_read_as_an_offset() {
    let cfg = VelOffsetConfig::default();
    for seed in [5u64, 6, 7] {
        let m = Motion::new(seed, 0.0);
        let (mut ins, gnss) = drive(&m, 0.0, Vec3::zeros(), 0.03, seed);
        for s in ins.iter_mut() {
            let psi = 3f64.to_radians() * (-s.t / 40.0).exp();
            s.a_n = dcm_from_euler(&Vec3::new(0.0, 0.0, psi)) * s.a_n;
        }
        let e = estimate_from_velocity(&ins, &gnss, &cfg);
        let t = e.tau_s.unwrap_or(0.0);
        assert!(
            !e.significant() || t.abs() < 0.005,
            "seed {seed}: {t} ± {} applied at τ = 0",
            e.std_s
        );
    }
}

/// A record too short to be split into two checkable halves (50 epochs)
/// gives an estimate but never a significant one, even from a precise
/// receiver (3 mm/s) whose residual σ alone would call it significant.
#[test]
fn a_record_too_short_to_check_is_never_significant() {
    let m = Motion::new(8, 0.0);
    let (ins, mut gnss) = drive(&m, 0.2, Vec3::zeros(), 0.003, 8);
    gnss.retain(|g| g.t >= 100.0 && g.t < 150.0);
    let e = estimate_from_velocity(&ins, &gnss, &VelOffsetConfig::default());
    assert!(e.tau_s.is_some(), "{e:?}");
    assert!(!e.significant(), "{e:?}");
}
