//! Synthetic drives with exact z-gyro increments (generated here: core cannot
//! use navfuse-sim). Heading rate = sum of raised-cosine turns, speed 5–20 m/s.
use super::*;
use crate::Vec3;
use alloc::vec;

/// xorshift64* + Box–Muller: a deterministic stream for tests.
pub(crate) struct Rng(u64);
impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    pub(crate) fn uni(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uni()
    }
    pub(crate) fn gauss(&mut self) -> f64 {
        let u = self.uni().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (core::f64::consts::TAU * self.uni()).cos()
    }
}

/// Raised-cosine turn: ω = a·½(1 + cos(π(t − c)/h)) for |t − c| < h.
struct Turn {
    c: f64,
    h: f64,
    a: f64,
}

struct Drive {
    turns: Vec<Turn>,
    speed_phase: f64,
    speed_period: f64,
}

impl Drive {
    fn speed(&self, t: f64) -> f64 {
        12.5 + 7.5 * (core::f64::consts::TAU * t / self.speed_period + self.speed_phase).sin()
    }
    fn rate(&self, t: f64) -> f64 {
        let pi = core::f64::consts::PI;
        self.turns
            .iter()
            .filter(|u| (t - u.c).abs() < u.h)
            .map(|u| u.a * 0.5 * (1.0 + (pi * (t - u.c) / u.h).cos()))
            .sum()
    }
    /// Exact heading ψ(t) = ∫₀ᵗ ω.
    fn heading(&self, t: f64) -> f64 {
        let pi = core::f64::consts::PI;
        let mut s = 0.3;
        for u in &self.turns {
            let x = (t - u.c).clamp(-u.h, u.h);
            s += u.a * 0.5 * ((x + u.h) + u.h / pi * (pi * x / u.h).sin());
        }
        s
    }
}

/// `turny`: turns every 3–15 s with |ω| 0.05–0.35 rad/s (lateral ≤ 4 m/s²);
/// otherwise a near-straight road with two gentle curves.
fn drive(rng: &mut Rng, dur: f64, turny: bool) -> Drive {
    let mut d = Drive {
        turns: vec![],
        speed_phase: rng.range(0.0, 6.3),
        speed_period: rng.range(60.0, 180.0),
    };
    if turny {
        let mut t = 5.0;
        while t < dur - 10.0 {
            let h = rng.range(1.5, 5.0);
            let c = t + h;
            let sign = if rng.uni() < 0.5 { -1.0 } else { 1.0 };
            let a = rng.range(0.05, 0.35).min(4.0 / d.speed(c)) * sign;
            d.turns.push(Turn { c, h, a });
            t = c + h + rng.range(3.0, 15.0);
        }
    } else {
        for _ in 0..2 {
            let sign = if rng.uni() < 0.5 { -1.0 } else { 1.0 };
            let c = rng.range(30.0, dur - 30.0);
            d.turns.push(Turn {
                c,
                h: rng.range(10.0, 20.0),
                a: sign * rng.range(0.002, 0.01),
            });
        }
    }
    d
}

struct Scenario {
    tau: f64,
    velocity: bool,
    turny: bool,
    jumps: usize,
    /// Antenna ahead of the rear axle [m].
    lever: f64,
}

const DUR: f64 = 300.0;
const GYRO_BIAS: f64 = 0.002; // rad/s (0.11 °/s, a MEMS turn-on bias)
const GYRO_SCALE: f64 = 0.003;
const GYRO_NOISE: f64 = 3e-4; // rad/s/√Hz = 1 °/√h, a consumer MEMS
const SIG_POS: f64 = 0.02; // RTK
const SIG_VEL: f64 = 0.1;

