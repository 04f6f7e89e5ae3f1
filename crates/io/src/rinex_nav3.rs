//! RINEX 3 navigation records of every Kepler-orbit system — GPS (`G`),
//! Galileo (`E`), BeiDou (`C`) and QZSS (`J`) — as [`GnssEph`]s
//! (RINEX 3.04 Tables A6, A8, A14, A10). GLONASS records (read by
//! [`crate::rinex_glonass`]), SBAS records (4 lines) and NavIC records are
//! counted and skipped here; RINEX 2 files give their GPS records through
//! [`crate::rinex::parse_nav_data`].
//!
//! Times become GPS seconds: the epoch (t_oc) and the week are in the
//! system's time scale — GST and QZSST are GPS time (GST's offset to GPS,
//! the GGTO, is tens of ns and neglected), BDT = GPST − 14 s and the BDT
//! week is the GPS week − 1356. Group delay kept for the single-frequency
//! user of the first signal (what [`navfuse_core::gnss::spp`] subtracts):
//! GPS/QZSS T_GD; Galileo BGD(E1,E5b) for I/NAV records and BGD(E1,E5a) for
//! F/NAV records (data-source bits, Galileo OS SIS ICD §5.1.5); BeiDou TGD1
//! (B1I, BDS-SIS-ICD-B1I §5.2.4.8). Health: any non-zero health word marks
//! the record unhealthy (for Galileo that is conservative: the word holds
//! the E1-B, E5a and E5b signal flags together).

use crate::rinex::{err, field, gps_seconds, record_date, record_values, LAYOUT_V3};
use crate::ReadError;
use navfuse_core::gnss::orbit_gnss::{OrbitKind, BDT_MINUS_GPST};
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};
use std::path::Path;

/// The error text of a file that is not RINEX 3 (callers reading RINEX 2
/// files elsewhere may let it pass).
pub const NOT_RINEX3: &str = "RINEX 3 navigation expected";

/// BDT week 0 starts at GPS week 1356.
pub const BDT_WEEK_OFFSET: f64 = 1356.0;

/// One broadcast ephemeris with its system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssEph {
    /// RINEX system letter (`G`, `E`, `C`, `J`).
    pub sys: char,
    /// How to evaluate the orbit (BeiDou GEO for C01–C05, C59–C63).
    pub kind: OrbitKind,
    /// Elements, clock and group delay; t_oe and t_oc in GPS seconds.
    pub orbit: KeplerOrbit,
    /// Broadcast accuracy [m] (GPS/QZSS URA, Galileo SISA, BeiDou URA).
    pub accuracy_m: f64,
}

/// A RINEX 3 navigation file's Kepler records, and what was skipped.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct GnssNav {
    pub ephs: Vec<GnssEph>,
    /// Records of other systems (GLONASS, SBAS, NavIC) skipped.
    pub skipped: usize,
}

/// Read a RINEX 3 navigation file (all Kepler systems).
pub fn read_nav_gnss(path: &Path) -> Result<GnssNav, ReadError> {
    let name = path.display().to_string();
    let text = crate::text::read_text_capped(path, u64::MAX)?;
    parse_nav_gnss(&text, &name)
}

const NAMES: [&str; 29] = [
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
    "codes/sources",
    "week",
    "spare",
    "accuracy",
    "health",
    "group delay",
    "group delay 2",
    "transmission time",
    "fit/AODC",
];

/// The header of a RINEX navigation file: the index of the first line after
/// `END OF HEADER`, the `RINEX VERSION / TYPE` version (0 when absent or
/// unreadable) and its file-type character (column 21). An error naming
/// `name` when there is no `END OF HEADER`.
pub(crate) fn nav_header(lines: &[&str], name: &str) -> Result<(usize, f64, char), ReadError> {
    let (mut version, mut kind) = (0.0, ' ');
    for (i, l) in lines.iter().enumerate() {
        let label = l.get(60..).unwrap_or("");
        if label.starts_with("RINEX VERSION") {
            version = field(l, 0, 9).trim().parse().unwrap_or(0.0);
            kind = field(l, 20, 21).chars().next().unwrap_or(' ');
        }
        if label.starts_with("END OF HEADER") {
            return Ok((i + 1, version, kind));
        }
    }
    Err(err(name, 1, "<header>", "no END OF HEADER"))
}

