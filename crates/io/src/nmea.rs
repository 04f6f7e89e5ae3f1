//! NMEA 0183 (v4.x sentence layouts, as receivers write them): a checked
//! sentence parser, a streaming reader that joins epochs into [`GnssFix`],
//! and a writer of fused solutions as GGA + RMC (+ GST).
//!
//! Sentences: GGA, RMC, VTG, GST, GSA, GSV, ZDA, HDT, THS, GNS; talkers GP (GPS),
//! GN (multi-GNSS), GL (GLONASS), GA (Galileo), GB/BD (BeiDou), GQ (QZSS),
//! GI (NavIC). The `*hh` checksum (XOR of the bytes between `$` and `*`) is
//! required and checked.
//!
//! **Fix assembly.** An epoch is the set of sentences with the same UTC time
//! of day. Position comes from GGA (or GNS): latitude, longitude, and the
//! ellipsoidal height `h = altitude(MSL) + geoid separation` (both fields of
//! the sentence). The date comes from RMC/ZDA (of this epoch, else the last
//! one seen, advanced by a day when the time of day wraps past midnight).
//! The 1-σ position error comes from GST (σ_lat → north, σ_lon → east, σ_alt
//! → down) when the epoch has one, else `hdop · uere` horizontally and
//! `1.5 · hdop · uere` vertically ([`NmeaOptions::uere_m`], an assumption).
//! NMEA carries no vertical velocity, so fixes have `v_n = None`; RMC/VTG
//! speed and course are parsed and available as sentences.
//! Quality is mapped to RTKLIB's Q convention (the crate-wide one for
//! [`GnssFix::quality`]): NMEA 4 (RTK fixed) → 1, 5 (RTK float) → 2,
//! 2 (DGPS) → 4, 1 (GPS SPS) → 5, 6 (dead reckoning) → 0 (unknown).
//!
//! **Robustness.** Receiver logs and live streams carry corrupt lines; the
//! reader never stops on one. Every line is counted used, skipped (blank) or
//! rejected by reason (`bad checksum`, `malformed sentence`, …); the last
//! rejection is kept as a [`ReadError`] naming file, line and field.
//! Only an I/O error ends the stream with an error.

use crate::error::{ReadError, RecordStats};
use crate::text::LineSource;
use crate::time::{calendar_from_gps, gps_from_calendar, Calendar, TimeSystem};
use crate::writers::TrajectoryWriter;
use navfuse_core::types::{GnssFix, NavSolution, Vec3};
use std::io::{self, BufRead, Write};

/// Metres per second per knot.
pub const MPS_PER_KNOT: f64 = 1852.0 / 3600.0;

/// Talker of a sentence (the two letters after `$`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Talker {
    Gp,
    Gn,
    Gl,
    Ga,
    Gb,
    Bd,
    Gq,
    Gi,
}

impl Talker {
    fn parse(b: &[u8]) -> Option<Talker> {
        Some(match b {
            b"GP" => Talker::Gp,
            b"GN" => Talker::Gn,
            b"GL" => Talker::Gl,
            b"GA" => Talker::Ga,
            b"GB" => Talker::Gb,
            b"BD" => Talker::Bd,
            b"GQ" => Talker::Gq,
            b"GI" => Talker::Gi,
            _ => return None,
        })
    }
}

/// GGA: time, position and fix data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gga {
    /// UTC seconds of day.
    pub sod: f64,
    /// Latitude, longitude [rad].
    pub lat: f64,
    pub lon: f64,
    /// NMEA fix quality (0 invalid, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, 6 DR).
    pub quality: u8,
    pub num_sats: u8,
    pub hdop: f64,
    /// Altitude above mean sea level [m].
    pub alt_msl: f64,
    /// Geoid separation (ellipsoid − geoid) [m].
    pub geoid_sep: f64,
}

/// RMC: recommended minimum data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rmc {
    pub sod: f64,
    /// Status `A` (valid).
    pub valid: bool,
    pub lat: f64,
    pub lon: f64,
    /// Speed over ground [m/s].
    pub speed: f64,
    /// Course over ground, true [rad] (NaN when empty).
    pub course: f64,
    pub year: i32,
    pub month: u8,
    pub day: u8,
}

/// VTG: course and speed over ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vtg {
    /// Course, true [rad] (NaN when empty).
    pub course: f64,
    /// Speed [m/s].
    pub speed: f64,
}

/// GST: pseudorange error statistics (1-σ, metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gst {
    pub sod: f64,
    pub rms: f64,
    pub sd_lat: f64,
    pub sd_lon: f64,
    pub sd_alt: f64,
}

/// GSA: DOP and active satellites.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gsa {
    /// 1 no fix, 2 2-D, 3 3-D.
    pub fix_type: u8,
    /// Number of satellite ids listed (up to 12).
    pub num_used: u8,
    pub pdop: f64,
    pub hdop: f64,
    pub vdop: f64,
}

/// GSV: satellites in view (one sentence of a group).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gsv {
    pub total: u8,
    pub index: u8,
    pub in_view: u16,
    /// Satellites in this sentence (≤ 4).
    pub count: u8,
}

/// ZDA: UTC time and date.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Zda {
    pub sod: f64,
    pub year: i32,
    pub month: u8,
    pub day: u8,
}

