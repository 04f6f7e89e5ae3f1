//! `[input.csv]`: the column map or preset of the generic CSV IMU reader
//! (navfuse-io's `CsvImuReader`), as written in the run TOML.

use crate::error::{PipelineError, Result};
use navfuse_io::csv_imu::{AccelUnit, Col, CsvImuConfig, CsvTime, GyroUnit};
use navfuse_io::imu::ImuForm;
use serde::{Deserialize, Serialize};

/// A column of `[input.csv]`: header name or 0-based index.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum ColCfg {
    /// 0-based column index.
    Index(usize),
    /// Header name.
    Name(String),
}

impl ColCfg {
    /// The reader's column.
    pub fn col(&self) -> Col {
        match self {
            ColCfg::Index(i) => Col::Index(*i),
            ColCfg::Name(s) => Col::Name(s.clone()),
        }
    }
}

/// `[input.csv]`: the generic CSV IMU reader. Either `preset`
/// (`drive_0708`, `vn310`) or the column map (`time`, or `week` + `tow`;
/// `gyro`, `accel`); the other keys override the preset or the defaults
/// (comma, header line, deg/s, m/s², rate form, sensor axes = body FRD).
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CsvCfg {
    pub preset: Option<String>,
    pub delimiter: Option<char>,
    pub comment: Option<char>,
    pub header: Option<bool>,
    /// Seconds column (GPS seconds, or time of week with `gps_week`).
    pub time: Option<ColCfg>,
    pub week: Option<ColCfg>,
    pub tow: Option<ColCfg>,
    pub gps_week: Option<u32>,
    pub gyro: Option<[ColCfg; 3]>,
    pub accel: Option<[ColCfg; 3]>,
    /// "deg" or "rad" (per second in rate form).
    pub gyro_unit: Option<String>,
    /// "g" or "m/s2".
    pub accel_unit: Option<String>,
    /// "rate" (trapezoid), "rate-rectangle" or "increment".
    pub form: Option<String>,
    /// Sensor axes w.r.t. body FRD: roll, pitch, yaw [deg].
    pub mount_rpy_deg: Option<[f64; 3]>,
    pub misalign_rpy_deg: Option<[f64; 3]>,
    pub reject_repeated_values: Option<bool>,
    /// Magnetometer x, y, z columns (sensor axes, any unit; calibrated for
    /// hard/soft iron): the initial heading from their static-window mean.
    pub mag: Option<[ColCfg; 3]>,
    /// A column of an AHRS's own yaw [deg]: the initial heading from its
    /// static-window circular mean.
    pub ahrs_yaw: Option<ColCfg>,
}

/// The reader configuration of `[input.csv]`.
///
/// Errors ([`PipelineError::Input`]) name the `[input.csv]` key.
pub fn csv_config(c: &CsvCfg, rate_hz: f64) -> Result<CsvImuConfig> {
    csv_config_inner(c, rate_hz).map_err(PipelineError::Input)
}

fn csv_config_inner(c: &CsvCfg, rate_hz: f64) -> Result<CsvImuConfig, String> {
    let mut cfg = match c.preset.as_deref() {
        Some("drive_0708") => CsvImuConfig::drive_0708(),
        Some("vn310") => CsvImuConfig::vn310(),
        Some(p) => {
            return Err(format!(
                "[input.csv] preset {p:?}: expected drive_0708 or vn310"
            ))
        }
        None => {
            let gyro = c
                .gyro
                .as_ref()
                .ok_or("[input.csv]: `gyro` columns missing (or give a preset)")?;
            let accel = c
                .accel
                .as_ref()
                .ok_or("[input.csv]: `accel` columns missing (or give a preset)")?;
            let time = match (&c.time, &c.week, &c.tow) {
                (Some(t), None, None) => CsvTime::Seconds(t.col()),
                (None, Some(w), Some(t)) => CsvTime::WeekTow {
                    week: w.col(),
                    tow: t.col(),
                },
                _ => return Err("[input.csv]: give `time`, or `week` and `tow`".into()),
            };
            CsvImuConfig::new(
                time,
                [gyro[0].col(), gyro[1].col(), gyro[2].col()],
                [accel[0].col(), accel[1].col(), accel[2].col()],
            )
        }
    };
    let byte = |ch: char, key: &str| {
        u8::try_from(ch)
            .ok()
            .filter(u8::is_ascii)
            .ok_or_else(|| format!("[input.csv] {key}: {ch:?} is not one ASCII character"))
    };
    if let Some(d) = c.delimiter {
        cfg.delimiter = byte(d, "delimiter")?;
    }
    if let Some(d) = c.comment {
        cfg.comment = Some(byte(d, "comment")?);
    }
    if let Some(h) = c.header {
        cfg.header = h;
    }
    if let Some(w) = c.gps_week {
        cfg.week = w;
    }
    if let Some(u) = c.gyro_unit.as_deref() {
        cfg.gyro_unit = match u {
            "deg" => GyroUnit::Deg,
            "rad" => GyroUnit::Rad,
            _ => return Err(format!("[input.csv] gyro_unit {u:?}: expected deg or rad")),
        };
    }
    if let Some(u) = c.accel_unit.as_deref() {
        cfg.accel_unit = match u {
            "g" => AccelUnit::G,
            "m/s2" => AccelUnit::Si,
            _ => return Err(format!("[input.csv] accel_unit {u:?}: expected g or m/s2")),
        };
    }
    if let Some(f) = c.form.as_deref() {
        cfg.form = match f {
            "rate" => ImuForm::RateTrapezoid,
            "rate-rectangle" => ImuForm::RateRectangle,
            "increment" => ImuForm::Increment,
            _ => {
                return Err(format!(
                    "[input.csv] form {f:?}: expected rate, rate-rectangle or increment"
                ))
            }
        };
    }
    if c.mount_rpy_deg.is_some() {
        cfg.mount_rpy_deg = c.mount_rpy_deg;
    }
    if c.misalign_rpy_deg.is_some() {
        cfg.misalign_rpy_deg = c.misalign_rpy_deg;
    }
    if let Some(r) = c.reject_repeated_values {
        cfg.reject_repeated_values = r;
    }
    cfg.nominal_rate_hz = Some(rate_hz);
    cfg.mag = c.mag.as_ref().map(|m| [m[0].col(), m[1].col(), m[2].col()]);
    cfg.yaw_deg = c.ahrs_yaw.as_ref().map(ColCfg::col);
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_config_needs_columns_or_a_preset() {
        let e = csv_config(&CsvCfg::default(), 100.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("gyro"), "{e}");
        let c = CsvCfg {
            preset: Some("vn310".into()),
            ..Default::default()
        };
        assert_eq!(csv_config(&c, 50.0).unwrap().nominal_rate_hz, Some(50.0));
        let c = CsvCfg {
            time: Some(ColCfg::Name("t".into())),
            gyro: Some([0, 1, 2].map(ColCfg::Index)),
            accel: Some([3, 4, 5].map(ColCfg::Index)),
            gyro_unit: Some("rpm".into()),
            ..Default::default()
        };
        assert!(csv_config(&c, 100.0)
            .unwrap_err()
            .to_string()
            .contains("rpm"));
    }
}
