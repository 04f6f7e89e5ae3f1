//! GPS time at the I/O edge: GPS week + time of week ↔ GPS seconds ↔
//! calendar date in GPST or UTC.
//!
//! GPS seconds `t` count from the GPS epoch 1980-01-06 00:00:00 GPST,
//! `t = week · 604800 + tow` (IS-GPS-200 §3.3.4; the crate-wide convention of
//! `navfuse_core::types`). GPST does not have leap seconds; UTC = GPST −
//! (GPS−UTC), with GPS−UTC = (TAI−UTC) − 19 s taken from hifitime's IERS
//! leap-second table (18 s since 2017-01-01). The calendar arithmetic is the
//! proleptic Gregorian day count (days from 1970-01-01), done in integers so
//! no precision is lost on sub-second times.

use hifitime::Epoch;

/// Seconds per GPS week.
pub const SECONDS_PER_WEEK: f64 = 604_800.0;
/// Days from 1970-01-01 to the GPS epoch 1980-01-06.
const GPS_EPOCH_DAYS: i64 = 3657;

/// GPS seconds from week and time of week.
pub fn gps_seconds(week: u32, tow: f64) -> f64 {
    week as f64 * SECONDS_PER_WEEK + tow
}

/// Week and time of week `[0, 604800)` of GPS seconds `t ≥ 0` (negative `t` gives week 0).
pub fn week_tow(t: f64) -> (u32, f64) {
    if !t.is_finite() || t < 0.0 {
        return (0, t);
    }
    let w = (t / SECONDS_PER_WEEK).floor();
    let mut tow = t - w * SECONDS_PER_WEEK;
    let mut w = w.min(u32::MAX as f64) as u32;
    if tow >= SECONDS_PER_WEEK {
        tow -= SECONDS_PER_WEEK;
        w = w.saturating_add(1);
    }
    (w, tow)
}

/// Time system of a calendar reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeSystem {
    /// GPS time (no leap seconds).
    Gpst,
    /// Coordinated Universal Time.
    Utc,
}

/// A calendar date and time of day.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calendar {
    pub year: i32,
    /// 1–12.
    pub month: u8,
    /// 1–31.
    pub day: u8,
    pub hour: u8,
    pub minute: u8,
    /// Seconds of the minute, `[0, 61)`.
    pub second: f64,
}

/// Days from 1970-01-01 of a proleptic Gregorian date (era/day-of-era method).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12; // March = 0
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Inverse of [`days_from_civil`].
fn civil_from_days(z: i64) -> (i64, u8, u8) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u8;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u8;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

fn days_in_month(y: i64, m: u8) -> u8 {
    match m {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        _ if (y % 4 == 0 && y % 100 != 0) || y % 400 == 0 => 29,
        _ => 28,
    }
}

/// GPS − UTC [s] at GPS time `t` (leap seconds; 0 before 1980, hifitime's
/// table after). Times outside ±10⁴ years are clamped.
pub fn gps_minus_utc(t: f64) -> f64 {
    let t = if t.is_finite() {
        t.clamp(-1e11, 1e11)
    } else {
        0.0
    };
    let tai_utc = Epoch::from_gpst_seconds(t)
        .leap_seconds(true)
        .unwrap_or(19.0);
    (tai_utc - 19.0).max(0.0)
}

