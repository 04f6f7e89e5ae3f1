//! The time bases IMU logs are stamped in, their conversion to navfuse GPS
//! seconds (since 1980-01-06, GPST, `t = week·604800 + tow`), and a check
//! that a file's first stamp is plausible for the declared base.
//!
//! - `gps_week_tow`: time of week [s] with the week given separately.
//! - `gps_seconds`: GPS seconds since 1980-01-06 (the internal time).
//! - `gps_seconds_1970`: GPS time counted from 1970-01-01 without leap
//!   seconds (RTKLIB `gtime_t`): `t = raw − 315964800`.
//! - `unix_utc`: POSIX seconds (UTC, leap seconds not counted): GPST is
//!   reached by adding GPS−UTC from the leap-second table in
//!   [`crate::time::gps_minus_utc`] (18 s since 2017-01-01).
//! - `counter_tag`: a device counter mapped by a
//!   [`crate::counter_clock::CounterClock`]; no conversion by value.
//!
//! `gps_seconds_1970` and `unix_utc` differ only by the leap seconds (18 s
//! in 2025), so values cannot tell them apart; the check names both.

use crate::tag::GPS_EPOCH_FROM_1970_S;
use crate::time::{calendar_from_gps, gps_minus_utc, TimeSystem, SECONDS_PER_WEEK};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Time base of a time column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimeBase {
    #[serde(rename = "gps_week_tow")]
    GpsWeekTow,
    /// Since 1980-01-06.
    #[serde(rename = "gps_seconds")]
    GpsSeconds,
    /// GPS time counted from 1970-01-01 like RTKLIB `gtime_t`, no leap seconds.
    #[serde(rename = "gps_seconds_1970")]
    GpsSeconds1970,
    /// POSIX UTC seconds; leap seconds added to reach GPST.
    #[serde(rename = "unix_utc")]
    UnixUtc,
    #[serde(rename = "counter_tag")]
    CounterTag,
}

const NAMES: [(TimeBase, &str); 5] = [
    (TimeBase::GpsWeekTow, "gps_week_tow"),
    (TimeBase::GpsSeconds, "gps_seconds"),
    (TimeBase::GpsSeconds1970, "gps_seconds_1970"),
    (TimeBase::UnixUtc, "unix_utc"),
    (TimeBase::CounterTag, "counter_tag"),
];

impl TimeBase {
    /// The configuration name (`gps_week_tow`, …).
    pub fn name(self) -> &'static str {
        NAMES.iter().find(|n| n.0 == self).map_or("", |n| n.1)
    }

    /// GPS seconds since 1980-01-06 of a stamp `raw` in this base.
    /// `week_hint` is the GPS week for `gps_week_tow` (required there,
    /// ignored elsewhere). `counter_tag` needs a clock, not a value: error.
    pub fn to_gps_seconds(self, raw: f64, week_hint: Option<u32>) -> Result<f64, String> {
        if !raw.is_finite() {
            return Err(format!("time stamp {raw} is not finite"));
        }
        match self {
            TimeBase::GpsWeekTow => match week_hint {
                Some(w) => Ok(crate::time::gps_seconds(w, raw)),
                None => Err("gps_week_tow needs the GPS week".to_string()),
            },
            TimeBase::GpsSeconds => Ok(raw),
            TimeBase::GpsSeconds1970 => Ok(raw - GPS_EPOCH_FROM_1970_S),
            TimeBase::UnixUtc => Ok(gps_from_unix_utc(raw)),
            TimeBase::CounterTag => {
                Err("counter_tag stamps need a counter clock (a tag file), not a value".to_string())
            }
        }
    }
}

/// GPS seconds of POSIX UTC seconds `u` (leap seconds of the table added;
/// the same two-step lookup as `gps_from_calendar` so the step lands on
/// the leap second itself).
pub fn gps_from_unix_utc(u: f64) -> f64 {
    let t_cal = u - GPS_EPOCH_FROM_1970_S;
    let l = gps_minus_utc(t_cal);
    t_cal + gps_minus_utc(t_cal + l)
}