/// One checked sentence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sentence {
    Gga(Gga),
    /// GNS is carried as GGA (same fields; its mode string → quality).
    Gns(Gga),
    Rmc(Rmc),
    Vtg(Vtg),
    Gst(Gst),
    Gsa(Gsa),
    Gsv(Gsv),
    Zda(Zda),
    /// HDT heading, true [rad].
    Hdt(f64),
    /// THS true heading [rad] (NaN when empty) and its mode indicator:
    /// `A` autonomous, `E` estimated (dead reckoning), `M` manual input,
    /// `S` simulator, `V` not valid (NMEA 0183 v4).
    Ths(f64, u8),
}

impl Sentence {
    /// Time of day [s] and UTC date (year, month, day) of an RMC or ZDA.
    pub fn dated_time(&self) -> Option<(f64, (i32, u8, u8))> {
        match *self {
            Sentence::Rmc(Rmc {
                sod,
                year,
                month,
                day,
                ..
            })
            | Sentence::Zda(Zda {
                sod,
                year,
                month,
                day,
            }) => Some((sod, (year, month, day))),
            _ => None,
        }
    }
}

/// Why a line is not a usable sentence: a reason (counted) and the field.
#[derive(Clone, Debug, PartialEq)]
pub struct NmeaError {
    pub reason: &'static str,
    pub field: &'static str,
    pub msg: String,
}

fn err(reason: &'static str, field: &'static str, msg: impl Into<String>) -> NmeaError {
    NmeaError {
        reason,
        field,
        msg: msg.into(),
    }
}

pub const REASON_CHECKSUM: &str = "bad checksum";
pub const REASON_NO_CHECKSUM: &str = "no checksum";
pub const REASON_NOT_NMEA: &str = "not an NMEA sentence";
pub const REASON_TALKER: &str = "unsupported talker";
pub const REASON_TYPE: &str = "unsupported sentence type";
pub const REASON_MALFORMED: &str = "malformed field";
pub const REASON_NO_FIX: &str = "no fix (quality 0)";
pub const REASON_NO_DATE: &str = "no date (no RMC/ZDA seen)";
pub const REASON_TIME_BACK: &str = "time not increasing";

/// XOR checksum of the bytes between `$` and `*`.
pub fn checksum(body: &[u8]) -> u8 {
    body.iter().fold(0u8, |a, &b| a ^ b)
}

fn hexval(b: u8) -> Option<u8> {
    (b as char).to_digit(16).map(|d| d as u8)
}

fn num(s: &str, field: &'static str) -> Result<f64, NmeaError> {
    crate::text::parse_finite(s).map_err(|m| err(REASON_MALFORMED, field, m))
}

fn opt_num(s: &str, field: &'static str) -> Result<f64, NmeaError> {
    if s.is_empty() {
        Ok(f64::NAN)
    } else {
        num(s, field)
    }
}

fn int<T: std::str::FromStr>(s: &str, field: &'static str) -> Result<T, NmeaError> {
    s.parse::<T>()
        .map_err(|_| err(REASON_MALFORMED, field, format!("not an integer: {s:?}")))
}

/// `hhmmss.sss` → seconds of day.
fn tod(s: &str) -> Result<f64, NmeaError> {
    let b = s.as_bytes();
    if b.len() < 6 || !b[..6].iter().all(u8::is_ascii_digit) {
        return Err(err(REASON_MALFORMED, "time", format!("not hhmmss: {s:?}")));
    }
    let h = f64::from((b[0] - b'0') * 10 + (b[1] - b'0'));
    let m = f64::from((b[2] - b'0') * 10 + (b[3] - b'0'));
    let sec = if b.len() > 6 {
        if b[6] != b'.' || !b[7..].iter().all(u8::is_ascii_digit) {
            return Err(err(REASON_MALFORMED, "time", format!("not hhmmss: {s:?}")));
        }
        num(&s[2 + 2..], "time")?
    } else {
        num(&s[4..6], "time")?
    };
    if h > 23.0 || m > 59.0 || sec >= 61.0 {
        return Err(err(
            REASON_MALFORMED,
            "time",
            format!("no such time: {s:?}"),
        ));
    }
    Ok(h * 3600.0 + m * 60.0 + sec)
}

/// `ddmm.mmmm`/`dddmm.mmmm` + hemisphere → radians.
fn angle(v: &str, hemi: &str, field: &'static str, lat: bool) -> Result<f64, NmeaError> {
    let deg_digits = if lat { 2 } else { 3 };
    let b = v.as_bytes();
    if b.len() < deg_digits + 2 || !b[..deg_digits + 2].iter().all(u8::is_ascii_digit) {
        return Err(err(
            REASON_MALFORMED,
            field,
            format!("not {}mm.mmm: {v:?}", if lat { "dd" } else { "ddd" }),
        ));
    }
    let d: f64 = num(&v[..deg_digits], field)?;
    let m: f64 = num(&v[deg_digits..], field)?;
    if m >= 60.0 {
        return Err(err(REASON_MALFORMED, field, format!("minutes ≥ 60: {v:?}")));
    }
    let deg = d + m / 60.0;
    let sign = match (hemi, lat) {
        ("N", true) | ("E", false) => 1.0,
        ("S", true) | ("W", false) => -1.0,
        _ => {
            return Err(err(
                REASON_MALFORMED,
                if lat { "N/S" } else { "E/W" },
                format!("not a hemisphere: {hemi:?}"),
            ))
        }
    };
    if deg > if lat { 90.0 } else { 180.0 } {
        return Err(err(REASON_MALFORMED, field, format!("out of range: {v:?}")));
    }
    Ok((sign * deg).to_radians())
}

