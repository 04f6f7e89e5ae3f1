//! `navfuse kf-gins --align`: the YAML's initial attitude checked against
//! the data, and replaced by navfuse's own alignment ([`crate::align`]) when
//! it is a guess.
//!
//! A KF-GINS YAML must give `initatt`; users who do not know it write a
//! guess (often `[0, 0, 0]`) with a small `initattstd` copied from a
//! template, and the filter then diverges or needs minutes to recover. With
//! `--align auto` the data's alignment (levelling when static, the GNSS
//! course or the yaw Gaussian-sum filter in motion) is computed too; the
//! YAML attitude, propagated by the gyro to the alignment's start sample, is
//! compared with it by a χ² test on the 3-D attitude difference φ (nav frame
//! NED, `C_data ≈ (I + [φ×]) C_yaml`), with the covariance
//! `diag(σ_yaml² + σ_data² + (σ_bg·T)² + (ω_ie·T)²)`: the YAML's stated σ,
//! the alignment's σ, the gyro bias over the propagation time `T` and the
//! earth rate the propagation ignores. Above the 0.9999 quantile of χ²(3)
//! (the gate `--enhanced` uses for measurements) the YAML attitude is
//! inconsistent with the data: the filter starts from the data's alignment
//! instead, and a warning says so. Consistent: the YAML's state is used
//! unchanged (outputs identical to `--align yaml`).

use crate::align::{align, AlignModel, Alignment};
use crate::config::{FilterCfg, RunConfig};
use crate::error::{PipelineError, Result};
use crate::profile::Profile;
use navfuse_core::attitude::{dcm_from_quat, dcm_from_rotvec, rotvec_from_dcm};
use navfuse_core::earth::OMEGA_IE;
use navfuse_core::estimators::eskf::{Eskf, EskfConfig};
use navfuse_core::kalman::chi2_quantile;
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::Path;

/// Probability of the χ²(3) attitude test (the gate `--enhanced` uses for
/// measurements): its quantile is ≈ 21.1.
const TEST_PROBABILITY: f64 = 0.9999;

/// Where `kf-gins` takes its initial state from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlignSource {
    /// The YAML's `initpos`/`initvel`/`initatt` (KF-GINS's behaviour).
    #[default]
    Yaml,
    /// navfuse's alignment from the data; the YAML's initial state ignored.
    Data,
    /// The YAML's state, unless its attitude fails the χ² test against the
    /// data's alignment (module documentation).
    Auto,
}

impl AlignSource {
    /// `yaml`, `data` or `auto`.
    pub fn parse(s: &str) -> std::result::Result<Self, String> {
        match s {
            "yaml" => Ok(Self::Yaml),
            "data" => Ok(Self::Data),
            "auto" => Ok(Self::Auto),
            _ => Err(format!("`{s}`: expected yaml, data or auto")),
        }
    }
}

/// The decision of [`decide`].
#[derive(Clone, Debug)]
pub struct AlignDecision {
    /// The data's alignment to start from (`None`: the YAML's state).
    pub alignment: Option<Alignment>,
    /// χ² statistic of the YAML attitude against the data (when tested).
    pub chi2: Option<f64>,
    /// Attitude difference data − YAML, NED [rad] (when tested).
    pub phi_n: Option<Vec3>,
    /// One line for the log: what was decided and why.
    pub note: String,
}

impl AlignDecision {
    /// The filter this decision starts (`ecfg`; the data's alignment, else
    /// the YAML's state) and its start time [s]. `imu`: the run's samples,
    /// `i0` the index of the first one at or after `starttime` (the
    /// alignment's `k_start` counts from it).
    pub fn start_filter(
        &self,
        cfg: &KfGinsConfig,
        ecfg: &EskfConfig,
        imu: &[ImuSample],
        i0: usize,
    ) -> (Eskf, f64) {
        match &self.alignment {
            Some(a) => (
                Eskf::new(*ecfg, a.nav, a.errors, &a.init_std),
                imu[(i0 + a.k_start).min(imu.len() - 1)].t,
            ),
            None => (
                Eskf::new(*ecfg, cfg.init_nav(), cfg.init_errors(), &cfg.init_std()),
                cfg.starttime,
            ),
        }
    }
}

