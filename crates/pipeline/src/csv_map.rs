//! `[input.csv]`: the column map or preset of the generic CSV IMU reader
//! (navfuse-io's `CsvImuReader`), as written in the run TOML.

use crate::error::{PipelineError, Result};
use navfuse_io::counter_clock::CounterClock;
use navfuse_io::csv_imu::{AccelUnit, Col, CsvImuConfig, CsvTime, GyroUnit};
use navfuse_io::imu::ImuForm;
use navfuse_io::timebase::TimeBase;
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

/// `[input.csv]`: the generic CSV IMU reader. Either `preset` (see
/// [`PRESETS`]) or the column map (one time source: `time`, `week` + `tow`,
/// or `counter`; `gyro`, `accel`); the other keys override the preset or
/// the defaults (comma, header line, deg/s, m/s², rate form, sensor axes =
/// body FRD). Every key is also what `summary.json`'s `resolved_input`
/// reports, so its `imu.csv` object can be pasted back here.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CsvCfg {
    pub preset: Option<String>,
    pub delimiter: Option<char>,
    pub comment: Option<char>,
    pub header: Option<bool>,
    /// Exact number of fields on a data line (without a header line).
    pub columns: Option<usize>,
    /// Seconds column, in the base `time_base` (or `[input] imu_time_base`).
    /// Undeclared: GPS seconds since 1980, or time of week with `gps_week`
    /// or below one week; an implausible first stamp is an error.
    pub time: Option<ColCfg>,
    /// The time base of `time` (`gps_week_tow`, `gps_seconds`,
    /// `gps_seconds_1970`, `unix_utc`; `counter_tag` goes with `counter`).
    pub time_base: Option<TimeBase>,
    pub week: Option<ColCfg>,
    pub tow: Option<ColCfg>,
    /// A device counter column, mapped to GPS time by a clock fitted on
    /// `[input] imu_tag` (RTKLIB `.tag` of the log).
    pub counter: Option<ColCfg>,
    /// Nominal seconds per counter count (default 0.001: a millisecond tick).
    pub counter_tick_s: Option<f64>,
    /// Counter width in bits, for the wrap-around (default 32).
    pub counter_bits: Option<u32>,
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

/// `[input.csv] preset` names: (name, deprecated alias). Named for the log
/// layout they read, not for one recording.
/// - `rtklib-imu-gpst`: an IMU serial log with GPS week and time of week
///   prepended (`gps_week,gps_tow_s,acc_x_g,…,gyro_z_dps`, the output of
///   rtklibexplorer's GNSS_IMU `convert_imu_file.py`, e.g.
///   `drive_0708/imu_1934_gpst.csv`).
/// - `rtklib-imu-counter`: the same serial log as recorded by RTKLIB
///   `str2str` (`ax,ay,az [g],gx,gy,gz [deg/s],counter [ms]`, no header),
///   timed by its `.tag` file (`[input] imu_tag`), e.g. `drive_0708/imu_1934.csv`.
/// - `vectornav-vn310`: an INSTINCT export of a VectorNav VN-310.
///
/// The two rtklib layouts carry the sensor axes of that project's car
/// (roll 180°, yaw 180° and a misalignment [0, −6.79, 5.35]°, from its
/// configuration): applied without `mount_rpy_deg` / `misalign_rpy_deg`
/// in `[input.csv]`, a warning says so.
pub const PRESETS: [(&str, Option<&str>); 3] = [
    ("rtklib-imu-gpst", Some("drive_0708")),
    ("rtklib-imu-counter", None),
    ("vectornav-vn310", Some("vn310")),
];

/// Nominal counter tick when `counter_tick_s` is not given: a millisecond
/// counter (the common MCU tick, e.g. Arduino `millis()`); the clock fit
/// catches a wrong tick ([`crate::imu_clock`]).
pub const DEFAULT_COUNTER_TICK_S: f64 = 1e-3;
/// Counter width when `counter_bits` is not given (a u32 tick count).
pub const DEFAULT_COUNTER_BITS: u32 = 32;

