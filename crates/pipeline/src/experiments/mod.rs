//! Simulation experiments on navfuse-sim's platform bench
//! ([`navfuse_sim::platform`]): how the default `navfuse run` configuration
//! generalises to platforms, IMU/GNSS grades and time offsets nobody tuned
//! it for ([`generalise`]), and whether the alignment copes with starts in
//! motion ([`align_check`]).
//!
//! Every run goes through [`crate::run_eskf`] with a [`RunConfig`] built the
//! way a user would write it ([`variant_config`]); scores compare the
//! solutions (IMU position, NED velocity, attitude) with the simulator's IMU
//! truth `traj.at(sol.t)` (GPS time, NED, radians inside). Targets and
//! scenario definitions are fixed before the runs (the numbers);
//! nothing here is tuned to make a cell pass.

pub mod aiding;
pub mod align_check;
pub mod attitude;
pub mod baseline;
#[cfg(test)]
mod consider_tests;
#[cfg(test)]
mod course_align_tests;
pub mod generalise;
#[cfg(test)]
mod honesty_diag;
pub mod paired;
pub mod rtk;
mod score;
pub mod seed002;
pub mod seed003;
pub mod seed004;
pub mod tight;
#[cfg(test)]
mod uav_diag;

pub use score::{h_error_ne, motion_start, RunDiag};

use crate::config::RunConfig;
use crate::time_offset::TimeOffsetCfg;
use navfuse_sim::platform::PlatformRun;
use serde::Serialize;

/// Stack of the experiments' worker threads [bytes]. A run
/// ([`crate::run_eskf`]) needs 1.2–2.5 MB of stack (measured with
/// `RUST_MIN_STACK` on the matrix's cells: the ESKF is ≈ 100 kB and the
/// yaw bank builds several), more than the 2 MiB rayon's global pool gives
/// its threads; 16 MiB leaves room for growth (virtual memory: only the
/// pages touched are committed).
pub const WORKER_STACK_BYTES: usize = 16 << 20;

/// Run `f` (whose `par_iter`s then use it) on the experiments' thread pool:
/// rayon's default thread count, [`WORKER_STACK_BYTES`] of stack each.
pub fn on_worker_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    let pool = POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .stack_size(WORKER_STACK_BYTES)
            .thread_name(|i| format!("navfuse-exp-{i}"))
            .build()
            .ok()
    });
    match pool {
        Some(p) => p.install(f),
        // No pool (threads could not be spawned): the caller's thread pool.
        None => f(),
    }
}

/// Errors of an experiment as a whole (a single run's failure is a result,
/// counted in the scores, not an error).
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// An invalid option (seed count, duration, cell filter).
    #[error("{0}")]
    Options(String),
}

/// Which configuration of the same simulated data is run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// What a user writes who only knows the platform and the IMU model:
    /// `[filter] platform` and `imu_preset`; no `[init]`, no time offset key.
    Default,
    /// The same plus everything the simulator knows: `imu_time_offset` = τ
    /// and `[init]` = the true state at the first IMU sample with small σ.
    Oracle,
    /// `preset = "kf-gins"` (plain KF-GINS model: no constraints, no
    /// gating) with the same IMU noise, the oracle's initial state and no
    /// time offset (`"none"`).
    KfginsModel,
    /// The default plus `imu_time_offset` = τ only: the reference of the
    /// time-offset check (what estimating τ costs, everything else being
    /// the default's), run by `generalise` on request.
    DefaultKnownOffset,
}

impl Variant {
    /// The matrix's three variants.
    pub const ALL: [Variant; 3] = [Variant::Default, Variant::Oracle, Variant::KfginsModel];
}

/// σ of the oracle's initial state: 1 cm, 1 cm/s, 0.1° — small against any
/// GNSS error, large enough to keep the covariance well conditioned.
const ORACLE_POS_STD_M: f64 = 0.01;
const ORACLE_VEL_STD_M_S: f64 = 0.01;
const ORACLE_ATT_STD_DEG: f64 = 0.1;

/// The run configuration of `variant` for the platform run `pr`
/// (`[input] imu`/`gnss` are placeholders: the data are passed in memory).
/// `[filter] lever_arm` is the simulated GNSS lever arm (body FRD, m).
pub fn variant_config(variant: Variant, pr: &PlatformRun) -> RunConfig {
    // Parsed from TOML so keys the pipeline adds later keep their defaults.
    let mut cfg: RunConfig = toml::from_str("[input]\nimu = \"sim\"\ngnss = \"sim\"\n")
        .expect("the minimal run configuration parses");
    cfg.filter.imu_preset = Some(pr.options.imu.preset().to_string());
    cfg.filter.lever_arm = pr.run.scenario.gnss.lever_arm_m;
    let platform = pr
        .platform
        .to_string()
        .parse()
        .expect("every sim platform is a pipeline profile");
    match variant {
        Variant::Default => cfg.filter.platform = Some(platform),
        Variant::DefaultKnownOffset => {
            cfg.filter.platform = Some(platform);
            cfg.input.imu_time_offset = Some(TimeOffsetCfg::Seconds(pr.imu_time_offset_s));
        }
        Variant::Oracle => {
            cfg.filter.platform = Some(platform);
            // The oracle's GNSS model is white with the reported σ.
            cfg.filter.gnss_error = Some(crate::gnss_error::GnssErrorCfg {
                model: Some("white".into()),
                ..Default::default()
            });
            cfg.input.imu_time_offset = Some(TimeOffsetCfg::Seconds(pr.imu_time_offset_s));
            set_true_init(&mut cfg, pr);
        }
        Variant::KfginsModel => {
            cfg.filter.preset = "kf-gins".into();
            cfg.input.imu_time_offset = Some(TimeOffsetCfg::Named("none".into()));
            set_true_init(&mut cfg, pr);
        }
    }
    cfg
}

/// `[init]` = the true state at the first IMU sample (degrees in the
/// config), `[input] start` = that sample's stamp.
pub(crate) fn set_true_init(cfg: &mut RunConfig, pr: &PlatformRun) {
    let s = &pr.init;
    // No `[input] start`: the state holds at the first IMU sample anyway.
    cfg.init.position = Some([s.lat.to_degrees(), s.lon.to_degrees(), s.h]);
    cfg.init.velocity = Some([s.v_n.x, s.v_n.y, s.v_n.z]);
    cfg.init.attitude = Some([
        s.rpy.x.to_degrees(),
        s.rpy.y.to_degrees(),
        s.rpy.z.to_degrees(),
    ]);
    cfg.init.position_std_m = Some(ORACLE_POS_STD_M);
    cfg.init.velocity_std_m_s = Some(ORACLE_VEL_STD_M_S);
    cfg.init.attitude_std_deg = Some([ORACLE_ATT_STD_DEG; 3]);
}

/// Run `cfg` on the platform run's data in memory.
pub(crate) fn run_variant(
    cfg: &RunConfig,
    pr: &PlatformRun,
) -> crate::error::Result<crate::EskfRun> {
    crate::run_eskf(
        cfg,
        std::path::Path::new("."),
        &pr.run.imu,
        &pr.run.gnss,
        None,
    )
}

/// Angle wrapped to (−π, π] [rad].
pub(crate) fn wrap_pi(a: f64) -> f64 {
    let w = a.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI {
        w - std::f64::consts::TAU
    } else {
        w
    }
}

/// RMS of `v` (NaN when empty).
pub(crate) fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}