fn date_ddmmyy(s: &str) -> Result<(i32, u8, u8), NmeaError> {
    let b = s.as_bytes();
    if b.len() != 6 || !b.iter().all(u8::is_ascii_digit) {
        return Err(err(REASON_MALFORMED, "date", format!("not ddmmyy: {s:?}")));
    }
    let d = (b[0] - b'0') * 10 + (b[1] - b'0');
    let m = (b[2] - b'0') * 10 + (b[3] - b'0');
    let y = i32::from((b[4] - b'0') * 10 + (b[5] - b'0'));
    // Two-digit years: 80–99 → 19xx, 00–79 → 20xx (GPS era).
    let y = if y >= 80 { 1900 + y } else { 2000 + y };
    check_date(y, m, d)?;
    Ok((y, m, d))
}

/// GPS seconds of 00:00 UTC of the date (year, month, day).
pub(crate) fn gps_of_utc_midnight((y, m, d): (i32, u8, u8)) -> Result<f64, String> {
    let c = Calendar {
        year: y,
        month: m,
        day: d,
        hour: 0,
        minute: 0,
        second: 0.0,
    };
    gps_from_calendar(&c, TimeSystem::Utc)
}

fn check_date(y: i32, m: u8, d: u8) -> Result<(), NmeaError> {
    gps_of_utc_midnight((y, m, d))
        .map(|_| ())
        .map_err(|m| err(REASON_MALFORMED, "date", m))
}

fn need(f: &[&str], n: usize) -> Result<(), NmeaError> {
    if f.len() < n {
        Err(err(
            REASON_MALFORMED,
            "<sentence>",
            format!("{} fields, expected at least {n}", f.len()),
        ))
    } else {
        Ok(())
    }
}

fn gga_like(f: &[&str], gns: bool) -> Result<Gga, NmeaError> {
    // GGA: time,lat,N,lon,E,quality,nsat,hdop,alt,M,sep,M,age,station
    // GNS: time,lat,N,lon,E,mode,nsat,hdop,alt,sep,age,station[,status]
    need(f, if gns { 10 } else { 12 })?;
    let sod = tod(f[0])?;
    let quality = if gns {
        // Mode letters per constellation; the best one decides.
        let mut q = 0u8;
        for c in f[5].bytes() {
            let qc = match c {
                b'R' => 4,
                b'F' => 5,
                b'D' | b'P' => 2,
                b'A' => 1,
                b'E' => 6,
                b'N' => 0,
                _ => {
                    return Err(err(
                        REASON_MALFORMED,
                        "mode",
                        format!("not a mode: {:?}", f[5]),
                    ))
                }
            };
            let rank = |q: u8| [0, 2, 4, 0, 6, 5, 1][q as usize];
            if rank(qc) > rank(q) {
                q = qc;
            }
        }
        q
    } else {
        int::<u8>(f[5], "quality")?
    };
    if quality == 0 {
        return Err(err(REASON_NO_FIX, "quality", "quality 0 (no fix)"));
    }
    let lat = angle(f[1], f[2], "lat", true)?;
    let lon = angle(f[3], f[4], "lon", false)?;
    let num_sats = if f[6].is_empty() {
        0
    } else {
        int::<u8>(f[6], "num_sats")?
    };
    let hdop = opt_num(f[7], "hdop")?;
    let alt_msl = num(f[8], "altitude")?;
    let sep_i = if gns { 9 } else { 10 };
    let geoid_sep = if f[sep_i].is_empty() {
        0.0
    } else {
        num(f[sep_i], "geoid_sep")?
    };
    if !gns && (f[9] != "M" || !(f[11] == "M" || f[11].is_empty())) {
        return Err(err(REASON_MALFORMED, "units", "altitude units are not M"));
    }
    Ok(Gga {
        sod,
        lat,
        lon,
        quality,
        num_sats,
        hdop,
        alt_msl,
        geoid_sep,
    })
}

