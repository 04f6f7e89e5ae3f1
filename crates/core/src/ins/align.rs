//! Initial alignment: static window detection, levelling and static sensor
//! calibration (`SEEDS.md §1` eq. 1–2), heading from the GNSS course or a
//! magnetometer.
//!
//! Body FRD; a level IMU at rest measures f_b ≈ (0, 0, −g).

use crate::earth;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::types::ImuSample;
use crate::Vec3;

/// Roll and pitch [rad] from the mean specific force at rest (levelling;
/// Groves eq. 5.101): f_b = g (sin θ, −sin φ cos θ, −cos φ cos θ).
pub fn level(f_b_mean: &Vec3) -> (f64, f64) {
    let roll = (-f_b_mean.y).atan2(-f_b_mean.z);
    let pitch = f_b_mean
        .x
        .atan2((f_b_mean.y * f_b_mean.y + f_b_mean.z * f_b_mean.z).sqrt());
    (roll, pitch)
}

/// Result of the static calibration over a window at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticCalibration {
    /// Roll, pitch [rad] by levelling.
    pub roll: f64,
    pub pitch: f64,
    /// Mean angular rate over the window [rad/s] (gyro bias + earth rate).
    pub w_mean_b: Vec3,
    /// Mean specific force [m/s²].
    pub f_mean_b: Vec3,
    /// Accelerometer bias of `SEEDS.md §1` eq. 1 for the given attitude: f̄ − f_expected.
    /// With the levelled attitude only the magnitude part survives (along f̄).
    pub accel_bias_b: Vec3,
    /// Accelerometer scale s_a = g/|f̄| (`SEEDS.md §1` eq. 2).
    pub accel_scale: f64,
    /// Std of |f| and the largest per-axis gyro std over the window.
    pub f_norm_std: f64,
    pub w_std_max: f64,
    /// Samples used.
    pub n: usize,
}

/// Static calibration (`SEEDS.md §1` eq. 1–2) over `samples` at latitude
/// `lat` and height `h`. The gyro bias is `w_mean_b − C_nb ω_ie^n`; the earth
/// rate needs the heading, so it is left to the caller ([`gyro_bias`]).
pub fn static_calibration(samples: &[ImuSample], lat: f64, h: f64) -> Option<StaticCalibration> {
    if samples.len() < 2 {
        return None;
    }
    let mut sf = Vec3::zeros();
    let mut sw = Vec3::zeros();
    let mut sw2 = Vec3::zeros();
    let (mut sn, mut sn2) = (0.0, 0.0);
    let mut ttot = 0.0;
    for s in samples {
        if s.dt.is_nan() || s.dt <= 0.0 {
            continue;
        }
        let f = s.dvel_b / s.dt;
        let w = s.dtheta_b / s.dt;
        sf += s.dvel_b;
        sw += s.dtheta_b;
        sw2 += w.component_mul(&w);
        sn += f.norm();
        sn2 += f.norm_squared();
        ttot += s.dt;
    }
    if ttot <= 0.0 {
        return None;
    }
    let n = samples.len() as f64;
    let f_mean = sf / ttot;
    let w_mean = sw / ttot;
    let mn = sn / n;
    let w_var = sw2 / n - w_mean.component_mul(&w_mean);
    let (roll, pitch) = level(&f_mean);
    let g = earth::gravity(lat, h);
    // Expected f at the levelled attitude is −g along f̄'s direction (eq. 1).
    let f_exp = f_mean.normalize() * g;
    Some(StaticCalibration {
        roll,
        pitch,
        w_mean_b: w_mean,
        f_mean_b: f_mean,
        accel_bias_b: f_mean - f_exp,
        accel_scale: g / f_mean.norm(),
        f_norm_std: (sn2 / n - mn * mn).max(0.0).sqrt(),
        w_std_max: w_var.map(|v| v.max(0.0).sqrt()).max(),
        n: samples.len(),
    })
}

