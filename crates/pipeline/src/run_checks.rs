//! Checks of a run's keys against its data, so that nothing is ignored or
//! guessed silently: time stamps plausible for their base, IMU and GNSS
//! spans that overlap, time-like keys (`[input] start`, `[outage] start`)
//! inside the data, and `[filter]` keys that contradict each other.
//!
//! Times are navfuse's: GPS seconds since 1980-01-06 when the IMU file
//! carries absolute time, the GPS time of week when it carries only that
//! (KF-GINS text); messages show spans as GPS week + TOW and calendar dates.

use crate::config::RunConfig;
use crate::error::Result;
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_io::csv_imu::{Col, CsvImuConfig, CsvImuReader, CsvTime};
use navfuse_io::time::{calendar_from_gps, week_tow, TimeSystem, SECONDS_PER_WEEK};
use navfuse_io::timebase::{check_stamp, now_gps_seconds, plausible_base, Plausibility, TimeBase};
use std::path::Path;

/// The base of the run's time axis: `gps_seconds` or `gps_week_tow` (TOW only).
pub fn run_base(t: f64) -> TimeBase {
    if t < SECONDS_PER_WEEK {
        TimeBase::GpsWeekTow
    } else {
        TimeBase::GpsSeconds
    }
}

/// What the run's time axis is, in words.
pub fn base_words(t: f64) -> &'static str {
    match run_base(t) {
        TimeBase::GpsWeekTow => "GPS time of week [s] (no week)",
        _ => "GPS seconds since 1980-01-06",
    }
}

/// `[t0, t1]` as GPS week + TOW with the calendar dates (GPST), or as a
/// time-of-week range when the week is unknown.
pub fn span_text(t0: f64, t1: f64) -> String {
    if t0 < SECONDS_PER_WEEK {
        return format!("TOW {t0:.3}–{t1:.3} s (week unknown)");
    }
    let d = |t: f64| {
        let c = calendar_from_gps(t, TimeSystem::Gpst, 0);
        format!(
            "{:04}-{:02}-{:02} {:02}:{:02}:{:02.0}",
            c.year, c.month, c.day, c.hour, c.minute, c.second
        )
    };
    let ((w0, s0), (w1, s1)) = (week_tow(t0), week_tow(t1));
    let tow = if w0 == w1 {
        format!("GPS week {w0} TOW {s0:.3}–{s1:.3}")
    } else {
        format!("GPS week {w0} TOW {s0:.3} – week {w1} TOW {s1:.3}")
    };
    format!("{tow} ({} – {} GPST)", d(t0), d(t1))
}

/// IMU and GNSS (on one time base) must overlap; an error names both spans.
/// A GNSS span covering less than half the IMU span gives a warning: the
/// rest is dead reckoning.
pub fn check_overlap(
    imu_file: &Path,
    imu: &[ImuSample],
    gnss_file: &Path,
    gnss: &[GnssFix],
) -> Result<Option<String>, String> {
    let (Some(i0), Some(i1)) = (imu.first(), imu.last()) else {
        return Err(format!("{}: no IMU samples", imu_file.display()));
    };
    let (Some(g0), Some(g1)) = (gnss.first(), gnss.last()) else {
        return Err(format!("{}: no GNSS fixes", gnss_file.display()));
    };
    let overlap = i1.t.min(g1.t) - i0.t.max(g0.t);
    let spans = || {
        format!(
            "IMU {} spans {}; GNSS {} spans {}",
            imu_file.display(),
            span_text(i0.t, i1.t),
            gnss_file.display(),
            span_text(g0.t, g1.t)
        )
    };
    if overlap < 0.0 {
        return Err(format!(
            "the IMU and GNSS data do not overlap in time: {} — check [input] imu_time_base / \
             gnss_time_base",
            spans()
        ));
    }
    let imu_len = i1.t - i0.t;
    Ok((overlap < 0.5 * imu_len).then(|| {
        format!(
            "GNSS covers only {overlap:.1} s of the {imu_len:.1} s of IMU data: {}",
            spans()
        )
    }))
}

/// The first stamp of a CSV `time` column whose base is not declared
/// ([`CsvTime::Seconds`]): below one week or with `gps_week` it is a time of
/// week, else GPS seconds since 1980 — unless that reading is no recording
/// date ([`check_stamp`]), which is an error naming file, line, field and
/// the dates of every reading. Returns the base taken.
pub fn check_undeclared_stamp(
    imu: &Path,
    cfg: &CsvImuConfig,
    first_t: f64,
) -> Result<TimeBase, String> {
    let CsvTime::Seconds(col) = &cfg.time else {
        return Err("not an undeclared time column".into());
    };
    let raw = first_t - cfg.week as f64 * SECONDS_PER_WEEK;
    let taken = if cfg.week != 0 || raw < SECONDS_PER_WEEK {
        TimeBase::GpsWeekTow
    } else {
        TimeBase::GpsSeconds
    };
    let now = now_gps_seconds();
    let week = (cfg.week != 0).then_some(cfg.week);
    let Plausibility::Error(_) = check_stamp(taken, raw, week, now) else {
        return Ok(taken);
    };
    // Read the first record again with the base stated, for the reader's
    // error naming the line and field.
    let located = first_stamp_error(imu, cfg, col, taken);
    let hint = match plausible_base(raw, now) {
        Some(TimeBase::UnixUtc) => {
            "gps_seconds_1970 (GPS time counted from 1970, e.g. RTKLIB) or unix_utc (POSIX UTC)"
                .to_string()
        }
        Some(b) => b.name().to_string(),
        None => "the base it was written in".to_string(),
    };
    Err(format!(
        "{located}; the time base is not declared: state it with [input] imu_time_base \
         (or [input.csv] time_base), here likely {hint}"
    ))
}

