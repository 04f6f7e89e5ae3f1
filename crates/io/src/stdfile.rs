//! navfuse σ files (`solution.std`, `solution_smoothed.std`): the 1-σ
//! uncertainty of every epoch of the matching `.nav`, row for row, and what
//! aided the epoch. Whitespace separated, no header (like KF-GINS's files):
//!
//! | col | content | unit |
//! |-----|---------|------|
//! | 1–2 | GPS week, seconds of week | –, s |
//! | 3–5 | σ position N, E, D | m |
//! | 6–8 | σ velocity N, E, D | m/s |
//! | 9–11 | σ roll, pitch, yaw | deg |
//! | 12–14 | σ gyro bias x, y, z | deg/h |
//! | 15–17 | σ accel bias x, y, z | mGal (1e-5 m/s²) |
//! | 18–20 | σ gyro scale factor x, y, z | ppm |
//! | 21–23 | σ accel scale factor x, y, z | ppm |
//! | 24 | last aid: `gnss_pos`, `gnss_vel`, `height`, `nhc`, `zupt`, `zaru`, `coast` | – |
//! | 25 | time since the last position update | s |
//! | 26 | updates gated in the last 10 s | – |
//!
//! Columns 3–23 are KF-GINS's `KF_GINS_STD.txt` columns 2–22 (same order
//! and units); a file without the status columns (24–26) reads too, and so
//! does KF-GINS's own STD file (22 columns: time of week, then the σ).

use crate::error::ReadError;
use crate::time::{gps_seconds, week_tow};
use navfuse_core::estimators::consistency::{EpochStatus, KINDS};
use navfuse_core::estimators::eskf::UpdateKind;
use navfuse_core::types::{NavSolution, Vec3};
use std::io::{self, BufRead, Write};
use std::sync::Arc;

/// 1-σ of one epoch, SI units (m, m/s, rad, rad/s, m/s², –).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StdRow {
    /// GPS time [s].
    pub t: f64,
    /// Position N, E, D [m].
    pub pos_ned: Vec3,
    /// Velocity N, E, D [m/s].
    pub vel_ned: Vec3,
    /// Attitude roll, pitch, yaw [rad].
    pub att_rpy: Vec3,
    /// Gyro bias [rad/s], accel bias [m/s²], scale factors [–], body axes.
    pub bg: Vec3,
    pub ba: Vec3,
    pub sg: Vec3,
    pub sa: Vec3,
    /// Position covariances off the diagonal (NE, ED, DN) [m²], NED; NaN
    /// when unknown. Not a column of the file (its layout is KF-GINS's):
    /// carried for the RTKLIB `.pos` writer ([`crate::pos_writer`]).
    pub pos_cross_ned: Vec3,
    /// What aided the epoch (`None`: the file had no status columns).
    pub status: Option<EpochStatus>,
}

const DEG_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// (unit factor SI → file) of the seven σ triples, in column order.
const SCALE: [f64; 7] = [1.0, 1.0, 180.0 / std::f64::consts::PI, DEG_H, 1e5, 1e6, 1e6];

impl StdRow {
    fn triples(&self) -> [Vec3; 7] {
        [
            self.pos_ned,
            self.vel_ned,
            self.att_rpy,
            self.bg,
            self.ba,
            self.sg,
            self.sa,
        ]
    }
}

/// Write one row (see the module table). Numbers with 6 decimals; unknown
/// values as `nan`.
pub fn write_std_row<W: Write>(w: &mut W, r: &StdRow) -> io::Result<()> {
    let (week, tow) = week_tow(r.t);
    write!(w, "{week} {tow:.6}")?;
    for (v, k) in r.triples().iter().zip(SCALE) {
        for x in v.iter() {
            let y = x * k;
            if y.is_finite() {
                write!(w, " {y:.6}")?;
            } else {
                w.write_all(b" nan")?;
            }
        }
    }
    if let Some(s) = &r.status {
        write!(w, " {} {:.3} {}", s.aid_name(), s.since_pos_s, s.gated_10s)?;
    }
    w.write_all(b"\n")
}

fn aid_from_name(s: &str) -> Option<Option<UpdateKind>> {
    if s == "coast" {
        return Some(None);
    }
    KINDS.iter().find(|k| k.name() == s).map(|k| Some(*k))
}

/// Read a σ file (`name` labels errors). A bad line is an error naming the
/// line and the column; blank lines and `#` comments are skipped.
pub fn read_std<R: BufRead>(rdr: R, name: &str) -> Result<Vec<StdRow>, ReadError> {
    let file: Arc<str> = Arc::from(name);
    let mut out = Vec::new();
    for (i, line) in crate::text::capped_lines(rdr).enumerate() {
        let ln = i as u64 + 1;
        let line = line.map_err(|e| ReadError::new(&file, ln, "<line>", e.to_string()))?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let tok: Vec<&str> = line.split_ascii_whitespace().collect();
        if ![22, 23, 26].contains(&tok.len()) {
            return Err(ReadError::new(
                &file,
                ln,
                "<line>",
                format!("expected 22 (KF-GINS), 23 or 26 columns, got {}", tok.len()),
            ));
        }
        // KF-GINS's own STD file: time of week only (week 0 = unknown).
        let o = usize::from(tok.len() == 22);
        let num = |c: usize| -> Result<f64, ReadError> {
            tok[c].parse::<f64>().map_err(|_| {
                ReadError::new(
                    &file,
                    ln,
                    format!("column {}", c + 1),
                    format!("not a number: {:?}", tok[c]),
                )
            })
        };
        let week = if o == 1 { 0.0 } else { num(0)? };
        if !(week >= 0.0 && week.fract() == 0.0) {
            return Err(ReadError::new(
                &file,
                ln,
                "column 1",
                "GPS week not a whole number ≥ 0",
            ));
        }
        let mut v = [Vec3::zeros(); 7];
        for (k, t) in v.iter_mut().enumerate() {
            for a in 0..3 {
                t[a] = num(2 - o + 3 * k + a)? / SCALE[k];
            }
        }
        let status = if tok.len() == 26 {
            let aid = aid_from_name(tok[23]).ok_or_else(|| {
                ReadError::new(&file, ln, "column 24", format!("unknown aid {:?}", tok[23]))
            })?;
            let gated = tok[25].parse::<u32>().map_err(|_| {
                ReadError::new(
                    &file,
                    ln,
                    "column 26",
                    format!("not a count: {:?}", tok[25]),
                )
            })?;
            Some(EpochStatus {
                aid,
                since_pos_s: num(24)?,
                gated_10s: gated,
            })
        } else {
            None
        };
        out.push(StdRow {
            t: gps_seconds(week as u32, num(1 - o)?),
            pos_ned: v[0],
            vel_ned: v[1],
            att_rpy: v[2],
            bg: v[3],
            ba: v[4],
            sg: v[5],
            sa: v[6],
            pos_cross_ned: Vec3::repeat(f64::NAN),
            status,
        });
    }
    Ok(out)
}