/// Gyro bias [rad/s] = mean rate − earth rate in the body frame, for the attitude (roll, pitch, yaw).
pub fn gyro_bias(cal: &StaticCalibration, yaw: f64, lat: f64) -> Vec3 {
    let q = crate::ins::mech::q_bn_from_rpy(&Vec3::new(cal.roll, cal.pitch, yaw));
    let c_nb = q.to_rotation_matrix().into_inner().transpose();
    cal.w_mean_b - c_nb * earth::omega_ie_n(lat)
}

/// Length (samples) of the static window at the start of `samples`: the
/// longest prefix whose sliding `window`-sample std of |f| stays below
/// `max_f_std` [m/s²] and of each gyro axis below `max_w_std` [rad/s].
pub fn initial_static_len(
    samples: &[ImuSample],
    window: usize,
    max_f_std: f64,
    max_w_std: f64,
) -> usize {
    let window = window.max(2);
    if samples.len() < window {
        return 0;
    }
    let mut end = 0;
    let mut i = 0;
    while i + window <= samples.len() {
        let w = &samples[i..i + window];
        let (mut sn, mut sn2, mut sw, mut sw2) = (0.0, 0.0, Vec3::zeros(), Vec3::zeros());
        for s in w {
            let dt = if s.dt > 0.0 { s.dt } else { return end };
            let f = (s.dvel_b / dt).norm();
            let r = s.dtheta_b / dt;
            sn += f;
            sn2 += f * f;
            sw += r;
            sw2 += r.component_mul(&r);
        }
        let n = window as f64;
        let fstd = (sn2 / n - (sn / n).powi(2)).max(0.0).sqrt();
        let wm = sw / n;
        let wstd = (sw2 / n - wm.component_mul(&wm))
            .map(|v| v.max(0.0).sqrt())
            .max();
        if fstd > max_f_std || wstd > max_w_std {
            break;
        }
        end = i + window;
        i += window / 2;
    }
    end
}

/// Stationarity of an IMU window said to be static: per axis, the χ² of
/// the mean angular rates and mean specific forces of `k` equal segments
/// about their weighted mean, `Σ_j (m_j − m̄)² / v_j`, `v_j = s_j²/n_j + q`
/// (s_j the segment's sample std, n_j its samples, `q` the variance of the
/// bias change the caller allows across the window: `q_w` [rad²/s²] for
/// the gyro, `q_f` [m²/s⁴] for the accelerometer; `m̄ = Σ m_j/v_j / Σ 1/v_j`).
/// A still IMU (white noise, vibration, a bias moving within q) gives
/// ≈ χ²(k − 1) or less per axis; a platform rolling in waves (the gyro
/// rate moves, and so does the direction of gravity in the body) or
/// heaving gives far more (Bar-Shalom, Li & Kirubarajan §5.4, a test of a
/// constant mean). A constant rotation about the vertical is not visible in
/// a short window: it is the gyro bias plus a rate no static window can
/// tell apart. Returns (gyro χ², accelerometer χ²); `None` if a segment has
/// fewer than 2 samples, `k < 2` or `k > 8`, or a sample has `dt ≤ 0`.
pub fn drift_chi2(samples: &[ImuSample], k: usize, q_w: Vec3, q_f: Vec3) -> Option<(Vec3, Vec3)> {
    const K_MAX: usize = 8;
    if !(2..=K_MAX).contains(&k) || samples.len() < 2 * k {
        return None;
    }
    // Per segment: mean and variance of the mean, rate (0..3) and force (3..6).
    let mut mean = [[0.0; 6]; K_MAX];
    let mut var = [[0.0; 6]; K_MAX];
    let n = samples.len();
    for j in 0..k {
        let seg = &samples[j * n / k..(j + 1) * n / k];
        let (mut s1, mut s2, mut m) = ([0.0; 6], [0.0; 6], 0.0);
        for s in seg {
            if s.dt.is_nan() || s.dt <= 0.0 {
                return None;
            }
            let w = s.dtheta_b / s.dt;
            let f = s.dvel_b / s.dt;
            for a in 0..3 {
                s1[a] += w[a];
                s2[a] += w[a] * w[a];
                s1[a + 3] += f[a];
                s2[a + 3] += f[a] * f[a];
            }
            m += 1.0;
        }
        for a in 0..6 {
            let mu = s1[a] / m;
            let sv = (s2[a] / m - mu * mu).max(0.0) * m / (m - 1.0);
            mean[j][a] = mu;
            var[j][a] = sv / m + if a < 3 { q_w[a] } else { q_f[a - 3] };
        }
    }
    let mut chi2 = [0.0; 6];
    for (a, c) in chi2.iter_mut().enumerate() {
        let (mut sw, mut swm) = (0.0, 0.0);
        for j in 0..k {
            let v = var[j][a].max(1e-300);
            sw += 1.0 / v;
            swm += mean[j][a] / v;
        }
        let mbar = swm / sw;
        *c = (0..k)
            .map(|j| (mean[j][a] - mbar).powi(2) / var[j][a].max(1e-300))
            .sum();
    }
    Some((
        Vec3::new(chi2[0], chi2[1], chi2[2]),
        Vec3::new(chi2[3], chi2[4], chi2[5]),
    ))
}

