//! The IMU–GNSS time offset of `navfuse kf-gins` where the course
//! estimate's model variants disagree: the filter's own GNSS likelihood
//! settles it ([`crate::offset_passes::likelihood_on_positions`]), as in
//! `navfuse run`. Each probe is the KF-GINS run itself (same model,
//! alignment decision and event order) with the IMU stamps shifted, no
//! smoother and nothing written. Convention: true time = IMU stamp + τ.

use crate::error::Result;
use crate::kf_gins_align::{self, AlignSource};
use crate::kfgins_input::RunInput;
use crate::offset_passes::{gnss_nll_terms, likelihood_on_positions, NllTerms, PositionsDecision};
use crate::profile::Profile;
use crate::time_offset::auto_estimate;
use navfuse_core::estimators::eskf::EskfConfig;
use navfuse_core::types::{Estimator, Event, ImuSample};
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::Path;

/// The offset to apply (`None`: the course estimate was conclusive or the
/// likelihood not significant) and the likelihood's note when it ran.
/// `ecfg`: the run's filter configuration; `end`: the run's end time [s].
pub fn likelihood_offset(
    yaml: &Path,
    cfg: &KfGinsConfig,
    ecfg: &EskfConfig,
    input: &RunInput,
    profile: Option<&Profile>,
    source: AlignSource,
    end: f64,
) -> Result<PositionsDecision> {
    let course = auto_estimate(&input.imu, &input.gnss);
    let ecfg = EskfConfig {
        smoother_every: 0,
        ..*ecfg
    };
    let gnss = &input.gnss;
    let mut terms_at = |tau: f64| -> Result<NllTerms> {
        let imu: Vec<ImuSample> = input
            .imu
            .iter()
            .map(|s| ImuSample { t: s.t + tau, ..*s })
            .collect();
        let i0 = imu.partition_point(|s| s.t < cfg.starttime);
        let d = kf_gins_align::decide(yaml, cfg, &ecfg, &imu[i0..], gnss, profile, source)?;
        let (mut eskf, start) = d.start_filter(cfg, &ecfg, &imu, i0);
        // The event order of `crate::kf_gins::run_kf_gins`'s filter.
        let mut g = gnss.partition_point(|f| f.t <= start);
        let mut updates = Vec::new();
        for s in &imu[imu.partition_point(|s| s.t < start)..] {
            if s.t > end {
                break;
            }
            while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
                eskf.push(&Event::Gnss(gnss[g]));
                updates.extend_from_slice(eskf.updates());
                g += 1;
            }
            let _ = eskf.push(&Event::Imu(*s));
            updates.extend_from_slice(eskf.updates());
        }
        Ok(gnss_nll_terms(&updates, gnss))
    };
    likelihood_on_positions(&course, &mut terms_at)
}