/// Parse one line (without line ending). Leading/trailing blanks are ignored.
pub fn parse_sentence(line: &[u8]) -> Result<Sentence, NmeaError> {
    let line = line.trim_ascii();
    if line.first() != Some(&b'$') {
        return Err(err(
            REASON_NOT_NMEA,
            "<sentence>",
            "does not start with `$`",
        ));
    }
    let Some(star) = line.iter().rposition(|&b| b == b'*') else {
        return Err(err(REASON_NO_CHECKSUM, "checksum", "no `*hh` checksum"));
    };
    let body = &line[1..star];
    let cs = &line[star + 1..];
    let want = match cs {
        [a, b] => hexval(*a).zip(hexval(*b)).map(|(a, b)| a * 16 + b),
        _ => None,
    }
    .ok_or_else(|| {
        err(
            REASON_NO_CHECKSUM,
            "checksum",
            "checksum is not two hex digits",
        )
    })?;
    let got = checksum(body);
    if got != want {
        return Err(err(
            REASON_CHECKSUM,
            "checksum",
            format!("checksum {want:02X} given, {got:02X} computed"),
        ));
    }
    let body =
        std::str::from_utf8(body).map_err(|_| err(REASON_MALFORMED, "<sentence>", "not ASCII"))?;
    let mut it = body.split(',');
    let addr = it.next().unwrap_or("");
    let f: Vec<&str> = it.collect();
    if addr.len() != 5 || !addr.is_ascii() {
        return Err(err(
            REASON_NOT_NMEA,
            "<address>",
            format!("address {addr:?}"),
        ));
    }
    let (talker, kind) = addr.split_at(2);
    if Talker::parse(talker.as_bytes()).is_none() {
        return Err(err(
            REASON_TALKER,
            "<address>",
            format!("talker {talker:?}"),
        ));
    }
    Ok(match kind {
        "GGA" => Sentence::Gga(gga_like(&f, false)?),
        "GNS" => Sentence::Gns(gga_like(&f, true)?),
        "RMC" => {
            need(&f, 9)?;
            let sod = tod(f[0])?;
            let valid = match f[1] {
                "A" => true,
                "V" => false,
                s => return Err(err(REASON_MALFORMED, "status", format!("{s:?}"))),
            };
            let (lat, lon) = if f[2].is_empty() {
                (f64::NAN, f64::NAN)
            } else {
                (
                    angle(f[2], f[3], "lat", true)?,
                    angle(f[4], f[5], "lon", false)?,
                )
            };
            let speed = opt_num(f[6], "speed")? * MPS_PER_KNOT;
            let course = opt_num(f[7], "course")?.to_radians();
            let (year, month, day) = date_ddmmyy(f[8])?;
            Sentence::Rmc(Rmc {
                sod,
                valid,
                lat,
                lon,
                speed,
                course,
                year,
                month,
                day,
            })
        }
        "VTG" => {
            need(&f, 7)?;
            let course = opt_num(f[0], "course")?.to_radians();
            let kmh = opt_num(f[6], "speed_kmh")?;
            let speed = if kmh.is_nan() {
                opt_num(f[4], "speed_knots")? * MPS_PER_KNOT
            } else {
                kmh / 3.6
            };
            Sentence::Vtg(Vtg { course, speed })
        }
        "GST" => {
            need(&f, 8)?;
            let sod = tod(f[0])?;
            let rms = opt_num(f[1], "rms")?;
            let sd = |i: usize, n: &'static str| -> Result<f64, NmeaError> {
                let v = num(f[i], n)?;
                if v < 0.0 {
                    return Err(err(REASON_MALFORMED, n, format!("negative σ {v}")));
                }
                Ok(v)
            };
            Sentence::Gst(Gst {
                sod,
                rms,
                sd_lat: sd(5, "sd_lat")?,
                sd_lon: sd(6, "sd_lon")?,
                sd_alt: sd(7, "sd_alt")?,
            })
        }
        "GSA" => {
            need(&f, 17)?;
            let fix_type = int::<u8>(f[1], "fix_type")?;
            let num_used = f[2..14].iter().filter(|s| !s.is_empty()).count() as u8;
            Sentence::Gsa(Gsa {
                fix_type,
                num_used,
                pdop: opt_num(f[14], "pdop")?,
                hdop: opt_num(f[15], "hdop")?,
                vdop: opt_num(f[16], "vdop")?,
            })
        }
        "GSV" => {
            need(&f, 3)?;
            let total = int::<u8>(f[0], "total")?;
            let index = int::<u8>(f[1], "index")?;
            let in_view = int::<u16>(f[2], "in_view")?;
            if index == 0 || index > total {
                return Err(err(
                    REASON_MALFORMED,
                    "index",
                    format!("{index} of {total}"),
                ));
            }
            let rest = &f[3..];
            // 4 fields per satellite, optionally one signal id at the end.
            let count = (rest.len() / 4).min(4) as u8;
            for s in 0..count as usize {
                for (k, n) in ["prn", "elevation", "azimuth", "snr"].iter().enumerate() {
                    let v = rest[4 * s + k];
                    if !v.is_empty() {
                        int::<u16>(v, n)?;
                    }
                }
            }
            Sentence::Gsv(Gsv {
                total,
                index,
                in_view,
                count,
            })
        }
        "ZDA" => {
            need(&f, 4)?;
            let sod = tod(f[0])?;
            let day = int::<u8>(f[1], "day")?;
            let month = int::<u8>(f[2], "month")?;
            let year = int::<i32>(f[3], "year")?;
            check_date(year, month, day)?;
            Sentence::Zda(Zda {
                sod,
                year,
                month,
                day,
            })
        }
        "HDT" => {
            need(&f, 1)?;
            let h = num(f[0], "heading")?;
            if !(0.0..=360.0).contains(&h) {
                return Err(err(
                    REASON_MALFORMED,
                    "heading",
                    format!("{h} outside [0, 360]"),
                ));
            }
            Sentence::Hdt(h.to_radians())
        }
        "THS" => {
            need(&f, 2)?;
            let mode = match f[1].as_bytes() {
                [m @ (b'A' | b'E' | b'M' | b'S' | b'V')] => *m,
                _ => {
                    return Err(err(
                        REASON_MALFORMED,
                        "mode",
                        format!("mode {:?} not one of A, E, M, S, V", f[1]),
                    ))
                }
            };
            let h = opt_num(f[0], "heading")?;
            if h.is_finite() && !(0.0..=360.0).contains(&h) {
                return Err(err(
                    REASON_MALFORMED,
                    "heading",
                    format!("{h} outside [0, 360]"),
                ));
            }
            Sentence::Ths(h.to_radians(), mode)
        }
        other => return Err(err(REASON_TYPE, "<address>", format!("sentence {other:?}"))),
    })
}

