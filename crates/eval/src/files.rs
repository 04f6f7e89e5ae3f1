//! Solution and reference files for evaluation (`navfuse eval`): reading
//! any trajectory format navfuse-io knows, placing time-of-week-only series
//! in a GPS week, and the text table and per-epoch error CSV of an
//! [`Evaluation`].
//!
//! Time of week vs GPS time: a file with GPS week 0 (KF-GINS writes 0 when
//! it does not know the week) has times of week only. When one series is
//! time-of-week-only and the other is not, the former is placed in the
//! other's week (or a given week), with a note on stderr.

use crate::{Align, Evaluation, OutageSchedule, Stats};
use navfuse_core::NavSolution;
use navfuse_io::trajectory::{open_nav_source, InFormat};
use navfuse_io::RecordStats;
use std::fmt::Write as _;
use std::path::Path;

/// Seconds in a GPS week.
pub const WEEK_S: f64 = 604_800.0;

/// A trajectory file that cannot be used: the message names the file and,
/// for a bad record, its line and field (navfuse-io's reader error).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct FileError(pub String);

impl From<String> for FileError {
    fn from(s: String) -> Self {
        FileError(s)
    }
}

impl From<FileError> for String {
    fn from(e: FileError) -> Self {
        e.0
    }
}

/// Read a trajectory with navfuse-io: format from the extension (`.nav`
/// KF-GINS, `.pos` RTKLIB, `.csv` navfuse trajectory CSV; with `txt_is_gnss`
/// a `.txt` is a KF-GINS GNSS file). `week` is used for time-of-week-only
/// lines (KF-GINS writes week 0); 0 = unknown.
pub fn read_trajectory(
    path: &Path,
    week: u32,
    txt_is_gnss: bool,
) -> Result<(Vec<NavSolution>, RecordStats), FileError> {
    let fmt = match InFormat::from_path(path) {
        Some(f) => f,
        None if txt_is_gnss => InFormat::KfGinsGnss,
        None => {
            return Err(format!(
                "{}: unknown trajectory format (expected .nav, .pos or .csv)",
                path.display()
            )
            .into())
        }
    };
    let mut src = open_nav_source(path, fmt, week).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for r in src.by_ref() {
        out.push(r.map_err(|e| e.to_string())?);
    }
    Ok((out, src.stats().clone()))
}

fn is_tow_only(s: &[NavSolution]) -> bool {
    s.iter().all(|x| x.t < WEEK_S)
}

fn week_of(s: &[NavSolution]) -> Option<f64> {
    s.first().map(|x| (x.t / WEEK_S).floor())
}

/// Put time-of-week-only series into the week of the other series (or
/// `--week`). Returns the week used for time-of-week inputs (`None`: all
/// times are used as they are).
pub fn harmonise_weeks(
    sol: &mut [NavSolution],
    sol_path: &Path,
    reference: &mut [NavSolution],
    ref_path: &Path,
    week_arg: Option<u32>,
) -> Result<Option<f64>, FileError> {
    let (sol_tow, ref_tow) = (is_tow_only(sol), is_tow_only(reference));
    let week = match (week_arg, sol_tow, ref_tow) {
        (Some(w), _, _) => Some(f64::from(w)),
        (None, true, false) => week_of(reference),
        (None, false, true) => week_of(sol),
        _ => None,
    };
    let Some(w) = week else {
        return Ok(if sol_tow && ref_tow { Some(0.0) } else { None });
    };
    for (series, path, tow) in [(sol, sol_path, sol_tow), (reference, ref_path, ref_tow)] {
        if tow && w > 0.0 {
            eprintln!(
                "note: {} has times of week only (GPS week 0); placed in GPS week {w}",
                path.display()
            );
            for x in series.iter_mut() {
                x.t += w * WEEK_S;
            }
        }
    }
    Ok(Some(w))
}

/// Shift a time given as time of week into `week` (when the data carry weeks).
pub fn in_week(t: f64, week: Option<f64>) -> f64 {
    match week {
        Some(w) if t < WEEK_S => t + w * WEEK_S,
        _ => t,
    }
}

/// "week W TOW s" for GPS seconds (just "TOW s" in week 0).
pub fn gps_time(t: f64) -> String {
    let w = (t / WEEK_S).floor();
    if w > 0.0 {
        format!("week {w} TOW {:.3} s", t - w * WEEK_S)
    } else {
        format!("{t:.3} s")
    }
}