/// A counter column whose clock is still to be fitted.
#[derive(Clone, Debug, PartialEq)]
pub struct CounterSpec {
    pub col: Col,
    /// Nominal seconds per count.
    pub tick_s: f64,
    /// Counter modulus (2^bits).
    pub modulus: f64,
}

/// The reader configuration resolved from `[input.csv]`, before the file is read.
#[derive(Clone, Debug)]
pub struct CsvPlan {
    /// The reader's configuration; with a counter its time is
    /// [`CsvTime::Counter`] with a placeholder clock until fitted.
    pub cfg: CsvImuConfig,
    /// The preset used (its current name).
    pub preset: Option<&'static str>,
    /// The counter column to fit on the tag file.
    pub counter: Option<CounterSpec>,
    /// Deprecated preset names, a preset's mounting applied unasked.
    pub warnings: Vec<String>,
}

/// The reader configuration of `[input.csv]` (a counter's clock not yet
/// fitted, see [`csv_plan`]).
///
/// Errors ([`PipelineError::Input`]) name the `[input.csv]` key.
pub fn csv_config(c: &CsvCfg, rate_hz: f64) -> Result<CsvImuConfig> {
    csv_plan(c, rate_hz, None).map(|p| p.cfg)
}

/// Resolve `[input.csv]` with the `[input] imu_time_base` `imu_base`:
/// preset, column map, time base, units, mounting. Errors
/// ([`PipelineError::Input`]) name the key.
pub fn csv_plan(c: &CsvCfg, rate_hz: f64, imu_base: Option<TimeBase>) -> Result<CsvPlan> {
    csv_plan_inner(c, rate_hz, imu_base).map_err(PipelineError::Input)
}

/// The preset named `p` (a current name or a deprecated alias, which adds a warning).
fn preset(p: &str, warnings: &mut Vec<String>) -> Result<(&'static str, CsvImuConfig), String> {
    let Some(&(name, alias)) = PRESETS.iter().find(|(n, a)| *n == p || *a == Some(p)) else {
        let names: Vec<&str> = PRESETS.iter().map(|x| x.0).collect();
        return Err(format!(
            "[input.csv] preset {p:?}: expected one of {}",
            names.join(", ")
        ));
    };
    if alias == Some(p) {
        warnings.push(format!(
            "[input.csv] preset {p:?} is deprecated: it is now {name:?} (named for the log layout it reads)"
        ));
    }
    let cfg = match name {
        "rtklib-imu-gpst" => CsvImuConfig::drive_0708(),
        "rtklib-imu-counter" => CsvImuConfig {
            columns: Some(7),
            time: CsvTime::Counter {
                col: Col::Index(6),
                clock: PLACEHOLDER_CLOCK,
            },
            accel: [Col::Index(0), Col::Index(1), Col::Index(2)],
            gyro: [Col::Index(3), Col::Index(4), Col::Index(5)],
            ..CsvImuConfig::drive_0708()
        },
        _ => CsvImuConfig::vn310(),
    };
    Ok((name, cfg))
}

/// The clock of a counter before the fit (identity, nominal ms).
const PLACEHOLDER_CLOCK: CounterClock = CounterClock {
    c_ref: 0.0,
    t_ref: 0.0,
    s_per_count: DEFAULT_COUNTER_TICK_S,
    nominal_s_per_count: DEFAULT_COUNTER_TICK_S,
    modulus: None,
};

