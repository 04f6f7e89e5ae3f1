//! RINEX GPS navigation and observation readers (RINEX 2.11, Gurtner &
//! Estey; RINEX 3.04, IGS/RTCM). Navigation records become [`KeplerOrbit`]s;
//! observation epochs keep every GPS observable in its header order, in the
//! file's units (carrier phase in cycles, pseudorange in metres) with the
//! loss-of-lock indicator. RINEX 3 observation codes are named as in RINEX 2
//! ([`rinex2_name`]) so both versions look alike to the consumers; other
//! constellations are counted per system and skipped. Times are GPS seconds
//! since the GPS epoch. Errors name file, line and field. RINEX 3 navigation
//! files (`G` records) are read too; Hatanaka (Compact RINEX) is refused.

use crate::ReadError;
use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};
use std::path::Path;
use std::sync::Arc;

pub(crate) fn err(file: &str, line: usize, field: &str, msg: impl Into<String>) -> ReadError {
    ReadError::new(&Arc::from(file), line as u64, field.to_string(), msg)
}

/// GPS seconds since 1980-01-06 of a calendar date/time (GPS time scale).
pub fn gps_seconds(y: i32, mo: u32, d: u32, h: u32, mi: u32, s: f64) -> f64 {
    // Days from civil (Howard Hinnant's algorithm).
    let days = |y: i32, m: u32, d: u32| -> i64 {
        let y = if m <= 2 { y - 1 } else { y } as i64;
        let era = if y >= 0 { y } else { y - 399 } / 400;
        let yoe = y - era * 400;
        let m = m as i64;
        let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d as i64 - 1;
        let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
        era * 146_097 + doe - 719_468
    };
    let dd = days(y, mo, d) - days(1980, 1, 6);
    dd as f64 * 86_400.0 + h as f64 * 3600.0 + mi as f64 * 60.0 + s
}

fn two_digit_year(y: i32) -> i32 {
    if y < 80 {
        2000 + y
    } else if y < 100 {
        1900 + y
    } else {
        y
    }
}

/// Parse a Fortran float (`D` or `E` exponent); blank → `None`.
pub(crate) fn ffloat(s: &str) -> Result<Option<f64>, String> {
    let t = s.trim();
    if t.is_empty() {
        return Ok(None);
    }
    t.replace(['D', 'd'], "E")
        .parse::<f64>()
        .map(Some)
        .map_err(|_| format!("not a number: `{t}`"))
}

pub(crate) fn field(line: &str, a: usize, b: usize) -> &str {
    let b = b.min(line.len());
    if a >= b {
        ""
    } else {
        line.get(a..b).unwrap_or("")
    }
}

/// Column layout of a Kepler navigation record (RINEX 2.11 / 3.04 Table
/// A4/A8): the epoch line's six date/time fields, where its three clock
/// values start, and the indent of the seven broadcast-orbit lines; every
/// value is 19 characters wide.
pub(crate) struct RecordLayout {
    pub date: [(usize, usize); 6],
    pub clk_start: usize,
    pub indent: usize,
}

/// RINEX 3 epoch line: `G01 2010 07 01 00 00 00` then the clock values.
pub(crate) const LAYOUT_V3: RecordLayout = RecordLayout {
    date: [(4, 8), (9, 11), (12, 14), (15, 17), (18, 20), (21, 23)],
    clk_start: 23,
    indent: 4,
};

/// RINEX 2 epoch line: ` 1 10  7  1  0  0  0.0` then the clock values.
pub(crate) const LAYOUT_V2: RecordLayout = RecordLayout {
    date: [(3, 5), (6, 8), (9, 11), (12, 14), (15, 17), (17, 22)],
    clk_start: 22,
    indent: 3,
};

/// The six date/time fields of the epoch line `lines[i]` (as written:
/// RINEX 2 years may have two digits).
pub(crate) fn record_date(
    lines: &[&str],
    i: usize,
    name: &str,
    lay: &RecordLayout,
) -> Result<[f64; 6], ReadError> {
    let mut dt = [0.0f64; 6];
    for (k, (a, b)) in lay.date.iter().enumerate() {
        let s = field(lines[i], *a, *b).trim();
        dt[k] = s.parse().map_err(|_| {
            err(
                name,
                i + 1,
                ["year", "month", "day", "hour", "minute", "second"][k],
                format!("not a number: `{s}`"),
            )
        })?;
    }
    Ok(dt)
}

/// The 29 values (3 clock + 7 × 4 orbit, `names` in order) of the 8-line
/// record whose epoch line is `lines[i]`. A blank value is an error where
/// `required(index)`, else 0; a NaN/inf value is always an error (an orbit
/// or clock term that is not a number would propagate into every position
/// computed from it). Errors name the file, line and field.
pub(crate) fn record_values(
    lines: &[&str],
    i: usize,
    name: &str,
    lay: &RecordLayout,
    names: &[&str; 29],
    required: impl Fn(usize) -> bool,
) -> Result<[f64; 29], ReadError> {
    const W: usize = 19;
    let (l0, ln0) = (lines[i], i + 1);
    let mut v = [0.0f64; 29];
    for k in 0..3 {
        let s = field(l0, lay.clk_start + k * W, lay.clk_start + (k + 1) * W);
        v[k] = ffloat(s)
            .map_err(|m| err(name, ln0, names[k], m))?
            .ok_or_else(|| err(name, ln0, names[k], "blank"))?;
        if !v[k].is_finite() {
            return Err(err(name, ln0, names[k], "not finite"));
        }
    }
    for r in 0..7 {
        let ln = i + 1 + r;
        let Some(l) = lines.get(ln) else {
            return Err(err(
                name,
                ln0,
                "<record>",
                "truncated navigation record (needs 8 lines)",
            ));
        };
        for k in 0..4 {
            let idx = 3 + r * 4 + k;
            if idx >= 29 {
                break;
            }
            let s = field(l, lay.indent + k * W, lay.indent + (k + 1) * W);
            match ffloat(s).map_err(|m| err(name, ln + 1, names[idx], m))? {
                Some(x) if !x.is_finite() => {
                    return Err(err(name, ln + 1, names[idx], "not finite"))
                }
                Some(x) => v[idx] = x,
                None if required(idx) => return Err(err(name, ln + 1, names[idx], "blank")),
                None => {}
            }
        }
    }
    Ok(v)
}

/// A navigation file's GPS content: ephemerides with their broadcast
/// accuracy, and the header's Klobuchar coefficients.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct NavData {
    pub orbits: Vec<KeplerOrbit>,
    /// "SV accuracy" of each record [m] (parallel to `orbits`; 0 when blank).
    pub ura_m: Vec<f64>,
    /// `ION ALPHA`/`ION BETA` (RINEX 2) or `IONOSPHERIC CORR GPSA`/`GPSB`
    /// (RINEX 3); `None` when either is missing.
    pub iono: Option<Klobuchar>,
}

impl NavData {
    /// Append another file's content (the first header's ionosphere wins).
    pub fn merge(&mut self, other: NavData) {
        self.orbits.extend(other.orbits);
        self.ura_m.extend(other.ura_m);
        if self.iono.is_none() {
            self.iono = other.iono;
        }
    }
}

/// Read a RINEX 2 (or 3) GPS navigation file.
pub fn read_nav(path: &Path) -> Result<Vec<KeplerOrbit>, ReadError> {
    Ok(read_nav_data(path)?.orbits)
}

/// Read a RINEX 2 (or 3) GPS navigation file with accuracies and ionosphere.
pub fn read_nav_data(path: &Path) -> Result<NavData, ReadError> {
    let name = path.display().to_string();
    let text = crate::text::read_text_capped(path, u64::MAX)?;
    parse_nav_data(&text, &name)
}

/// Parse RINEX navigation text; `name` is used in errors.
pub fn parse_nav(text: &str, name: &str) -> Result<Vec<KeplerOrbit>, ReadError> {
    Ok(parse_nav_data(text, name)?.orbits)
}