/// GPS seconds of a calendar reading in `sys`. Errors on an impossible date
/// or time (month 13, 31 April, minute 60, …).
pub fn gps_from_calendar(c: &Calendar, sys: TimeSystem) -> Result<f64, String> {
    if !(1..=12).contains(&c.month) {
        return Err(format!("month {} outside 1..12", c.month));
    }
    if !(-100_000..=100_000).contains(&c.year) {
        return Err(format!("year {} out of range", c.year));
    }
    let dim = days_in_month(c.year as i64, c.month);
    if c.day < 1 || c.day > dim {
        return Err(format!("day {} outside 1..{dim}", c.day));
    }
    if c.hour > 23 || c.minute > 59 {
        return Err(format!("time {:02}:{:02} invalid", c.hour, c.minute));
    }
    if !(0.0..61.0).contains(&c.second) {
        return Err(format!("second {} outside [0, 61)", c.second));
    }
    let days = days_from_civil(c.year as i64, c.month as i64, c.day as i64) - GPS_EPOCH_DAYS;
    let sod = (c.hour as i64 * 3600 + c.minute as i64 * 60) as f64;
    let t_cal = (days * 86_400) as f64 + sod + c.second;
    Ok(match sys {
        TimeSystem::Gpst => t_cal,
        TimeSystem::Utc => {
            let l = gps_minus_utc(t_cal);
            t_cal + gps_minus_utc(t_cal + l)
        }
    })
}

/// Calendar reading of GPS time `t` in `sys`, seconds rounded to `decimals`
/// (≤ 9) digits so that the rounding never produces second 60.
pub fn calendar_from_gps(t: f64, sys: TimeSystem, decimals: u32) -> Calendar {
    let t = if t.is_finite() {
        t.clamp(-1e11, 1e11)
    } else {
        0.0
    };
    let t = match sys {
        TimeSystem::Gpst => t,
        TimeSystem::Utc => t - gps_minus_utc(t),
    };
    let scale = 10i64.pow(decimals.min(9));
    let ticks = (t * scale as f64).round() as i64;
    let per_day = 86_400 * scale;
    let days = ticks.div_euclid(per_day);
    let rem = ticks.rem_euclid(per_day);
    let (y, m, d) = civil_from_days(days + GPS_EPOCH_DAYS);
    let secs = rem / scale;
    let frac = (rem % scale) as f64 / scale as f64;
    Calendar {
        year: y as i32,
        month: m,
        day: d,
        hour: (secs / 3600) as u8,
        minute: ((secs / 60) % 60) as u8,
        second: (secs % 60) as f64 + frac,
    }
}

/// ISO-8601 UTC text of GPS time `t` with milliseconds, e.g. `2025-07-08T19:34:00.500Z`.
pub fn iso8601_utc(t: f64) -> String {
    let c = calendar_from_gps(t, TimeSystem::Utc, 3);
    format!(
        "{:04}-{:02}-{:02}T{:02}:{:02}:{:06.3}Z",
        c.year, c.month, c.day, c.hour, c.minute, c.second
    )
}