/// Options of [`NmeaReader`].
#[derive(Clone, Copy, Debug)]
pub struct NmeaOptions {
    /// User equivalent range error [m] turning HDOP into σ when an epoch has no GST.
    pub uere_m: f64,
    /// UTC date (year, month, day) to use before any RMC/ZDA is seen.
    pub date: Option<(i32, u8, u8)>,
}

impl Default for NmeaOptions {
    fn default() -> Self {
        NmeaOptions {
            uere_m: 3.0,
            date: None,
        }
    }
}

/// NMEA quality → RTKLIB Q (see the module doc).
pub fn rtklib_q_from_nmea(q: u8) -> u8 {
    match q {
        4 => 1,
        5 => 2,
        2 | 3 => 4,
        1 => 5,
        _ => 0,
    }
}

/// RTKLIB Q → NMEA quality (1 → 4 RTK fixed, 2 → 5 float, 3/4/6 → 2 DGPS, 5 → 1; 0 → 1).
pub fn nmea_from_rtklib_q(q: u8) -> u8 {
    match q {
        1 => 4,
        2 => 5,
        3 | 4 | 6 => 2,
        _ => 1,
    }
}

#[derive(Clone, Copy, Debug)]
struct Epoch {
    gga: Gga,
    /// Line of the GGA/GNS sentence.
    line: u64,
    gst: Option<Gst>,
    date: Option<(i32, u8, u8)>,
}

/// Streaming NMEA reader → [`GnssFix`] (see the module doc for the rules).
pub struct NmeaReader<R> {
    src: LineSource<R>,
    opt: NmeaOptions,
    pending: Option<Epoch>,
    /// Last date seen and the time of day it belongs to.
    date: Option<((i32, u8, u8), f64)>,
    last_t: f64,
    last_reject: Option<ReadError>,
    out: Option<GnssFix>,
    fixes: u64,
    done: bool,
}

impl<R: BufRead> NmeaReader<R> {
    pub fn new(rdr: R, file: &str, opt: NmeaOptions) -> Self {
        NmeaReader {
            src: LineSource::new(rdr, file),
            opt,
            pending: None,
            date: opt.date.map(|d| (d, 0.0)),
            last_t: f64::NEG_INFINITY,
            last_reject: None,
            out: None,
            fixes: 0,
            done: false,
        }
    }

    /// Line accounting (used = valid sentences; rejected by reason).
    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    /// Fixes produced so far.
    pub fn fixes(&self) -> u64 {
        self.fixes
    }

    /// The most recent rejection, as a file:line:field error.
    pub fn last_rejection(&self) -> Option<&ReadError> {
        self.last_reject.as_ref()
    }

    fn reject(&mut self, reason: &'static str, field: &'static str, msg: String) {
        self.src.stats.reject(reason);
        self.last_reject = Some(self.src.err(field, msg));
    }

    /// Reject the epoch whose GGA (counted used) is at `line`: that line
    /// moves from used to rejected.
    fn reject_epoch(&mut self, line: u64, reason: &'static str, field: &'static str, msg: String) {
        self.src.stats.used -= 1;
        self.src.stats.reject(reason);
        let mut e = self.src.err(field, msg);
        e.line = line;
        self.last_reject = Some(e);
    }

    /// Close the pending epoch into a fix (or a counted rejection).
    fn close(&mut self) {
        let Some(ep) = self.pending.take() else {
            return;
        };
        let date = ep.date.or_else(|| {
            self.date.map(|(d, sod)| {
                if ep.gga.sod + 43_200.0 < sod {
                    next_day(d)
                } else {
                    d
                }
            })
        });
        let Some((y, m, d)) = date else {
            self.reject_epoch(
                ep.line,
                REASON_NO_DATE,
                "date",
                "GGA before any RMC/ZDA date".into(),
            );
            return;
        };
        let c = Calendar {
            year: y,
            month: m,
            day: d,
            hour: 0,
            minute: 0,
            second: 0.0,
        };
        let Ok(t0) = gps_from_calendar(&c, TimeSystem::Utc) else {
            self.reject_epoch(ep.line, REASON_NO_DATE, "date", "invalid date".into());
            return;
        };
        // Leap second at midnight: gps_from_calendar gives midnight; add sod
        // in UTC seconds (no leap second inside a day in practice).
        let t = t0 + ep.gga.sod;
        if t <= self.last_t {
            self.reject_epoch(
                ep.line,
                REASON_TIME_BACK,
                "time",
                format!("epoch {t} not after {}", self.last_t),
            );
            return;
        }
        self.last_t = t;
        let (std_ned, _) = match ep.gst {
            Some(g) => (Vec3::new(g.sd_lat, g.sd_lon, g.sd_alt), ()),
            None => {
                let s = if ep.gga.hdop.is_finite() {
                    ep.gga.hdop * self.opt.uere_m
                } else {
                    // No HDOP either: a conservative 10 m (documented assumption).
                    10.0
                };
                (Vec3::new(s, s, 1.5 * s), ())
            }
        };
        self.fixes += 1;
        self.out = Some(GnssFix {
            t,
            lat: ep.gga.lat,
            lon: ep.gga.lon,
            h: ep.gga.alt_msl + ep.gga.geoid_sep,
            std_ned,
            v_n: None,
            std_v_n: None,
            quality: rtklib_q_from_nmea(ep.gga.quality),
            num_sats: ep.gga.num_sats,
        });
    }

