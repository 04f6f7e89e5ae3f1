//! `summary.json` of an ESKF run: the configuration, what was read, used and
//! rejected, the alignment and the time-offset check.

use crate::config::RunConfig;
use crate::eskf_run::EskfRun;
use serde::Serialize;

/// The ESKF run's `summary.json` (field order is the file's).
#[derive(Serialize)]
pub(crate) struct Summary<'a> {
    pub config: &'a RunConfig,
    /// The effective filter configuration (SI units), not the TOML echo.
    pub filter: serde_json::Value,
    pub alignment: String,
    /// How the filter was started: method, wait, initial yaw σ.
    pub alignment_detail: serde_json::Value,
    /// Warnings the user should read (alignment, inputs).
    pub warnings: Vec<String>,
    /// Per input file: records read, used, skipped, rejected by reason.
    pub inputs: serde_json::Value,
    /// The effective reader configuration (format, time base, columns,
    /// units, mounting, counter clock; [`crate::resolved`]).
    pub resolved_input: &'a serde_json::Value,
    pub imu_samples_read: usize,
    pub imu_samples_before_start: usize,
    pub gnss_fixes_read: usize,
    pub gnss_fixes_cut_by_outage: usize,
    /// Fixes outside the filtered IMU span (before alignment ended, after the last sample).
    pub gnss_fixes_outside_filter_span: usize,
    pub gnss_fixes_fed: usize,
    pub used_rejected: serde_json::Value,
    pub time_offset: String,
    pub seconds_read: f64,
    pub seconds_filter: f64,
    /// Share of epochs coasting and the longest time without a position update.
    pub coasting: serde_json::Value,
    /// NIS self-check per measurement type ([`crate::sigma::nis_json`]).
    pub nis_check: serde_json::Value,
    pub outputs: Vec<String>,
    /// `[filter] coupling = "tight"`: every raw record by satellite and
    /// reason, the NIS and the receiver clock ([`crate::tight_run`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tight_coupling: Option<crate::tight_run::TightAccount>,
    /// `[filter] coupling = "rtk"`: every rover epoch and record, the fix
    /// decisions, the base ([`crate::rtk_run::RtkAccount`]).
    pub rtk: Option<crate::rtk_run::RtkAccount>,
}

impl<'a> Summary<'a> {
    /// The summary of `run` made with `config`.
    pub fn new(
        config: &'a RunConfig,
        run: &EskfRun,
        inputs: serde_json::Value,
        time_offset: String,
        seconds_read: f64,
        outputs: Vec<String>,
    ) -> Self {
        let st = &run.stats;
        let (nis_check, nis_warnings) = crate::sigma::nis_json(&run.nis);
        let mut warnings = run.warnings.clone();
        warnings.extend(nis_warnings);
        warnings.extend(crate::sigma::nis_adaptation_warnings(run.nis_adaptation));
        if let Some(r) = &run.rtk {
            warnings.extend(r.warnings.iter().cloned());
        }
        Summary {
            config,
            filter: filter_json(run),
            alignment: run.alignment.clone(),
            alignment_detail: serde_json::json!({
                "method": run.align_method,
                "seconds_after_first_imu_sample": run.align_wait_s,
                "initial_yaw_std_deg": run.align_yaw_std_deg,
            }),
            warnings,
            inputs,
            resolved_input: &serde_json::Value::Null,
            imu_samples_read: run.imu_samples_read,
            imu_samples_before_start: run.imu_samples_before_start,
            gnss_fixes_read: run.gnss_fixes_read,
            gnss_fixes_cut_by_outage: run.gnss_fixes_cut_by_outage,
            gnss_fixes_outside_filter_span: run.gnss_fixes_read
                - run.gnss_fixes_cut_by_outage
                - run.gnss_fixes_fed,
            gnss_fixes_fed: run.gnss_fixes_fed,
            used_rejected: serde_json::json!({
                "imu": {"used": st.imu_samples, "rejected_bad": st.imu_rejected_bad},
                "gnss_position": {"used": st.gnss_pos_used, "rejected_gate": st.gnss_pos_rejected_gate,
                    "forced_after_rejections": st.gnss_pos_forced, "rejected_bad_or_late": st.gnss_rejected_bad},
                "gnss_velocity": {"used": st.gnss_vel_used, "rejected_gate": st.gnss_vel_rejected_gate},
                "height": {"used": st.height_used, "rejected_gate": st.height_rejected_gate},
                "nhc": {"used": st.nhc_used, "rejected_gate": st.nhc_rejected_gate},
                "zupt": {"used": st.zupt_used, "rejected_gate": st.zupt_rejected_gate},
                "zaru": {"used": st.zaru_used},
                "aiding": crate::aiding_cfg::stats_json(&st.aiding),
                "deweighted": st.deweighted,
                "singular": st.singular,
            }),
            time_offset,
            seconds_read,
            seconds_filter: run.seconds_filter,
            coasting: crate::sigma::coasting_json(&run.std, run.coast_after_s),
            nis_check,
            outputs,
            tight_coupling: run.tight.clone(),
            rtk: run.rtk.clone(),
        }
    }
}