impl fmt::Display for TimeBase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for TimeBase {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        NAMES.iter().find(|n| n.1 == s).map(|n| n.0).ok_or_else(|| {
            let all: Vec<&str> = NAMES.iter().map(|n| n.1).collect();
            format!("unknown time base {s:?} (one of {})", all.join(", "))
        })
    }
}

/// The verdict on a first stamp.
#[derive(Clone, Debug, PartialEq)]
pub enum Plausibility {
    Ok,
    /// Readable, but the user should know (e.g. week 0 for a time of week).
    Warning(String),
    /// Almost surely the wrong base; the text names the likely one.
    Error(String),
}

/// GPS time now, from the system clock (the upper bound of a recording's date).
pub fn now_gps_seconds() -> f64 {
    let u = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    gps_from_unix_utc(u)
}

/// `YYYY-MM-DD HH:MM:SS GPST` of GPS seconds `t`.
fn date(t: f64) -> String {
    let c = calendar_from_gps(t, TimeSystem::Gpst, 0);
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02}:{:02.0} GPST",
        c.year, c.month, c.day, c.hour, c.minute, c.second
    )
}

/// Slack [s] above "now" for a recording's date: one day covers a clock set
/// in another time zone or a PC clock a few hours off.
const FUTURE_SLACK_S: f64 = 86_400.0;

/// Whether `t` (GPS s) can be the date of a recording made by `now_gps`:
/// not before the GPS epoch, not in the future.
fn is_recording_date(t: f64, now_gps: f64) -> bool {
    (0.0..=now_gps + FUTURE_SLACK_S).contains(&t)
}

/// The absolute base under which `first_stamp` is a plausible recording
/// date (between 1980-01-06 and `now_gps` + 1 day), when exactly one
/// reading fits: `gps_seconds`, or a 1970-based base (returned as
/// `unix_utc`: `gps_seconds_1970` differs by the leap seconds only). A
/// value below one week is a time of week (`gps_week_tow`). None when
/// both readings fit (values between 3.2e8 and ≈1.45e9 are dates in both)
/// or neither does.
pub fn plausible_base(first_stamp: f64, now_gps: f64) -> Option<TimeBase> {
    if !first_stamp.is_finite() || first_stamp < 0.0 {
        return None;
    }
    if first_stamp < SECONDS_PER_WEEK {
        return Some(TimeBase::GpsWeekTow);
    }
    let as_1980 = is_recording_date(first_stamp, now_gps);
    let as_1970 = is_recording_date(first_stamp - GPS_EPOCH_FROM_1970_S, now_gps);
    match (as_1980, as_1970) {
        (true, false) => Some(TimeBase::GpsSeconds),
        (false, true) => Some(TimeBase::UnixUtc),
        _ => None,
    }
}