fn row(out: &mut String, name: &str, unit: &str, s: &Option<Stats>, scale: f64) {
    match s {
        Some(s) => {
            let _ = writeln!(
                out,
                "  {name:<16} {unit:<6} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>8}",
                s.rms * scale,
                s.mean * scale,
                s.max_abs * scale,
                s.p95_abs * scale,
                s.count
            );
        }
        None => {
            let _ = writeln!(out, "  {name:<16} {unit:<6} {:>11}", "—");
        }
    }
}

/// The `navfuse eval` table of `ev`: what was compared and how, the error
/// statistics (positions [m], velocities [m/s], attitude [deg]; NED), and the
/// per-outage drift of `schedule` when scored.
pub fn render_table(
    ev: &Evaluation,
    solution: &Path,
    truth: &Path,
    schedule: Option<&OutageSchedule>,
) -> String {
    let mut o = String::new();
    let c = &ev.counts;
    let _ = writeln!(
        o,
        "navfuse eval: {} vs {}",
        solution.display(),
        truth.display()
    );
    let la = ev.config.lever_arm_b.map_or("none".to_string(), |l| {
        format!("({}, {}, {}) m FRD", l[0], l[1], l[2])
    });
    let (at, other) = match ev.config.align {
        Align::AtSolution => ("solution", "reference"),
        Align::AtReference => ("reference", "solution"),
    };
    let _ = writeln!(
        o,
        "  compared at the {at} epochs ({other} interpolated, max gap {} s); lever arm {la}",
        ev.config.max_gap
    );
    let _ = writeln!(
        o,
        "  {at} epochs: {}, evaluated {}; excluded: {} before the {other} span, {} after, {} in {other} gaps, {} invalid",
        c.epochs, c.evaluated, c.before_span, c.after_span, c.in_gap, c.invalid
    );
    let _ = writeln!(
        o,
        "\n  {:<16} {:<6} {:>11} {:>11} {:>11} {:>11} {:>8}",
        "error", "unit", "RMS", "mean", "max|x|", "p95|x|", "n"
    );
    let s = &ev.summary;
    row(&mut o, "horizontal", "m", &s.horizontal, 1.0);
    row(&mut o, "vertical", "m", &s.vertical, 1.0);
    row(&mut o, "north", "m", &s.north, 1.0);
    row(&mut o, "east", "m", &s.east, 1.0);
    row(&mut o, "down", "m", &s.down, 1.0);
    if s.vel_north.is_some() {
        row(&mut o, "vel horizontal", "m/s", &s.vel_horizontal, 1.0);
        row(&mut o, "vel north", "m/s", &s.vel_north, 1.0);
        row(&mut o, "vel east", "m/s", &s.vel_east, 1.0);
        row(&mut o, "vel down", "m/s", &s.vel_down, 1.0);
    }
    if s.yaw.is_some() {
        let d = 180.0 / std::f64::consts::PI;
        row(&mut o, "roll", "deg", &s.roll, d);
        row(&mut o, "pitch", "deg", &s.pitch, d);
        row(&mut o, "yaw", "deg", &s.yaw, d);
    } else {
        let _ = writeln!(o, "  (attitude: reference attitude unknown)");
    }
    if let Some(rep) = &ev.outages {
        if let Some(OutageSchedule::Periodic(p)) = schedule {
            let _ = writeln!(
                o,
                "\n  outages: {} s every {} s from t0 + {} s, t0 = {}",
                p.length,
                p.period,
                p.first_after,
                gps_time(p.t0)
            );
        }
        let _ = writeln!(
            o,
            "  {:>3} {:>16} {:>16} {:>16} {:>8} {:>12} {:>10}",
            "#", "start TOW s", "end TOW s", "scored to TOW s", "n", "max horiz m", "at +s"
        );
        for (k, r) in rep.outages.iter().enumerate() {
            let (m, at) = match (r.max_horizontal, r.t_max) {
                (Some(m), Some(t)) => (format!("{m:.3}"), format!("{:.2}", t - r.start)),
                _ => ("—".into(), "—".into()),
            };
            let _ = writeln!(
                o,
                "  {:>3} {:>16.3} {:>16.3} {:>16.3} {:>8} {:>12} {:>10}",
                k + 1,
                r.start.rem_euclid(WEEK_S),
                r.end.rem_euclid(WEEK_S),
                r.window_end.rem_euclid(WEEK_S),
                r.count,
                m,
                at
            );
        }
        match rep.rms_of_max {
            Some(rms) => {
                let _ = writeln!(
                    o,
                    "  RMS of per-outage maxima: {rms:.3} m ({} outages{})",
                    rep.outages.len() - rep.empty_outages,
                    if rep.empty_outages > 0 {
                        format!(", {} without epochs not scored", rep.empty_outages)
                    } else {
                        String::new()
                    }
                );
            }
            None => {
                let _ = writeln!(o, "  no outage with evaluated epochs");
            }
        }
    }
    o
}

