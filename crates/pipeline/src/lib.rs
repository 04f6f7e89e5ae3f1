//! navfuse's run pipeline as a library: what `navfuse run` and
//! `navfuse kf-gins` do, callable from the CLI, Python and other Rust
//! programs alike.
//!
//! - [`RunConfig`] (the `navfuse run` TOML) → [`run()`]: load the inputs
//!   ([`input::load`]), run the estimator, write solutions and `summary.json`.
//! - [`run_eskf`]: the same ESKF run in memory on given IMU/GNSS streams,
//!   writing nothing (for simulation experiments); [`run()`] is built on it.
//! - [`kf_gins::run_kf_gins`]: a KF-GINS YAML configuration, KF-GINS's files.
//! - [`template::run_template`]: the commented TOML `navfuse init` writes
//!   (every key: `docs/config.md`); [`noise_cfg`]: `[filter.imu_noise]` in
//!   KF-GINS or datasheet keys.
//!
//! Frames: body FRD, navigation NED; GPS time in seconds (or time of week
//! for KF-GINS files); SI units inside, degrees only in files and configs.

pub mod aiding_cfg;
pub mod align;
pub mod allan;
pub mod base_station;
pub mod check;
pub mod config;
pub mod course_filter;
pub mod cp_att_run;
pub mod csv_map;
pub mod csv_sniff;
pub mod demo;
pub mod error;
pub mod eskf_run;
pub mod experiments;
pub mod fix_dynamics;
pub mod gnss_error;
pub mod heading_input;
pub mod imu_clock;
pub mod input;
pub mod kf_gins;
pub mod kf_gins_align;
mod kf_gins_offset;
mod kf_gins_out;
pub mod kfgins_input;
pub mod live;
pub mod live_align;
pub mod live_cp_att;
pub mod live_replay;
pub mod live_session;
pub mod motion_tilt;
pub mod noise_cfg;
pub mod odo_input;
pub mod offset_passes;
pub mod offset_sens;
mod other;
pub mod outputs;
pub mod pos_out;
pub mod profile;
pub mod raw_drive;
pub mod raw_input;
pub mod resolved;
pub mod rtk_gnss;
pub mod rtk_run;
pub mod run;
pub mod run_checks;
pub mod sensors;
pub mod sigma;
pub mod smooth_gps;
pub mod spp;
pub mod stream_sigma;
mod summary;
pub mod template;
pub mod tight_run;
pub mod time_offset;
mod tool_error;
pub mod ubx_input;
mod yaw_bank;

#[cfg(test)]
mod aiding_run_tests;
#[cfg(test)]
mod input_tests;
#[cfg(test)]
mod kf_gins_sigma_tests;
#[cfg(test)]
mod kf_gins_tests;
#[cfg(test)]
mod run_tests;

pub use config::{resolve_path, FilterCfg, InitCfg, InputCfg, OutageCfg, RunConfig};
pub use error::PipelineError;
pub use eskf_run::{run_eskf, EskfRun};
pub use input::AuxSeries;
pub use run::{run, RunOptions, RunOutcome};
pub use tool_error::ToolError;

/// `n` IMU samples from `t0 + dt` on of a level, unaccelerated body (no
/// rotation, specific force `−g` down): the synthetic drives of the tests.
#[cfg(test)]
pub(crate) fn level_imu(t0: f64, n: usize, dt: f64, g: f64) -> Vec<navfuse_core::types::ImuSample> {
    (1..=n)
        .map(|k| navfuse_core::types::ImuSample {
            t: t0 + k as f64 * dt,
            dt,
            dtheta_b: navfuse_core::Vec3::zeros(),
            dvel_b: navfuse_core::Vec3::new(0.0, 0.0, -g * dt),
        })
        .collect()
}

/// A per-process scratch folder for a test, created:
/// `navfuse-{name}-{pid}` in the system temp dir.
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("navfuse-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