/// Parse `YYYY/MM/DD` and `HH:MM:SS.sss` (RTKLIB's date and time tokens;
/// `-` is accepted as the date separator too).
pub fn parse_date_time(date: &str, time: &str) -> Result<Calendar, String> {
    let mut d = date.split(['/', '-']);
    let mut tt = time.split(':');
    let bad = || format!("not a date/time: {:?}", format!("{date} {time}"));
    let next_int = |it: &mut dyn Iterator<Item = &str>| -> Result<i64, String> {
        let s = it.next().ok_or_else(bad)?;
        if s.is_empty() || s.len() > 6 || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad());
        }
        s.parse::<i64>().map_err(|_| bad())
    };
    let year = next_int(&mut d)?;
    let month = next_int(&mut d)?;
    let day = next_int(&mut d)?;
    let hour = next_int(&mut tt)?;
    let minute = next_int(&mut tt)?;
    let sec_s = tt.next().ok_or_else(bad)?;
    if d.next().is_some() || tt.next().is_some() {
        return Err(bad());
    }
    let second = sec_s.parse::<f64>().map_err(|_| bad())?;
    if !second.is_finite() || !(0..=12).contains(&month) || !(0..=31).contains(&day) {
        return Err(bad());
    }
    if !(0..=23).contains(&hour) || !(0..=59).contains(&minute) {
        return Err(bad());
    }
    Ok(Calendar {
        year: year as i32,
        month: month as u8,
        day: day as u8,
        hour: hour as u8,
        minute: minute as u8,
        second,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_epoch_week_2374() {
        // GPS week 2374, TOW 243258.5 = 2025-07-08 19:34:18.5 GPST = 19:34:00.5 UTC.
        let t = gps_seconds(2374, 243_258.5);
        let c = Calendar {
            year: 2025,
            month: 7,
            day: 8,
            hour: 19,
            minute: 34,
            second: 18.5,
        };
        assert_eq!(gps_from_calendar(&c, TimeSystem::Gpst).unwrap(), t);
        let u = Calendar { second: 0.5, ..c };
        assert_eq!(gps_from_calendar(&u, TimeSystem::Utc).unwrap(), t);
        assert_eq!(gps_minus_utc(t), 18.0);
        assert_eq!(calendar_from_gps(t, TimeSystem::Gpst, 3), c);
        assert_eq!(calendar_from_gps(t, TimeSystem::Utc, 3), u);
        assert_eq!(iso8601_utc(t), "2025-07-08T19:34:00.500Z");
        assert_eq!(week_tow(t), (2374, 243_258.5));
    }

    #[test]
    fn gps_epoch_and_leap_history() {
        let c0 = Calendar {
            year: 1980,
            month: 1,
            day: 6,
            hour: 0,
            minute: 0,
            second: 0.0,
        };
        assert_eq!(gps_from_calendar(&c0, TimeSystem::Gpst).unwrap(), 0.0);
        assert_eq!(gps_minus_utc(0.0), 0.0);
        // 2016-12-31 → 17 s, 2017-01-02 → 18 s (leap second at 2017-01-01).
        let before = Calendar {
            year: 2016,
            month: 12,
            day: 31,
            ..c0
        };
        let after = Calendar {
            year: 2017,
            month: 1,
            day: 2,
            ..c0
        };
        let tb = gps_from_calendar(&before, TimeSystem::Gpst).unwrap();
        let ta = gps_from_calendar(&after, TimeSystem::Gpst).unwrap();
        assert_eq!(gps_minus_utc(tb), 17.0);
        assert_eq!(gps_minus_utc(ta), 18.0);
    }

    #[test]
    fn rejects_impossible_dates() {
        let c = Calendar {
            year: 2025,
            month: 4,
            day: 31,
            hour: 0,
            minute: 0,
            second: 0.0,
        };
        assert!(gps_from_calendar(&c, TimeSystem::Gpst).is_err());
        assert!(gps_from_calendar(
            &Calendar {
                month: 13,
                day: 1,
                ..c
            },
            TimeSystem::Gpst
        )
        .is_err());
        assert!(parse_date_time("2025/07/08", "19:34:18.5").is_ok());
        for (d, t) in [
            ("2025/07", "1:2:3"),
            ("2025/07/08", "19:34"),
            ("x/1/1", "1:1:1"),
            ("2025/07/08", "1:1:nan"),
        ] {
            assert!(parse_date_time(d, t).is_err(), "{d} {t}");
        }
    }

    proptest! {
        #[test]
        fn calendar_round_trip(t in 0.0f64..3.0e9, utc in any::<bool>()) {
            let sys = if utc { TimeSystem::Utc } else { TimeSystem::Gpst };
            let c = calendar_from_gps(t, sys, 6);
            let back = gps_from_calendar(&c, sys).unwrap();
            prop_assert!((back - t).abs() < 2e-6, "{t} -> {c:?} -> {back}");
        }

        #[test]
        fn never_panics_on_any_time(t in any::<f64>(), d in 0u32..20) {
            let _ = calendar_from_gps(t, TimeSystem::Utc, d);
            let _ = iso8601_utc(t);
            let _ = week_tow(t);
            let _ = gps_minus_utc(t);
        }

        #[test]
        fn week_tow_round_trip(w in 0u32..5000, tow in 0.0f64..604_799.999) {
            let (w2, tow2) = week_tow(gps_seconds(w, tow));
            prop_assert_eq!(w2, w);
            prop_assert!((tow2 - tow).abs() < 1e-6);
        }
    }
}
