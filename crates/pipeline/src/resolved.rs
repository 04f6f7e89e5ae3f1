//! `summary.json`'s `resolved_input`: the reader configuration a run
//! actually used (format, time base, columns, units, mounting, counter
//! clock), written with the `[input.csv]` keys so that a run can be
//! reproduced from its summary without the preset tables of this version.

use crate::csv_map::{ColCfg, CounterSpec};
use navfuse_io::csv_imu::{AccelUnit, Col, CsvImuConfig, CsvTime, GyroUnit};
use navfuse_io::imu::ImuForm;
use navfuse_io::timebase::TimeBase;
use serde_json::{json, Map, Value};

fn col(c: &Col) -> Value {
    serde_json::to_value(match c {
        Col::Index(i) => ColCfg::Index(*i),
        Col::Name(n) => ColCfg::Name(n.clone()),
    })
    .unwrap_or(Value::Null)
}

fn cols(c: &[Col; 3]) -> Value {
    Value::Array(c.iter().map(col).collect())
}

/// `cfg` as `[input.csv]` keys (no preset): parsing the object back as
/// [`crate::csv_map::CsvCfg`] gives the same reader configuration. `base`
/// is the base of a `time` column as resolved after reading (an undeclared
/// column is reported with the base its stamps were taken in); `counter`
/// the counter's tick and width.
pub fn csv_keys(
    cfg: &CsvImuConfig,
    base: Option<TimeBase>,
    counter: Option<&CounterSpec>,
) -> Value {
    let mut m = Map::new();
    let mut put = |k: &str, v: Value| {
        m.insert(k.to_string(), v);
    };
    put("delimiter", json!((cfg.delimiter as char).to_string()));
    if let Some(c) = cfg.comment {
        put("comment", json!((c as char).to_string()));
    }
    put("header", json!(cfg.header));
    if let Some(n) = cfg.columns {
        put("columns", json!(n));
    }
    match &cfg.time {
        CsvTime::Seconds(c) => {
            put("time", col(c));
            if let Some(b) = base {
                put("time_base", json!(b.name()));
            }
        }
        CsvTime::Based { col: c, base } => {
            put("time", col(c));
            put("time_base", json!(base.name()));
        }
        CsvTime::WeekTow { week, tow } => {
            put("week", col(week));
            put("tow", col(tow));
            put("time_base", json!(TimeBase::GpsWeekTow.name()));
        }
        CsvTime::Counter { col: c, .. } => {
            put("counter", col(c));
            put("time_base", json!(TimeBase::CounterTag.name()));
            if let Some(s) = counter {
                put("counter_tick_s", json!(s.tick_s));
                put("counter_bits", json!(s.modulus.log2().round() as u32));
            }
        }
    }
    if cfg.week != 0 {
        put("gps_week", json!(cfg.week));
    }
    put("gyro", cols(&cfg.gyro));
    put("accel", cols(&cfg.accel));
    let gyro_unit = match cfg.gyro_unit {
        GyroUnit::Deg => "deg",
        GyroUnit::Rad => "rad",
    };
    put("gyro_unit", json!(gyro_unit));
    let accel_unit = match cfg.accel_unit {
        AccelUnit::G => "g",
        AccelUnit::Si => "m/s2",
    };
    put("accel_unit", json!(accel_unit));
    let form = match cfg.form {
        ImuForm::RateTrapezoid => "rate",
        ImuForm::RateRectangle => "rate-rectangle",
        ImuForm::Increment => "increment",
    };
    put("form", json!(form));
    // Stated even when absent ([0, 0, 0]): a reproduction must not pick up a preset's.
    put(
        "mount_rpy_deg",
        json!(cfg.mount_rpy_deg.unwrap_or([0.0; 3])),
    );
    put(
        "misalign_rpy_deg",
        json!(cfg.misalign_rpy_deg.unwrap_or([0.0; 3])),
    );
    put("reject_repeated_values", json!(cfg.reject_repeated_values));
    if let Some(mg) = &cfg.mag {
        put("mag", cols(mg));
    }
    if let Some(y) = &cfg.yaw_deg {
        put("ahrs_yaw", col(y));
    }
    Value::Object(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csv_map::{csv_plan, CsvCfg};

    /// Every preset, resolved and written as keys, reads back as the same
    /// reader configuration without the preset (and without warnings).
    #[test]
    fn resolved_keys_reproduce_every_preset() {
        for (name, _) in crate::csv_map::PRESETS {
            let c = CsvCfg {
                preset: Some(name.into()),
                ..Default::default()
            };
            let p = csv_plan(&c, 100.0, None).unwrap();
            let keys = csv_keys(&p.cfg, None, p.counter.as_ref());
            let back: CsvCfg = serde_json::from_value(keys.clone()).unwrap();
            let q = csv_plan(&back, 100.0, None).unwrap();
            let mut want = p.cfg.clone();
            // [0, 0, 0] stated = identity rotation: the same reader output.
            want.mount_rpy_deg = want.mount_rpy_deg.or(Some([0.0; 3]));
            want.misalign_rpy_deg = want.misalign_rpy_deg.or(Some([0.0; 3]));
            assert_eq!(q.cfg, want, "{name}: {keys}");
            assert_eq!(q.counter, p.counter, "{name}");
            assert!(q.warnings.is_empty(), "{name}: {:?}", q.warnings);
        }
    }
}