/// The time source of `[input.csv]`: the keys `time`/`week`+`tow`/`counter`
/// (None = the preset's) and the declared base.
fn time_source(c: &CsvCfg, base: Option<TimeBase>) -> Result<Option<CsvTime>, String> {
    let t = match (&c.time, &c.week, &c.tow, &c.counter) {
        (None, None, None, None) => return Ok(None),
        (Some(t), None, None, None) => match base {
            None => CsvTime::Seconds(t.col()),
            Some(TimeBase::CounterTag) => {
                return Err(
                    "[input.csv] time_base = \"counter_tag\": name the counter column \
                            with `counter = COL` (not `time`) and give [input] imu_tag"
                        .into(),
                )
            }
            Some(b) => CsvTime::Based {
                col: t.col(),
                base: b,
            },
        },
        (None, Some(w), Some(t), None) => CsvTime::WeekTow {
            week: w.col(),
            tow: t.col(),
        },
        (None, None, None, Some(k)) => CsvTime::Counter {
            col: k.col(),
            clock: PLACEHOLDER_CLOCK,
        },
        _ => {
            return Err(
                "[input.csv]: give one time source: `time`, or `week` and `tow`, or `counter`"
                    .into(),
            )
        }
    };
    Ok(Some(t))
}

/// The base a time source fixes by itself (week + TOW columns, a counter).
fn inherent_base(t: &CsvTime) -> Option<TimeBase> {
    match t {
        CsvTime::WeekTow { .. } => Some(TimeBase::GpsWeekTow),
        CsvTime::Counter { .. } => Some(TimeBase::CounterTag),
        CsvTime::Based { base, .. } => Some(*base),
        CsvTime::Seconds(_) => None,
    }
}

fn csv_plan_inner(c: &CsvCfg, rate_hz: f64, imu_base: Option<TimeBase>) -> Result<CsvPlan, String> {
    let base = match (c.time_base, imu_base) {
        (Some(a), Some(b)) if a != b => {
            return Err(format!(
                "[input] imu_time_base = {b:?} and [input.csv] time_base = {a:?} disagree",
                a = a.name(),
                b = b.name()
            ))
        }
        (a, b) => a.or(b),
    };
    let mut warnings = Vec::new();
    let time = time_source(c, base)?;
    let (name, mut cfg) = match c.preset.as_deref() {
        Some(p) => {
            let (name, cfg) = preset(p, &mut warnings)?;
            (Some(name), cfg)
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
            let time = time.clone().ok_or(
                "[input.csv]: give `time`, or `week` and `tow`, or `counter` (or a preset)",
            )?;
            let cols = |a: &[ColCfg; 3]| [a[0].col(), a[1].col(), a[2].col()];
            (None, CsvImuConfig::new(time, cols(gyro), cols(accel)))
        }
    };
    if let Some(t) = time {
        cfg.time = t;
    }
    if let (Some(b), Some(own)) = (base, inherent_base(&cfg.time)) {
        if b != own {
            return Err(format!(
                "[input.csv]: the time {} is {own} by its layout; time_base {b} contradicts it",
                match cfg.time {
                    CsvTime::Counter { .. } => "counter",
                    _ => "of week + week columns",
                },
            ));
        }
    }
    if let Some(g) = &c.gyro {
        cfg.gyro = [g[0].col(), g[1].col(), g[2].col()];
    }
    if let Some(a) = &c.accel {
        cfg.accel = [a[0].col(), a[1].col(), a[2].col()];
    }
    apply_overrides(c, &mut cfg)?;
    cfg.nominal_rate_hz = Some(rate_hz);
    if let Some(p) = name {
        let preset_cfg = preset(p, &mut Vec::new())?.1;
        if let Some(w) = unasked_mounting(p, &preset_cfg, c) {
            warnings.push(w);
        }
    }
    let counter = match &cfg.time {
        CsvTime::Counter { col, .. } => {
            let tick_s = c.counter_tick_s.unwrap_or(DEFAULT_COUNTER_TICK_S);
            if !(tick_s.is_finite() && tick_s > 0.0) {
                return Err(format!(
                    "[input.csv] counter_tick_s = {tick_s}: must be > 0"
                ));
            }
            let bits = c.counter_bits.unwrap_or(DEFAULT_COUNTER_BITS);
            if !(8..=64).contains(&bits) {
                return Err(format!("[input.csv] counter_bits = {bits}: expected 8…64"));
            }
            Some(CounterSpec {
                col: col.clone(),
                tick_s,
                modulus: 2f64.powi(bits as i32),
            })
        }
        _ => None,
    };
    Ok(CsvPlan {
        cfg,
        preset: name,
        counter,
        warnings,
    })
}

