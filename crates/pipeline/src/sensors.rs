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
}