/// Heading (course over ground) [rad] from a NED velocity, if the horizontal
/// speed exceeds `min_speed` [m/s]. For a car without side slip the course is
/// the yaw of the body.
pub fn heading_from_velocity(v_n: &Vec3, min_speed: f64) -> Option<f64> {
    let s = (v_n.x * v_n.x + v_n.y * v_n.y).sqrt();
    (s >= min_speed).then(|| v_n.y.atan2(v_n.x))
}

/// Heading (yaw, true north) [rad] from a magnetometer vector in body FRD
/// (any unit; hard/soft-iron calibrated), tilt-compensated with the levelled
/// roll and pitch [rad] (Groves 2nd ed. eq. 6.8: magnetic heading
/// `ψ_m = atan2(−m_y cos φ + m_z sin φ, m_x cos θ + m_y sin φ sin θ +
/// m_z cos φ sin θ)`), plus the magnetic declination [rad] (east positive).
/// `None` when the horizontal field vanishes (or the input is not finite).
pub fn heading_from_magnetometer(
    m_b: &Vec3,
    roll: f64,
    pitch: f64,
    declination: f64,
) -> Option<f64> {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let y = -m_b.y * cr + m_b.z * sr;
    let x = m_b.x * cp + m_b.y * sr * sp + m_b.z * cr * sp;
    let h = (x * x + y * y).sqrt();
    if !(h.is_finite() && h > 1e-6 * m_b.norm() && declination.is_finite()) {
        return None;
    }
    let psi = y.atan2(x) + declination;
    Some(crate::attitude::wrap_pi(psi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magnetometer_heading_recovers_yaw_at_any_tilt() {
        use crate::attitude::dcm_from_euler;
        // Field at ~40°N: 21 µT north, 1 µT east, 45 µT down (NED).
        let m_n = Vec3::new(21.0, 1.0, 45.0);
        let dec = 1.0f64.atan2(21.0);
        for &(r, p, y) in &[
            (0.0, 0.0, 0.3),
            (0.2, -0.1, -2.5),
            (-0.4, 0.3, 3.0),
            (0.05, 0.6, 1.2),
        ] {
            let c_bn = dcm_from_euler(&Vec3::new(r, p, y));
            let m_b = c_bn.transpose() * m_n;
            let psi = heading_from_magnetometer(&m_b, r, p, dec).unwrap();
            let d = (psi - y + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
                - core::f64::consts::PI;
            assert!(d.abs() < 1e-12, "rpy ({r}, {p}, {y}): {psi}");
        }
        // A vertical field has no heading.
        assert!(heading_from_magnetometer(&Vec3::new(0.0, 0.0, 45.0), 0.0, 0.0, 0.0).is_none());
    }

    fn at_rest(roll: f64, pitch: f64, n: usize) -> ImuSample {
        let g = earth::gravity(0.7, 100.0);
        let f = Vec3::new(
            g * pitch.sin(),
            -g * roll.sin() * pitch.cos(),
            -g * roll.cos() * pitch.cos(),
        );
        ImuSample {
            t: n as f64 * 0.01,
            dt: 0.01,
            dtheta_b: Vec3::new(1e-5, -2e-5, 3e-5),
            dvel_b: f * 0.01,
        }
    }

    #[test]
    fn levelling_recovers_roll_and_pitch() {
        for (r, p) in [(0.1, -0.2), (-0.5, 0.3), (0.0, 0.0), (3.0, 0.1)] {
            let s = at_rest(r, p, 0);
            let (rr, pp) = level(&(s.dvel_b / s.dt));
            assert!(
                (rr - r).abs() < 1e-12 && (pp - p).abs() < 1e-12,
                "{r} {p} -> {rr} {pp}"
            );
        }
    }

    #[test]
    fn static_calibration_and_window() {
        let mut v: [ImuSample; 400] = core::array::from_fn(|i| at_rest(0.05, -0.02, i));
        // Start moving after 300 samples.
        for (i, s) in v.iter_mut().enumerate().skip(300) {
            s.dvel_b.x += 0.02 * ((i as f64) * 0.7).sin();
            s.dtheta_b.z += 0.01 * ((i as f64) * 0.3).cos();
        }
        let n = initial_static_len(&v, 50, 0.05, 0.01);
        assert!((275..=300).contains(&n), "static len {n}");
        let cal = static_calibration(&v[..n], 0.7, 100.0).unwrap();
        assert!((cal.roll - 0.05).abs() < 1e-9 && (cal.pitch + 0.02).abs() < 1e-9);
        assert!((cal.w_mean_b - Vec3::new(1e-3, -2e-3, 3e-3)).norm() < 1e-12);
        assert!((cal.accel_scale - 1.0).abs() < 1e-9);
    }

    /// A still IMU at `rate` Hz, `secs` long: bias + white noise of density
    /// `arw` [rad/√s] and `arw` × 5 m/s/rad of velocity random walk (0.5°/√h
    /// goes with 0.04 m/s/√h, a consumer MEMS pair), + a 30 Hz engine
    /// vibration of `vib` rad/s (and `vib` × 20 m/s² per rad/s); or a moored
    /// boat rolling with rate amplitude `wave` [rad/s] at period `period`
    /// [s], phase `phi` (roll angle and the gravity it tilts consistent).
    #[allow(clippy::too_many_arguments)]
    fn window(
        seed: u64,
        rate: f64,
        secs: f64,
        arw: f64,
        vib: f64,
        wave: f64,
        period: f64,
        phi: f64,
    ) -> Vec<ImuSample> {
        let mut rng = crate::TestGauss(seed.wrapping_mul(2654435761) + 1);
        let mut gauss = || rng.next();
        let dt = 1.0 / rate;
        let (sw, sf) = (arw / dt.sqrt(), 5.0 * arw / dt.sqrt());
        let g = earth::gravity(0.7, 100.0);
        let om = core::f64::consts::TAU / period;
        (0..(secs * rate) as usize)
            .map(|i| {
                let t = i as f64 * dt;
                let vibe = vib * (core::f64::consts::TAU * 30.0 * t).sin();
                let mut w = Vec3::new(2e-3, -1e-3, 5e-4);
                w += Vec3::new(gauss(), gauss(), gauss()) * sw;
                w += Vec3::repeat(vibe);
                w.x += wave * (om * t + phi).cos();
                let roll = wave / om * (om * t + phi).sin();
                let mut f = Vec3::new(0.05, -g * roll.sin(), -g * roll.cos());
                f += Vec3::new(gauss(), gauss(), gauss()) * sf;
                f += Vec3::repeat(20.0 * vibe);
                ImuSample {
                    t,
                    dt,
                    dtheta_b: w * dt,
                    dvel_b: f * dt,
                }
            })
            .collect()
    }

    #[test]
    fn drift_test_passes_still_imus_and_catches_waves() {
        let deg = core::f64::consts::PI / 180.0;
        // Threshold: χ²(3) at 1e-6 (30.7), as the pipeline uses.
        let lim = 30.7;
        let z = Vec3::zeros();
        // Still: consumer (0.5°/√h), industrial (0.15) and tactical (0.05°/√h)
        // ARW at 100–400 Hz, 1–40 s windows, with and without vibration of
        // 10× the noise: no false alarm in 300 windows.
        let mut worst: f64 = 0.0;
        for seed in 0..300u64 {
            let arw = [0.5, 0.15, 0.05][seed as usize % 3] * deg / 60.0;
            let rate = [100.0, 200.0, 400.0][(seed / 3) as usize % 3];
            let secs = [1.0, 5.0, 40.0][(seed / 9) as usize % 3];
            let vib = if seed % 2 == 0 {
                10.0 * arw * rate.sqrt()
            } else {
                0.0
            };
            let v = window(seed, rate, secs, arw, vib, 0.0, 1.0, 0.0);
            let (cw, cf) = drift_chi2(&v, 4, z, z).unwrap();
            worst = worst.max(cw.max()).max(cf.max());
        }
        assert!(worst < lim, "still IMU: worst chi2 {worst}");
        // Moored waves (a third of 1–6° roll at 4–8 s: rate amplitude
        // 0.26–3.1°/s): caught at every phase, consumer noise, 1 s windows.
        for (i, &(amp_deg, period)) in [(0.26, 8.0), (0.5, 6.0), (3.1, 4.0)].iter().enumerate() {
            for p in 0..8 {
                let phi = p as f64 * core::f64::consts::TAU / 8.0;
                let arw = 0.5 * deg / 60.0;
                let v = window(i as u64, 100.0, 1.0, arw, 0.0, amp_deg * deg, period, phi);
                let (cw, cf) = drift_chi2(&v, 4, z, z).unwrap();
                let c = cw.max().max(cf.max());
                assert!(
                    c > lim,
                    "wave {amp_deg} deg/s {period} s phase {p}: chi2 {c}"
                );
            }
        }
        // Degenerate input: too short, k < 2.
        let v = window(1, 100.0, 0.05, 1e-4, 0.0, 0.0, 1.0, 0.0);
        assert!(drift_chi2(&v, 4, z, z).is_none());
        assert!(drift_chi2(&v, 1, z, z).is_none());
    }

    #[test]
    fn heading_needs_speed() {
        assert!(heading_from_velocity(&Vec3::new(0.1, 0.1, 0.0), 1.0).is_none());
        let h = heading_from_velocity(&Vec3::new(0.0, -5.0, 0.0), 1.0).unwrap();
        assert!((h + core::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}

/// Roll and pitch [rad] in motion for a known yaw `yaw` [rad], from one
/// specific-force vector pair: `f_b` in the body frame (FRD) and `f_n` in NED,
/// the same force (`f_n = C_bn f_b`, `C_bn = R_z(ψ) R_y(θ) R_x(φ)`,
/// `SEEDS.md §1` eq. 3). In motion `f_n = a_n − g_n + (2ω_ie + ω_en) × v_n`
/// (Groves eq. 5.54) with the acceleration taken from GNSS velocities; at
/// rest it reduces to [`level`]. Only the directions are used.
///
/// With `u = R_zᵀ f_n` (the heading frame): `f_b,x = u_x cos θ − u_z sin θ`
/// fixes θ (the root nearest level), then φ is the angle that turns
/// `(R_yᵀ u)_yz` into `f_b,yz`. `None` when either vector is degenerate
/// (free fall, NaN) or the pair admits no tilt (|f_b,x| > |u_xz|).
pub fn tilt_given_yaw(f_b: &Vec3, f_n: &Vec3, yaw: f64) -> Option<(f64, f64)> {
    let (nb, nn) = (f_b.norm(), f_n.norm());
    if !(nb > 1.0 && nn > 1.0 && nb.is_finite() && nn.is_finite()) {
        return None;
    }
    let (f, fnn) = (f_b / nb, f_n / nn);
    let (sy, cy) = yaw.sin_cos();
    // u = R_z(ψ)ᵀ f_n.
    let u = Vec3::new(cy * fnn.x + sy * fnn.y, -sy * fnn.x + cy * fnn.y, fnn.z);
    let r = u.x.hypot(u.z);
    if r < 1e-6 || f.x.abs() > r * (1.0 + 1e-9) {
        return None;
    }
    let beta = u.z.atan2(u.x);
    let a = (f.x / r).clamp(-1.0, 1.0).acos();
    let wrap = crate::attitude::wrap_pi;
    // Both roots of the pitch equation fit the pair exactly (the force
    // direction leaves one rotation free); the vehicle is the one nearer
    // level: the larger cos φ cos θ (body down closest to nav down).
    let solve = |pitch: f64| {
        let (sp, cp) = pitch.sin_cos();
        // w = R_y(θ)ᵀ u; f = R_x(φ)ᵀ w turns (w_y, w_z) by −φ.
        let (wy, wz) = (u.y, sp * u.x + cp * u.z);
        let roll = wrap(wz.atan2(wy) - f.z.atan2(f.y));
        // A ZYX pitch lies in [−90°, 90°]; the other range is the same
        // rotation with roll and yaw turned by 180°, not this yaw.
        let c = if cp >= 0.0 {
            roll.cos() * cp
        } else {
            f64::NEG_INFINITY
        };
        (roll, pitch, c)
    };
    let (r1, p1, c1) = solve(wrap(a - beta));
    let (r2, p2, c2) = solve(wrap(-a - beta));
    let (roll, pitch, c) = if c1 >= c2 { (r1, p1, c1) } else { (r2, p2, c2) };
    (c > f64::NEG_INFINITY).then_some((roll, pitch))
}

#[cfg(test)]
mod tilt_tests {
    use super::*;
    use crate::ins::mech::q_bn_from_rpy;

    /// Any vehicle attitude (roll, pitch within ±45°) and any acceleration
    /// up to 0.5 g horizontally: the pair gives back roll and pitch to 1e-9
    /// rad (the second, steeper root is the one left out).
    #[test]
    fn tilt_given_yaw_recovers_roll_and_pitch() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let rpy = Vec3::new(rnd() * 0.78, rnd() * 0.78, rnd() * 3.1);
            let a_n = Vec3::new(rnd() * 3.4, rnd() * 3.4, rnd() * 2.0);
            let f_n = a_n - Vec3::new(0.0, 0.0, 9.81);
            let c_bn = q_bn_from_rpy(&rpy).to_rotation_matrix().into_inner();
            let f_b = c_bn.transpose() * f_n;
            let (r, p) = tilt_given_yaw(&f_b, &f_n, rpy.z).expect("a valid pair");
            assert!((r - rpy.x).abs() < 1e-9, "roll {r} vs {}", rpy.x);
            assert!((p - rpy.y).abs() < 1e-9, "pitch {p} vs {}", rpy.y);
        }
        // At rest it is levelling.
        let f_b = Vec3::new(0.8, -1.1, -9.7);
        let (r, p) = tilt_given_yaw(&f_b, &Vec3::new(0.0, 0.0, -9.8), 0.3).unwrap();
        let (rl, pl) = level(&f_b);
        assert!((r - rl).abs() < 1e-12 && (p - pl).abs() < 1e-12);
        assert!(tilt_given_yaw(&Vec3::zeros(), &Vec3::new(0.0, 0.0, -9.8), 0.0).is_none());
    }
}