/// Four Fortran floats of width 12 from column `start` (header ionosphere lines).
fn four_floats(
    l: &str,
    start: usize,
    name: &str,
    ln: usize,
    what: &str,
) -> Result<[f64; 4], ReadError> {
    let mut out = [0.0; 4];
    for (k, o) in out.iter_mut().enumerate() {
        let s = field(l, start + 12 * k, start + 12 * (k + 1));
        *o = ffloat(s)
            .map_err(|m| err(name, ln, what, m))?
            .unwrap_or(0.0);
        if !o.is_finite() {
            return Err(err(name, ln, what, format!("not finite: `{}`", s.trim())));
        }
    }
    Ok(out)
}

/// Parse RINEX navigation text with accuracies and the header's ionosphere.
pub fn parse_nav_data(text: &str, name: &str) -> Result<NavData, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    let mut version = 2.0;
    let (mut alpha, mut beta) = (None, None);
    while i < lines.len() {
        let l = lines[i];
        if l.get(60..).is_some_and(|r| r.starts_with("RINEX VERSION")) {
            version = field(l, 0, 9).trim().parse().unwrap_or(2.0);
        }
        let label = l.get(60..).unwrap_or("");
        if label.starts_with("ION ALPHA") {
            alpha = Some(four_floats(l, 2, name, i + 1, "ION ALPHA")?);
        } else if label.starts_with("ION BETA") {
            beta = Some(four_floats(l, 2, name, i + 1, "ION BETA")?);
        } else if label.starts_with("IONOSPHERIC CORR") {
            match field(l, 0, 4) {
                "GPSA" => alpha = Some(four_floats(l, 5, name, i + 1, "GPSA")?),
                "GPSB" => beta = Some(four_floats(l, 5, name, i + 1, "GPSB")?),
                _ => {}
            }
        }
        i += 1;
        if l.get(60..).is_some_and(|s| s.starts_with("END OF HEADER")) {
            break;
        }
    }
    if i >= lines.len() && !text.contains("END OF HEADER") {
        return Err(err(name, 1, "<header>", "no END OF HEADER"));
    }
    let v3 = version >= 3.0;
    let mut out = Vec::new();
    let mut ura_m = Vec::new();
    while i < lines.len() {
        let l0 = lines[i];
        if l0.trim().is_empty() {
            i += 1;
            continue;
        }
        let ln0 = i + 1;
        if v3 && !l0.starts_with('G') {
            // Other constellations: skip the record (GLONASS/SBAS 4 lines,
            // GLONASS 5 from RINEX 3.05 on, others 8).
            let n = match l0.chars().next() {
                Some('R') => crate::rinex_glonass::record_lines(version),
                Some('S') => 4,
                _ => 8,
            };
            i += n;
            continue;
        }
        // Epoch line.
        let (prn_s, lay) = if v3 {
            (field(l0, 1, 3), &LAYOUT_V3)
        } else {
            (field(l0, 0, 2), &LAYOUT_V2)
        };
        let prn: u8 = prn_s
            .trim()
            .parse()
            .map_err(|_| err(name, ln0, "PRN", format!("not a PRN: `{}`", prn_s.trim())))?;
        let names = [
            "af0",
            "af1",
            "af2",
            "IODE",
            "Crs",
            "delta_n",
            "M0",
            "Cuc",
            "e",
            "Cus",
            "sqrtA",
            "Toe",
            "Cic",
            "OMEGA0",
            "Cis",
            "i0",
            "Crc",
            "omega",
            "OMEGA_DOT",
            "IDOT",
            "L2 codes",
            "GPS week",
            "L2P flag",
            "SV accuracy",
            "SV health",
            "TGD",
            "IODC",
            "transmission time",
            "fit interval",
        ];
        let required = |idx: usize| idx <= 22 || idx == 24 || idx == 25;
        let dt = record_date(&lines, i, name, lay)?;
        let v = record_values(&lines, i, name, lay, &names, required)?;
        let year = two_digit_year(dt[0] as i32);
        let t_oc = gps_seconds(
            year,
            dt[1] as u32,
            dt[2] as u32,
            dt[3] as u32,
            dt[4] as u32,
            dt[5],
        );
        let week = v[21];
        let t_oe = week * SECONDS_PER_WEEK + v[11];
        if !(4000.0..6000.0).contains(&v[10]) {
            return Err(err(
                name,
                ln0 + 2,
                "sqrtA",
                format!("√a {} is not a GPS orbit", v[10]),
            ));
        }
        out.push(KeplerOrbit {
            prn,
            health: v[24] as u32,
            t_oe,
            t_oc,
            sqrt_a: v[10],
            e: v[8],
            i0: v[15],
            idot: v[19],
            omega0: v[13],
            omega_dot: v[18],
            argp: v[17],
            m0: v[6],
            delta_n: v[5],
            cuc: v[7],
            cus: v[9],
            crc: v[16],
            crs: v[4],
            cic: v[12],
            cis: v[14],
            af0: v[0],
            af1: v[1],
            af2: v[2],
            tgd: v[25],
        });
        ura_m.push(v[23]);
        i += 8;
    }
    let iono = match (alpha, beta) {
        (Some(alpha), Some(beta)) => Some(Klobuchar { alpha, beta }),
        _ => None,
    };
    Ok(NavData {
        orbits: out,
        ura_m,
        iono,
    })
}

/// The ephemeris of `prn` whose t_oe is nearest `t` (healthy, within 4 h).
pub fn select_ephemeris(ephs: &[KeplerOrbit], prn: u8, t: f64) -> Option<&KeplerOrbit> {
    ephs.iter()
        .filter(|e| e.prn == prn && e.health == 0 && (e.t_oe - t).abs() <= 4.0 * 3600.0)
        .min_by(|a, b| (a.t_oe - t).abs().total_cmp(&(b.t_oe - t).abs()))
}

/// One observation value with its loss-of-lock indicator.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ObsValue {
    pub value: f64,
    /// Loss of lock indicator (bit 0: lost lock → possible cycle slip).
    pub lli: u8,
}

/// One observation epoch.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ObsEpoch {
    /// Time tag, GPS seconds (receiver clock).
    pub t: f64,
    /// Epoch flag (0 OK, 1 power failure; events > 1 are skipped, not kept).
    pub flag: u8,
    /// (PRN, one value per observable of [`ObsFile::types`], `None` when blank).
    pub sats: Vec<(u8, Vec<Option<ObsValue>>)>,
}

/// A RINEX 2.xx or 3.0x observation file, GPS satellites only.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ObsFile {
    /// Format version from `RINEX VERSION / TYPE` (2.10, 2.11, 3.04, …).
    pub version: f64,
    pub marker: String,
    /// Header APPROX POSITION XYZ, ECEF [m].
    pub approx_pos: [f64; 3],
    /// GPS observable codes in order, RINEX 2 names (`L1`, `C1`, `L2`, `P2`, …).
    /// For RINEX 3 files each `SYS / # / OBS TYPES` GPS code is named by
    /// [`rinex2_name`]'s mapping when it is the preferred code for that name,
    /// else it keeps its 3-character RINEX 3 code (`L2L`, `C5Q`, …).
    pub types: Vec<String>,
    /// RINEX 3 only: the original GPS codes, parallel to `types` (empty for RINEX 2).
    pub codes: Vec<String>,
    pub epochs: Vec<ObsEpoch>,
    /// Non-GPS satellite entries (one per satellite and epoch) skipped.
    pub skipped_non_gps: usize,
    /// The same per system letter (`R`, `E`, `C`, `J`, `S`, `I`), sorted by letter.
    pub other_systems: Vec<(char, u64)>,
    /// Event records (epoch flag > 1) skipped.
    pub events_skipped: usize,
}

