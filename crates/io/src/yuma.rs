//! YUMA GPS almanac reader → [`KeplerOrbit`]s (IS-GPS-200 almanac terms).
//!
//! Each record is a `******** Week N almanac for PRN-xx ********` banner then
//! `Name: value` lines (ID, Health, Eccentricity, Time of Applicability(s),
//! Orbital Inclination(rad), Rate of Right Ascen(r/s), SQRT(A), Right Ascen at
//! Week(rad), Argument of Perigee(rad), Mean Anom(rad), Af0(s), Af1(s/s), week).
//! The week is broadcast modulo 1024; the caller gives the number of
//! roll-overs (`week_rollovers`, 2 for April 2019 – 2038; the shared
//! `yuma_week1011.alm` of January 2019 needs 1 → GPS week 2035).

use crate::ReadError;
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};
use std::path::Path;
use std::sync::Arc;

type GnssParseError = ReadError;

fn err(file: &str, line: usize, field: &str, msg: impl Into<String>) -> ReadError {
    ReadError::new(&Arc::from(file), line as u64, field.to_string(), msg)
}

/// Read a YUMA almanac file.
pub fn read_yuma(path: &Path, week_rollovers: u32) -> Result<Vec<KeplerOrbit>, GnssParseError> {
    let name = path.display().to_string();
    let text = crate::text::read_text_capped(path, u64::MAX)?;
    parse_yuma(&text, &name, week_rollovers)
}

/// Parse YUMA text (`name` is used in error messages).
pub fn parse_yuma(
    text: &str,
    name: &str,
    week_rollovers: u32,
) -> Result<Vec<KeplerOrbit>, GnssParseError> {
    let mut out = Vec::new();
    let mut cur: Option<(KeplerOrbit, usize, u32, f64)> = None; // orbit, banner line, fields seen, toa
    const ALL: u32 = (1 << 13) - 1;
    let finish = |c: (KeplerOrbit, usize, u32, f64),
                  out: &mut Vec<KeplerOrbit>|
     -> Result<(), GnssParseError> {
        let (o, line, seen, _) = c;
        if seen != ALL {
            let missing = (0..13).find(|b| seen & (1 << b) == 0).unwrap_or(0);
            return Err(err(
                name,
                line,
                FIELDS[missing],
                "missing from this almanac record",
            ));
        }
        out.push(o);
        Ok(())
    };
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if line.starts_with("****") {
            if let Some(c) = cur.take() {
                finish(c, &mut out)?;
            }
            cur = Some((KeplerOrbit::default(), ln, 0, 0.0));
            continue;
        }
        let Some((key, val)) = line.split_once(':') else {
            return Err(err(
                name,
                ln,
                "line",
                format!("expected `Name: value`, got `{line}`"),
            ));
        };
        let Some(c) = cur.as_mut() else {
            return Err(err(
                name,
                ln,
                key.trim(),
                "field before the first `****` banner",
            ));
        };
        let key = key.trim();
        let idx = field_index(key).ok_or_else(|| err(name, ln, key, "unknown YUMA field"))?;
        let v: f64 = val
            .trim()
            .parse()
            .map_err(|_| err(name, ln, key, format!("not a number: `{}`", val.trim())))?;
        if !v.is_finite() {
            return Err(err(name, ln, key, "not finite"));
        }
        let o = &mut c.0;
        match idx {
            0 => {
                if !(1.0..=63.0).contains(&v) || v.fract() != 0.0 {
                    return Err(err(name, ln, key, format!("PRN {v} out of 1..63")));
                }
                o.prn = v as u8
            }
            1 => o.health = v as u32,
            2 => {
                if !(0.0..1.0).contains(&v) {
                    return Err(err(
                        name,
                        ln,
                        key,
                        format!("eccentricity {v} not in [0, 1)"),
                    ));
                }
                o.e = v
            }
            3 => c.3 = v,
            4 => o.i0 = v,
            5 => o.omega_dot = v,
            6 => {
                if !(4000.0..6000.0).contains(&v) {
                    return Err(err(name, ln, key, format!("√a {v} is not a GPS orbit")));
                }
                o.sqrt_a = v
            }
            7 => o.omega0 = v,
            8 => o.argp = v,
            9 => o.m0 = v,
            10 => o.af0 = v,
            11 => o.af1 = v,
            12 => {
                let week = v as u32 % 1024 + 1024 * week_rollovers;
                let t = week as f64 * SECONDS_PER_WEEK + c.3;
                o.t_oe = t;
                o.t_oc = t;
            }
            _ => unreachable!(),
        }
        if idx == 3 && c.2 & (1 << 12) != 0 {
            // `week` came before toa: recompute.
            let w = (c.0.t_oe / SECONDS_PER_WEEK).floor();
            c.0.t_oe = w * SECONDS_PER_WEEK + v;
            c.0.t_oc = c.0.t_oe;
        }
        c.2 |= 1 << idx;
    }
    if let Some(c) = cur.take() {
        finish(c, &mut out)?;
    }
    if out.is_empty() {
        return Err(err(name, 0, "<file>", "no almanac records"));
    }
    Ok(out)
}

