//! `summary.json` of an ESKF run: the configuration, what was read, used and
//! rejected, the alignment and the time-offset check.

use crate::config::RunConfig;
use crate::eskf_run::EskfRun;
use serde::Serialize;

/// The ESKF run's `summary.json` (field order is the file's).
#[derive(Serialize)]
pub(crate) struct Summary<'a> {
    pub config: &'a RunConfig,
    pub filter: String,
    pub alignment: String,
    /// Per input file: records read, used, skipped, rejected by reason.
    pub inputs: serde_json::Value,
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
    pub outputs: Vec<String>,
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
        Summary {
            config,
            filter: format!("{:?}", run.config),
            alignment: run.alignment.clone(),
            inputs,
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
                "deweighted": st.deweighted,
                "singular": st.singular,
            }),
            time_offset,
            seconds_read,
            seconds_filter: run.seconds_filter,
            outputs,
        }
    }
}