    fn same_epoch(&self, sod: f64) -> bool {
        self.pending
            .as_ref()
            .is_some_and(|p| (p.gga.sod - sod).abs() < 5e-4)
    }

    fn step(&mut self) -> Result<bool, ReadError> {
        if !self.src.next_line()? {
            self.close();
            return Ok(false);
        }
        if self.src.is_blank() {
            self.src.stats.skipped += 1;
            return Ok(true);
        }
        let s = match parse_sentence(self.src.bytes()) {
            Ok(s) => s,
            Err(e) => {
                self.reject(e.reason, e.field, e.msg);
                return Ok(true);
            }
        };
        self.src.stats.used += 1;
        match s {
            Sentence::Gga(g) | Sentence::Gns(g) => {
                if self.same_epoch(g.sod) {
                    // GGA and GNS of one epoch: keep the first, the other is redundant.
                    return Ok(true);
                }
                self.close();
                self.pending = Some(Epoch {
                    gga: g,
                    line: self.src.line_no,
                    gst: None,
                    date: None,
                });
            }
            Sentence::Gst(g) if self.same_epoch(g.sod) => {
                if let Some(p) = self.pending.as_mut() {
                    p.gst = Some(g);
                }
            }
            Sentence::Rmc(_) | Sentence::Zda(_) => {
                let Some((sod, (year, month, day))) = s.dated_time() else {
                    return Ok(true);
                };
                self.date = Some(((year, month, day), sod));
                if self.same_epoch(sod) {
                    if let Some(p) = self.pending.as_mut() {
                        p.date = Some((year, month, day));
                    }
                }
            }
            _ => {}
        }
        Ok(true)
    }
}

fn next_day((y, m, d): (i32, u8, u8)) -> (i32, u8, u8) {
    let c = Calendar {
        year: y,
        month: m,
        day: d,
        hour: 12,
        minute: 0,
        second: 0.0,
    };
    match gps_from_calendar(&c, TimeSystem::Gpst) {
        Ok(t) => {
            let n = calendar_from_gps(t + 86_400.0, TimeSystem::Gpst, 0);
            (n.year, n.month, n.day)
        }
        Err(_) => (y, m, d),
    }
}

impl<R: BufRead> Iterator for NmeaReader<R> {
    type Item = Result<GnssFix, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(f) = self.out.take() {
                return Some(Ok(f));
            }
            if self.done {
                return None;
            }
            match self.step() {
                Ok(true) => {}
                Ok(false) => self.done = true,
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            }
        }
    }
}

/// Write `$body*hh\r\n`.
fn sentence<W: Write>(w: &mut W, body: &str) -> io::Result<()> {
    write!(w, "${body}*{:02X}\r\n", checksum(body.as_bytes()))
}

fn dm(a_rad: f64, lat: bool) -> (String, char) {
    let deg = a_rad.to_degrees();
    let hemi = match (lat, deg < 0.0) {
        (true, false) => 'N',
        (true, true) => 'S',
        (false, false) => 'E',
        (false, true) => 'W',
    };
    // Round to 1e-8 minute first so minutes never print as 60.
    let total = (deg.abs() * 60.0 * 1e8).round() as u64;
    let (d, mfrac) = (total / (60 * 100_000_000), total % (60 * 100_000_000));
    let m = mfrac as f64 / 1e8;
    let s = if lat {
        format!("{d:02}{m:011.8}")
    } else {
        format!("{d:03}{m:011.8}")
    };
    (s, hemi)
}

/// NMEA writer: per solution GGA, RMC and (with σ known) GST, talker `GN`.
///
/// Time: UTC with milliseconds. Height: the solution's ellipsoidal height is
/// written as the GGA altitude with geoid separation 0.000 (no geoid model is
/// applied; a reader computing `alt + sep` gets the ellipsoidal height back).
/// Quality from [`nmea_from_rtklib_q`] of `quality` (default 1 = RTK fixed
/// for fused solutions is *not* claimed: fused solutions use 6, dead
/// reckoning, unless set with [`NmeaWriter::with_quality`]). Latitude and
/// longitude with 8 decimals of minutes (≈ 0.02 mm; 9-decimal degrees are
/// kept exactly), height with 4 decimals (0.1 mm), σ with 3 (1 mm).
pub struct NmeaWriter<W: Write> {
    w: W,
    quality: u8,
    num_sats: u8,
    gst: bool,
}

impl<W: Write> NmeaWriter<W> {
    pub fn new(w: W) -> Self {
        NmeaWriter {
            w,
            quality: 6,
            num_sats: 0,
            gst: true,
        }
    }