/// The warning for a preset's mounting / misalignment applied without the
/// user stating them in `[input.csv]`.
fn unasked_mounting(name: &str, p: &CsvImuConfig, c: &CsvCfg) -> Option<String> {
    let mut parts = Vec::new();
    if let (Some(m), None) = (p.mount_rpy_deg, c.mount_rpy_deg) {
        parts.push(format!("mount_rpy_deg = {m:?}"));
    }
    if let (Some(m), None) = (p.misalign_rpy_deg, c.misalign_rpy_deg) {
        parts.push(format!("misalign_rpy_deg = {m:?}"));
    }
    (!parts.is_empty()).then(|| {
        format!(
            "[input.csv] preset {name:?} applied the sensor mounting of the installation it was \
             made for ({}); for another installation state mount_rpy_deg and misalign_rpy_deg \
             in [input.csv] (stating them silences this warning)",
            parts.join(", ")
        )
    })
}

/// The keys that override a preset or the defaults, in place.
fn apply_overrides(c: &CsvCfg, cfg: &mut CsvImuConfig) -> Result<(), String> {
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
    if c.columns.is_some() {
        cfg.columns = c.columns;
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
    cfg.mag = c.mag.as_ref().map(|m| [m[0].col(), m[1].col(), m[2].col()]);
    cfg.yaw_deg = c.ahrs_yaw.as_ref().map(ColCfg::col);
    Ok(())
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

    /// Old preset names still work but say they are deprecated; a preset's
    /// mounting applied unasked is a warning, stated it is not.
    #[test]
    fn preset_aliases_and_unasked_mounting_warn() {
        let plan = |c: CsvCfg| csv_plan(&c, 100.0, None).unwrap();
        let old = plan(CsvCfg {
            preset: Some("drive_0708".into()),
            ..Default::default()
        });
        let new = plan(CsvCfg {
            preset: Some("rtklib-imu-gpst".into()),
            ..Default::default()
        });
        assert_eq!(old.cfg, new.cfg);
        assert_eq!(old.preset, Some("rtklib-imu-gpst"));
        assert_eq!(old.warnings.len(), 2, "{:?}", old.warnings);
        assert!(
            old.warnings[0].contains("deprecated") && old.warnings[0].contains("rtklib-imu-gpst")
        );
        assert_eq!(new.warnings.len(), 1, "{:?}", new.warnings);
        assert!(
            new.warnings[0].contains("misalign_rpy_deg = [0.0, -6.79, 5.35]")
                && new.warnings[0].contains("mount_rpy_deg = [180.0, 0.0, 180.0]"),
            "{}",
            new.warnings[0]
        );
        let stated = plan(CsvCfg {
            preset: Some("rtklib-imu-gpst".into()),
            mount_rpy_deg: Some([180.0, 0.0, 180.0]),
            misalign_rpy_deg: Some([0.0; 3]),
            ..Default::default()
        });
        assert!(stated.warnings.is_empty(), "{:?}", stated.warnings);
        assert_eq!(stated.cfg.misalign_rpy_deg, Some([0.0; 3]));
        let vn = plan(CsvCfg {
            preset: Some("vn310".into()),
            ..Default::default()
        });
        assert_eq!(
            vn.warnings.len(),
            1,
            "only the deprecation: {:?}",
            vn.warnings
        );
        // The counter layout fits its clock; a time base contradicting a layout is an error.
        let counter = plan(CsvCfg {
            preset: Some("rtklib-imu-counter".into()),
            ..Default::default()
        });
        assert_eq!(counter.counter.as_ref().unwrap().col, Col::Index(6));
        let e = csv_plan(
            &CsvCfg {
                preset: Some("rtklib-imu-gpst".into()),
                ..Default::default()
            },
            100.0,
            Some(TimeBase::UnixUtc),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("contradicts"), "{e}");
    }
}