fn simulate(seed: u64, sc: &Scenario) -> (Vec<ImuSample>, Vec<GnssFix>) {
    let mut rng = Rng::new(seed);
    let d = drive(&mut rng, DUR, sc.turny);
    let dt = 0.01;
    // IMU stamp s measured true time s + τ.
    let imu: Vec<ImuSample> = (-200..=((DUR + 2.0) / dt) as i64)
        .map(|k| {
            let s = k as f64 * dt;
            let dth = (1.0 + GYRO_SCALE) * (d.heading(s + sc.tau) - d.heading(s - dt + sc.tau))
                + GYRO_BIAS * dt
                + GYRO_NOISE * dt.sqrt() * rng.gauss();
            ImuSample {
                t: s,
                dt,
                dtheta_b: Vec3::new(0.0, 0.0, dth),
                dvel_b: Vec3::zeros(),
            }
        })
        .collect();
    // Integrate the antenna position (rear axle + lever along body x).
    let (lat0, h) = (0.7, 100.0);
    let (mut lat, mut lon) = (lat0, 0.3);
    let antenna_v = |t: f64| {
        let (psi, v, w) = (d.heading(t), d.speed(t), d.rate(t));
        let (vx, vy) = (v, w * sc.lever);
        (
            vx * psi.cos() - vy * psi.sin(),
            vx * psi.sin() + vy * psi.cos(),
        )
    };
    let mut gnss = vec![];
    let step = 0.01;
    let mut t = 0.0;
    let mut next_fix = 1.0;
    while next_fix < DUR {
        if t >= next_fix - 1e-9 {
            let (vn, ve) = antenna_v(t);
            let (mut la, mut lo) = (lat, lon);
            let (rm, rn) = earth::radii(lat);
            la += SIG_POS * rng.gauss() / (rm + h);
            lo += SIG_POS * rng.gauss() / ((rn + h) * lat.cos());
            gnss.push(GnssFix {
                t,
                lat: la,
                lon: lo,
                h,
                std_ned: Vec3::new(SIG_POS, SIG_POS, 2.0 * SIG_POS),
                v_n: sc.velocity.then(|| {
                    Vec3::new(vn + SIG_VEL * rng.gauss(), ve + SIG_VEL * rng.gauss(), 0.0)
                }),
                std_v_n: sc.velocity.then(|| Vec3::repeat(SIG_VEL)),
                quality: 1,
                num_sats: 20,
            });
            next_fix += 1.0;
        }
        // Midpoint rule on lat/lon (error ≪ 1 mm per step).
        let (vn, ve) = antenna_v(t + 0.5 * step);
        let (rm, rn) = earth::radii(lat);
        lat += vn * step / (rm + h);
        lon += ve * step / ((rn + h) * lat.cos());
        t += step;
    }
    for _ in 0..sc.jumps {
        let i = (rng.uni() * gnss.len() as f64) as usize;
        let (r, az) = (rng.range(20.0, 100.0), rng.range(0.0, 6.3));
        let (rm, rn) = earth::radii(gnss[i].lat);
        gnss[i].lat += r * az.cos() / (rm + h);
        gnss[i].lon += r * az.sin() / ((rn + h) * gnss[i].lat.cos());
    }
    let _ = lat0;
    (imu, gnss)
}

fn run(seed: u64, sc: &Scenario) -> TimeOffsetEstimate {
    let (imu, gnss) = simulate(seed, sc);
    estimate(&imu, &gnss, &TimeOffsetConfig::default())
}

fn base(tau: f64, velocity: bool) -> Scenario {
    Scenario {
        tau,
        velocity,
        turny: true,
        jumps: 0,
        lever: 0.0,
    }
}

#[test]
fn zero_offset_is_not_applied() {
    for velocity in [true, false] {
        let (mut applied, mut max_tau) = (0, 0.0_f64);
        let mut zs = vec![];
        for seed in 0..50 {
            let e = run(seed, &base(0.0, velocity));
            let tau = e.tau_s.expect("a turny drive must give a fit");
            zs.push(tau / e.std_s);
            if e.apply {
                applied += 1;
                max_tau = max_tau.max(tau.abs());
            }
        }
        let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
        std::println!("zero offset, velocity={velocity}: applied {applied}/50, max |tau| applied {max_tau:.4} s, rms(tau/sigma) {rms:.2}");
        assert!(applied <= 2, "applied a zero offset in {applied}/50 drives");
    }
}