impl ObsFile {
    /// Index of an observable code.
    pub fn index(&self, code: &str) -> Option<usize> {
        self.types.iter().position(|t| t == code)
    }

    /// Count of skipped satellite entries of system `sys`.
    pub fn other_count(&self, sys: char) -> u64 {
        self.other_systems
            .iter()
            .find(|(c, _)| *c == sys)
            .map_or(0, |(_, n)| *n)
    }

    fn count_other(&mut self, sys: char) {
        self.skipped_non_gps += 1;
        match self.other_systems.binary_search_by(|(c, _)| c.cmp(&sys)) {
            Ok(k) => self.other_systems[k].1 += 1,
            Err(k) => self.other_systems.insert(k, (sys, 1)),
        }
    }
}

/// RINEX 2 name of a RINEX 3 GPS observation code and its preference rank
/// (lower wins when several codes map to one name). RINEX 3.04 Table 4 →
/// RINEX 2.11 §5.1:
///
/// | RINEX 3 (GPS)                       | RINEX 2 |
/// |-------------------------------------|---------|
/// | `C1C`                               | `C1`    |
/// | `C1W` > `C1P` > `C1Y`               | `P1`    |
/// | `C2W` > `C2P` > `C2Y` > `C2D`       | `P2`    |
/// | `C2L` > `C2X` > `C2S` > `C2C`       | `C2`    |
/// | `C5Q` > `C5X` > `C5I`               | `C5`    |
/// | `x1C` > `x1W` > `x1P` > `x1Y` > `x1S` > `x1L` > `x1X` > `x1M` > `x1N` | `x1` |
/// | `x2W` > `x2P` > `x2Y` > `x2D` > `x2L` > `x2X` > `x2S` > `x2C` > `x2M` > `x2N` | `x2` |
/// | `x5Q` > `x5X` > `x5I`               | `x5`    |
///
/// with `x` = `L` (phase), `D` (Doppler), `S` (signal strength). The L2
/// phase prefers the P(Y)-tracked `L2W` so it pairs with `P2`; an L2C-only
/// receiver gives `L2` from `L2L`/`L2X` and `C2`, but no `P2`.
pub fn rinex2_name(code: &str) -> Option<(String, u8)> {
    let b = code.as_bytes();
    if b.len() != 3 {
        return None;
    }
    let (kind, band, attr) = (b[0] as char, b[1] as char, b[2] as char);
    let rank = |order: &str| order.find(attr).map(|r| r as u8);
    let (name, r) = match (kind, band) {
        ('C', '1') if attr == 'C' => ("C1".to_string(), Some(0)),
        ('C', '1') => ("P1".to_string(), rank("WPY")),
        ('C', '2') => match rank("WPYD") {
            Some(r) => ("P2".to_string(), Some(r)),
            None => ("C2".to_string(), rank("LXSC")),
        },
        ('C', '5') => ("C5".to_string(), rank("QXI")),
        ('L' | 'D' | 'S', '1') => (format!("{kind}1"), rank("CWPYSLXMN")),
        ('L' | 'D' | 'S', '2') => (format!("{kind}2"), rank("WPYDLXSCMN")),
        ('L' | 'D' | 'S', '5') => (format!("{kind}5"), rank("QXI")),
        _ => return None,
    };
    r.map(|r| (name, r))
}

/// The `types` list for RINEX 3 GPS `codes` (see [`rinex2_name`]).
fn map_gps_codes(codes: &[String]) -> Vec<String> {
    let mapped: Vec<Option<(String, u8)>> = codes.iter().map(|c| rinex2_name(c)).collect();
    (0..codes.len())
        .map(|i| match &mapped[i] {
            Some((name, r)) => {
                let best = mapped.iter().enumerate().all(|(j, m)| match m {
                    Some((n2, r2)) if n2 == name && j != i => r < r2 || (r == r2 && i < j),
                    _ => true,
                });
                if best {
                    name.clone()
                } else {
                    codes[i].clone()
                }
            }
            None => codes[i].clone(),
        })
        .collect()
}

/// File bytes as text; invalid UTF-8 is an error naming its line.
fn text_of<'a>(bytes: &'a [u8], name: &str) -> Result<&'a str, ReadError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = bytes[..at].iter().filter(|&&c| c == b'\n').count() + 1;
        err(
            name,
            line,
            "<text>",
            format!("not UTF-8 text (byte {at}): not a RINEX text file (compressed?)"),
        )
    })
}

/// Read a RINEX 2.xx or 3.0x observation file (GPS satellites kept; others
/// counted per system and skipped).
pub fn read_obs(path: &Path) -> Result<ObsFile, ReadError> {
    let name = path.display().to_string();
    let bytes = crate::text::read_bytes_capped(path, u64::MAX)?;
    parse_obs(text_of(&bytes, &name)?, &name)
}

/// One satellite's observations: (system letter, PRN, one value per code
/// of that system's `SYS / # / OBS TYPES`).
pub type SatObs = (char, u8, Vec<Option<ObsValue>>);

/// Every system's observations of a RINEX 3 file, epoch by epoch parallel
/// to [`ObsFile::epochs`] (GPS included), with the RINEX 3 codes.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct GnssObs {
    /// Per system letter, its `SYS / # / OBS TYPES` codes.
    pub sys_codes: Vec<(char, Vec<String>)>,
    /// Per epoch: (system, PRN, one value per code of that system).
    pub epochs: Vec<Vec<SatObs>>,
}

impl GnssObs {
    /// Index of `code` among system `sys`'s codes.
    pub fn index(&self, sys: char, code: &str) -> Option<usize> {
        self.sys_codes
            .iter()
            .find(|(s, _)| *s == sys)
            .and_then(|(_, c)| c.iter().position(|x| x == code))
    }

    /// The first non-zero value among `codes` (in preference order) of one
    /// satellite's values `vals` of system `sys` (a zero is RINEX's "not
    /// tracked"); `None` when no code has one.
    pub fn first_value(&self, sys: char, codes: &[&str], vals: &[Option<ObsValue>]) -> Option<f64> {
        codes
            .iter()
            .filter_map(|c| self.index(sys, c))
            .filter_map(|i| vals.get(i).copied().flatten())
            .map(|v| v.value)
            .find(|v| *v != 0.0)
    }
}

/// Read an observation file keeping every system (RINEX 3; for RINEX 2 the
/// [`GnssObs`] is empty and the GPS observations are in the [`ObsFile`]).
pub fn read_obs_gnss(path: &Path) -> Result<(ObsFile, GnssObs), ReadError> {
    let name = path.display().to_string();
    let bytes = crate::text::read_bytes_capped(path, u64::MAX)?;
    parse_obs_gnss(text_of(&bytes, &name)?, &name)
}

/// [`parse_obs`] keeping every system's observations of a RINEX 3 file.
pub fn parse_obs_gnss(text: &str, name: &str) -> Result<(ObsFile, GnssObs), ReadError> {
    let mut g = GnssObs::default();
    let f = parse_obs_impl(text, name, Some(&mut g))?;
    Ok((f, g))
}

/// Parse RINEX 2.xx or 3.0x observation text (version from the
/// `RINEX VERSION / TYPE` line). Hatanaka-compressed (Compact RINEX) text is
/// recognised and refused with an error.
pub fn parse_obs(text: &str, name: &str) -> Result<ObsFile, ReadError> {
    parse_obs_impl(text, name, None)
}