/// Check the first stamp `raw` of a file against its declared `base`
/// (`week_hint` as in [`TimeBase::to_gps_seconds`], `now_gps` from
/// [`now_gps_seconds`]). Errors say what the value would be in the other
/// bases, as dates.
pub fn check_stamp(base: TimeBase, raw: f64, week_hint: Option<u32>, now_gps: f64) -> Plausibility {
    if !raw.is_finite() || raw < 0.0 {
        return Plausibility::Error(format!("time stamp {raw} is negative or not finite"));
    }
    let readings = || {
        let mut v = Vec::new();
        if raw < SECONDS_PER_WEEK {
            v.push(format!(
                "a time of week ({})",
                base_hint(TimeBase::GpsWeekTow)
            ));
        }
        if is_recording_date(raw, now_gps) {
            v.push(format!("{} as gps_seconds", date(raw)));
        }
        let t70 = raw - GPS_EPOCH_FROM_1970_S;
        if is_recording_date(t70, now_gps) {
            v.push(format!(
                "{} as gps_seconds_1970, {} as unix_utc",
                date(t70),
                date(gps_from_unix_utc(raw))
            ));
        }
        if v.is_empty() {
            "no plausible reading".to_string()
        } else {
            v.join("; ")
        }
    };
    match base {
        TimeBase::GpsWeekTow => {
            if raw >= SECONDS_PER_WEEK + 1.0 {
                return Plausibility::Error(format!(
                    "{raw} is not a time of week (≥ 604800 s); it reads as {}",
                    readings()
                ));
            }
            match week_hint {
                None | Some(0) => Plausibility::Warning(format!(
                    "time of week {raw} s without a GPS week: times are relative to week 0"
                )),
                Some(w) => {
                    let t = crate::time::gps_seconds(w, raw);
                    if is_recording_date(t, now_gps) {
                        Plausibility::Ok
                    } else {
                        Plausibility::Error(format!(
                            "week {w} puts the data at {}, in the future",
                            date(t)
                        ))
                    }
                }
            }
        }
        TimeBase::GpsSeconds | TimeBase::GpsSeconds1970 | TimeBase::UnixUtc => {
            let t = base.to_gps_seconds(raw, week_hint).unwrap_or(f64::NAN);
            if is_recording_date(t, now_gps) && raw >= SECONDS_PER_WEEK {
                return Plausibility::Ok;
            }
            let why = if raw < SECONDS_PER_WEEK {
                "is less than one week, not an absolute time".to_string()
            } else if t < 0.0 {
                format!("would be before the GPS epoch 1980-01-06 ({:.0} s)", t)
            } else {
                format!("would be {}, in the future", date(t))
            };
            Plausibility::Error(format!(
                "{raw} declared as {base} {why}; it reads as {}",
                readings()
            ))
        }
        TimeBase::CounterTag => Plausibility::Ok,
    }
}

