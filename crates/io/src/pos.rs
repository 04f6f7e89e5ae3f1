//! RTKLIB `.pos` solution files (RTKLIB manual, "Output file format") →
//! [`GnssFix`].
//!
//! Header lines start with `%`; the last `%` line before the first record
//! that names the columns (`%  GPST  latitude(deg) longitude(deg) …`) sets
//! the time system (`GPST`, `UTC` or `JST`) and the column order. Without
//! such a line RTKLIB's default order is assumed. The time takes two tokens,
//! either `YYYY/MM/DD HH:MM:SS.sss` or `week tow`. Only lat/lon/height
//! position output is supported (ECEF/ENU/DMS headers are an error naming the
//! header line).
//!
//! Columns: lat/lon [deg], ellipsoidal height [m], Q (1 fix, 2 float, 3 SBAS,
//! 4 DGPS, 5 single, 6 PPP, 7 dead reckoning), ns, sdn/sde/sdu [m] (→
//! `std_ned`, σ_down = sdu), sdne/sdeu/sdun, age [s], ratio, and when present
//! vn/ve/vu [m/s] and sdvn/sdve/sdvu/sdvne/sdveu/sdvun. **vu is up**:
//! `v_n = (vn, ve, −vu)`. σ columns may be `nan` (unknown, as
//! [`crate::pos_writer`] writes them). The position cross terms (sdne…,
//! RTKLIB's signed square roots of covariances) are available per record as
//! NED covariances from [`PosReader::cross_ned`]; age and ratio are checked
//! to be numbers but not carried.

use crate::error::{ReadError, RecordStats};
use crate::kfgins::wrap_pi;
use crate::text::{in_range, LineSource, Sep};
use crate::time::{gps_from_calendar, gps_seconds, parse_date_time, TimeSystem};
use navfuse_core::types::{GnssFix, Vec3};
use std::io::BufRead;

/// Column names as RTKLIB writes them (llh output), in its default order.
const NAMES: [&str; 22] = [
    "latitude(deg)",
    "longitude(deg)",
    "height(m)",
    "Q",
    "ns",
    "sdn(m)",
    "sde(m)",
    "sdu(m)",
    "sdne(m)",
    "sdeu(m)",
    "sdun(m)",
    "age(s)",
    "ratio",
    "vn(m/s)",
    "ve(m/s)",
    "vu(m/s)",
    "sdvn",
    "sdve",
    "sdvu",
    "sdvne",
    "sdveu",
    "sdvun",
];
const I_LAT: usize = 0;
const I_LON: usize = 1;
const I_H: usize = 2;
const I_Q: usize = 3;
const I_NS: usize = 4;
const I_SDN: usize = 5;
const I_VN: usize = 13;
const I_SDVN: usize = 16;

/// Time system label of the header (`JST` = UTC + 9 h).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PosTime {
    Gpst,
    Utc,
    Jst,
}

#[derive(Clone, Debug)]
struct Layout {
    time: PosTime,
    /// Data token index of each of [`NAMES`] (None = column absent).
    col: [Option<usize>; 22],
    ncols: usize,
}

impl Layout {
    fn default_for(ncols: usize) -> Layout {
        let n = if ncols >= 2 + 22 { 22 } else { 13 };
        let mut col = [None; 22];
        for (k, c) in col.iter_mut().enumerate().take(n) {
            *c = Some(2 + k);
        }
        Layout {
            time: PosTime::Gpst,
            col,
            ncols: 2 + n,
        }
    }
}

/// Streaming RTKLIB `.pos` reader.
pub struct PosReader<R> {
    src: LineSource<R>,
    layout: Option<Layout>,
    header: Option<Layout>,
    done: bool,
    cross_ned: Vec3,
}

impl<R: BufRead> PosReader<R> {
    pub fn new(rdr: R, file: &str) -> Self {
        PosReader {
            src: LineSource::new(rdr, file),
            layout: None,
            header: None,
            done: false,
            cross_ned: Vec3::repeat(f64::NAN),
        }
    }