/// Read the σ file `path`.
pub fn read_std_file(path: &std::path::Path) -> Result<Vec<StdRow>, ReadError> {
    let (rdr, name) = crate::open(path)?;
    read_std(rdr, &name)
}

/// Put the position, velocity and attitude σ of `rows` into `sols`: row
/// for row when both have the same length (a `.std` beside its `.nav`),
/// else by equal time (within 1 µs). Returns how many solutions got a σ.
pub fn attach_std(sols: &mut [NavSolution], rows: &[StdRow]) -> usize {
    let set = |s: &mut NavSolution, r: &StdRow| {
        s.std_pos_ned = r.pos_ned;
        s.std_v_n = r.vel_ned;
        s.std_rpy = r.att_rpy;
    };
    if sols.len() == rows.len() {
        sols.iter_mut().zip(rows).for_each(|(s, r)| set(s, r));
        return rows.len();
    }
    let mut n = 0;
    for s in sols.iter_mut() {
        let i = rows.partition_point(|r| r.t < s.t - 1e-6);
        if i < rows.len() && (rows[i].t - s.t).abs() <= 1e-6 {
            set(s, &rows[i]);
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, k: f64, status: Option<EpochStatus>) -> StdRow {
        let v = |a: f64| Vec3::new(a, 2.0 * a, 3.0 * a) * k;
        StdRow {
            t,
            pos_ned: v(0.5),
            vel_ned: v(0.01),
            att_rpy: v(1e-3),
            bg: v(1e-5),
            ba: v(1e-3),
            sg: v(1e-4),
            sa: v(2e-4),
            pos_cross_ned: Vec3::repeat(f64::NAN),
            status,
        }
    }

    #[test]
    fn rows_round_trip_with_and_without_status() {
        let st = EpochStatus {
            aid: Some(UpdateKind::Nhc),
            since_pos_s: 12.25,
            gated_10s: 3,
        };
        let coast = EpochStatus { aid: None, ..st };
        let rows = [
            row(2374.0 * 604_800.0 + 243_262.01, 1.0, Some(st)),
            row(2374.0 * 604_800.0 + 243_262.02, 2.0, Some(coast)),
            row(2374.0 * 604_800.0 + 243_262.03, 3.0, None),
        ];
        let mut buf = Vec::new();
        for r in &rows {
            write_std_row(&mut buf, r).unwrap();
        }
        let text = String::from_utf8(buf.clone()).unwrap();
        assert!(
            text.starts_with("2374 243262.010000 0.500000 1.000000 1.500000 "),
            "{text}"
        );
        assert!(text.lines().next().unwrap().ends_with(" nhc 12.250 3"));
        let back = read_std(&buf[..], "x.std").unwrap();
        assert_eq!(back.len(), 3);
        for (a, b) in rows.iter().zip(&back) {
            assert!((a.t - b.t).abs() < 1e-6);
            assert_eq!(a.status, b.status);
            for (x, y) in a.triples().iter().zip(b.triples()) {
                // 6 decimals in the file's units.
                assert!((x - y).abs().max() < 1e-6, "{x} {y}");
                assert!(((x - y).component_div(x)).abs().max() < 1e-3, "{x} {y}");
            }
        }
        let e = read_std(&b"2374 1.0 2.0\n"[..], "x.std").unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.std:1: field `<line>`: expected 22 (KF-GINS), 23 or 26 columns, got 3"
        );
        // KF-GINS's STD layout (no week) reads as week 0.
        let first = text.lines().next().unwrap();
        let kf: Vec<&str> = first.split(' ').skip(1).take(22).collect();
        let k = read_std(kf.join(" ").as_bytes(), "KF_GINS_STD.txt").unwrap();
        assert!((k[0].t - 243_262.01).abs() < 1e-6 && k[0].status.is_none());
        assert!((k[0].sa - back[0].sa).abs().max() < 1e-12);
        let mut sols: Vec<NavSolution> =
            rows.iter().map(|r| NavSolution::unknown_at(r.t)).collect();
        assert_eq!(attach_std(&mut sols, &back), 3);
        assert_eq!(sols[1].std_pos_ned, back[1].pos_ned);
        assert_eq!(attach_std(&mut sols[1..2], &back), 1, "by time");
        let bad = text.lines().next().unwrap().replace(" nhc ", " bus ");
        let e = read_std(bad.as_bytes(), "x.std").unwrap_err();
        assert!(e.to_string().contains("column 24"), "{e}");
    }
}
