//! Aiding sensors of issue 17 on a simulated trajectory: wheel speed
//! (scale error, tick quantisation, slip episodes, noise), dual-antenna
//! heading (σ from the baseline length), and a magnetometer (WMM field,
//! residual hard-iron bias, noise, disturbance episodes). Deterministic in
//! the seed, one ChaCha12 stream per sensor, independent of the IMU and
//! GNSS streams (adding a sensor changes nothing else of a run).

use crate::trajectory::{Trajectory, TruthEpoch};
use navfuse_core::attitude::dcm_from_euler;
use navfuse_core::measurements::wmm;
use navfuse_core::{earth, HeadingFix, HeadingSource, MagSample, Mat3, OdometerSample, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;

const STREAM_WHEEL: u64 = 20;
const STREAM_HEADING: u64 = 21;
const STREAM_MAG: u64 = 22;
const STREAM_SCALE: u64 = 23;

/// A per-seed true odometer scale error, uniform in `[−max, max]` (its own
/// stream: the same seed gives the same wheel whatever else is simulated).
pub fn draw_scale_error(seed: u64, max: f64) -> f64 {
    rng(seed, STREAM_SCALE).gen_range(-max..=max)
}

/// Wheel-speed sensor (ABS tone ring or CAN vehicle speed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelSpec {
    /// Wheel reference point from the IMU, body FRD [m].
    pub lever_arm_b: Vec3,
    /// True scale-factor error s: reported = (1 + s) · true (a wrong wheel
    /// radius; tyre pressure and wear give ±0.5–2 %).
    pub scale_error: f64,
    /// Distance per tick [m] (0: no quantisation). A 48-tooth ABS ring on
    /// a 2 m tyre, both edges counted, is 2/96 ≈ 0.021 m.
    pub tick_m: f64,
    /// Output rate [Hz]; the speed is the tick count over the interval.
    pub rate_hz: f64,
    /// White noise added to the reported speed [m/s] (CAN resolution, jitter).
    pub noise_mps: f64,
    /// Slip episodes: mean rate [1/s], duration range [s], and the relative
    /// speed error during one (drawn uniformly in ±`slip_max`; spin > 0, lock < 0).
    pub slip_rate_hz: f64,
    pub slip_duration_s: (f64, f64),
    pub slip_max: f64,
}

/// Dual-antenna GNSS heading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualAntennaSpec {
    /// Baseline length [m].
    pub baseline_m: f64,
    /// Baseline azimuth / elevation in the body frame [rad] (as
    /// `navfuse_core::measurements::heading::HeadingConfig`).
    pub mount_yaw_rad: f64,
    pub mount_pitch_rad: f64,
    /// Carrier-phase noise of one antenna's position [m] (RTK ~ 3–5 mm).
    pub phase_std_m: f64,
    pub rate_hz: f64,
}

impl DualAntennaSpec {
    /// Heading 1-σ [rad]: the baseline is the difference of two antenna
    /// positions, each with carrier-phase-level noise σ_φ, so its
    /// across-baseline error has σ_φ·√2; divided by the length it is an
    /// angle (small-angle). Pitch: the vertical error is ~2× the horizontal
    /// one (VDOP ≈ 2 HDOP), so σ_θ = 2 σ_ψ.
    pub fn heading_std(&self) -> f64 {
        self.phase_std_m * core::f64::consts::SQRT_2 / self.baseline_m
    }
}

/// Magnetometer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagSpec {
    /// Per-axis white noise [T].
    pub noise_t: f64,
    /// Residual hard-iron bias after calibration, 1-σ per axis [T].
    pub bias_t: f64,
    /// Disturbance episodes (a passing truck, a steel bridge): rate [1/s],
    /// duration range [s], added field magnitude [T] (random direction).
    pub disturb_rate_hz: f64,
    pub disturb_duration_s: (f64, f64),
    pub disturb_t: f64,
    pub rate_hz: f64,
    /// Date for the WMM [decimal year].
    pub decimal_year: f64,
}

