//! RINEX 2.x GPS navigation and observation readers (RINEX 2.11 spec,
//! Gurtner & Estey). Navigation records become [`KeplerOrbit`]s; observation
//! epochs keep every observable in its header order, in the file's units
//! (carrier phase in cycles, pseudorange in metres) with the loss-of-lock
//! indicator. Times are GPS seconds since the GPS epoch. Errors name file,
//! line and field. RINEX 3 navigation files (`G` records) are read too.

use crate::ReadError;
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};
use std::path::Path;
use std::sync::Arc;

fn err(file: &str, line: usize, field: &str, msg: impl Into<String>) -> ReadError {
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
fn ffloat(s: &str) -> Result<Option<f64>, String> {
    let t = s.trim();
    if t.is_empty() {
        return Ok(None);
    }
    t.replace(['D', 'd'], "E")
        .parse::<f64>()
        .map(Some)
        .map_err(|_| format!("not a number: `{t}`"))
}

fn field(line: &str, a: usize, b: usize) -> &str {
    let b = b.min(line.len());
    if a >= b {
        ""
    } else {
        line.get(a..b).unwrap_or("")
    }
}

/// Read a RINEX 2 (or 3) GPS navigation file.
pub fn read_nav(path: &Path) -> Result<Vec<KeplerOrbit>, ReadError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(&name, 0, "<file>", format!("cannot read: {e}")))?;
    parse_nav(&text, &name)
}

/// Parse RINEX navigation text; `name` is used in errors.
pub fn parse_nav(text: &str, name: &str) -> Result<Vec<KeplerOrbit>, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    let mut version = 2.0;
    while i < lines.len() {
        let l = lines[i];
        if l.get(60..).is_some_and(|r| r.starts_with("RINEX VERSION")) {
            version = field(l, 0, 9).trim().parse().unwrap_or(2.0);
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
    while i < lines.len() {
        let l0 = lines[i];
        if l0.trim().is_empty() {
            i += 1;
            continue;
        }
        let ln0 = i + 1;
        if v3 && !l0.starts_with('G') {
            // Other constellations: skip the record (GLONASS/SBAS 4 lines, others 8).
            let n = match l0.chars().next() {
                Some('R') | Some('S') => 4,
                _ => 8,
            };
            i += n;
            continue;
        }
        // Epoch line.
        let (prn_s, date_fields, clk_start, w) = if v3 {
            (
                field(l0, 1, 3),
                vec![(4, 8), (9, 11), (12, 14), (15, 17), (18, 20), (21, 23)],
                23,
                19,
            )
        } else {
            (
                field(l0, 0, 2),
                vec![(3, 5), (6, 8), (9, 11), (12, 14), (15, 17), (17, 22)],
                22,
                19,
            )
        };
        let prn: u8 = prn_s
            .trim()
            .parse()
            .map_err(|_| err(name, ln0, "PRN", format!("not a PRN: `{}`", prn_s.trim())))?;
        let mut dt = [0.0f64; 6];
        for (k, (a, b)) in date_fields.iter().enumerate() {
            let s = field(l0, *a, *b).trim();
            dt[k] = s.parse().map_err(|_| {
                err(
                    name,
                    ln0,
                    ["year", "month", "day", "hour", "minute", "second"][k],
                    format!("not a number: `{s}`"),
                )
            })?;
        }
        let year = two_digit_year(dt[0] as i32);
        let t_oc = gps_seconds(
            year,
            dt[1] as u32,
            dt[2] as u32,
            dt[3] as u32,
            dt[4] as u32,
            dt[5],
        );
        let off = if v3 { 4 } else { 3 };
        let mut v = [0.0f64; 29];
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
        for k in 0..3 {
            let s = field(l0, clk_start + k * w, clk_start + (k + 1) * w);
            v[k] = ffloat(s)
                .map_err(|m| err(name, ln0, names[k], m))?
                .ok_or_else(|| err(name, ln0, names[k], "blank"))?;
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
                let s = field(l, off + k * w, off + (k + 1) * w);
                match ffloat(s).map_err(|m| err(name, ln + 1, names[idx], m))? {
                    Some(x) => v[idx] = x,
                    None if idx <= 22 || idx == 24 || idx == 25 => {
                        return Err(err(name, ln + 1, names[idx], "blank"))
                    }
                    None => {}
                }
            }
        }
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
        i += 8;
    }
    Ok(out)
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
    pub flag: u8,
    /// (PRN, one value per header observable, `None` when blank).
    pub sats: Vec<(u8, Vec<Option<ObsValue>>)>,
}

/// A RINEX 2 observation file.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ObsFile {
    pub marker: String,
    /// Header APPROX POSITION XYZ, ECEF [m].
    pub approx_pos: [f64; 3],
    /// Observable codes in order (`L1`, `C1`, `L2`, `P2`, …).
    pub types: Vec<String>,
    pub epochs: Vec<ObsEpoch>,
    /// Non-GPS satellite entries skipped.
    pub skipped_non_gps: usize,
}

impl ObsFile {
    /// Index of an observable code.
    pub fn index(&self, code: &str) -> Option<usize> {
        self.types.iter().position(|t| t == code)
    }
}

/// Read a RINEX 2 observation file (GPS satellites; others counted and skipped).
pub fn read_obs(path: &Path) -> Result<ObsFile, ReadError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(&name, 0, "<file>", format!("cannot read: {e}")))?;
    parse_obs(&text, &name)
}

/// Parse RINEX 2 observation text.
pub fn parse_obs(text: &str, name: &str) -> Result<ObsFile, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut f = ObsFile::default();
    let mut i = 0;
    let mut have_end = false;
    while i < lines.len() {
        let l = lines[i];
        let label = l.get(60..).unwrap_or("").trim();
        let ln = i + 1;
        i += 1;
        match label {
            "RINEX VERSION / TYPE" => {
                let v: f64 = field(l, 0, 9)
                    .trim()
                    .parse()
                    .map_err(|_| err(name, ln, "RINEX version", "not a number"))?;
                if v >= 3.0 {
                    return Err(err(
                        name,
                        ln,
                        "RINEX version",
                        format!("{v}: only RINEX 2 observation files are read"),
                    ));
                }
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
            "# / TYPES OF OBSERV" if f.types.is_empty() => {
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
                f.skipped_non_gps += 1;
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
        f.epochs.push(ObsEpoch { t, flag, sats });
    }
    Ok(f)
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

    #[test]
    fn nav_errors_name_line_and_field() {
        let bad = NAV.replace("0.515480139732D+04", "0.5154801397x2D+04");
        let e = parse_nav(&bad, "t.n").unwrap_err().to_string();
        assert!(e.starts_with("t.n:5: field `sqrtA`: not a number"), "{e}");
        let trunc: String = NAV.lines().take(6).collect::<Vec<_>>().join("\n");
        let e = parse_nav(&trunc, "t.n").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
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

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn reads_shared_rinex() {
        let nav = read_nav(&crate::data::require("gnss/rinex/brdc1820.10n")).unwrap();
        assert!(nav.len() > 200, "{}", nav.len());
        let obs = read_obs(&crate::data::require("gnss/rinex/07590920.05o")).unwrap();
        assert_eq!(obs.epochs.len(), 120);
        assert!(obs.epochs.iter().all(|e| e.sats.len() >= 7));
    }
}