/// Parse RINEX 3 navigation text; `name` is used in errors.
pub fn parse_nav_gnss(text: &str, name: &str) -> Result<GnssNav, ReadError> {
    let lines: Vec<&str> = text.lines().collect();
    let (mut i, version, _) = nav_header(&lines, name)?;
    if version < 3.0 {
        return Err(err(
            name,
            1,
            "RINEX VERSION / TYPE",
            format!("version {version}: {NOT_RINEX3} (RINEX 2: GPS reader)"),
        ));
    }
    let mut out = GnssNav::default();
    while i < lines.len() {
        let l0 = lines[i];
        if l0.trim().is_empty() {
            i += 1;
            continue;
        }
        let ln0 = i + 1;
        let sys = l0.chars().next().unwrap_or(' ');
        match sys {
            'G' | 'E' | 'C' | 'J' => {}
            'R' => {
                // GLONASS: read by `crate::rinex_glonass` (4 lines, 5 from 3.05).
                out.skipped += 1;
                i += crate::rinex_glonass::record_lines(version);
                continue;
            }
            'S' => {
                out.skipped += 1;
                i += 4;
                continue;
            }
            'I' => {
                out.skipped += 1;
                i += 8;
                continue;
            }
            c => {
                return Err(err(
                    name,
                    ln0,
                    "system",
                    format!("unknown satellite system `{c}`"),
                ))
            }
        }
        let prn_s = field(l0, 1, 3).trim();
        let prn: u8 = prn_s
            .parse()
            .ok()
            .filter(|p| (1..=99).contains(p))
            .ok_or_else(|| err(name, ln0, "PRN", format!("not a PRN: `{prn_s}`")))?;
        let dt = record_date(&lines, i, name, &LAYOUT_V3)?;
        let valid_date = (1980.0..2200.0).contains(&dt[0])
            && (1.0..=12.0).contains(&dt[1])
            && (1.0..=31.0).contains(&dt[2])
            && (0.0..24.0).contains(&dt[3])
            && (0.0..60.0).contains(&dt[4])
            && (0.0..61.0).contains(&dt[5]);
        if !valid_date {
            return Err(err(name, ln0, "epoch", "date/time out of range"));
        }
        let required = |idx: usize| idx <= 19 || idx == 21 || idx == 24;
        let v = record_values(&lines, i, name, &LAYOUT_V3, &NAMES, required)?;
        if !(4000.0..7000.0).contains(&v[10]) {
            return Err(err(
                name,
                ln0 + 2,
                "sqrtA",
                format!("√a {} is not a GNSS orbit", v[10]),
            ));
        }
        if !(0.0..3000.0).contains(&v[21]) || !(0.0..SECONDS_PER_WEEK).contains(&v[11]) {
            return Err(err(name, ln0 + 5, "week", "week or Toe out of range"));
        }
        // Epoch and week in the system's time scale → GPS seconds.
        let (kind, shift, week) = match sys {
            'C' => (
                OrbitKind::beidou(prn),
                -BDT_MINUS_GPST,
                v[21] + BDT_WEEK_OFFSET,
            ),
            'E' => (OrbitKind::Galileo, 0.0, v[21]),
            _ => (OrbitKind::Gps, 0.0, v[21]),
        };
        let t_oc = gps_seconds(
            dt[0] as i32,
            dt[1] as u32,
            dt[2] as u32,
            dt[3] as u32,
            dt[4] as u32,
            dt[5],
        ) + shift;
        let mut t_oe = week * SECONDS_PER_WEEK + v[11] + shift;
        // A week number of the transmission rather than of t_oe: keep t_oe
        // within half a week of t_oc.
        if t_oe - t_oc > SECONDS_PER_WEEK / 2.0 {
            t_oe -= SECONDS_PER_WEEK;
        } else if t_oc - t_oe > SECONDS_PER_WEEK / 2.0 {
            t_oe += SECONDS_PER_WEEK;
        }
        let tgd = match sys {
            // Data sources bit 1: F/NAV (E5a clock) → BGD(E1,E5a); else I/NAV.
            'E' if (v[20] as u32) & 2 != 0 => v[25],
            'E' => v[26],
            _ => v[25],
        };
        out.ephs.push(GnssEph {
            sys,
            kind,
            orbit: KeplerOrbit {
                prn,
                health: if v[24] == 0.0 { 0 } else { 1 },
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
                tgd,
            },
            accuracy_m: v[23],
        });
        i += 8;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::gnss::orbit_gnss::position_ecef;

    /// A Galileo I/NAV record (E11, 2019-01-01, data sources 517 = I/NAV
    /// E1-B) and a BeiDou GEO record (C01) with BDT epoch/week, values of
    /// the kind the IGS BRDM files carry, written here to exercise the
    /// fields.
    pub const NAV3: &str =
        "     3.04           N: GNSS NAV DATA    M: MIXED            RINEX VERSION / TYPE
                                                            END OF HEADER
E11 2019 01 01 00 10 00-6.408181018196E-04-7.261957228184E-12 0.000000000000E+00
     1.200000000000E+01-3.190625000000E+01 2.826546881327E-09 1.060935766467E+00
    -1.504272222519E-06 1.573478034697E-04 5.958601832390E-06 5.440611837387E+03
     1.746000000000E+05 4.656612873077E-09-1.196298196014E+00 2.793967723846E-08
     9.847683962432E-01 2.245625000000E+02 3.136049563113E-01-5.625586602126E-09
    -2.007226171524E-10 5.170000000000E+02 2.034000000000E+03 0.000000000000E+00
     3.120000000000E+00 0.000000000000E+00-1.629814505577E-09-1.862645149231E-09
     1.753940000000E+05
R05 2019 01 01 00 15 00 7.406435906887E-05 0.000000000000E+00 1.746000000000E+05
     1.0E+04 0.0E+00 0.0E+00 0.0E+00
     1.0E+04 0.0E+00 0.0E+00 1.0E+00
     1.0E+04 0.0E+00 0.0E+00 0.0E+00
C01 2019 01 01 00 00 00 5.287066334859E-04 4.010480264303E-11 0.000000000000E+00
     1.000000000000E+00 6.398437500000E+00 4.121242095640E-10-2.733027462568E+00
     2.021389082074E-07 4.872011882253E-04 2.132053486000E-05 6.493390665054E+03
     1.728000000000E+05 1.862645149231E-08 2.825587713009E+00-4.470348358154E-08
     9.072369124127E-02-6.549687500000E+02-3.010917932913E+00 2.878691633015E-10
    -1.046472733001E-09 0.000000000000E+00 6.780000000000E+02 0.000000000000E+00
     2.000000000000E+00 0.000000000000E+00-5.800000000000E-09-1.020000000000E-08
     1.728000000000E+05 1.000000000000E+00
";

    #[test]
    fn galileo_and_beidou_geo_records() {
        let n = parse_nav_gnss(NAV3, "t.rnx").unwrap();
        assert_eq!(n.ephs.len(), 2);
        assert_eq!(n.skipped, 1);
        let e = &n.ephs[0];
        assert_eq!((e.sys, e.kind, e.orbit.prn), ('E', OrbitKind::Galileo, 11));
        // GAL week 2034 = GPS week 2034; I/NAV → BGD(E1,E5b).
        assert_eq!(e.orbit.t_oe, 2034.0 * SECONDS_PER_WEEK + 174_600.0);
        assert_eq!(e.orbit.tgd, -1.862645149231e-9);
        assert_eq!(e.accuracy_m, 3.12);
        let r = position_ecef(&e.orbit, e.kind, e.orbit.t_oe).norm();
        assert!((r - 29.6e6).abs() < 0.1e6, "Galileo radius {r}");
        // BeiDou: BDT week 678 + 1356 = GPS week 2034, BDT = GPST − 14 s.
        let c = &n.ephs[1];
        assert_eq!((c.sys, c.kind, c.orbit.prn), ('C', OrbitKind::BeiDouGeo, 1));
        assert_eq!(c.orbit.t_oe, 2034.0 * SECONDS_PER_WEEK + 172_800.0 + 14.0);
        assert_eq!(c.orbit.t_oc, c.orbit.t_oe);
        assert_eq!(c.orbit.tgd, -5.8e-9);
        let p = position_ecef(&c.orbit, c.kind, c.orbit.t_oe);
        assert!(
            (p.norm() - 42.16e6).abs() < 0.1e6,
            "GEO radius {}",
            p.norm()
        );
        // Geostationary: latitude within a few degrees of the equator.
        assert!((p.z / p.norm()).abs() < 0.1, "GEO z {}", p.z);
    }

    #[test]
    fn errors_name_line_and_field() {
        let bad = NAV3.replace("5.440611837387E+03", "5.44061183x387E+03");
        let e = parse_nav_gnss(&bad, "t.rnx").unwrap_err().to_string();
        assert!(e.starts_with("t.rnx:5: field `sqrtA`"), "{e}");
        let bad = NAV3.replace("C01 2019", "X01 2019");
        let e = parse_nav_gnss(&bad, "t.rnx").unwrap_err().to_string();
        assert!(e.contains("field `system`"), "{e}");
        let trunc: String = NAV3.lines().take(8).collect::<Vec<_>>().join("\n");
        let e = parse_nav_gnss(&trunc, "t.rnx").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        let v2 = NAV3.replace("     3.04", "     2.11");
        assert!(parse_nav_gnss(&v2, "t.rnx").is_err());
    }
}