    /// Position covariances off the diagonal (NE, ED, DN) [m²], NED, of the
    /// last record read (from sdne/sdeu/sdun, [`crate::pos_writer::ned_cross`]);
    /// NaN when the file has no such columns or writes `nan`.
    pub fn cross_ned(&self) -> Vec3 {
        self.cross_ned
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    /// Time system of the file (known after the first record).
    pub fn time_system(&self) -> Option<PosTime> {
        self.layout.as_ref().map(|l| l.time)
    }

    /// Parse a `%` line; a line that names columns becomes the header layout.
    fn header_line(&mut self) -> Result<(), ReadError> {
        let s = &mut self.src;
        s.split_from(1, Sep::Whitespace);
        let mut toks = Vec::with_capacity(s.n_fields());
        for i in 0..s.n_fields() {
            match s.text(i, "<header>") {
                Ok(t) => toks.push(t.to_string()),
                Err(_) => return Ok(()), // a free-text comment with odd bytes
            }
        }
        let time = match toks.first().map(String::as_str) {
            Some("GPST") => PosTime::Gpst,
            Some("UTC") => PosTime::Utc,
            Some("JST") => PosTime::Jst,
            _ => return Ok(()),
        };
        if toks.len() < 2 {
            return Ok(());
        }
        if toks.iter().any(|t| {
            t.starts_with("x-ecef") || t.starts_with("e-baseline") || t.starts_with("latitude(d'")
        }) {
            return Err(s.err(
                "<header>",
                "only latitude(deg)/longitude(deg)/height(m) output is supported (not ECEF, ENU or d'm\"s)",
            ));
        }
        let mut col = [None; 22];
        for (k, t) in toks.iter().enumerate().skip(1) {
            if let Some(j) = NAMES.iter().position(|n| n == t) {
                col[j] = Some(k + 1); // header token k ↔ data token k+1 (time is two tokens)
            }
        }
        if col[I_LAT].is_none() || col[I_LON].is_none() || col[I_H].is_none() {
            return Ok(()); // not a column header
        }
        self.header = Some(Layout {
            time,
            col,
            ncols: toks.len() + 1,
        });
        Ok(())
    }

    fn read(&mut self) -> Result<Option<GnssFix>, ReadError> {
        loop {
            let min = self.layout.as_ref().map_or(15, |l| l.ncols);
            if !self.src.next_line()? {
                return Ok(None);
            }
            if self.src.starts_with(b'%') {
                self.src.stats.skipped += 1;
                if self.layout.is_none() {
                    self.header_line()?;
                }
                continue;
            }
            if self.src.is_blank() {
                self.src.stats.skipped += 1;
                continue;
            }
            self.src.split(Sep::Whitespace);
            if self.src.is_unterminated_last() && self.src.n_fields() < min {
                self.src.stats.reject(crate::kfgins::REASON_TRUNCATED_LAST);
                continue;
            }
            break;
        }
        if self.layout.is_none() {
            self.layout = Some(match self.header.take() {
                Some(h) => h,
                None => Layout::default_for(self.src.n_fields()),
            });
        }
        let (s, l) = (&self.src, self.layout.as_ref().expect("set above"));
        let n = s.n_fields();
        if n != l.ncols {
            // Name the first missing column, or the first extra one.
            let field: String = if n < l.ncols {
                if n < 2 {
                    "time".into()
                } else {
                    (0..22)
                        .find(|&j| l.col[j] == Some(n))
                        .map_or_else(|| format!("<column {}>", n + 1), |j| NAMES[j].to_string())
                }
            } else {
                format!("<column {}>", l.ncols + 1)
            };
            return Err(s.err(
                field,
                format!("line has {n} columns, the header implies {}", l.ncols),
            ));
        }
        let t0 = s.text(0, "time")?;
        let t1 = s.text(1, "time")?;
        let t = if t0.contains('/') || t0.contains('-') {
            let c = parse_date_time(t0, t1).map_err(|m| s.err("time", m))?;
            let sys = if l.time == PosTime::Gpst {
                TimeSystem::Gpst
            } else {
                TimeSystem::Utc
            };
            let t = gps_from_calendar(&c, sys).map_err(|m| s.err("time", m))?;
            if l.time == PosTime::Jst {
                t - 9.0 * 3600.0
            } else {
                t
            }
        } else {
            let w = crate::text::parse_finite(t0).map_err(|m| s.err("week", m))?;
            if w < 0.0 || w.fract() != 0.0 || w > 1.0e5 {
                return Err(s.err("week", format!("not a GPS week number: {t0:?}")));
            }
            let tow = crate::text::parse_finite(t1).map_err(|m| s.err("tow", m))?;
            let tow = in_range(tow, 0.0, 1.0e6, "time of week").map_err(|m| s.err("tow", m))?;
            gps_seconds(w as u32, tow)
        };
        let get = |j: usize| -> Result<Option<f64>, ReadError> {
            match l.col[j] {
                Some(i) => s.f64(i, NAMES[j]).map(Some),
                None => Ok(None),
            }
        };
        let lat = get(I_LAT)?.unwrap_or_default();
        let lat = in_range(lat, -90.0, 90.0, "latitude").map_err(|m| s.err(NAMES[I_LAT], m))?;
        let lon = get(I_LON)?.unwrap_or_default();
        let lon = in_range(lon, -180.0, 360.0, "longitude").map_err(|m| s.err(NAMES[I_LON], m))?;
        let h = get(I_H)?.unwrap_or_default();
        let small_int = |j: usize, max: f64| -> Result<u8, ReadError> {
            match get(j)? {
                None => Ok(0),
                Some(v) if v >= 0.0 && v <= max && v.fract() == 0.0 => Ok(v as u8),
                Some(v) => Err(s.err(NAMES[j], format!("not an integer in 0..={max}: {v}"))),
            }
        };
        let quality = small_int(I_Q, 7.0)?;
        let num_sats = small_int(I_NS, 255.0)?;
        // σ and cross terms: a number or `nan` (unknown).
        let get_sd = |j: usize| -> Result<Option<f64>, ReadError> {
            match l.col[j] {
                Some(i) => s.f64_or_nan(i, NAMES[j]).map(Some),
                None => Ok(None),
            }
        };
        let nonneg = |j: usize| -> Result<f64, ReadError> {
            match get_sd(j)? {
                Some(v) if v < 0.0 => {
                    Err(s.err(NAMES[j], format!("standard deviation {v} is negative")))
                }
                Some(v) => Ok(v),
                None => Ok(f64::NAN),
            }
        };
        let std_ned = Vec3::new(nonneg(I_SDN)?, nonneg(I_SDN + 1)?, nonneg(I_SDN + 2)?);
        let mut x = [f64::NAN; 3];
        for (k, v) in x.iter_mut().enumerate() {
            *v = get_sd(8 + k)?.unwrap_or(f64::NAN);
        }
        let cross_ned = crate::pos_writer::ned_cross(x);
        for j in 11..13 {
            get(j)?; // age, ratio: must be numbers
        }
        let v = [get(I_VN)?, get(I_VN + 1)?, get(I_VN + 2)?];
        let v_n = match v {
            [Some(n), Some(e), Some(u)] => Some(Vec3::new(n, e, -u)),
            _ => None,
        };
        let std_v_n = if l.col[I_SDVN].is_some() {
            let sv = Vec3::new(nonneg(I_SDVN)?, nonneg(I_SDVN + 1)?, nonneg(I_SDVN + 2)?);
            for j in 19..22 {
                get_sd(j)?;
            }
            Some(sv)
        } else {
            None
        };
        self.cross_ned = cross_ned;
        Ok(Some(GnssFix {
            t,
            lat: lat.to_radians(),
            lon: wrap_pi(lon.to_radians()),
            h,
            std_ned,
            v_n,
            std_v_n: v_n.and(std_v_n),
            quality,
            num_sats,
        }))
    }
}

impl<R: BufRead> Iterator for PosReader<R> {
    type Item = Result<GnssFix, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{assert_err, collect, token_lines};
    use proptest::prelude::*;