/// The effective ESKF configuration as JSON (SI units, names of
/// [`navfuse_core::estimators::eskf::EskfConfig`]), with the platform, the
/// noise source and the constraint noise the adaptation learnt.
fn filter_json(run: &EskfRun) -> serde_json::Value {
    let c = &run.config;
    let v = |x: &navfuse_core::Vec3| [x.x, x.y, x.z];
    let a = &run.adapted;
    serde_json::json!({
        "platform": run.platform.map(|p| p.to_string()),
        "imu_noise_source": run.noise_source,
        "coupling": if run.tight.is_some() {
            "tight"
        } else if run.rtk.is_some() {
            "rtk"
        } else {
            "loose"
        },
        "augmented_states": run.augmented_states,
        "augmented_estimate": run.augmented.map(|a| serde_json::json!({
            "gnss_error_ned_m": v(&a.gnss_error_n), "gnss_error_std_m": v(&a.gnss_error_std),
            "time_offset_s": a.time_offset_s, "time_offset_std_s": a.time_offset_std_s,
            "nhc_mount_pitch_yaw_deg": [a.nhc_mount.x.to_degrees(), a.nhc_mount.y.to_degrees()],
            "nhc_mount_pitch_yaw_std_deg": [a.nhc_mount_std.x.to_degrees(), a.nhc_mount_std.y.to_degrees()],
            "nhc_lever_x_m": a.nhc_mount.z, "nhc_lever_x_std_m": a.nhc_mount_std.z,
        })),
        "noise": {
            "arw_rad_per_sqrt_s": v(&c.noise.arw), "vrw_m_s_per_sqrt_s": v(&c.noise.vrw),
            "gyro_bias_gm_std_rad_s": v(&c.noise.bg_std), "accel_bias_gm_std_m_s2": v(&c.noise.ba_std),
            "gyro_scale_std": v(&c.noise.sg_std), "accel_scale_std": v(&c.noise.sa_std),
            "corr_time_s": if c.noise.corr_time.is_finite() { Some(c.noise.corr_time) } else { None },
        },
        "lever_arm_b_m": v(&c.lever_arm_b),
        "scale_factors": c.scale_factors,
        "gate_probability": c.gate_probability,
        "gate_deweight_factor": c.gate_deweight_factor,
        "gnss_force_after": c.gnss_force_after,
        "use_gnss_velocity": c.use_gnss_velocity,
        "position_until_s": c.position_until,
        "nhc": c.nhc.map(|n| serde_json::json!({
            "std_m_s": n.std, "interval_s": n.interval, "min_speed_m_s": n.min_speed,
            "adapted_std_m_s": a.nhc_std, "adaptation_used_rejected": a.nhc_counts,
        })),
        "zupt": c.zupt.map(|z| serde_json::json!({
            "window_samples": z.window, "max_accel_std_m_s2": z.max_accel_std,
            "max_gyro_std_rad_s": z.max_gyro_std, "max_accel_dev_m_s2": z.max_accel_dev,
            "max_speed_m_s": z.max_speed, "vel_std_m_s": z.vel_std, "zaru_std_rad_s": z.zaru_std,
            "interval_s": z.interval,
            "adapted_vel_std_m_s": a.zupt_std, "adapted_zaru_std_rad_s": a.zaru_std,
        })),
        "smoother_every": c.smoother_every,
        "nis_adaptation": crate::sigma::nis_adaptation_json(run.nis_adaptation),
        "aiding": crate::aiding_cfg::config_json(&c.aiding),
    })
}