/// Decide the initial state of a `kf-gins` run. `imu` starts at the YAML's
/// `starttime` (already shifted by any time offset), `gnss` is on the same
/// time base; `profile` is the platform's (course = heading or not).
pub fn decide(
    yaml: &Path,
    cfg: &KfGinsConfig,
    ecfg: &EskfConfig,
    imu: &[ImuSample],
    gnss: &[GnssFix],
    profile: Option<&Profile>,
    source: AlignSource,
) -> Result<AlignDecision> {
    if source == AlignSource::Yaml {
        return Ok(AlignDecision {
            alignment: None,
            chi2: None,
            phi_n: None,
            note: "initial state from the YAML".into(),
        });
    }
    if imu.len() < 2 {
        return Err(PipelineError::Alignment(format!(
            "{}: fewer than 2 IMU samples after starttime",
            yaml.display()
        )));
    }
    let run_cfg = RunConfig::for_streams(FilterCfg::default(), Some(yaml.to_path_buf()));
    let model = AlignModel {
        noise: &ecfg.noise,
        sensor: None,
        profile,
        lever_arm_b: ecfg.lever_arm_b,
    };
    let a = align(&run_cfg, imu, gnss, None, &model)?;
    if source == AlignSource::Data {
        let note = format!("initial state from the data: {}", a.description);
        return Ok(AlignDecision {
            alignment: Some(a),
            chi2: None,
            phi_n: None,
            note,
        });
    }
    // The YAML attitude carried by the gyro to the alignment's start
    // sample, with the gyro bias the static window measured when there was
    // one (its σ is the one in the test below; a phone gyro's 0.5 °/s
    // turn-on bias carried as the YAML's 0 turned 41 s into 79° of false
    // disagreement), else the YAML's.
    let bg = if a.static_s > 0.0 {
        a.errors.bg
    } else {
        cfg.init_errors().bg
    };
    let mut c_bn = dcm_from_quat(&cfg.init_nav().q_bn);
    for s in &imu[..=a.k_start.min(imu.len() - 1)] {
        c_bn *= dcm_from_rotvec(&(s.dtheta_b - bg * s.dt));
    }
    let c_data = dcm_from_quat(&a.nav.q_bn);
    let phi = rotvec_from_dcm(&(c_data * c_bn.transpose()));
    let t = imu[a.k_start.min(imu.len() - 1)].t - (imu[0].t - imu[0].dt);
    let yaml_std = cfg.init_std();
    let var = |i: usize| {
        yaml_std.att[i].powi(2)
            + a.init_std.att[i].powi(2)
            + (a.init_std.bg[i] * t).powi(2)
            + (OMEGA_IE * t).powi(2)
    };
    let chi2: f64 = (0..3).map(|i| phi[i] * phi[i] / var(i).max(1e-12)).sum();
    let deg = phi.map(f64::to_degrees);
    let diff = format!(
        "attitude difference data − YAML [{:.1}, {:.1}, {:.1}]° (N, E, D), χ² {chi2:.1}",
        deg.x, deg.y, deg.z
    );
    let limit = chi2_quantile(3, TEST_PROBABILITY);
    if chi2 > limit {
        let note = format!(
            "the YAML's initial attitude disagrees with the data ({diff} > {limit:.3}): \
             started from the data's alignment instead ({}); use --align yaml to keep the YAML's",
            a.description
        );
        Ok(AlignDecision {
            alignment: Some(a),
            chi2: Some(chi2),
            phi_n: Some(phi),
            note,
        })
    } else {
        Ok(AlignDecision {
            alignment: None,
            chi2: Some(chi2),
            phi_n: Some(phi),
            note: format!("the YAML's initial attitude agrees with the data ({diff})"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kf_gins::{run_kf_gins, KfGinsOptions};
    use crate::profile::Platform;
    use navfuse_sim::platform::Platform as SimPlatform;
    use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Outages, PlatformOptions};

    /// A simulated car (industrial MEMS, RTK, static start, no outages)
    /// written as KF-GINS files, and a YAML whose initial attitude is the
    /// truth's rotated by `yaw_error_deg` in yaw, with KF-GINS's usual small
    /// stated σ. Returns the YAML path and the truth at the end of the run.
    fn sim_yaml(name: &str, yaw_error_deg: f64) -> (std::path::PathBuf, (f64, f64)) {
        sim_yaml_imu(name, yaw_error_deg, ImuGrade::Industrial)
    }

    fn sim_yaml_imu(
        name: &str,
        yaw_error_deg: f64,
        imu: ImuGrade,
    ) -> (std::path::PathBuf, (f64, f64)) {
        let pr = platform_run(
            SimPlatform::Car,
            7,
            &PlatformOptions {
                duration_s: 180.0,
                static_start: true,
                imu,
                gnss: GnssGrade::Rtk,
                outages: Outages::None,
                ..Default::default()
            },
        )
        .unwrap();
        let dir = crate::test_dir(name);
        navfuse_sim::output::write_run(&pr.run, &dir).unwrap();
        let i = pr.init;
        let rpy = i.rpy.map(f64::to_degrees);
        let (_, tow0) = navfuse_io::time::week_tow(pr.run.imu[0].t);
        let yaml = format!(
            "imupath: imu.txt\ngnsspath: gnss.txt\noutputpath: out\nimudatalen: 7\nimudatarate: 100\n\
             starttime: {tow0:.6}\nendtime: -1\n\
             initpos: [{:.10}, {:.10}, {:.4}]\ninitvel: [{:.4}, {:.4}, {:.4}]\n\
             initatt: [{:.4}, {:.4}, {:.4}]\n\
             initgyrbias: [0, 0, 0]\ninitaccbias: [0, 0, 0]\ninitgyrscale: [0, 0, 0]\ninitaccscale: [0, 0, 0]\n\
             initposstd: [0.1, 0.1, 0.1]\ninitvelstd: [0.1, 0.1, 0.1]\ninitattstd: [1.0, 1.0, 2.0]\n\
             imunoise:\n  arw: [0.3, 0.3, 0.3]\n  vrw: [0.1, 0.1, 0.1]\n  gbstd: [20, 20, 20]\n  \
             abstd: [500, 500, 500]\n  gsstd: [1000, 1000, 1000]\n  asstd: [1000, 1000, 1000]\n  corrtime: 1.0\n\
             antlever: [0, 0, 0]\n",
            i.lat.to_degrees(),
            i.lon.to_degrees(),
            i.h,
            i.v_n.x,
            i.v_n.y,
            i.v_n.z,
            rpy.x,
            rpy.y,
            rpy.z + yaw_error_deg,
        );
        let path = dir.join("run.yaml");
        std::fs::write(&path, yaml).unwrap();
        let last = pr.run.traj.truth.last().unwrap();
        (path, (last.lat, last.lon))
    }

    fn end_error(run: &crate::kf_gins::KfGinsRun, truth: (f64, f64)) -> f64 {
        let s = run.solutions.last().unwrap();
        let (rm, rn) = navfuse_core::earth::radii(s.lat);
        ((s.lat - truth.0) * rm).hypot((s.lon - truth.1) * rn * s.lat.cos())
    }

    fn run(yaml: &Path, align: Option<AlignSource>) -> crate::kf_gins::KfGinsRun {
        run_kf_gins(
            yaml,
            &KfGinsOptions {
                platform: Some(Platform::Car),
                time_offset: Some("none".into()),
                output: Some(yaml.parent().unwrap().join(format!("out_{align:?}"))),
                align,
                ..Default::default()
            },
        )
        .unwrap()
    }

    /// Written before the result was seen: a YAML yaw 90° off (a guess) is
    /// caught and replaced, and the run ends within 1 m of the truth while
    /// the YAML's state (kept by `--align yaml`) ends worse.
    #[test]
    fn a_guessed_yaw_is_detected_and_replaced() {
        let (yaml, truth) = sim_yaml("kfalign-guess", 90.0);
        let auto = run(&yaml, None);
        assert!(auto.align.alignment.is_some(), "{}", auto.align.note);
        assert!(auto.align.chi2.unwrap() > chi2_quantile(3, TEST_PROBABILITY));
        let e_auto = end_error(&auto, truth);
        let kept = run(&yaml, Some(AlignSource::Yaml));
        let e_kept = end_error(&kept, truth);
        eprintln!("end error: auto {e_auto:.3} m, YAML kept {e_kept:.3} m");
        assert!(e_auto < 1.0, "auto end error {e_auto} m");
        assert!(e_auto < e_kept, "auto {e_auto} m vs kept {e_kept} m");
    }

    /// A correct YAML attitude passes the test and is used unchanged
    /// (identical solutions to `--align yaml`).
    #[test]
    fn a_correct_yaml_attitude_is_kept() {
        let (yaml, _) = sim_yaml("kfalign-true", 0.0);
        let auto = run(&yaml, None);
        assert!(auto.align.alignment.is_none(), "{}", auto.align.note);
        assert!(auto.align.chi2.unwrap() < chi2_quantile(3, TEST_PROBABILITY));
        let kept = run(&yaml, Some(AlignSource::Yaml));
        assert_eq!(auto.solutions.len(), kept.solutions.len());
        let same = auto
            .solutions
            .iter()
            .zip(&kept.solutions)
            .all(|(a, b)| a.lat == b.lat && a.lon == b.lon && a.h == b.h);
        assert!(same, "a kept YAML state must give identical solutions");
    }

    #[test]
    fn align_source_parses() {
        assert_eq!(AlignSource::parse("auto"), Ok(AlignSource::Auto));
        assert!(AlignSource::parse("guess")
            .unwrap_err()
            .contains("yaml, data or auto"));
    }

    /// A phone-grade IMU (0.5 °/s turn-on gyro bias) under a correct YAML
    /// attitude: the YAML attitude carried to the alignment's start with the
    /// YAML's zero bias drifted tens of degrees and the χ² test replaced it
    /// (seen on simulated phone drives: 79° of false disagreement, χ² 2960);
    /// carried with the static window's bias it agrees.
    #[test]
    fn a_correct_yaml_attitude_is_kept_with_a_phone_gyro() {
        let (yaml, _) = sim_yaml_imu("kfalign-phone", 0.0, ImuGrade::Consumer);
        let auto = run(&yaml, None);
        assert!(auto.align.alignment.is_none(), "{}", auto.align.note);
    }
}