fn rng(seed: u64, stream: u64) -> rand_chacha::ChaCha12Rng {
    use rand::SeedableRng;
    let mut r = rand_chacha::ChaCha12Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

fn c_bn(e: &TruthEpoch) -> Mat3 {
    dcm_from_euler(&e.rpy)
}

/// Exact wheel-point velocity, body frame: `C_nb v_n + ω_nb^b × l`.
fn wheel_v_b(e: &TruthEpoch, l: &Vec3) -> Vec3 {
    let c = c_bn(e);
    let c_nb = c.transpose();
    let w_nb = e.w_ib_b - c_nb * (earth::omega_ie_n(e.lat) + earth::omega_en_n(e.lat, e.h, &e.v_n));
    c_nb * e.v_n + w_nb.cross(l)
}

/// Random episodes `[start, end)` over `[t0, t1]` (Poisson onsets).
fn episodes<R: Rng>(
    r: &mut R,
    t0: f64,
    t1: f64,
    rate: f64,
    dur: (f64, f64),
) -> Vec<(f64, f64, f64)> {
    let mut v = Vec::new();
    if rate <= 0.0 {
        return v;
    }
    let mut t = t0;
    loop {
        let u: f64 = r.gen_range(1e-12..1.0);
        t += -u.ln() / rate;
        if t >= t1 {
            return v;
        }
        let d = r.gen_range(dur.0..=dur.1.max(dur.0));
        let a: f64 = r.gen_range(-1.0..=1.0);
        v.push((t, t + d, a));
        t += d;
    }
}

/// Wheel-speed samples over the trajectory (true GPS time).
pub fn wheel_speed(traj: &Trajectory, spec: &WheelSpec, seed: u64) -> Vec<OdometerSample> {
    let mut r = rng(seed, STREAM_WHEEL);
    let tr = &traj.truth;
    let (t0, t1) = (tr[0].t, tr[tr.len() - 1].t);
    let slips = episodes(&mut r, t0, t1, spec.slip_rate_hz, spec.slip_duration_s);
    let dt_out = 1.0 / spec.rate_hz;
    let mut out = Vec::new();
    let mut dist = 0.0; // reported (scaled, slipping) distance [m]
    let mut ticks_prev = 0.0;
    let mut next = t0 + dt_out;
    let mut v_prev = wheel_v_b(&tr[0], &spec.lever_arm_b).x;
    for w in tr.windows(2) {
        let v = wheel_v_b(&w[1], &spec.lever_arm_b).x;
        let tm = 0.5 * (w[0].t + w[1].t);
        let slip = slips
            .iter()
            .find(|s| tm >= s.0 && tm < s.1)
            .map_or(0.0, |s| s.2 * spec.slip_max);
        dist += 0.5 * (v + v_prev) * (w[1].t - w[0].t) * (1.0 + spec.scale_error) * (1.0 + slip);
        v_prev = v;
        if w[1].t + 1e-9 >= next {
            let ticks = if spec.tick_m > 0.0 {
                (dist / spec.tick_m).floor() * spec.tick_m
            } else {
                dist
            };
            let noise: f64 = r.sample(StandardNormal);
            out.push(OdometerSample {
                t: w[1].t,
                dt: dt_out,
                speed_mps: (ticks - ticks_prev) / dt_out + spec.noise_mps * noise,
                std_mps: 0.0,
                wheel: 0,
            });
            ticks_prev = ticks;
            next += dt_out;
        }
    }
    out
}

/// Dual-antenna heading (and pitch) fixes at `rate_hz` (true GPS time).
pub fn dual_antenna(traj: &Trajectory, spec: &DualAntennaSpec, seed: u64) -> Vec<HeadingFix> {
    let mut r = rng(seed, STREAM_HEADING);
    let u_b =
        navfuse_core::measurements::heading::baseline_b(spec.mount_yaw_rad, spec.mount_pitch_rad);
    let s = spec.heading_std();
    let every = (1.0 / (spec.rate_hz * traj.imu_dt)).round().max(1.0) as usize;
    let mut out = Vec::new();
    for e in traj.truth.iter().step_by(every).skip(1) {
        let u_n = c_bn(e) * u_b;
        let (n1, n2): (f64, f64) = (r.sample(StandardNormal), r.sample(StandardNormal));
        let psi = u_n.y.atan2(u_n.x) + s * n1;
        let theta = (-u_n.z).atan2(u_n.xy().norm()) + 2.0 * s * n2;
        out.push(HeadingFix {
            t: e.t,
            heading_rad: navfuse_core::measurements::wrap_pi(psi),
            pitch_rad: theta,
            std_heading_rad: s,
            std_pitch_rad: 2.0 * s,
            baseline_m: spec.baseline_m,
            source: HeadingSource::DualAntenna,
        });
    }
    out
}

/// Magnetometer samples at `rate_hz` (true GPS time).
pub fn magnetometer(traj: &Trajectory, spec: &MagSpec, seed: u64) -> Vec<MagSample> {
    let mut r = rng(seed, STREAM_MAG);
    let tr = &traj.truth;
    let (t0, t1) = (tr[0].t, tr[tr.len() - 1].t);
    let mut g = || -> Vec3 { Vec3::from_fn(|_, _| r.sample::<f64, _>(StandardNormal)) };
    let bias = g() * spec.bias_t;
    let mut r2 = rng(seed, STREAM_MAG + 100);
    let dist = episodes(
        &mut r2,
        t0,
        t1,
        spec.disturb_rate_hz,
        spec.disturb_duration_s,
    );
    let dirs: Vec<Vec3> = dist
        .iter()
        .map(|_| g().normalize() * spec.disturb_t)
        .collect();
    let every = (1.0 / (spec.rate_hz * traj.imu_dt)).round().max(1.0) as usize;
    let mut out = Vec::new();
    for e in tr.iter().step_by(every).skip(1) {
        let Some(f) = wmm::field(e.lat, e.lon, e.h, spec.decimal_year) else {
            continue;
        };
        let mut m_b = c_bn(e).transpose() * f.b_n + bias + g() * spec.noise_t;
        if let Some(k) = dist.iter().position(|d| e.t >= d.0 && e.t < d.1) {
            m_b += dirs[k];
        }
        out.push(MagSample { t: e.t, m_b });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{generate, Segment, Start};

    fn traj() -> Trajectory {
        let start = Start {
            lat_deg: 30.0,
            lon_deg: 114.0,
            h_m: 20.0,
            rpy_deg: [0.0, 0.0, 30.0],
            v_b: [10.0, 0.0, 0.0],
            gps_week: 2300,
            tow_s: 1000.0,
        };
        let segs = vec![Segment::Cruise {
            duration_s: Some(20.0),
            distance_m: None,
        }];
        generate(&start, &segs, 100.0, 2).unwrap()
    }

    #[test]
    fn wheel_speed_carries_the_scale_error_and_the_ticks() {
        let t = traj();
        let spec = WheelSpec {
            lever_arm_b: Vec3::new(0.0, 0.0, 0.3),
            scale_error: 0.01,
            tick_m: 0.02,
            rate_hz: 10.0,
            noise_mps: 0.0,
            slip_rate_hz: 0.0,
            slip_duration_s: (0.5, 1.0),
            slip_max: 0.0,
        };
        let w = wheel_speed(&t, &spec, 1);
        assert!(w.len() >= 199, "{}", w.len());
        let mean = w.iter().map(|s| s.speed_mps).sum::<f64>() / w.len() as f64;
        // 10 m/s · 1.01 up to one tick over the run.
        assert!((mean - 10.1).abs() < 0.02 / 20.0 + 1e-6, "{mean}");
        // Each sample is a whole number of ticks per interval.
        for s in &w {
            let k = s.speed_mps * 0.1 / 0.02;
            assert!((k - k.round()).abs() < 1e-6);
        }
    }

    #[test]
    fn dual_antenna_reads_the_baseline_heading() {
        let t = traj();
        let spec = DualAntennaSpec {
            baseline_m: 1.0,
            mount_yaw_rad: 0.5 * core::f64::consts::PI,
            mount_pitch_rad: 0.0,
            phase_std_m: 0.0,
            rate_hz: 1.0,
        };
        let h = dual_antenna(&t, &spec, 1);
        assert_eq!(h.len(), 20);
        // Baseline across the car (to the right): heading = yaw + 90°.
        assert!((h[0].heading_rad.to_degrees() - 120.0).abs() < 1e-6);
        let d = DualAntennaSpec {
            phase_std_m: 0.005,
            ..spec
        };
        assert!((d.heading_std() - 0.005 * 2f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn magnetometer_reads_the_wmm_field_in_the_body_frame() {
        let t = traj();
        let spec = MagSpec {
            noise_t: 0.0,
            bias_t: 0.0,
            disturb_rate_hz: 0.0,
            disturb_duration_s: (1.0, 2.0),
            disturb_t: 0.0,
            rate_hz: 10.0,
            decimal_year: 2026.9,
        };
        let m = magnetometer(&t, &spec, 3);
        let f = wmm::field(30f64.to_radians(), 114f64.to_radians(), 20.0, 2026.9).unwrap();
        assert!((m[0].m_b.norm() - f.total).abs() < 1e-9);
    }
}