const FIELDS: [&str; 13] = [
    "ID",
    "Health",
    "Eccentricity",
    "Time of Applicability(s)",
    "Orbital Inclination(rad)",
    "Rate of Right Ascen(r/s)",
    "SQRT(A)  (m 1/2)",
    "Right Ascen at Week(rad)",
    "Argument of Perigee(rad)",
    "Mean Anom(rad)",
    "Af0(s)",
    "Af1(s/s)",
    "week",
];

fn field_index(key: &str) -> Option<usize> {
    let k = key.to_ascii_lowercase();
    let k = k.as_str();
    Some(match () {
        _ if k == "id" => 0,
        _ if k.starts_with("health") => 1,
        _ if k.starts_with("eccentricity") => 2,
        _ if k.starts_with("time of applicability") => 3,
        _ if k.starts_with("orbital inclination") => 4,
        _ if k.starts_with("rate of right ascen") => 5,
        _ if k.starts_with("sqrt(a)") => 6,
        _ if k.starts_with("right ascen at week") => 7,
        _ if k.starts_with("argument of perigee") => 8,
        _ if k.starts_with("mean anom") => 9,
        _ if k.starts_with("af0") => 10,
        _ if k.starts_with("af1") => 11,
        _ if k == "week" => 12,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const REC: &str = "******** Week 1011 almanac for PRN-01 ********
ID:                         01
Health:                     000
Eccentricity:               0.8266448975E-002
Time of Applicability(s):  319488.0000
Orbital Inclination(rad):   0.9741820631
Rate of Right Ascen(r/s):  -0.7988904198E-008
SQRT(A)  (m 1/2):           5153.613281
Right Ascen at Week(rad):  -0.4742011737E+000
Argument of Perigee(rad):   0.690451644
Mean Anom(rad):             0.8327879083E+000
Af0(s):                    -0.1430511475E-003
Af1(s/s):                  -0.7275957614E-011
week:                        1011
";

    #[test]
    fn parses_a_record() {
        let v = parse_yuma(REC, "t.alm", 1).unwrap();
        assert_eq!(v.len(), 1);
        let o = &v[0];
        assert_eq!(o.prn, 1);
        assert_eq!(o.t_oe, 2035.0 * SECONDS_PER_WEEK + 319488.0);
        assert!((o.sqrt_a - 5153.613281).abs() < 1e-9);
        let r = o.position_ecef(o.t_oe).norm();
        assert!((r - 2.656e7).abs() < 3e5, "{r}");
    }

    #[test]
    fn errors_name_line_and_field() {
        let bad = REC.replace("0.9741820631", "0.97x");
        let e = parse_yuma(&bad, "t.alm", 1).unwrap_err().to_string();
        assert!(
            e.starts_with("t.alm:6: field `Orbital Inclination(rad)`: not a number"),
            "{e}"
        );
        let missing = REC.replace("Af1(s/s):                  -0.7275957614E-011\n", "");
        let e = parse_yuma(&missing, "t.alm", 1).unwrap_err().to_string();
        assert!(e.contains("t.alm:1: field `Af1(s/s)`: missing"), "{e}");
        let e = parse_yuma("", "t.alm", 1).unwrap_err().to_string();
        assert!(e.contains("no almanac records"));
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn reads_shared_almanac() {
        let p = crate::data::require("gnss/almanac/yuma_week1011.alm");
        let v = read_yuma(&p, 1).unwrap();
        assert_eq!(v.len(), 31);
        for o in &v {
            let r = o.position_ecef(o.t_oe + 3600.0).norm();
            assert!(r > 2.5e7 && r < 2.8e7, "PRN {} r {r}", o.prn);
        }
    }
}