fn base_hint(b: TimeBase) -> &'static str {
    match b {
        TimeBase::GpsWeekTow => "declare gps_week_tow with the week",
        _ => b.name(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::{gps_from_calendar, gps_seconds, Calendar};

    /// 2026-01-01 as "now": fixed so the tests do not depend on the clock.
    fn now() -> f64 {
        let c = Calendar {
            year: 2026,
            month: 1,
            day: 1,
            hour: 0,
            minute: 0,
            second: 0.0,
        };
        gps_from_calendar(&c, TimeSystem::Gpst).unwrap()
    }

    #[test]
    fn names_round_trip_through_fromstr_display_and_serde() {
        for (b, n) in NAMES {
            assert_eq!(n.parse::<TimeBase>().unwrap(), b);
            assert_eq!(b.to_string(), n);
            assert_eq!(serde_json::to_string(&b).unwrap(), format!("\"{n}\""));
            assert_eq!(
                serde_json::from_str::<TimeBase>(&format!("\"{n}\"")).unwrap(),
                b
            );
        }
        let e = "gps_seconds1970".parse::<TimeBase>().unwrap_err();
        assert!(e.contains("gps_seconds_1970"), "{e}");
    }

    #[test]
    fn conversions_of_a_known_date_with_leap_seconds() {
        // 2025-07-08 19:34:18.5 GPST = week 2374 TOW 243258.5 = 19:34:00.5 UTC (GPS−UTC = 18 s).
        let t = gps_seconds(2374, 243_258.5);
        // POSIX time of 2025-07-08 19:34:00.5 UTC: days 1970→2025-07-08 = 20277.
        let unix = 20_277.0 * 86_400.0 + 19.0 * 3600.0 + 34.0 * 60.0 + 0.5;
        assert_eq!(TimeBase::UnixUtc.to_gps_seconds(unix, None).unwrap(), t);
        assert_eq!(
            TimeBase::GpsSeconds1970
                .to_gps_seconds(unix + 18.0, None)
                .unwrap(),
            t
        );
        assert_eq!(TimeBase::GpsSeconds.to_gps_seconds(t, None).unwrap(), t);
        assert_eq!(
            TimeBase::GpsWeekTow
                .to_gps_seconds(243_258.5, Some(2374))
                .unwrap(),
            t
        );
        assert!(TimeBase::GpsWeekTow.to_gps_seconds(1.0, None).is_err());
        assert!(TimeBase::CounterTag.to_gps_seconds(1.0, None).is_err());
        assert!(TimeBase::GpsSeconds.to_gps_seconds(f64::NAN, None).is_err());
        // Before the 2017-01-01 leap second GPS−UTC was 17 s: 2016-12-31 12:00 UTC.
        let u16 = 17_166.0 * 86_400.0 + 43_200.0;
        let c = Calendar {
            year: 2016,
            month: 12,
            day: 31,
            hour: 12,
            minute: 0,
            second: 17.0,
        };
        assert_eq!(
            gps_from_unix_utc(u16),
            gps_from_calendar(&c, TimeSystem::Gpst).unwrap()
        );
    }

    #[test]
    fn a_1970_based_stamp_declared_as_gps_seconds_is_named_with_both_dates() {
        let raw = 1_752_003_279.25; // RTKLIB-style GPST since 1970 of 2025-07-08
        assert_eq!(plausible_base(raw, now()), Some(TimeBase::UnixUtc));
        match check_stamp(TimeBase::GpsSeconds, raw, None, now()) {
            Plausibility::Error(m) => {
                assert!(
                    m.contains("2035-07-"),
                    "the 1980 reading, in the future: {m}"
                );
                assert!(
                    m.contains("2025-07-08 19:34:39 GPST as gps_seconds_1970"),
                    "{m}"
                );
                assert!(m.contains("2025-07-08 19:34:57 GPST as unix_utc"), "{m}");
            }
            p => panic!("{p:?}"),
        }
        assert_eq!(
            check_stamp(TimeBase::GpsSeconds1970, raw, None, now()),
            Plausibility::Ok
        );
        assert_eq!(
            check_stamp(TimeBase::UnixUtc, raw, None, now()),
            Plausibility::Ok
        );
    }

    #[test]
    fn other_implausible_declarations() {
        let t = gps_seconds(2374, 243_258.5);
        assert_eq!(
            check_stamp(TimeBase::GpsSeconds, t, None, now()),
            Plausibility::Ok
        );
        // GPS seconds declared as unix_utc: 2015, plausible both ways → no error but no unique base.
        assert_eq!(plausible_base(t, now()), None);
        // A time of week declared as an absolute base.
        let Plausibility::Error(m) = check_stamp(TimeBase::UnixUtc, 243_258.5, None, now()) else {
            panic!()
        };
        assert!(
            m.contains("less than one week") && m.contains("time of week"),
            "{m}"
        );
        assert_eq!(plausible_base(243_258.5, now()), Some(TimeBase::GpsWeekTow));
        // Absolute seconds declared as a time of week.
        let Plausibility::Error(m) = check_stamp(TimeBase::GpsWeekTow, t, Some(2374), now()) else {
            panic!()
        };
        assert!(
            m.contains("not a time of week") && m.contains("as gps_seconds"),
            "{m}"
        );
        assert!(matches!(
            check_stamp(TimeBase::GpsWeekTow, 5.0, None, now()),
            Plausibility::Warning(_)
        ));
        assert_eq!(
            check_stamp(TimeBase::GpsWeekTow, 5.0, Some(2374), now()),
            Plausibility::Ok
        );
        assert!(matches!(
            check_stamp(TimeBase::GpsWeekTow, 5.0, Some(9999), now()),
            Plausibility::Error(_)
        ));
        assert!(matches!(
            check_stamp(TimeBase::GpsSeconds, -1.0, None, now()),
            Plausibility::Error(_)
        ));
        // POSIX seconds before 1980.
        let Plausibility::Error(m) = check_stamp(TimeBase::UnixUtc, 2.0e8, None, now()) else {
            panic!()
        };
        assert!(m.contains("before the GPS epoch"), "{m}");
    }
}
