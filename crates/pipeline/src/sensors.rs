//! IMU noise from the sensor, not from a recording: `[filter] imu_preset =
//! "<model>"` names a sensor whose datasheet numbers (and their source) live
//! in navfuse-sim's preset table ([`navfuse_sim::imu_model::imu_preset`]),
//! converted to the ESKF's noise model by
//! [`navfuse_sim::imu_model::ImuSpec::filter_noise`] (IEEE Std 952, Groves
//! 2nd ed. §4.4, §14.2.6). The simulator draws its sensor errors from the
//! same table, so a simulated run and a filter that names the same sensor
//! agree by construction, and a real sensor gets its datasheet.
//!
//! With no noise named at all, [`DEFAULT_IMU_PRESET`] is used: a consumer
//! (phone-grade) MEMS, the largest noise of the MEMS presets, so a run of an
//! unknown MEMS IMU is never told its sensor is better than it is.

use crate::error::{PipelineError, Result};
use navfuse_core::estimators::eskf::ImuNoise;
use navfuse_core::types::ImuSample;
use navfuse_core::Vec3;
use navfuse_sim::imu_model::{imu_preset, IMU_PRESETS};

/// The preset used when a run names no IMU noise: consumer-grade MEMS
/// (conservative: the noisiest MEMS preset).
pub const DEFAULT_IMU_PRESET: &str = "phone";

/// A sensor's noise for the ESKF, with the initial σ of its error states.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorNoise {
    /// Preset name and the sensor it describes.
    pub preset: String,
    pub sensor: String,
    /// Where the numbers come from.
    pub source: String,
    /// Process noise (SI; Gauss–Markov biases and scale factors).
    pub noise: ImuNoise,
    /// Initial 1-σ of the gyro bias [rad/s] (turn-on ⊕ in-run) …
    pub init_bg_std: f64,
    /// … of the accelerometer bias [m/s²] …
    pub init_ba_std: f64,
    /// … and of the gyro and accelerometer scale factors [-].
    pub init_sg_std: f64,
    pub init_sa_std: f64,
}

/// The ESKF noise of the sensor preset `name` (see [`IMU_PRESETS`]).
///
/// Mapping: ARW/VRW pass through (rad/√s, m/s/√s); the first-order
/// Gauss–Markov bias σ and correlation time pass through (the ESKF has one
/// correlation time: the gyro's, which governs heading drift); a preset with
/// a bias random walk and no Gauss–Markov term becomes a random walk
/// (`corr_time = ∞`, `bg_std` = its density); scale-factor σ seeds both the
/// scale states' process and their initial σ. Axis misalignment,
/// g-sensitivity and quantisation are not states of the ESKF.
pub fn imu_noise_preset(name: &str) -> Result<SensorNoise> {
    let spec = imu_preset(name).map_err(|_| {
        PipelineError::Options(format!(
            "imu_preset {name:?}: expected one of {}",
            IMU_PRESETS.join(", ")
        ))
    })?;
    let fnz = spec.filter_noise();
    let g = fnz.gyro.ok_or_else(|| {
        PipelineError::Options(format!(
            "imu_preset {name:?} ({}) has no gyro: the ESKF needs one",
            spec.name
        ))
    })?;
    let a = fnz.accel;
    let (bg, ba, corr_time) = if g.bias_gm_tau_s > 0.0 {
        (g.bias_gm_sigma, a.bias_gm_sigma, g.bias_gm_tau_s)
    } else {
        (g.bias_rw, a.bias_rw, f64::INFINITY)
    };
    Ok(SensorNoise {
        preset: name.to_string(),
        sensor: spec.name.clone(),
        source: spec.source.clone(),
        noise: ImuNoise {
            arw: Vec3::repeat(g.white),
            vrw: Vec3::repeat(a.white),
            bg_std: Vec3::repeat(bg),
            ba_std: Vec3::repeat(ba),
            sg_std: Vec3::repeat(g.scale_sigma),
            sa_std: Vec3::repeat(a.scale_sigma),
            corr_time,
        },
        init_bg_std: g.bias_init_sigma,
        init_ba_std: a.bias_init_sigma,
        init_sg_std: g.scale_sigma,
        init_sa_std: a.scale_sigma,
    })
}

