//! `[input] ubx = "log.ubx"`: one u-blox UBX log as the source of IMU
//! (ESF-RAW/ESF-MEAS), GNSS (NAV-PVT), wheel ticks / speed (ESF) and
//! dual-antenna heading (NAV-RELPOSNED), converted by
//! [`navfuse_io::ubx_events`] (issue 17). It replaces `[input] imu` and
//! `gnss`. Keys: `ubx_metres_per_tick` (distance per wheel tick [m]; without
//! it tick words are rejected and counted) and `ubx_esf_tick_s` (the ESF
//! sensor time tag unit [s], default 1 ms).
//!
//! Reports: the `imu` report counts the log's items (every NAV-PVT, ESF data
//! word, NAV-RELPOSNED: used or rejected by reason; records = IMU samples),
//! the `gnss` report counts its frames (records = fixes). IMU and GNSS are
//! stamped by the same receiver clock, so no IMU time offset is estimated
//! unless `imu_time_offset` asks for one. Odometer and heading events are
//! kept in [`UbxLog::aiding`] for the estimators that model them.

use crate::input::InputReport;
use navfuse_core::types::{Event, GnssFix, ImuSample};
use navfuse_io::ubx::UbxReader;
use navfuse_io::ubx_events::{UbxEvents, UbxEventsConfig};
use std::path::Path;

/// What a UBX log held, by stream.
pub struct UbxLog {
    pub imu: Vec<ImuSample>,
    pub gnss: Vec<GnssFix>,
    /// Odometer and heading events, in time order.
    pub aiding: Vec<Event>,
    pub imu_report: InputReport,
    pub gnss_report: InputReport,
}

/// The converter settings of `[input]` (`imu_rate` gives the first IMU
/// sample's interval, as for the other IMU readers).
pub fn events_config(
    metres_per_tick: Option<f64>,
    esf_tick_s: Option<f64>,
    imu_rate: f64,
) -> Result<UbxEventsConfig, String> {
    let mut c = UbxEventsConfig {
        metres_per_tick,
        imu_rate_hz: Some(imu_rate),
        ..Default::default()
    };
    if let Some(m) = metres_per_tick {
        if !(m.is_finite() && m > 0.0) {
            return Err(format!("[input] ubx_metres_per_tick {m}: must be > 0"));
        }
    }
    if let Some(s) = esf_tick_s {
        if !(s.is_finite() && s > 0.0) {
            return Err(format!("[input] ubx_esf_tick_s {s}: must be > 0"));
        }
        c.esf_tick_s = s;
    }
    Ok(c)
}

/// Read a UBX log (see the module doc). Errors name the file and frame.
pub fn read_ubx_log(path: &Path, cfg: UbxEventsConfig) -> Result<UbxLog, String> {
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let mut r = UbxReader::new(rdr, &name);
    let mut conv = UbxEvents::new(cfg);
    let (mut imu, mut gnss, mut aiding) = (Vec::new(), Vec::new(), Vec::new());
    let mut put = |e: Event| match e {
        Event::Imu(s) => imu.push(s),
        Event::Gnss(f) => gnss.push(f),
        other => aiding.push(other),
    };
    for m in r.by_ref() {
        conv.push(&m.map_err(|e| e.to_string())?, &mut put);
    }
    conv.finish(&mut put);
    gnss.sort_by(|a, b| a.t.total_cmp(&b.t));
    aiding.sort_by(|a, b| a.t().total_cmp(&b.t()));
    if imu.is_empty() {
        let why = conv
            .stats()
            .rejected
            .iter()
            .map(|(r, n)| format!("{n} × {r}"))
            .collect::<Vec<_>>()
            .join(", ");
        return Err(format!(
            "{name}: no IMU samples in the UBX log ({} frames; rejected: {})",
            r.stats().lines,
            if why.is_empty() { "none".into() } else { why }
        ));
    }
    let imu_report = InputReport::new(path, "ubx", conv.stats(), imu.len());
    let gnss_report = InputReport::new(path, "ubx", r.stats(), gnss.len());
    Ok(UbxLog {
        imu,
        gnss,
        aiding,
        imu_report,
        gnss_report,
    })
}

/// Odometer and heading event counts (`summary.json` inputs), null when none.
pub fn aiding_counts(ev: &[Event]) -> serde_json::Value {
    if ev.is_empty() {
        return serde_json::Value::Null;
    }
    let n = |f: fn(&Event) -> bool| ev.iter().filter(|e| f(e)).count();
    serde_json::json!({
        "odometer": n(|e| matches!(e, Event::Odometer(_))),
        "heading": n(|e| matches!(e, Event::Heading(_))),
    })
}