/// RTK chords must meet 10 ms; 0.1 m/s velocities over 300 s carry less
/// timing information (σ_τ ≈ 10–20 ms), so there |err| < 3.29 σ is required.
#[test]
fn known_offsets_are_recovered_with_honest_sigma() {
    let (mut worst_rtk, mut worst_vel, mut within2, mut n) = (0.0_f64, 0.0_f64, 0, 0);
    let mut zs = vec![];
    for (j, tau) in [-0.2, -0.05, 0.05, 0.2].into_iter().enumerate() {
        for i in 0..10 {
            let velocity = i % 2 == 0;
            let e = run(100 + 10 * j as u64 + i, &base(tau, velocity));
            let err = e.tau_s.expect("fit") - tau;
            if velocity {
                assert!(err.abs() < 3.29 * e.std_s, "tau {tau}: err {err}, {e:?}");
                worst_vel = worst_vel.max(err.abs());
            } else {
                assert!(err.abs() < 0.010 && e.apply, "tau {tau}: err {err}, {e:?}");
                worst_rtk = worst_rtk.max(err.abs());
            }
            within2 += usize::from(err.abs() < 2.0 * e.std_s);
            zs.push(err / e.std_s);
            n += 1;
        }
    }
    let rms = (zs.iter().map(|z| z * z).sum::<f64>() / n as f64).sqrt();
    std::println!("known offsets: worst |err| RTK {worst_rtk:.4} s, velocity {worst_vel:.4} s; |err| < 2 sigma in {within2}/{n}; rms(err/sigma) {rms:.2}");
    assert!(
        within2 * 100 >= 85 * n,
        "sigma too optimistic: {within2}/{n} within 2 sigma"
    );
}

#[test]
fn straight_road_is_never_confidently_wrong() {
    for seed in 0..20 {
        let sc = Scenario {
            turny: false,
            ..base(0.1, seed % 2 == 0)
        };
        let e = run(200 + seed, &sc);
        std::println!("straight: sigma {:.3} s {:?}", e.std_s, e.reason);
        if e.apply {
            let err = e.tau_s.unwrap() - 0.1;
            assert!(
                err.abs() < 0.010,
                "confidently wrong on a straight road: {e:?}"
            );
        }
    }
}

/// Outlier rejection in isolation: the drive has no antenna lever, so the
/// lever is not fitted here (with it σ_τ ≈ 8–10 ms on 300 s of RTK chords).
#[test]
fn position_jumps_are_rejected() {
    let cfg = TimeOffsetConfig {
        fit_lever: false,
        ..Default::default()
    };
    let mut worst = 0.0_f64;
    for seed in 0..5 {
        let sc = Scenario {
            jumps: 50,
            ..base(0.05, false)
        };
        let (imu, gnss) = simulate(300 + seed, &sc);
        let e = estimate(&imu, &gnss, &cfg);
        let err = e.tau_s.expect("fit") - 0.05;
        std::println!(
            "jumps: err {err:+.4} sigma {:.4} outliers {} used {}",
            e.std_s,
            e.outliers,
            e.pairs_used
        );
        assert!(err.abs() < 0.010 && e.apply, "{e:?}");
        worst = worst.max(err.abs());
    }
    std::println!("position jumps: worst |err| {worst:.4} s");
}

#[test]
fn antenna_lever_is_not_taken_for_a_time_offset() {
    for seed in 0..5 {
        let sc = Scenario {
            lever: 1.5,
            ..base(0.0, true)
        };
        let e = run(400 + seed, &sc);
        std::println!(
            "lever 1.5 m: tau {:?} sigma {:.4} lever {:.3} {:?}",
            e.tau_s,
            e.std_s,
            e.lever_m,
            e.reason
        );
        assert!(!e.apply, "{e:?}");
    }
}

/// The galloping sample search finds the index of the plain binary search
/// for times inside, between, on and outside the stamps, in any order,
/// with a repeated stamp.
#[test]
fn heading_find_equals_partition_point() {
    let mut imu: Vec<ImuSample> = (0..1000)
        .map(|k| ImuSample {
            t: 100.0 + 0.01 * k as f64,
            dt: 0.01,
            ..Default::default()
        })
        .collect();
    imu[500].t = imu[499].t;
    let h = super::Heading::new(&imu);
    assert!(h.sorted);
    let mut x = 0.123_f64;
    for i in 0..20_000 {
        // Pseudo-random jumps, plus exact stamps.
        x = (x * 997.0 + 0.371).fract();
        let t = if i % 7 == 0 {
            imu[(x * 999.0) as usize].t
        } else {
            99.5 + 11.0 * x
        };
        assert_eq!(h.find(t), imu.partition_point(|s| s.t < t), "t {t}");
    }
}
