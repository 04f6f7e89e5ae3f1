//! GLONASS navigation records of RINEX 3 (`R` records of a mixed or
//! GLONASS file, RINEX 3.04 Table A10; 3.05 adds a fifth line, skipped
//! here) and RINEX 2 GLONASS navigation files (`.g`, RINEX 2.11 Table A11)
//! as [`GlonassEph`]s.
//!
//! Fields: epoch t_b (UTC), −τ_n [s], +γ_n, message frame time; then X, Ẋ,
//! Ẍ, health; Y, Ẏ, Ÿ, frequency number; Z, Ż, Z̈, age of operational
//! information [days] — positions in km, velocities km/s, accelerations
//! km/s² (converted to SI). t_b becomes GPS seconds with the leap seconds
//! of [`crate::time::gps_minus_utc`] (GLONASS time is UTC(SU) + 3 h; the
//! RINEX epoch is already UTC).

use crate::rinex::{
    err, ffloat, field, gps_seconds, record_date, RecordLayout, LAYOUT_V2, LAYOUT_V3,
};
use crate::ReadError;
use navfuse_core::gnss::glonass::GlonassEph;
use navfuse_core::Vec3;
use std::path::Path;

/// Lines of a GLONASS record in a RINEX file of `version` (4; 5 from 3.05).
pub fn record_lines(version: f64) -> usize {
    if version >= 3.05 - 1e-9 {
        5
    } else {
        4
    }
}

const NAMES: [&str; 15] = [
    "-TauN",
    "GammaN",
    "frame time",
    "X",
    "Xdot",
    "Xacc",
    "health",
    "Y",
    "Ydot",
    "Yacc",
    "freq number",
    "Z",
    "Zdot",
    "Zacc",
    "age",
];

/// GLONASS radius bounds [m]: the orbit has a ≈ 25 510 km, e ≈ 0; anything
/// outside 20 000–30 000 km is not a GLONASS state.
const RADIUS_M: core::ops::Range<f64> = 20.0e6..30.0e6;

/// One GLONASS record starting at `lines[i]` (`lay`: RINEX 2 or 3 columns),
/// satellite slot `slot`.
pub(crate) fn parse_record(
    lines: &[&str],
    i: usize,
    name: &str,
    lay: &RecordLayout,
    slot: u8,
) -> Result<GlonassEph, ReadError> {
    const W: usize = 19;
    let ln0 = i + 1;
    let dt = record_date(lines, i, name, lay)?;
    let year = if dt[0] < 80.0 {
        dt[0] + 2000.0
    } else if dt[0] < 100.0 {
        dt[0] + 1900.0
    } else {
        dt[0]
    };
    let valid = (1980.0..2200.0).contains(&year)
        && (1.0..=12.0).contains(&dt[1])
        && (1.0..=31.0).contains(&dt[2])
        && (0.0..24.0).contains(&dt[3])
        && (0.0..60.0).contains(&dt[4])
        && (0.0..61.0).contains(&dt[5]);
    if !valid {
        return Err(err(name, ln0, "epoch", "date/time out of range"));
    }
    let mut v = [0.0f64; 15];
    for (k, x) in v.iter_mut().enumerate() {
        let (ln, a) = if k < 3 {
            (i, lay.clk_start + k * W)
        } else {
            (i + 1 + (k - 3) / 4, lay.indent + ((k - 3) % 4) * W)
        };
        let Some(l) = lines.get(ln) else {
            return Err(err(
                name,
                ln0,
                "<record>",
                "truncated GLONASS record (needs 4 lines)",
            ));
        };
        *x = ffloat(field(l, a, a + W))
            .map_err(|m| err(name, ln + 1, NAMES[k], m))?
            .ok_or_else(|| err(name, ln + 1, NAMES[k], "blank"))?;
        if !x.is_finite() {
            return Err(err(name, ln + 1, NAMES[k], "not finite"));
        }
    }
    let t_utc = gps_seconds(
        year as i32,
        dt[1] as u32,
        dt[2] as u32,
        dt[3] as u32,
        dt[4] as u32,
        dt[5],
    );
    let leap = crate::time::gps_minus_utc(t_utc + crate::time::gps_minus_utc(t_utc));
    let pos_m = Vec3::new(v[3], v[7], v[11]) * 1e3;
    if !RADIUS_M.contains(&pos_m.norm()) {
        return Err(err(
            name,
            ln0 + 1,
            "X",
            format!("radius {:.0} km is not a GLONASS orbit", pos_m.norm() / 1e3),
        ));
    }
    // RINEX 3.04: frequency numbers −7…+13 (+7…+13 of early satellites).
    if !(-7.0..=13.0).contains(&v[10]) || v[10].fract() != 0.0 {
        return Err(err(
            name,
            ln0 + 2,
            "freq number",
            format!("{} outside -7..13", v[10]),
        ));
    }
    Ok(GlonassEph {
        slot,
        freq_ch: v[10] as i8,
        health: u32::from(v[6] != 0.0),
        age_days: v[14].clamp(0.0, 255.0) as u8,
        t_b: t_utc + leap,
        pos_m,
        vel_mps: Vec3::new(v[4], v[8], v[12]) * 1e3,
        acc_mps2: Vec3::new(v[5], v[9], v[13]) * 1e3,
        tau_n: -v[0],
        gamma_n: v[1],
    })
}