/// The white-noise densities the recording itself shows, per sensor:
/// `(gyro [rad/√s], accel [m/s/√s])`, from second differences of the rate
/// samples (`x_{k+1} − 2x_k + x_{k−1}` has variance `6 N²/dt` for white rate
/// noise of density N; a smooth motion of frequency f leaks only
/// `(2π f dt)²` of its amplitude into it), per axis over 1 s windows, the
/// median window (robust to shocks), the mean over the three axes.
///
/// A datasheet gives the sensor's noise on a quiet bench; on a vehicle,
/// engine and road vibration (1–6 °/s at 20–40 Hz on a car roof) adds an
/// effective white noise far above it, and a filter told the datasheet
/// value is overconfident. The run uses `max(datasheet, measured)`.
/// `None` with fewer than 10 windows.
pub fn measured_white_noise(imu: &[ImuSample]) -> Option<(f64, f64)> {
    const W: usize = 100;
    let n = imu.len();
    if n < 10 * W + 2 {
        return None;
    }
    let rate = |s: &ImuSample| (s.dtheta_b / s.dt, s.dvel_b / s.dt);
    let mut vg = Vec::with_capacity(n / W);
    let mut va = Vec::with_capacity(n / W);
    let mut k = 1;
    while k + W < n {
        let (mut sg, mut sa, mut dt_sum) = (Vec3::zeros(), Vec3::zeros(), 0.0);
        for i in k..k + W {
            let (w0, f0) = rate(&imu[i - 1]);
            let (w1, f1) = rate(&imu[i]);
            let (w2, f2) = rate(&imu[i + 1]);
            let dw = w2 - w1 * 2.0 + w0;
            let df = f2 - f1 * 2.0 + f0;
            sg += dw.component_mul(&dw);
            sa += df.component_mul(&df);
            dt_sum += imu[i].dt;
        }
        let dt = dt_sum / W as f64;
        // N² = var · dt / 6, averaged over the axes.
        vg.push(sg.sum() / (3.0 * W as f64) * dt / 6.0);
        va.push(sa.sum() / (3.0 * W as f64) * dt / 6.0);
        k += W;
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2].sqrt()
    };
    let (g, a) = (med(&mut vg), med(&mut va));
    (g.is_finite() && a.is_finite()).then_some((g, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_gyro_preset_converts_and_unknown_names_list_the_presets() {
        for p in IMU_PRESETS {
            match imu_noise_preset(p) {
                Ok(s) => {
                    assert!(s.noise.arw.x >= 0.0 && s.noise.vrw.x >= 0.0, "{p}");
                    assert!(s.init_bg_std >= s.noise.bg_std.x, "{p}");
                }
                // Accelerometer-only presets are refused with a reason.
                Err(e) => assert!(e.to_string().contains("no gyro"), "{p}: {e}"),
            }
        }
        let e = imu_noise_preset("nope").unwrap_err().to_string();
        assert!(e.contains("adis16465") && e.contains("nope"), "{e}");
        // The default is the noisiest MEMS gyro of the table.
        let d = imu_noise_preset(DEFAULT_IMU_PRESET).unwrap();
        let i = imu_noise_preset("adis16465").unwrap();
        assert!(d.noise.arw.x > i.noise.arw.x && d.init_bg_std > i.init_bg_std);
    }

    #[test]
    fn measured_white_noise_recovers_a_white_density_and_ignores_smooth_motion() {
        // White gyro/accel noise of known density on a smooth 2 Hz sway:
        // the second-difference estimate finds the density within 10 %.
        let (ng, na, dt) = (1e-3, 5e-3, 0.01);
        let mut x: u64 = 88172645463325252;
        let mut gauss = || {
            let mut u = || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (core::f64::consts::TAU * b).cos()
        };
        let imu: Vec<ImuSample> = (0..6000)
            .map(|k| {
                let t = k as f64 * dt;
                let sway = (core::f64::consts::TAU * 2.0 * t).sin();
                let w = Vec3::new(0.3 * sway, 0.0, 0.1) * dt
                    + Vec3::from_fn(|_, _| gauss()) * ng * dt.sqrt();
                let f = Vec3::new(2.0 * sway, 0.0, -9.81) * dt
                    + Vec3::from_fn(|_, _| gauss()) * na * dt.sqrt();
                ImuSample {
                    t,
                    dt,
                    dtheta_b: w,
                    dvel_b: f,
                }
            })
            .collect();
        let (g, a) = measured_white_noise(&imu).unwrap();
        assert!((g / ng - 1.0).abs() < 0.1, "gyro {g} vs {ng}");
        assert!((a / na - 1.0).abs() < 0.1, "accel {a} vs {na}");
        assert!(measured_white_noise(&imu[..500]).is_none());
    }
}