/// The per-epoch error series as CSV: t [s], NED and horizontal/vertical
/// position [m], NED velocity [m/s], roll/pitch/yaw [deg] (empty when unknown).
pub fn errors_csv(ev: &Evaluation) -> String {
    let mut o = String::from(
        "t_s,north_m,east_m,down_m,horizontal_m,vertical_m,vel_north_mps,vel_east_mps,vel_down_mps,roll_deg,pitch_deg,yaw_deg\n",
    );
    let d = 180.0 / std::f64::consts::PI;
    for e in &ev.errors {
        let _ = write!(
            o,
            "{:.4},{:.5},{:.5},{:.5},{:.5},{:.5}",
            e.t, e.pos_ned[0], e.pos_ned[1], e.pos_ned[2], e.horizontal, e.vertical
        );
        match e.vel_ned {
            Some(v) => {
                let _ = write!(o, ",{:.5},{:.5},{:.5}", v[0], v[1], v[2]);
            }
            None => o.push_str(",,,"),
        }
        match e.att_rpy {
            Some(a) => {
                let _ = write!(o, ",{:.5},{:.5},{:.5}", a[0] * d, a[1] * d, a[2] * d);
            }
            None => o.push_str(",,,"),
        }
        o.push('\n');
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp_file(name: &str, text: &str) -> PathBuf {
        let p = std::env::temp_dir().join(format!("navfuse-eval-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_nav_and_reports_bad_lines() {
        let good = temp_file(
            "good.nav",
            "2374 100.5 40.0 -105.0 1600.0 1.0 2.0 3.0 1.0 2.0 359.0\n\
             0 100.75 40.0 -105.0 1600.0 0 0 0 nan nan nan\n",
        );
        let (v, st) = read_trajectory(&good, 0, false).unwrap();
        assert_eq!(v.len(), 2);
        assert_eq!(st.used, 2);
        assert_eq!(v[0].t, 2374.0 * WEEK_S + 100.5);
        assert!((v[0].rpy.z.to_degrees() + 1.0).abs() < 1e-9); // 359° → −1°
        assert_eq!(v[1].t, 100.75); // week 0, no week given: time of week
        let bad = temp_file(
            "bad.nav",
            "2374 1 40 -105 1600 0 0 0 0 0 0\n2374 2 4x0 -105 1600 0 0 0 0 0 0\n",
        );
        let e = read_trajectory(&bad, 0, false).unwrap_err().0;
        assert!(e.contains("bad.nav:2") && e.contains("lat"), "{e}");
        let e = read_trajectory(Path::new("x.unknown"), 0, false)
            .unwrap_err()
            .0;
        assert!(e.contains("unknown trajectory format"), "{e}");
        let _ = std::fs::remove_file(good);
        let _ = std::fs::remove_file(bad);
    }

    #[test]
    fn tow_only_series_is_moved_into_the_other_week() {
        let mut a = vec![NavSolution::unknown_at(100.0)];
        let mut b = vec![NavSolution::unknown_at(2374.0 * WEEK_S + 99.0)];
        let w = harmonise_weeks(&mut a, Path::new("a"), &mut b, Path::new("b"), None).unwrap();
        assert_eq!(w, Some(2374.0));
        assert_eq!(a[0].t, 2374.0 * WEEK_S + 100.0);
        assert_eq!(b[0].t, 2374.0 * WEEK_S + 99.0);
        assert_eq!(in_week(243262.0, w), 2374.0 * WEEK_S + 243262.0);
    }
}
