//! `[input] odometer = "wheels.csv"` with its column map `[input.odometer_csv]`:
//! wheel speed / odometer samples ([`navfuse_io::odometer_csv`]) for the
//! ESKF's odometer model (`[filter.odometer]`, on by default when they are
//! given). The samples are the vehicle reference point's (wheel 0): one
//! column, or the wheels of one axle averaged (the axle centre, whose lever
//! arm is `[filter.odometer] lever_arm_m`).
//!
//! Time: the time column is on the IMU file's clock (a CAN / wheel-speed log
//! recorded by the same logger), in GPS seconds or, like a KF-GINS IMU file,
//! the time of week; it is moved to the IMU's base as the GNSS times are
//! (the week from the IMU file), and the IMU time offset applied to the IMU
//! (`imu_time_offset`, true time = stamp + τ) is applied to it too.

use crate::csv_map::ColCfg;
use crate::input::{InputReport, Loaded};
use navfuse_core::types::Event;
use navfuse_io::odometer_csv::{OdoCsvConfig, OdoCsvReader, OdoQuantity};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Seconds per GPS week.
const WEEK: f64 = 604_800.0;

/// `[input.odometer_csv]`: the column map of `[input] odometer`.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OdoCsvCfg {
    /// Time column [s] (default `"t"`), on the IMU file's clock.
    pub time: Option<ColCfg>,
    /// `"speed"` (default), `"distance"` (cumulative) or `"increment"`.
    pub quantity: Option<String>,
    /// One value column (vehicle speed / distance), or the 2–4 wheel columns
    /// of one axle (averaged). Default `["speed"]`.
    pub columns: Option<Vec<ColCfg>>,
    /// A direction column (non-zero: reversing; values are then magnitudes).
    /// Without it values are signed.
    pub reverse: Option<ColCfg>,
    /// Factor from a value to m/s or m (default 1; 1/3.6 for km/h; metres
    /// per tick for a tick count).
    pub unit: Option<f64>,
    pub header: Option<bool>,
    pub delimiter: Option<char>,
    pub comment: Option<char>,
}

/// The reader configuration of `c`.
pub fn reader_config(c: &OdoCsvCfg) -> Result<OdoCsvConfig, String> {
    let quantity = match c.quantity.as_deref().unwrap_or("speed") {
        "speed" => OdoQuantity::Speed,
        "distance" => OdoQuantity::Distance,
        "increment" => OdoQuantity::Increment,
        q => {
            return Err(format!(
                "[input.odometer_csv] quantity {q:?}: expected speed, distance or increment"
            ))
        }
    };
    let byte = |ch: Option<char>, d: Option<u8>, key: &str| -> Result<Option<u8>, String> {
        match ch {
            None => Ok(d),
            Some(x) if x.is_ascii() => Ok(Some(x as u8)),
            Some(x) => Err(format!(
                "[input.odometer_csv] {key} {x:?}: one ASCII character"
            )),
        }
    };
    let cfg = OdoCsvConfig {
        time: c
            .time
            .as_ref()
            .map_or(navfuse_io::csv_imu::Col::Name("t".into()), ColCfg::col),
        quantity,
        values: c.columns.as_ref().map_or_else(
            || vec![navfuse_io::csv_imu::Col::Name("speed".into())],
            |v| v.iter().map(ColCfg::col).collect(),
        ),
        reverse: c.reverse.as_ref().map(ColCfg::col),
        unit: c.unit.unwrap_or(1.0),
        header: c.header.unwrap_or(true),
        delimiter: byte(c.delimiter, Some(b','), "delimiter")?.unwrap_or(b','),
        comment: byte(c.comment, Some(b'#'), "comment")?,
    };
    cfg.check()
        .map_err(|m| format!("[input.odometer_csv] {m}"))?;
    Ok(cfg)
}

/// Read `path` with the map `c`, put the samples on `loaded`'s IMU time
/// base and merge them into `loaded.aiding` (time order). Returns the
/// file's report (`summary.json` `inputs.odometer`). Errors name
/// `file:line:field`.
pub fn load_odometer(
    path: &Path,
    c: &OdoCsvCfg,
    loaded: &mut Loaded,
) -> Result<InputReport, String> {
    let cfg = reader_config(c)?;
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let mut r = OdoCsvReader::new(rdr, &name, cfg);
    let mut v = r
        .by_ref()
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let report = InputReport::new(path, "odometer-csv", r.stats(), v.len());
    if v.is_empty() {
        let st = r.stats();
        let why: Vec<String> = st
            .rejected
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect();
        return Err(format!(
            "{}: no usable odometer rows ({} lines read{}{})",
            path.display(),
            st.lines,
            if why.is_empty() { "" } else { "; rejected: " },
            why.join(", ")
        ));
    }
    let (Some(i0), Some(o0)) = (loaded.imu.first(), v.first()) else {
        return Ok(report);
    };
    // The IMU stamps already carry the offset τ: compare without it.
    let tau = loaded.imu_time_offset.as_ref().map_or(0.0, |o| o.0);
    let imu_t0 = i0.t - tau;
    let shift = match (imu_t0 < WEEK, o0.t < WEEK) {
        (true, false) => None,
        (false, true) => Some(((imu_t0 - o0.t) / WEEK).round() * WEEK),
        _ => Some(0.0),
    };
    for o in v.iter_mut() {
        o.t = match shift {
            Some(s) => o.t + s,
            None => navfuse_io::time::week_tow(o.t).1,
        } + tau;
    }
    merge_aiding(
        loaded,
        path,
        "odometer samples",
        " (the time column must be on the IMU file's clock)",
        v.into_iter().map(Event::Odometer).collect(),
    )?;
    Ok(report)
}

/// Merge aiding `events` (time order, on the IMU time base, at least one)
/// into `loaded.aiding`, keeping it in time order; an error naming `path`
/// when they do not overlap the IMU span (`what` names them, `hint` ends
/// the message).
pub(crate) fn merge_aiding(
    loaded: &mut Loaded,
    path: &Path,
    what: &str,
    hint: &str,
    events: Vec<Event>,
) -> Result<(), String> {
    let (Some(e0), Some(e1), Some(i0), Some(i1)) = (
        events.first(),
        events.last(),
        loaded.imu.first(),
        loaded.imu.last(),
    ) else {
        return Ok(());
    };
    let (t0, t1, a, b) = (e0.t(), e1.t(), i0.t, i1.t);
    if t1 < a || t0 > b {
        return Err(format!(
            "{}: {what} span [{t0:.3}, {t1:.3}] s, the IMU [{a:.3}, {b:.3}] s: no \
             overlap{hint}",
            path.display()
        ));
    }
    loaded.aiding.extend(events);
    loaded.aiding.sort_by(|a, b| a.t().total_cmp(&b.t()));
    Ok(())
}
