//! The inputs named by a KF-GINS YAML configuration: KF-GINS IMU and GNSS
//! text (via navfuse-io) and navfuse's optional GNSS velocity file.

use crate::error::{PipelineError, Result};
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;
use navfuse_io::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::Path;

/// Time-ordered inputs of one run.
pub struct RunInput {
    /// IMU increments, body FRD, time-ordered.
    pub imu: Vec<ImuSample>,
    /// GNSS fixes (antenna), time-ordered.
    pub gnss: Vec<GnssFix>,
}

fn read(path: &Path) -> Result<String> {
    navfuse_io::text::read_text_capped(path, u64::MAX).map_err(input_err)
}

fn fields<const N: usize>(
    line: &str,
    name: &Path,
    ln: usize,
    names: &[&str; N],
) -> Result<[f64; N]> {
    let mut out = [0.0; N];
    let mut it = line.split_ascii_whitespace();
    for (i, o) in out.iter_mut().enumerate() {
        let s = it.next().ok_or_else(|| {
            PipelineError::Input(format!(
                "{}:{}: field `{}`: missing",
                name.display(),
                ln,
                names[i]
            ))
        })?;
        *o = s
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                PipelineError::Input(format!(
                    "{}:{}: field `{}`: not a finite number: {s:?}",
                    name.display(),
                    ln,
                    names[i]
                ))
            })?;
    }
    Ok(out)
}

/// KF-GINS IMU text via navfuse-io (`dt` from consecutive stamps, the first
/// from the nominal rate; duplicates/bad lines rejected and counted there).
pub fn read_kfgins_imu(path: &Path, rate: f64, columns: usize) -> Result<Vec<ImuSample>> {
    let (rdr, name) = navfuse_io::open(path).map_err(input_err)?;
    let opt = KfGinsImuOptions {
        week: 0,
        columns,
        nominal_rate_hz: Some(rate),
    };
    KfGinsImuReader::new(rdr, &name, opt)
        .collect::<Result<Vec<_>, _>>()
        .map_err(input_err)
}

/// KF-GINS GNSS text (`tow lat lon h σN σE σD`, optionally + velocity) via navfuse-io.
pub fn read_kfgins_gnss(path: &Path) -> Result<Vec<GnssFix>> {
    let (rdr, name) = navfuse_io::open(path).map_err(input_err)?;
    KfGinsGnssReader::new(rdr, &name, 0)
        .collect::<Result<Vec<_>, _>>()
        .map_err(input_err)
}

/// navfuse's GNSS velocity file: `tow vN vE vD σvN σvE σvD` ([m/s]); merged into
/// the fixes of the same epoch (±1 ms).
pub fn merge_gnss_velocity(path: &Path, fixes: &mut [GnssFix]) -> Result<usize> {
    let text = read(path)?;
    const N: [&str; 7] = ["tow", "v_n", "v_e", "v_d", "std_vn", "std_ve", "std_vd"];
    let mut merged = 0;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f = fields(line, path, i + 1, &N)?;
        let k = fixes.partition_point(|g| g.t < f[0] - 1e-3);
        if k < fixes.len() && (fixes[k].t - f[0]).abs() <= 1e-3 {
            fixes[k].v_n = Some(Vec3::new(f[1], f[2], f[3]));
            fixes[k].std_v_n = Some(Vec3::new(f[4], f[5], f[6]));
            merged += 1;
        }
    }
    Ok(merged)
}

/// All inputs named by a KF-GINS configuration.
pub fn read_kfgins(cfg: &KfGinsConfig) -> Result<RunInput> {
    let imu = read_kfgins_imu(&cfg.resolve(&cfg.imupath), cfg.imudatarate, cfg.imudatalen)?;
    let mut gnss = read_kfgins_gnss(&cfg.resolve(&cfg.gnsspath))?;
    if let Some(v) = &cfg.gnssvelpath {
        merge_gnss_velocity(&cfg.resolve(v), &mut gnss)?;
    }
    Ok(RunInput { imu, gnss })
}

/// A reader error as [`PipelineError::Input`] (its `file:line: field` text kept).
pub(crate) fn input_err(e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Input(e.to_string())
}