    /// Set the NMEA quality and satellite count written in GGA.
    pub fn with_quality(mut self, nmea_quality: u8, num_sats: u8) -> Self {
        self.quality = nmea_quality;
        self.num_sats = num_sats;
        self
    }

    /// Whether to write GST (σ) sentences (default yes).
    pub fn with_gst(mut self, on: bool) -> Self {
        self.gst = on;
        self
    }

    /// Write one fix with its own quality and satellite count.
    pub fn write_fix(&mut self, f: &GnssFix) -> io::Result<()> {
        let (q, n) = (self.quality, self.num_sats);
        self.quality = nmea_from_rtklib_q(f.quality);
        self.num_sats = f.num_sats;
        let mut s = crate::trajectory::nav_from_fix(f);
        s.v_n = f.v_n.unwrap_or(Vec3::repeat(f64::NAN));
        let r = self.write_solution(&s);
        self.quality = q;
        self.num_sats = n;
        r
    }

    fn write_solution(&mut self, s: &NavSolution) -> io::Result<()> {
        if !(s.lat.is_finite() && s.lon.is_finite() && s.h.is_finite() && s.t.is_finite()) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("position or time not finite at t = {}", s.t),
            ));
        }
        let c = calendar_from_gps(s.t, TimeSystem::Utc, 3);
        let hms = format!("{:02}{:02}{:06.3}", c.hour, c.minute, c.second);
        let (la, ns) = dm(s.lat, true);
        let lon = (s.lon.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
        let (lo, ew) = dm(lon.to_radians(), false);
        let hdop = if s.std_pos_ned.x.is_finite() && s.std_pos_ned.y.is_finite() {
            ((s.std_pos_ned.x.powi(2) + s.std_pos_ned.y.powi(2)).sqrt() / 3.0).clamp(0.1, 99.9)
        } else {
            99.9
        };
        sentence(
            &mut self.w,
            &format!(
                "GNGGA,{hms},{la},{ns},{lo},{ew},{},{:02},{hdop:.1},{:.4},M,0.000,M,,",
                self.quality, self.num_sats, s.h
            ),
        )?;
        let (spd, crs) = if s.v_n.x.is_finite() && s.v_n.y.is_finite() {
            let sp = s.v_n.x.hypot(s.v_n.y);
            let c = s.v_n.y.atan2(s.v_n.x).to_degrees().rem_euclid(360.0);
            (
                format!("{:.3}", sp / MPS_PER_KNOT),
                format!("{:.2}", if c >= 359.995 { 0.0 } else { c }),
            )
        } else {
            (String::new(), String::new())
        };
        sentence(
            &mut self.w,
            &format!(
                "GNRMC,{hms},A,{la},{ns},{lo},{ew},{spd},{crs},{:02}{:02}{:02},,,D",
                c.day,
                c.month,
                c.year.rem_euclid(100)
            ),
        )?;
        let sd = s.std_pos_ned;
        if self.gst && sd.iter().all(|v| v.is_finite() && *v >= 0.0) {
            sentence(
                &mut self.w,
                &format!(
                    "GNGST,{hms},,,,,{:.3},{:.3},{:.3}",
                    sd.x.min(9.99e5),
                    sd.y.min(9.99e5),
                    sd.z.min(9.99e5)
                ),
            )?;
        }
        Ok(())
    }
}