    const HDR: &str = "% program   : RTKPOST\n\
%  GPST            latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m) sdun(m) age(s) ratio vn(m/s) ve(m/s) vu(m/s) sdvn sdve sdvu sdvne sdveu sdvun\n";
    const L1: &str = "2025/07/08 19:34:18.500 40.0966268 -105.1474483 1601.4740 1 21 0.0099 0.0098 0.0100 0.0 0.0 0.0 0.0 0.0 0.0100 -0.0020 0.0090 0.0586 0.0587 0.0588 0.0 0.0 0.0\n";
    const L2: &str = "2025/07/08 19:34:18.750 40.0966268 -105.1474483 1601.4760 2 20 0.0099 0.0098 0.0100 0.0 0.0 0.0 0.0 0.0 0.0010 0.0020 -0.0060 0.0558 0.0558 0.0558 0.0 0.0 0.0\n";

    fn pos(data: &[u8]) -> Result<Vec<GnssFix>, ReadError> {
        collect(PosReader::new(data, "sol.pos"))
    }
    fn file(l2: &str) -> Vec<u8> {
        format!("{HDR}{L1}{l2}").into_bytes()
    }
    fn l2_with(k: usize, v: &str) -> String {
        let mut f: Vec<&str> = L2.split_whitespace().collect();
        f[k] = v;
        f.join(" ") + "\n"
    }