fn parse_obs_impl(
    text: &str,
    name: &str,
    mut keep: Option<&mut GnssObs>,
) -> Result<ObsFile, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut f = ObsFile {
        version: 2.0,
        ..ObsFile::default()
    };
    // RINEX 3: per system letter, its observation codes.
    let mut sys_codes: Vec<(char, Vec<String>)> = Vec::new();
    let mut i = 0;
    let mut have_end = false;
    while i < lines.len() {
        let l = lines[i];
        let label = l.get(60..).unwrap_or("").trim();
        let ln = i + 1;
        i += 1;
        if label.starts_with("CRINEX VERS") || (ln == 1 && l.contains("COMPACT RINEX")) {
            return Err(err(
                name,
                ln,
                "CRINEX VERS / TYPE",
                "Hatanaka-compressed (Compact RINEX) observation file: not supported, \
                 expand it with CRX2RNX first",
            ));
        }
        match label {
            "RINEX VERSION / TYPE" => {
                let v: f64 = field(l, 0, 9)
                    .trim()
                    .parse()
                    .map_err(|_| err(name, ln, "RINEX version", "not a number"))?;
                if !(1.0..4.0).contains(&v) {
                    return Err(err(
                        name,
                        ln,
                        "RINEX version",
                        format!("{v}: only RINEX 2.xx and 3.0x observation files are read"),
                    ));
                }
                let ty = field(l, 20, 21);
                if ty != "O" {
                    return Err(err(
                        name,
                        ln,
                        "file type",
                        format!("`{ty}`: not an observation (`O`) file"),
                    ));
                }
                f.version = v;
            }
            "MARKER NAME" => f.marker = field(l, 0, 60).trim().to_string(),
            "APPROX POSITION XYZ" => {
                for k in 0..3 {
                    let s = field(l, k * 14, (k + 1) * 14);
                    f.approx_pos[k] = s.trim().parse().map_err(|_| {
                        err(
                            name,
                            ln,
                            "APPROX POSITION XYZ",
                            format!("not a number: `{}`", s.trim()),
                        )
                    })?;
                }
            }
            "# / TYPES OF OBSERV" if f.types.is_empty() && f.version < 3.0 => {
                let n: usize = field(l, 0, 6)
                    .trim()
                    .parse()
                    .map_err(|_| err(name, ln, "# / TYPES OF OBSERV", "bad count"))?;
                let mut cur = l;
                let mut cur_ln = ln;
                loop {
                    for k in 0..9 {
                        if f.types.len() == n {
                            break;
                        }
                        let c = field(cur, 6 + k * 6, 12 + k * 6).trim();
                        if !c.is_empty() {
                            f.types.push(c.to_string());
                        }
                    }
                    if f.types.len() >= n {
                        break;
                    }
                    let Some(next) = lines.get(i) else {
                        return Err(err(
                            name,
                            cur_ln,
                            "# / TYPES OF OBSERV",
                            "continuation line missing",
                        ));
                    };
                    cur = next;
                    cur_ln = i + 1;
                    i += 1;
                }
            }
            "SYS / # / OBS TYPES" if f.version >= 3.0 => {
                const L: &str = "SYS / # / OBS TYPES";
                let sys = l.chars().next().unwrap_or(' ');
                if !"GRECJSI".contains(sys) {
                    return Err(err(
                        name,
                        ln,
                        L,
                        format!("`{sys}` is not a satellite system (G R E C J S I)"),
                    ));
                }
                if sys_codes.iter().any(|(s, _)| *s == sys) {
                    return Err(err(name, ln, L, format!("system {sys} declared twice")));
                }
                let n: usize = field(l, 3, 6)
                    .trim()
                    .parse()
                    .map_err(|_| err(name, ln, L, "bad count"))?;
                let mut codes = Vec::with_capacity(n);
                let mut cur = l;
                loop {
                    for k in 0..13 {
                        if codes.len() == n {
                            break;
                        }
                        let c = field(cur, 7 + k * 4, 10 + k * 4).trim();
                        if !c.is_empty() {
                            codes.push(c.to_string());
                        }
                    }
                    if codes.len() >= n {
                        break;
                    }
                    // Continuation: blank system column, same label.
                    let next = lines.get(i).copied().unwrap_or("");
                    if !next.starts_with(' ') || next.get(60..).unwrap_or("").trim() != L {
                        return Err(err(
                            name,
                            i,
                            L,
                            format!("system {sys}: {n} codes announced, {} given", codes.len()),
                        ));
                    }
                    cur = next;
                    i += 1;
                }
                sys_codes.push((sys, codes));
            }
            "END OF HEADER" => {
                have_end = true;
                break;
            }
            _ => {}
        }
    }
    if !have_end {
        return Err(err(name, lines.len(), "<header>", "no END OF HEADER"));
    }
    if f.version >= 3.0 {
        if sys_codes.is_empty() {
            return Err(err(name, 1, "SYS / # / OBS TYPES", "missing from header"));
        }
        if let Some((_, c)) = sys_codes.iter().find(|(s, _)| *s == 'G') {
            f.types = map_gps_codes(c);
            f.codes = c.clone();
        }
        if let Some(g) = keep.as_deref_mut() {
            g.sys_codes = sys_codes.clone();
        }
        parse_obs_body_v3(&lines, i, name, &sys_codes, &mut f, keep)?;
        return Ok(f);
    }
    if f.types.is_empty() {
        return Err(err(name, 1, "# / TYPES OF OBSERV", "missing from header"));
    }
    let nt = f.types.len();
    let lines_per_sat = nt.div_ceil(5);
    while i < lines.len() {
        let l = lines[i];
        let ln = i + 1;
        if l.trim().is_empty() {
            i += 1;
            continue;
        }
        let num = |a: usize, b: usize, fname: &str| -> Result<f64, ReadError> {
            let s = field(l, a, b).trim();
            s.parse::<f64>()
                .map_err(|_| err(name, ln, fname, format!("not a number: `{s}`")))
        };
        let flag = num(28, 29, "epoch flag")? as u8;
        // A 3-digit count (a value like `inf` or `1e9` must not size a Vec).
        let nsat = num(29, 32, "number of satellites")?;
        if !(0.0..=999.0).contains(&nsat) || nsat.fract() != 0.0 {
            return Err(err(
                name,
                ln,
                "number of satellites",
                format!("not a count 0..999: {nsat}"),
            ));
        }
        let nsat = nsat as usize;
        if flag > 1 {
            // Event records: `nsat` header lines follow.
            f.events_skipped += 1;
            i += 1 + nsat;
            continue;
        }
        let y = two_digit_year(num(0, 3, "year")? as i32);
        let t = gps_seconds(
            y,
            num(3, 6, "month")? as u32,
            num(6, 9, "day")? as u32,
            num(9, 12, "hour")? as u32,
            num(12, 15, "minute")? as u32,
            num(15, 26, "second")?,
        );
        // Satellite list, 12 per line.
        let mut prns = Vec::with_capacity(nsat);
        let mut cur = l;
        let mut cur_ln = ln;
        i += 1;
        for k in 0..nsat {
            if k > 0 && k % 12 == 0 {
                let Some(next) = lines.get(i) else {
                    return Err(err(
                        name,
                        cur_ln,
                        "satellite list",
                        "continuation line missing",
                    ));
                };
                cur = next;
                cur_ln = i + 1;
                i += 1;
            }
            let p = field(cur, 32 + (k % 12) * 3, 35 + (k % 12) * 3);
            prns.push((cur_ln, p.to_string()));
        }
        let mut sats = Vec::with_capacity(nsat);
        let mut glo: Vec<SatObs> = Vec::new();
        for (pln, p) in prns {
            let sys = p.chars().next().unwrap_or(' ');
            let num_s = p.get(1..).unwrap_or("").trim();
            let mut vals = Vec::with_capacity(nt);
            for r in 0..lines_per_sat {
                let Some(ol) = lines.get(i + r) else {
                    return Err(err(name, i + r, "observation", "record truncated"));
                };
                for k in 0..5 {
                    if vals.len() == nt {
                        break;
                    }
                    let a = k * 16;
                    let s = field(ol, a, a + 14);
                    let v = ffloat(s).map_err(|m| err(name, i + r + 1, &f.types[vals.len()], m))?;
                    let lli = field(ol, a + 14, a + 15).trim().parse::<u8>().unwrap_or(0);
                    vals.push(v.map(|value| ObsValue { value, lli }));
                }
            }
            i += lines_per_sat;
            if sys != 'G' && sys != ' ' {
                f.count_other(sys);
                if sys == 'R' && keep.is_some() {
                    if let Ok(slot) = num_s.parse::<u8>() {
                        glo.push(('R', slot, vals));
                    }
                }
                continue;
            }
            let prn: u8 = num_s.parse().map_err(|_| {
                err(
                    name,
                    pln,
                    "satellite list",
                    format!("not a satellite: `{p}`"),
                )
            })?;
            sats.push((prn, vals));
        }
        // RINEX 2 GLONASS entries (counted as skipped in `f` as before) kept
        // with RINEX 3 codes, epochs parallel to `f.epochs` from the first
        // GLONASS entry on (a GPS-only file keeps an empty GnssObs).
        if let Some(g) = keep.as_deref_mut() {
            if !glo.is_empty() || !g.epochs.is_empty() {
                if g.sys_codes.is_empty() {
                    g.sys_codes = vec![('R', f.types.iter().map(|t| v2_glonass_code(t)).collect())];
                }
                g.epochs.resize(f.epochs.len(), Vec::new());
                g.epochs.push(glo);
            }
        }
        f.epochs.push(ObsEpoch { t, flag, sats });
    }
    Ok(f)
}