impl<W: Write> TrajectoryWriter for NmeaWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        self.write_solution(s)
    }
    fn finish(&mut self) -> io::Result<()> {
        self.w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::gps_seconds;

    fn read(s: &str) -> (Vec<GnssFix>, RecordStats) {
        let mut r = NmeaReader::new(s.as_bytes(), "t.nmea", NmeaOptions::default());
        let v: Vec<GnssFix> = r.by_ref().map(|x| x.unwrap()).collect();
        (v, r.stats().clone())
    }

    #[test]
    fn checksum_of_known_sentence() {
        // Widely published example sentence and its checksum.
        let s = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47";
        let g = parse_sentence(s).unwrap();
        let Sentence::Gga(g) = g else { panic!() };
        assert!((g.lat.to_degrees() - (48.0 + 7.038 / 60.0)).abs() < 1e-12);
        assert!((g.lon.to_degrees() - (11.0 + 31.0 / 60.0)).abs() < 1e-12);
        assert_eq!(g.sod, 12.0 * 3600.0 + 35.0 * 60.0 + 19.0);
        assert_eq!((g.quality, g.num_sats), (1, 8));
        let mut bad = s.to_vec();
        bad[20] = b'9';
        assert_eq!(parse_sentence(&bad).unwrap_err().reason, REASON_CHECKSUM);
    }

    #[test]
    fn each_sentence_type_parses() {
        let bodies = [
            "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W",
            "GNVTG,054.7,T,034.4,M,005.5,N,010.2,K",
            "GPGST,172814.0,0.006,0.023,0.020,273.6,0.023,0.020,0.031",
            "GNGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1",
            "GPGSV,2,1,08,01,40,083,46,02,17,308,41,12,07,344,39,14,22,228,45",
            "GPZDA,201530.00,04,07,2002,00,00",
            "GPHDT,274.07,T",
            "GNGNS,014035.00,4332.69262,S,17235.48549,E,RR,13,0.9,25.63,11.24,,",
            "GLGGA,000001,0000.0000,N,00000.0000,W,4,12,0.5,1.0,M,,M,,",
            "GAGGA,000001,0000.0000,N,00000.0000,W,4,12,0.5,1.0,M,,M,,",
            "GBGGA,000001,0000.0000,N,00000.0000,W,4,12,0.5,1.0,M,,M,,",
        ];
        for b in bodies {
            let line = format!("${b}*{:02X}", checksum(b.as_bytes()));
            parse_sentence(line.as_bytes()).unwrap_or_else(|e| panic!("{b}: {e:?}"));
        }
        let rmc = format!("${}*{:02X}", bodies[0], checksum(bodies[0].as_bytes()));
        let Sentence::Rmc(r) = parse_sentence(rmc.as_bytes()).unwrap() else {
            panic!()
        };
        assert_eq!((r.year, r.month, r.day), (1994, 3, 23));
        assert!((r.speed - 22.4 * MPS_PER_KNOT).abs() < 1e-12);
        let gns = format!("${}*{:02X}", bodies[7], checksum(bodies[7].as_bytes()));
        let Sentence::Gns(g) = parse_sentence(gns.as_bytes()).unwrap() else {
            panic!()
        };
        assert_eq!(g.quality, 4);
        assert!(g.lat < 0.0);
        let bad = "$XXGGA,1*00";
        assert_eq!(
            parse_sentence(bad.as_bytes()).unwrap_err().reason,
            REASON_CHECKSUM
        );
    }

    #[test]
    fn writer_reader_round_trip_and_date_join() {
        let t0 = gps_seconds(2374, 243_262.999);
        let mut buf = Vec::new();
        let mut w = NmeaWriter::new(&mut buf);
        let mut fixes = Vec::new();
        for k in 0..10 {
            let f = GnssFix {
                t: t0 + 0.25 * k as f64,
                lat: (40.1 + 1e-5 * k as f64).to_radians(),
                lon: (-105.15 - 2e-5 * k as f64).to_radians(),
                h: 1600.123 + k as f64 * 0.01,
                std_ned: Vec3::new(0.012, 0.011, 0.03),
                quality: 1,
                num_sats: 12,
                ..Default::default()
            };
            w.write_fix(&f).unwrap();
            fixes.push(f);
        }
        let text = String::from_utf8(buf).unwrap();
        // Drop the RMC of the first epoch: its date must come from the next RMC?
        // No: the first epoch has its own RMC; check the plain round trip.
        let (got, st) = read(&text);
        assert_eq!(got.len(), 10, "{st}");
        assert!(st.is_balanced());
        for (a, b) in got.iter().zip(&fixes) {
            assert!((a.t - b.t).abs() < 1e-6, "{} {}", a.t, b.t);
            assert!((a.lat - b.lat).abs() * 6.4e6 < 3e-4);
            assert!((a.lon - b.lon).abs() * 6.4e6 < 3e-4);
            assert!((a.h - b.h).abs() < 6e-4);
            assert_eq!(a.std_ned, b.std_ned);
            assert_eq!((a.quality, a.num_sats), (1, 12));
        }
        // GGA without any date before it and no RMC at all → rejected, counted.
        let gga_only: String = text
            .lines()
            .filter(|l| l.contains("GGA"))
            .map(|l| format!("{l}\n"))
            .collect();
        let (got, st) = read(&gga_only);
        assert!(got.is_empty());
        assert_eq!(st.rejected_for(REASON_NO_DATE), 10);
    }

    #[test]
    fn corrupt_lines_are_counted_not_fatal() {
        let good = "$GPZDA,201530.00,04,07,2002,00,00";
        let good = format!("{good}*{:02X}", checksum(&good.as_bytes()[1..]));
        let gga = "GPGGA,201530.00,4807.038,N,01131.000,E,4,08,0.9,545.4,M,46.9,M,,";
        let gga = format!("${gga}*{:02X}", checksum(gga.as_bytes()));
        let s = format!(
            "{good}\ngarbage\n$GPGGA,1,2*ZZ\n\n{gga}\n$GPXXX,1*{:02X}\n",
            checksum(b"GPXXX,1")
        );
        let (got, st) = read(&s);
        assert_eq!(got.len(), 1);
        assert!((got[0].h - (545.4 + 46.9)).abs() < 1e-9);
        assert_eq!(st.rejected_for(REASON_NOT_NMEA), 1);
        assert_eq!(st.rejected_for(REASON_NO_CHECKSUM), 1);
        assert_eq!(st.rejected_for(REASON_TYPE), 1);
        assert_eq!(st.skipped, 1);
        assert!(st.is_balanced(), "{st}");
        // σ from HDOP when there is no GST.
        assert!((got[0].std_ned.x - 0.9 * 3.0).abs() < 1e-12);
    }

    #[test]
    fn midnight_rollover_advances_date() {
        let z = "GPZDA,235959.50,31,12,2024,00,00";
        let g1 = "GPGGA,235959.50,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
        let g2 = "GPGGA,000000.50,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
        let s: String = [z, g1, g2]
            .iter()
            .map(|b| format!("${b}*{:02X}\n", checksum(b.as_bytes())))
            .collect();
        let (got, _) = read(&s);
        assert_eq!(got.len(), 2);
        assert!(
            (got[1].t - got[0].t - 1.0).abs() < 1e-6,
            "{}",
            got[1].t - got[0].t
        );
    }
}