    #[test]
    fn reads_gpst_with_velocity_up_to_down() {
        let v = pos(&file(L2)).unwrap();
        assert_eq!(v.len(), 2);
        let t0 = gps_seconds(2374, 243_258.5);
        assert_eq!(v[0].t, t0);
        assert!((v[1].t - t0 - 0.25).abs() < 1e-9);
        assert_eq!((v[0].quality, v[0].num_sats, v[1].quality), (1, 21, 2));
        assert!((v[0].lat.to_degrees() - 40.0966268).abs() < 1e-12);
        assert_eq!(v[0].std_ned, Vec3::new(0.0099, 0.0098, 0.0100));
        assert_eq!(
            v[0].v_n,
            Some(Vec3::new(0.01, -0.002, -0.009)),
            "vu up → v_d = −vu"
        );
        assert_eq!(v[0].std_v_n, Some(Vec3::new(0.0586, 0.0587, 0.0588)));
    }

    #[test]
    fn utc_header_and_week_tow_time() {
        let utc = HDR.replace("GPST", "UTC ") + &L1.replace("19:34:18.500", "19:34:00.500");
        let v = pos(utc.as_bytes()).unwrap();
        assert_eq!(v[0].t, gps_seconds(2374, 243_258.5), "UTC + 18 s");
        let wt = HDR.to_string() + &L1.replace("2025/07/08 19:34:18.500", "2374 243258.500");
        assert_eq!(
            pos(wt.as_bytes()).unwrap()[0].t,
            gps_seconds(2374, 243_258.5)
        );
        // No header at all: default column order (13 columns, no velocity).
        let short: Vec<&str> = L1.split_whitespace().take(15).collect();
        let v = pos((short.join(" ") + "\n").as_bytes()).unwrap();
        assert_eq!((v[0].v_n, v[0].quality), (None, 1));
    }

    #[test]
    fn ecef_header_is_an_error() {
        let h = "%  GPST  x-ecef(m) y-ecef(m) z-ecef(m) Q ns\n";
        assert_err(pos(h.as_bytes()), "sol.pos", 1, "<header>");
    }

    #[test]
    fn corruptions_name_file_line_field() {
        let trunc: Vec<&str> = L2.split_whitespace().take(9).collect();
        assert_err(
            pos(&file(&(trunc.join(" ") + "\n"))),
            "sol.pos",
            4,
            "sdu(m)",
        );
        assert_err(
            pos(&file(&l2_with(4, "1601.47.6"))),
            "sol.pos",
            4,
            "height(m)",
        );
        assert_err(
            pos(&file(&L2.replace('\n', " 7\n"))),
            "sol.pos",
            4,
            "<column 25>",
        );
        assert_err(
            pos(&file(&l2_with(2, "nan"))),
            "sol.pos",
            4,
            "latitude(deg)",
        );
        assert_err(
            pos(&file(&l2_with(16, "0.0\u{fffd}"))),
            "sol.pos",
            4,
            "ve(m/s)",
        );
        let mut raw = file(L2);
        let at = raw.len() - 10;
        raw[at] = 0xfe;
        assert_err(pos(&raw), "sol.pos", 4, "sdvne");
        assert_err(pos(&file(&l2_with(5, "1.5"))), "sol.pos", 4, "Q");
        assert_err(pos(&file(&l2_with(1, "19:61:00"))), "sol.pos", 4, "time");
        assert_err(pos(&file(&l2_with(7, "-0.01"))), "sol.pos", 4, "sdn(m)");
    }

    #[test]
    fn truncated_last_line_is_counted() {
        let data = format!("{HDR}{L1}2025/07/08 19:34:18.750 40.09");
        let mut r = PosReader::new(data.as_bytes(), "sol.pos");
        assert_eq!(r.by_ref().filter(|x| x.is_ok()).count(), 1);
        assert_eq!(r.stats().rejected_total(), 1);
        assert!(r.stats().is_balanced());
    }

    proptest! {
        #[test]
        fn never_panics(data in proptest::collection::vec(any::<u8>(), 0..400), lines in token_lines()) {
            let _ = pos(&data);
            let mut with_hdr = HDR.as_bytes().to_vec();
            with_hdr.extend_from_slice(&lines);
            for d in [&lines, &with_hdr] {
                let mut r = PosReader::new(&d[..], "p");
                if r.by_ref().all(|x| x.is_ok()) {
                    prop_assert!(r.stats().is_balanced());
                }
            }
        }
    }
}