/// `FILE:LINE: field `F`: MSG` of the first stamp read in `base`.
fn first_stamp_error(imu: &Path, cfg: &CsvImuConfig, col: &Col, base: TimeBase) -> String {
    let based = CsvImuConfig {
        time: CsvTime::Based {
            col: col.clone(),
            base,
        },
        ..cfg.clone()
    };
    let Ok((rdr, name)) = navfuse_io::open(imu) else {
        return imu.display().to_string();
    };
    let mut r = CsvImuReader::new(rdr, &name, based);
    match r.next() {
        Some(Err(e)) => e.to_string(),
        _ => imu.display().to_string(),
    }
}

/// `[input] start` must lie inside the IMU data (`imu` on the run's time
/// base); the error says which base the start is read in.
pub fn check_start(cfg: &RunConfig, imu: &[ImuSample]) -> Result<()> {
    let (Some(start), Some(i0), Some(i1)) = (cfg.input.start, imu.first(), imu.last()) else {
        return Ok(());
    };
    if (i0.t..=i1.t).contains(&start) {
        return Ok(());
    }
    let mut msg = format!(
        "[input] start = {start} is outside the IMU data: {} carries {}, from {} to {} ({})",
        cfg.input.imu,
        base_words(i0.t),
        i0.t,
        i1.t,
        span_text(i0.t, i1.t)
    );
    if run_base(i0.t) == TimeBase::GpsSeconds && start < SECONDS_PER_WEEK {
        let (w, _) = week_tow(i0.t);
        msg += &format!(
            "; start is given as a time of week: in GPS seconds it is {} (week {w})",
            w as f64 * SECONDS_PER_WEEK + start
        );
    } else if run_base(i0.t) == TimeBase::GpsWeekTow && start >= SECONDS_PER_WEEK {
        msg += &format!(
            "; start is given in GPS seconds: as a time of week it is {}",
            week_tow(start).1
        );
    }
    Err(cfg.err(msg))
}

/// `[outage] start` (seconds after the first IMU sample used, `t_first`)
/// must fall inside the data: at or after 0 and before the end of both the
/// IMU and the GNSS data.
pub fn check_outage_start(
    cfg: &RunConfig,
    t_first: f64,
    t_imu_end: f64,
    gnss: &[GnssFix],
) -> Result<()> {
    let Some(o) = &cfg.outage else {
        return Ok(());
    };
    let t_gnss_end = gnss.last().map_or(f64::NEG_INFINITY, |g| g.t);
    let end = t_imu_end.min(t_gnss_end);
    if o.start >= 0.0 && t_first + o.start < end {
        return Ok(());
    }
    Err(cfg.err(format!(
        "[outage] start = {} s (seconds after the first IMU sample used, {}) is outside the \
         data: the IMU ends {:.3} s and the GNSS {:.3} s after that sample",
        o.start,
        span_text(t_first, t_first),
        t_imu_end - t_first,
        t_gnss_end - t_first
    )))
}

/// `[filter] preset = "seed001"` replaces the whole filter configuration,
/// IMU noise included: with `imu_noise`, `noise_yaml` or `imu_preset` the
/// noise given would be dropped — an error.
pub fn check_filter_keys(cfg: &RunConfig) -> Result<()> {
    let f = &cfg.filter;
    if f.preset != "seed001" {
        return Ok(());
    }
    let given: Vec<&str> = [
        ("imu_noise", f.imu_noise.is_some()),
        ("noise_yaml", f.noise_yaml.is_some()),
        ("imu_preset", f.imu_preset.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, g)| g.then_some(k))
    .collect();
    if given.is_empty() {
        return Ok(());
    }
    Err(cfg.err(format!(
        "[filter] preset = \"seed001\" replaces the whole filter model including the IMU \
         noise (the seed 001 values), so [filter] {} would be ignored: remove {}, or use \
         preset = \"kf-gins\" or \"enhanced\", which keep the noise given",
        given.join(", "),
        if given.len() == 1 { "it" } else { "them" }
    )))
}

/// Every check of the run keys against the data (`imu` all samples read,
/// `gnss` all fixes, on one time base): `[filter]`, `[input] start`,
/// `[outage] start` (checked when the span has the 200 samples
/// [`crate::eskf_run`] needs; fewer is its error).
pub fn check_run_keys(cfg: &RunConfig, imu: &[ImuSample], gnss: &[GnssFix]) -> Result<()> {
    check_filter_keys(cfg)?;
    check_start(cfg, imu)?;
    let start = cfg.input.start.unwrap_or(f64::NEG_INFINITY);
    let used = &imu[imu.partition_point(|s| s.t < start)..];
    // Too few samples after the start is the span selection's error.
    if let (true, Some(f), Some(l)) = (used.len() >= 200, used.first(), used.last()) {
        check_outage_start(cfg, f.t, l.t, gnss)?;
    }
    Ok(())
}

/// `[input] start` and `[outage] start` with their bases, for `resolved_input`.
pub fn time_keys_json(cfg: &RunConfig, imu: &[ImuSample]) -> serde_json::Value {
    let t0 = imu.first().map_or(0.0, |s| s.t);
    serde_json::json!({
        "start": cfg.input.start.map(|s| serde_json::json!({"value": s, "base": run_base(t0).name()})),
        "outage_start": cfg.outage.as_ref().map(|o| serde_json::json!({
            "value_s": o.start, "base": "seconds after the first IMU sample used"})),
    })
}