/// RINEX 3 code of a RINEX 2 GLONASS observable (RINEX 2.11 §5.1 and 3.04
/// Table 5): `C1` is the C/A code `C1C`, `P1` the P code `C1P`, `L1`/`D1`/
/// `S1` the C/A tracking's `L1C`/`D1C`/`S1C`; others keep their RINEX 2
/// name (not used by the single-frequency solvers).
fn v2_glonass_code(t: &str) -> String {
    match t {
        "C1" => "C1C",
        "P1" => "C1P",
        "L1" => "L1C",
        "D1" => "D1C",
        "S1" => "S1C",
        _ => t,
    }
    .to_string()
}

/// RINEX 3.0x observation records (RINEX 3.04 §5.2, Table A3): an epoch line
/// `> yyyy mm dd hh mm ss.sssssss  f nnn`, then one line per satellite,
/// `snn` followed by 16-column fields (F14.3 value, LLI, SSI) in the order of
/// that system's `SYS / # / OBS TYPES`. Event epochs (flag > 1) are skipped
/// with their `nnn` special records (header lines, or cycle-slip records for
/// flag 6), as in RINEX 2; header changes inside the file (flag 4) are not
/// applied.
fn parse_obs_body_v3(
    lines: &[&str],
    mut i: usize,
    name: &str,
    sys_codes: &[(char, Vec<String>)],
    f: &mut ObsFile,
    mut keep: Option<&mut GnssObs>,
) -> Result<(), ReadError> {
    while i < lines.len() {
        let l = lines[i];
        let ln = i + 1;
        if l.trim().is_empty() {
            i += 1;
            continue;
        }
        if !l.starts_with('>') {
            return Err(err(
                name,
                ln,
                "epoch line",
                format!(
                    "expected `>` record marker, found `{}`",
                    field(l, 0, 20).trim_end()
                ),
            ));
        }
        let int = |a: usize, b: usize, fname: &str, lo: u32, hi: u32| -> Result<u32, ReadError> {
            let s = field(l, a, b).trim();
            match s.parse::<u32>() {
                Ok(v) if (lo..=hi).contains(&v) => Ok(v),
                _ => Err(err(
                    name,
                    ln,
                    fname,
                    format!("not an integer {lo}..{hi}: `{s}`"),
                )),
            }
        };
        let flag = int(31, 32, "epoch flag", 0, 6)? as u8;
        let nsat = int(32, 35, "number of satellites", 0, 999)? as usize;
        if flag > 1 {
            f.events_skipped += 1;
            i += 1 + nsat;
            continue;
        }
        let sec_s = field(l, 18, 29).trim();
        let sec = sec_s
            .parse::<f64>()
            .ok()
            .filter(|s| (0.0..61.0).contains(s))
            .ok_or_else(|| err(name, ln, "second", format!("not a second 0..61: `{sec_s}`")))?;
        let t = gps_seconds(
            int(2, 6, "year", 1980, 2200)? as i32,
            int(7, 9, "month", 1, 12)?,
            int(10, 12, "day", 1, 31)?,
            int(13, 15, "hour", 0, 23)?,
            int(16, 18, "minute", 0, 59)?,
            sec,
        );
        let mut sats = Vec::with_capacity(nsat.min(64));
        let mut all = Vec::new();
        for k in 0..nsat {
            let sl = i + 1 + k;
            let s = match lines.get(sl) {
                Some(s) if !s.starts_with('>') => *s,
                next => {
                    let where_ = if next.is_some() {
                        format!("the next epoch starts at line {}", sl + 1)
                    } else {
                        "the file ends".to_string()
                    };
                    return Err(err(
                        name,
                        ln,
                        "number of satellites",
                        format!("{nsat} announced, {where_} after {k}"),
                    ));
                }
            };
            let sln = sl + 1;
            let sys = s.chars().next().unwrap_or(' ');
            let id = field(s, 0, 3);
            let Some((_, codes)) = sys_codes.iter().find(|(c, _)| *c == sys) else {
                return Err(err(
                    name,
                    sln,
                    "satellite",
                    format!("`{id}`: system not in SYS / # / OBS TYPES"),
                ));
            };
            let prn: u8 = field(s, 1, 3)
                .trim()
                .parse()
                .ok()
                .filter(|p| *p > 0)
                .ok_or_else(|| err(name, sln, "satellite", format!("not a satellite: `{id}`")))?;
            let mut vals = Vec::with_capacity(codes.len());
            for (j, code) in codes.iter().enumerate() {
                let a = 3 + 16 * j;
                let v = ffloat(field(s, a, a + 14)).map_err(|m| err(name, sln, code, m))?;
                let lli_s = field(s, a + 14, a + 15);
                let lli = match lli_s.trim() {
                    "" => 0,
                    d => d.parse::<u8>().map_err(|_| {
                        err(
                            name,
                            sln,
                            &format!("{code} LLI"),
                            format!("not a digit: `{d}`"),
                        )
                    })?,
                };
                vals.push(v.map(|value| ObsValue { value, lli }));
            }
            if keep.is_some() {
                all.push((sys, prn, vals.clone()));
            }
            if sys == 'G' {
                sats.push((prn, vals));
            } else {
                f.count_other(sys);
            }
        }
        i += 1 + nsat;
        f.epochs.push(ObsEpoch { t, flag, sats });
        if let Some(g) = keep.as_deref_mut() {
            g.epochs.push(all);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAV: &str =
        "     2              NAVIGATION DATA                         RINEX VERSION / TYPE
                                                            END OF HEADER
 1 10  7  1  0  0  0.0-0.136290676892D-03-0.397903932026D-11 0.000000000000D+00
    0.630000000000D+02-0.897500000000D+02 0.468055210664D-08-0.307674634178D+01
   -0.476092100143D-05 0.483528291807D-02 0.545941293240D-05 0.515480139732D+04
    0.345600000000D+06 0.558793544769D-08 0.292603518708D+01-0.931322574615D-07
    0.965451250348D+00 0.278437500000D+03 0.884778937154D+00-0.813998192006D-08
   -0.171792870148D-09 0.100000000000D+01 0.159000000000D+04 0.000000000000D+00
    0.200000000000D+01 0.630000000000D+02-0.190921127796D-07 0.630000000000D+02
    0.341670000000D+06 0.000000000000D+00 0.000000000000D+00 0.000000000000D+00
";

    #[test]
    fn gps_time_of_known_dates() {
        assert_eq!(gps_seconds(1980, 1, 6, 0, 0, 0.0), 0.0);
        // 2010-07-01 is Thursday of GPS week 1590 (t_oe 345600 = Thursday 00:00).
        assert_eq!(
            gps_seconds(2010, 7, 1, 0, 0, 0.0),
            1590.0 * SECONDS_PER_WEEK + 345_600.0
        );
    }

    #[test]
    fn parses_nav_record() {
        let v = parse_nav(NAV, "t.n").unwrap();
        assert_eq!(v.len(), 1);
        let e = &v[0];
        assert_eq!(e.prn, 1);
        assert_eq!(e.t_oe, 1590.0 * SECONDS_PER_WEEK + 345_600.0);
        assert_eq!(e.t_oc, e.t_oe);
        assert!((e.sqrt_a - 5154.80139732).abs() < 1e-6);
        assert!((e.tgd + 1.90921127796e-8).abs() < 1e-18);
        let r = e.position_ecef(e.t_oe).norm();
        assert!((r - 2.656e7).abs() < 2e5);
    }

    /// The header's Klobuchar coefficients (RINEX 2 and RINEX 3 labels) and
    /// each record's SV accuracy come through `parse_nav_data`.
    #[test]
    fn nav_header_ionosphere_and_accuracy() {
        let ion2 = "    1.1180D-08  1.4900D-08 -5.9600D-08 -5.9600D-08          ION ALPHA\n    8.8060D+04  1.6380D+04 -1.9660D+05 -1.3110D+05          ION BETA\n";
        let text = NAV.replacen("\n", &format!("\n{ion2}"), 1);
        let d = parse_nav_data(&text, "t.n").unwrap();
        let k = d.iono.expect("ionosphere");
        assert_eq!(k.alpha, [1.118e-8, 1.49e-8, -5.96e-8, -5.96e-8]);
        assert_eq!(k.beta, [8.806e4, 1.638e4, -1.966e5, -1.311e5]);
        assert_eq!(d.ura_m, [2.0]);
        assert_eq!(d.orbits.len(), 1);
        // RINEX 3 `IONOSPHERIC CORR` lines.
        let ion3 = "GPSA   1.1180D-08  1.4900D-08 -5.9600D-08 -5.9600D-08       IONOSPHERIC CORR\nGPSB   8.8060D+04  1.6380D+04 -1.9660D+05 -1.3110D+05       IONOSPHERIC CORR\n";
        let text = NAV.replacen("\n", &format!("\n{ion3}"), 1);
        assert_eq!(parse_nav_data(&text, "t.n").unwrap().iono, Some(k));
        // Without the header lines there is no model; a bad number is named.
        assert_eq!(parse_nav_data(NAV, "t.n").unwrap().iono, None);
        let bad = text.replace("8.8060D+04", "8.80x0D+04");
        let e = parse_nav_data(&bad, "t.n").unwrap_err().to_string();
        assert!(e.starts_with("t.n:3: field `GPSB`"), "{e}");
    }

    #[test]
    fn nav_errors_name_line_and_field() {
        let bad = NAV.replace("0.515480139732D+04", "0.5154801397x2D+04");
        let e = parse_nav(&bad, "t.n").unwrap_err().to_string();
        assert!(e.starts_with("t.n:5: field `sqrtA`: not a number"), "{e}");
        let trunc: String = NAV.lines().take(6).collect::<Vec<_>>().join("\n");
        let e = parse_nav(&trunc, "t.n").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        // A NaN/inf orbit or clock term is named, not propagated (Rust's
        // float parser accepts both spellings).
        let nan = NAV.replace("0.483528291807D-02", "               NaN");
        let e = parse_nav(&nan, "t.n").unwrap_err().to_string();
        assert!(e.starts_with("t.n:5: field `e`: not finite"), "{e}");
        let inf = NAV.replace("-0.397903932026D-11", "                inf");
        let e = parse_nav(&inf, "t.n").unwrap_err().to_string();
        assert!(e.starts_with("t.n:3: field `af1`: not finite"), "{e}");
    }

    const OBS: &str =
        "     2.10           OBSERVATION DATA    G (GPS)             RINEX VERSION / TYPE
 -3976219.5082  3382372.5671  3652512.9849                  APPROX POSITION XYZ
     4    L1    C1    L2    P2                              # / TYPES OF OBSERV
                                                            END OF HEADER
 05  4  2  0  0  0.0000000  0  2G 3G 7
  55923622.160    24767686.375    43647388.2424   24767684.8224
   -691177.8981   24361933.475                    24361930.5994
";

    #[test]
    fn parses_obs_epoch() {
        let f = parse_obs(OBS, "t.o").unwrap();
        assert_eq!(f.types, ["L1", "C1", "L2", "P2"]);
        assert_eq!(f.approx_pos[0], -3976219.5082);
        assert_eq!(f.epochs.len(), 1);
        let e = &f.epochs[0];
        assert_eq!(e.t, gps_seconds(2005, 4, 2, 0, 0, 0.0));
        assert_eq!(e.sats.len(), 2);
        assert_eq!(e.sats[1].0, 7);
        let l1 = e.sats[1].1[0].unwrap();
        assert_eq!(l1.value, -691177.898);
        assert_eq!(l1.lli, 1);
        assert!(e.sats[1].1[2].is_none());
        assert_eq!(e.sats[0].1[3].unwrap().value, 24767684.822);
    }

    #[test]
    fn obs_errors_name_line_and_field() {
        let bad = OBS.replace("24361933.475", "2436x933.475");
        let e = parse_obs(&bad, "t.o").unwrap_err().to_string();
        assert!(e.starts_with("t.o:7: field `C1`: not a number"), "{e}");
        let e = parse_obs("garbage\n", "t.o").unwrap_err().to_string();
        assert!(e.contains("END OF HEADER"), "{e}");
    }

    /// RINEX 3.04, mixed: GPS (9 codes, two for L2), GLONASS, Galileo (16
    /// codes: a continuation line), 3 epochs + 1 event record (flag 4).
    const OBS3: &str = include_str!("../testdata/rinex3_mixed.rnx");

    /// The same observations as RINEX 2.11 (types in another order).
    const OBS2: &str =
        "     2.11           OBSERVATION DATA    M (MIXED)           RINEX VERSION / TYPE
TEST                                                        MARKER NAME
 -3976219.5082  3382372.5671  3652512.9849                  APPROX POSITION XYZ
     7    L1    L2    C1    P2    C2    D1    S1            # / TYPES OF OBSERV
                                                            END OF HEADER
 20  6 30  0  0  0.0000000  0  4G05R03G12E11
 105100710.028 7  81896657.165 5  20000000.125 7  20000003.250 5  20000003.625 6
     -1234.567          45.250
 112000000.250                    21000000.500

 120865819.718 7  94181158.222 5  23000000.750 7  23000003.875 5  23000004.250 6
     -1234.567          45.250
  25000001.000                    25000000.000
  25000002.000    25000003.000
                            4  1
an event with one header line                               COMMENT
 20  6 30  0  0 30.0000000  0  3G05E11G12
 105116477.105 7  81908943.199 5  20003000.500 7  20003003.625 5  20003004.000 6
     -1234.567          45.250
                                  25001000.000

 120855307.020 7  94172966.50915  22998000.250 7  22998003.375 5  22998003.750 6
     -1234.567          45.250
 20  6 30  0  1  0.0000000  0  3G12R03R04
 120844795.635 7  94164775.820 5  22996000.000 7  22996003.125 5  22996003.500 6
     -1234.567          45.250
                                  21002000.500

                                  21500000.500

";

    fn val(f: &ObsFile, e: usize, s: usize, code: &str) -> Option<ObsValue> {
        f.epochs[e].sats[s].1[f.index(code).unwrap()]
    }

    /// `parse_obs_gnss` keeps every system, epoch by epoch parallel to the
    /// GPS-only `ObsFile`, with the GPS values identical.
    #[test]
    fn rinex3_all_systems_are_kept() {
        let (f, g) = parse_obs_gnss(OBS3, "t.rnx").unwrap();
        assert_eq!(f, parse_obs(OBS3, "t.rnx").unwrap());
        assert_eq!(g.epochs.len(), f.epochs.len());
        let sys: Vec<char> = g.sys_codes.iter().map(|(s, _)| *s).collect();
        assert!(sys.contains(&'G') && sys.contains(&'R') && sys.contains(&'E'));
        assert_eq!(
            g.sys_codes.iter().find(|(s, _)| *s == 'E').unwrap().1.len(),
            16
        );
        let mut others = 0u64;
        for (e, ge) in f.epochs.iter().zip(&g.epochs) {
            let gps: Vec<_> = ge
                .iter()
                .filter(|(s, _, _)| *s == 'G')
                .map(|(_, p, v)| (*p, v.clone()))
                .collect();
            assert_eq!(gps, e.sats);
            others += ge.iter().filter(|(s, _, _)| *s != 'G').count() as u64;
        }
        assert_eq!(others as usize, f.skipped_non_gps);
        assert!(others > 0);
        let i = g.index('E', "C1C").expect("Galileo C1C");
        assert!(g.epochs[0]
            .iter()
            .any(|(s, p, v)| *s == 'E' && *p == 11 && v[i].is_some()));
        // RINEX 2: GLONASS entries kept with RINEX 3 codes (C1 → C1C),
        // epochs parallel to the ObsFile's (R03 in the first epoch, none in
        // the second, R03 and R04 in the last); nothing else.
        let (f2, g2) = parse_obs_gnss(OBS2, "t.o").unwrap();
        assert_eq!(g2.epochs.len(), f2.epochs.len());
        assert_eq!(g2.epochs[0].len(), 1);
        assert_eq!(
            g2.epochs[0][0].2[g2.index('R', "C1C").unwrap()]
                .unwrap()
                .value,
            21000000.5
        );
        assert!(g2.epochs[1].is_empty());
        let last = g2.epochs.last().unwrap();
        assert_eq!(
            last.iter().map(|x| (x.0, x.1)).collect::<Vec<_>>(),
            [('R', 3), ('R', 4)]
        );
        let i = g2.index('R', "C1C").unwrap();
        assert_eq!(last[0].2[i].unwrap().value, 21002000.5);
        assert_eq!(g2.index('R', "D1C"), f2.index("D1"));
        assert_eq!(f2, parse_obs(OBS2, "t.o").unwrap());
    }

    #[test]
    fn parses_rinex3_obs() {
        let f = parse_obs(OBS3, "t.rnx").unwrap();
        assert_eq!(f.version, 3.04);
        assert_eq!(f.marker, "TEST");
        assert_eq!(f.approx_pos, [-3976219.5082, 3382372.5671, 3652512.9849]);
        assert_eq!(
            f.codes,
            ["C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "C2L", "L2L", "C5Q"]
        );
        assert_eq!(
            f.types,
            ["C1", "L1", "D1", "S1", "P2", "L2", "C2", "L2L", "C5"]
        );
        assert_eq!(f.epochs.len(), 3);
        assert_eq!(f.events_skipped, 1);
        let t0 = gps_seconds(2020, 6, 30, 0, 0, 0.0);
        let ts: Vec<f64> = f.epochs.iter().map(|e| e.t - t0).collect();
        assert_eq!(ts, [0.0, 30.0, 60.0]);
        let prns: Vec<Vec<u8>> = f
            .epochs
            .iter()
            .map(|e| e.sats.iter().map(|s| s.0).collect())
            .collect();
        assert_eq!(prns, [vec![5, 12], vec![5, 12], vec![12]]);
        // Every GPS satellite line carries 9 fields, C5Q blank: 5 × 8 values.
        let n: usize = f
            .epochs
            .iter()
            .flat_map(|e| &e.sats)
            .map(|(_, v)| {
                assert_eq!(v.len(), 9);
                v.iter().flatten().count()
            })
            .sum();
        assert_eq!(n, 40);
        assert_eq!(f.other_systems, [('E', 2), ('R', 3)]);
        assert_eq!((f.other_count('R'), f.other_count('C')), (3, 0));
        assert_eq!(f.skipped_non_gps, 5);
        let v = |e, s, c| val(&f, e, s, c).unwrap();
        assert_eq!(v(0, 0, "C1").value, 20000000.125);
        assert_eq!(v(0, 0, "L1").value, 105100710.028);
        assert_eq!(v(0, 0, "D1").value, -1234.567);
        assert_eq!(v(0, 0, "S1").value, 45.25);
        assert_eq!(v(0, 0, "P2").value, 20000003.25);
        assert_eq!(v(0, 0, "L2").value, 81896657.165);
        assert_eq!(v(0, 0, "C2").value, 20000003.625);
        assert_eq!(v(0, 0, "L2L").value, 81896657.415);
        assert!(val(&f, 0, 0, "C5").is_none());
        assert_eq!(v(2, 0, "C1").value, 22996000.0);
        // LLI kept (SSI digits do not leak into it).
        assert_eq!(v(1, 1, "L2").lli, 1);
        assert_eq!(v(1, 1, "L2").value, 94172966.509);
        assert_eq!(v(1, 1, "L1").lli, 0);
        assert_eq!(v(1, 0, "L2").lli, 0);
    }

    #[test]
    fn rinex2_and_rinex3_give_the_same_gps_observations() {
        let f3 = parse_obs(OBS3, "t.rnx").unwrap();
        let f2 = parse_obs(OBS2, "t.o").unwrap();
        assert_eq!(f2.version, 2.11);
        assert!(f2.codes.is_empty());
        assert_eq!(f2.epochs.len(), 3);
        assert_eq!(f2.events_skipped, 1);
        assert_eq!(f2.other_systems, f3.other_systems);
        let mut compared = 0;
        for (e2, e3) in f2.epochs.iter().zip(&f3.epochs) {
            assert_eq!((e2.t, e2.flag), (e3.t, e3.flag));
            assert_eq!(e2.sats.len(), e3.sats.len());
            for ((p2, v2), (p3, v3)) in e2.sats.iter().zip(&e3.sats) {
                assert_eq!(p2, p3);
                for c in ["C1", "L1", "D1", "S1", "P2", "L2", "C2"] {
                    let a = v2[f2.index(c).unwrap()];
                    assert_eq!(a, v3[f3.index(c).unwrap()], "{c} G{p2}");
                    assert!(a.is_some());
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 5 * 7);
    }

    #[test]
    fn rinex3_gps_codes_map_to_rinex2_names() {
        let m = |c: &[&str]| map_gps_codes(&c.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        assert_eq!(m(&["C1C", "L1C", "L2W", "C2W"]), ["C1", "L1", "L2", "P2"]);
        assert_eq!(m(&["L2X", "C2X", "C1W"]), ["L2", "C2", "P1"]);
        // L2W wins over L2L whatever the order; the loser keeps its code.
        assert_eq!(m(&["L2L", "C2L", "L2W", "C2W"]), ["L2L", "C2", "L2", "P2"]);
        assert_eq!(
            m(&["L1W", "L1C", "S5Q", "X1C", "C1"]),
            ["L1W", "L1", "S5", "X1C", "C1"]
        );
        assert_eq!(rinex2_name("C2D"), Some(("P2".to_string(), 3)));
        assert_eq!(rinex2_name("C1X"), None);
    }

    #[test]
    fn rinex3_errors_name_line_and_field() {
        let e = |t: &str| parse_obs(t, "t.rnx").unwrap_err().to_string();
        // Truncated epoch line.
        let bad = OBS3.replace("> 2020 06 30 00 00  0.0000000  0  4", "> 2020 06 30 00");
        let m = e(&bad);
        assert!(m.starts_with("t.rnx:9: field `epoch flag`: "), "{m}");
        let bad = OBS3.replace(" 0.0000000  0  4", " 0.00x0000  0  4");
        let m = e(&bad);
        assert!(m.starts_with("t.rnx:9: field `second`: "), "{m}");
        // Bad number in a field.
        let m = e(&OBS3.replace("23000003.875", "2300x003.875"));
        assert!(m.starts_with("t.rnx:12: field `C2W`: not a number"), "{m}");
        let m = e(&OBS3.replace("94172966.50915", "94172966.509x5"));
        assert!(
            m.starts_with("t.rnx:19: field `L2W LLI`: not a digit"),
            "{m}"
        );
        // Wrong satellite count, both ways.
        let m = e(&OBS3.replace(" 0.0000000  0  4", " 0.0000000  0  5"));
        assert!(
            m.starts_with("t.rnx:9: field `number of satellites`: 5 announced, the next epoch starts at line 14 after 4"),
            "{m}"
        );
        let m = e(&OBS3.replace(" 0.0000000  0  4", " 0.0000000  0  3"));
        assert!(
            m.starts_with("t.rnx:13: field `epoch line`: expected `>`"),
            "{m}"
        );
        let trunc: String = OBS3.lines().take(10).map(|l| format!("{l}\n")).collect();
        let m = e(&trunc);
        assert!(
            m.contains(":9: field `number of satellites`: 4 announced, the file ends after 1"),
            "{m}"
        );
        // Satellite of an undeclared system; missing code continuation.
        let m = e(&OBS3.replace("R04", "C04"));
        assert!(m.starts_with("t.rnx:23: field `satellite`: `C04`"), "{m}");
        let m = e(&OBS3.replace("       L8Q D8Q S8Q", "E      L8Q D8Q S8Q"));
        assert!(
            m.contains("field `SYS / # / OBS TYPES`: system E: 16 codes announced, 13 given"),
            "{m}"
        );
        // Hatanaka and versions we do not read.
        let crx =
            "1.0                 COMPACT RINEX FORMAT                    CRINEX VERS   / TYPE\n";
        let m = e(&format!("{crx}{OBS3}"));
        assert!(
            m.starts_with("t.rnx:1: field `CRINEX VERS / TYPE`: Hatanaka"),
            "{m}"
        );
        let m = e(&OBS3.replacen("3.04", "4.01", 1));
        assert!(m.starts_with("t.rnx:1: field `RINEX version`"), "{m}");
        let m = e(&OBS3.replacen("OBSERVATION DATA", "NAVIGATION DATA ", 1));
        assert!(m.starts_with("t.rnx:1: field `file type`"), "{m}");
    }

    #[test]
    fn non_utf8_obs_file_is_an_error_naming_the_line() {
        let mut b = OBS3.as_bytes().to_vec();
        let at = OBS3.find("R03").unwrap(); // line 11
        b[at + 1] = 0xFF;
        let p = std::env::temp_dir().join(format!("navfuse_rinex3_{}.rnx", std::process::id()));
        std::fs::write(&p, &b).unwrap();
        let r = read_obs(&p);
        let _ = std::fs::remove_file(&p);
        let m = r.unwrap_err().to_string();
        assert!(m.contains(".rnx:11: field `<text>`: not UTF-8"), "{m}");
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn reads_shared_rinex() {
        let nav = read_nav(&crate::data::require("gnss/rinex/brdc1820.10n")).unwrap();
        assert!(nav.len() > 200, "{}", nav.len());
        let obs = read_obs(&crate::data::require("gnss/rinex/07590920.05o")).unwrap();
        assert_eq!(obs.epochs.len(), 120);
        assert!(obs.epochs.iter().all(|e| e.sats.len() >= 7));
        assert!(obs.version < 3.0 && obs.codes.is_empty());
    }

    /// Test-only RINEX 3.04 writer for a GPS [`ObsFile`] with RINEX 2 types.
    fn to_rinex3(f: &ObsFile) -> String {
        let v3 = |c: &str| match c {
            "C1" => "C1C",
            "P1" => "C1W",
            "P2" => "C2W",
            "C2" => "C2L",
            "L1" | "D1" | "S1" => ["L1C", "D1C", "S1C"]["LDS".find(&c[..1]).unwrap()],
            "L2" | "D2" | "S2" => ["L2W", "D2W", "S2W"]["LDS".find(&c[..1]).unwrap()],
            _ => panic!("no RINEX 3 code for {c}"),
        };
        let h = |t: String, l: &str| format!("{t:<60}{l}\n");
        let mut s = h(
            format!("{:9.2}{:11}{:<20}{:<20}", 3.04, "", "O", "G"),
            "RINEX VERSION / TYPE",
        );
        s += &h(f.marker.clone(), "MARKER NAME");
        let p = f.approx_pos;
        s += &h(
            format!("{:14.4}{:14.4}{:14.4}", p[0], p[1], p[2]),
            "APPROX POSITION XYZ",
        );
        let codes: String = f.types.iter().map(|c| format!(" {}", v3(c))).collect();
        s += &h(
            format!("G  {:3}{codes}", f.types.len()),
            "SYS / # / OBS TYPES",
        );
        s += &h(String::new(), "END OF HEADER");
        for e in &f.epochs {
            // Back from GPS seconds to the calendar (the test's epochs are in 2005).
            let d0 = gps_seconds(2005, 1, 1, 0, 0, 0.0);
            let (mut day, sod) = (
                ((e.t - d0) / 86_400.0).floor() as u32,
                (e.t - d0).rem_euclid(86_400.0),
            );
            let mut mo = 1;
            let ml = [31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
            while day >= ml[mo - 1] {
                day -= ml[mo - 1];
                mo += 1;
            }
            let (hh, mm, ss) = (
                (sod / 3600.0) as u32,
                ((sod % 3600.0) / 60.0) as u32,
                sod % 60.0,
            );
            s += &format!(
                "> 2005 {mo:02} {:02} {hh:02} {mm:02}{ss:11.7}  {}{:3}\n",
                day + 1,
                e.flag,
                e.sats.len()
            );
            for (prn, vals) in &e.sats {
                s += &format!("G{prn:02}");
                for v in vals {
                    s += &match v {
                        Some(o) if o.lli != 0 => format!("{:14.3}{} ", o.value, o.lli),
                        Some(o) => format!("{:14.3}  ", o.value),
                        None => " ".repeat(16),
                    };
                }
                s += "\n";
            }
        }
        s
    }

    /// The GEONET RINEX 2.10 files written as RINEX 3.04 read back to the same
    /// epochs, satellites and values (what the carrier-phase code consumes).
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn shared_rinex2_rewritten_as_rinex3_reads_the_same() {
        for file in ["gnss/rinex/07590920.05o", "gnss/rinex/30400920.05o"] {
            let f2 = read_obs(&crate::data::require(file)).unwrap();
            let text = to_rinex3(&f2);
            let f3 = parse_obs(&text, "rewritten.rnx").unwrap();
            assert_eq!(f3.version, 3.04);
            assert_eq!(f3.types, f2.types, "{file}");
            assert_eq!(f3.epochs.len(), f2.epochs.len());
            assert_eq!(f3.epochs.len(), 120);
            let mut n = 0;
            for (a, b) in f2.epochs.iter().zip(&f3.epochs) {
                assert!((a.t - b.t).abs() < 1e-6, "{} {}", a.t, b.t);
                assert_eq!(a.sats, b.sats, "{file} t={}", a.t);
                n += a
                    .sats
                    .iter()
                    .map(|(_, v)| v.iter().flatten().count())
                    .sum::<usize>();
            }
            assert!(n > 120 * 7 * 3, "{n} values");
            println!(
                "{file}: {} epochs, {n} GPS values identical through RINEX 3",
                f3.epochs.len()
            );
        }
    }
}