/// Read a GLONASS navigation file: RINEX 2 (`.g`) or the `R` records of a
/// RINEX 3 file.
pub fn read_nav_glonass(path: &Path) -> Result<Vec<GlonassEph>, ReadError> {
    let name = path.display().to_string();
    let text = crate::text::read_text_capped(path, u64::MAX)?;
    parse_nav_glonass(&text, &name)
}

/// Parse a RINEX 2 GLONASS or RINEX 3 navigation file's GLONASS records.
pub fn parse_nav_glonass(text: &str, name: &str) -> Result<Vec<GlonassEph>, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let (mut i, version, kind) = crate::rinex_nav3::nav_header(&lines, name)?;
    let v3 = version >= 3.0;
    if !v3 && kind != 'G' {
        return Err(err(
            name,
            1,
            "RINEX VERSION / TYPE",
            format!("RINEX {version} type `{kind}`: GLONASS navigation (G) expected"),
        ));
    }
    let mut out = Vec::new();
    while i < lines.len() {
        let l0 = lines[i];
        if l0.trim().is_empty() {
            i += 1;
            continue;
        }
        let ln0 = i + 1;
        let (prn_s, lay) = if v3 {
            match l0.chars().next() {
                Some('R') => {}
                Some('S') => {
                    i += 4;
                    continue;
                }
                Some('G' | 'E' | 'C' | 'J' | 'I') => {
                    i += 8;
                    continue;
                }
                c => {
                    return Err(err(
                        name,
                        ln0,
                        "system",
                        format!("unknown satellite system `{}`", c.unwrap_or(' ')),
                    ))
                }
            }
            (field(l0, 1, 3), &LAYOUT_V3)
        } else {
            (field(l0, 0, 2), &LAYOUT_V2)
        };
        let slot: u8 = prn_s
            .trim()
            .parse()
            .ok()
            .filter(|p| (1..=64).contains(p))
            .ok_or_else(|| {
                err(
                    name,
                    ln0,
                    "slot",
                    format!("not a slot number: `{}`", prn_s.trim()),
                )
            })?;
        out.push(parse_record(&lines, i, name, lay, slot)?);
        i += if v3 { record_lines(version) } else { 4 };
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rinex::gps_seconds;

    /// A RINEX 2.11 GLONASS file (values of the ICD example state, slot 1,
    /// channel 1, 2012-09-07 00:15:00 UTC = 03:15:00 Moscow time = t_b
    /// 11700 s) with D exponents, and the same record in RINEX 3.04.
    const NAV2: &str =
        "     2.11           G: GLONASS NAV DATA                     RINEX VERSION / TYPE
                                                            END OF HEADER
 1 12  9  7  0 15  0.0-1.200000000000D-04 1.000000000000D-12 0.000000000000D+00
    7.003008789000D+03 7.835417000000D-01 0.000000000000D+00 0.000000000000D+00
   -1.220662695300D+04 2.804253000000D+00 1.700000000000D-09 1.000000000000D+00
    2.128076562500D+04 1.352515000000D+00-5.410000000000D-09 0.000000000000D+00
";
    const NAV3: &str =
        "     3.04           N: GNSS NAV DATA    M: MIXED            RINEX VERSION / TYPE
                                                            END OF HEADER
R01 2012 09 07 00 15 00-1.200000000000E-04 1.000000000000E-12 0.000000000000E+00
     7.003008789000E+03 7.835417000000E-01 0.000000000000E+00 0.000000000000E+00
    -1.220662695300E+04 2.804253000000E+00 1.700000000000E-09 1.000000000000E+00
     2.128076562500E+04 1.352515000000E+00-5.410000000000E-09 0.000000000000E+00
";

    #[test]
    fn rinex_2_and_3_records_give_the_same_ephemeris() {
        let a = parse_nav_glonass(NAV2, "t.12g").unwrap();
        let b = parse_nav_glonass(NAV3, "t.rnx").unwrap();
        assert_eq!(a.len(), 1);
        assert_eq!(a, b);
        let e = a[0];
        assert_eq!((e.slot, e.freq_ch, e.health), (1, 1, 0));
        // 2012-09-07 00:15:00 UTC + 16 leap seconds (GPS − UTC in 2012).
        assert_eq!(e.t_b, gps_seconds(2012, 9, 7, 0, 15, 0.0) + 16.0);
        assert_eq!(e.tau_n, 1.2e-4);
        assert_eq!(e.gamma_n, 1e-12);
        assert!((e.pos_m.x - 7003.008789e3).abs() < 1e-6);
        assert!((e.acc_mps2.y - 1.7e-6).abs() < 1e-20);
        // The orbit integrates to the ICD example's 600 s state (the core
        // test checks the numbers); here: a GLONASS radius after 600 s.
        let r = e.position_ecef(e.t_b + 600.0).norm();
        assert!((r - 25.5e6).abs() < 0.1e6, "{r}");
        assert_eq!(e.clock_offset(e.t_b), -1.2e-4);
    }

    #[test]
    fn errors_name_line_and_field() {
        let bad = NAV3.replace("7.003008789000E+03", "7.00300878x000E+03");
        let e = parse_nav_glonass(&bad, "t.rnx").unwrap_err().to_string();
        assert!(e.starts_with("t.rnx:4: field `X`"), "{e}");
        let bad = NAV3.replace(
            "2.804253000000E+00 1.700000000000E-09 1.000000000000E+00",
            "2.804253000000E+00 1.700000000000E-09 2.500000000000E+01",
        );
        let e = parse_nav_glonass(&bad, "t.rnx").unwrap_err().to_string();
        assert!(e.contains("freq number"), "{e}");
        let bad = NAV3.replace("7.003008789000E+03", "7.003008789000E+06");
        let e = parse_nav_glonass(&bad, "t.rnx").unwrap_err().to_string();
        assert!(e.contains("not a GLONASS orbit"), "{e}");
        let trunc: String = NAV3.lines().take(4).collect::<Vec<_>>().join("\n");
        let e = parse_nav_glonass(&trunc, "t.rnx").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        let gps2 = NAV2.replace("G: GLONASS NAV DATA", "N: GPS NAV DATA    ");
        assert!(parse_nav_glonass(&gps2, "t.n").is_err());
    }

    #[test]
    fn rinex_3_05_records_have_five_lines() {
        let v305 = NAV3.replace("     3.04", "     3.05").replace(
            "-5.410000000000E-09 0.000000000000E+00\n",
            "-5.410000000000E-09 0.000000000000E+00\n     1.790000000000E+02 0.000000000000E+00 0.000000000000E+00 0.000000000000E+00\n",
        );
        let two = format!(
            "{v305}{}",
            v305.lines().skip(2).collect::<Vec<_>>().join("\n")
        );
        let n = parse_nav_glonass(&two, "t.rnx").unwrap();
        assert_eq!(n.len(), 2);
    }
}
