//! RINEX 3.04 writers: mixed-system observation files and mixed-system
//! Kepler navigation files (GPS LNAV, Galileo I/NAV, BeiDou D1/D2, QZSS),
//! the inverse of [`crate::rinex::parse_obs_gnss`] and
//! [`crate::rinex_nav3::parse_nav_gnss`] / [`crate::rinex::parse_nav_data`].
//! They exist so that simulated raw data can be handed to other programs
//! (RTKLIB `rnx2rtkp`) as files (issue 14, must-show 4).
//!
//! Formats (RINEX 3.04, IGS/RTCM 2018): observation records Table A3
//! (`>` epoch line `1X,I4,4(1X,I2.2),F11.7,2X,I1,I3`, satellite lines
//! `A1,I2.2,m(F14.3,I1,1X)`), navigation records Tables A6 (GPS), A8
//! (Galileo), A14 (BeiDou), A10 (QZSS): epoch line `A1,I2.2,1X,I4,5(1X,I2.2),3D19.12`,
//! seven orbit lines `4X,4D19.12`. Times: observation epochs and GPS,
//! Galileo and QZSS navigation epochs in GPS time (GST = GPST, the GGTO
//! neglected as in the reader), BeiDou epochs and t_oe in BDT
//! (= GPST − 14 s, BDT week = GPS week − 1356). Values are written with 12
//! significant decimals (D19.12), so a written-and-read-back record differs
//! from the original by at most half a unit in the 13th digit.

use crate::rinex::{GnssObs, NavData, ObsValue};
use crate::rinex_nav3::{GnssEph, BDT_WEEK_OFFSET};
use crate::time::{calendar_from_gps, TimeSystem};
use navfuse_core::gnss::glonass::GlonassEph;
use navfuse_core::gnss::orbit_gnss::BDT_MINUS_GPST;
use navfuse_core::gnss::SECONDS_PER_WEEK;
use std::fmt::Write as _;

/// A 60-column header line with its label.
fn header(s: &mut String, text: &str, label: &str) {
    let _ = writeln!(s, "{text:<60}{label}");
}

/// Fortran `Ew.d` text of `x`: `d` decimals, a signed two-digit exponent
/// (`-4.788350421580E-10`, `1.1176E-08`), right-aligned in `w` columns.
fn fortran_e(x: f64, w: usize, d: usize) -> String {
    let t = format!("{x:.d$E}");
    let (m, e) = t.split_once('E').unwrap_or((&t, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>w$}", format!("{m}E{sign}{:02}", e.abs()))
}

/// `D19.12` field of a navigation record.
fn d19(x: f64) -> String {
    fortran_e(x, 19, 12)
}

/// `D12.4` field of the ionosphere header lines.
fn d12(x: f64) -> String {
    fortran_e(x, 12, 4)
}

/// RINEX 3.04 mixed observation text. `times[k]` is the receiver time tag
/// (GPS seconds) of `gnss.epochs[k]`; every system's codes are those of
/// `gnss.sys_codes` (RINEX 3 codes, `C1C`, `L1C`, `D1C`, `S1C`, `C2I`, …).
/// Values are written `F14.3` (mm, mHz, 0.001 dB-Hz) with their loss-of-lock
/// indicator; `None` is a blank field. `approx_pos` is the header's ECEF
/// position [m].
pub fn obs3_text(marker: &str, approx_pos: [f64; 3], times: &[f64], gnss: &GnssObs) -> String {
    let mut s = String::with_capacity(64 + times.len() * 40 * 70);
    header(
        &mut s,
        &format!("{:9.2}{:11}{:<20}{:<20}", 3.04, "", "OBSERVATION DATA", "M"),
        "RINEX VERSION / TYPE",
    );
    header(
        &mut s,
        &format!("{:<20}{:<20}{:<20}", "navfuse", "", ""),
        "PGM / RUN BY / DATE",
    );
    header(&mut s, marker, "MARKER NAME");
    header(
        &mut s,
        &format!(
            "{:14.4}{:14.4}{:14.4}",
            approx_pos[0], approx_pos[1], approx_pos[2]
        ),
        "APPROX POSITION XYZ",
    );
    header(
        &mut s,
        &format!("{:14.4}{:14.4}{:14.4}", 0.0, 0.0, 0.0),
        "ANTENNA: DELTA H/E/N",
    );
    for (sys, codes) in &gnss.sys_codes {
        for (k, chunk) in codes.chunks(13).enumerate() {
            let mut t = if k == 0 {
                format!("{sys}  {:3}", codes.len())
            } else {
                " ".repeat(6)
            };
            for c in chunk {
                t.push(' ');
                t.push_str(c);
            }
            header(&mut s, &t, "SYS / # / OBS TYPES");
        }
    }
    if let Some(&t0) = times.first() {
        let c = calendar_from_gps(t0, TimeSystem::Gpst, 7);
        header(
            &mut s,
            &format!(
                "{:6}{:6}{:6}{:6}{:6}{:13.7}     GPS",
                c.year, c.month, c.day, c.hour, c.minute, c.second
            ),
            "TIME OF FIRST OBS",
        );
    }
    header(&mut s, "", "END OF HEADER");
    for (t, sats) in times.iter().zip(&gnss.epochs) {
        let c = calendar_from_gps(*t, TimeSystem::Gpst, 7);
        let _ = writeln!(
            s,
            "> {:4} {:02} {:02} {:02} {:02}{:11.7}  0{:3}",
            c.year,
            c.month,
            c.day,
            c.hour,
            c.minute,
            c.second,
            sats.len()
        );
        for (sys, prn, vals) in sats {
            let _ = write!(s, "{sys}{prn:02}");
            for v in vals {
                match v {
                    Some(ObsValue { value, lli }) if *lli != 0 => {
                        let _ = write!(s, "{value:14.3}{} ", lli % 10);
                    }
                    Some(ObsValue { value, .. }) => {
                        let _ = write!(s, "{value:14.3}  ");
                    }
                    None => s.push_str(&" ".repeat(16)),
                }
            }
            // Trailing blanks are optional (RINEX 3.04 §5.2).
            while s.ends_with(' ') {
                s.pop();
            }
            s.push('\n');
        }
    }
    s
}

/// One navigation record: epoch line in the record's time scale, then the
/// seven orbit lines.
fn record(s: &mut String, id: &str, t_oc_sys: f64, clock: [f64; 3], rows: &[[f64; 4]; 7]) {
    let c = calendar_from_gps(t_oc_sys, TimeSystem::Gpst, 0);
    let _ = write!(
        s,
        "{id} {:4} {:02} {:02} {:02} {:02} {:02}",
        c.year, c.month, c.day, c.hour, c.minute, c.second as u32
    );
    for x in clock {
        s.push_str(&d19(x));
    }
    s.push('\n');
    for r in rows {
        s.push_str("    ");
        for x in r {
            s.push_str(&d19(*x));
        }
        s.push('\n');
    }
}

/// RINEX 3.04 mixed navigation text: the GPS records of `gps` (with its
/// header Klobuchar coefficients as `IONOSPHERIC CORR GPSA/GPSB`) and the
/// Galileo, BeiDou and QZSS records of `other`. Fields the reader does not
/// keep are written as the ICD's neutral values: IODE/IODC/IODnav/AODE 0,
/// code-on-L2 1 (C/A), L2 P flag 0, fit interval 4 h, transmission time =
/// t_oe. Galileo records are I/NAV (data sources 517 = E1-B, E5b, clock for
/// E5b/E1) with both BGD fields set to the record's group delay; BeiDou
/// TGD2 is set to TGD1 (only B1I is used).
pub fn nav3_text(gps: &NavData, other: &[GnssEph]) -> String {
    let mut s = String::with_capacity(600 * (gps.orbits.len() + other.len()) + 400);
    header(
        &mut s,
        &format!(
            "{:9.2}{:11}{:<20}{:<20}",
            3.04, "", "N: GNSS NAV DATA", "M: MIXED"
        ),
        "RINEX VERSION / TYPE",
    );
    header(
        &mut s,
        &format!("{:<20}{:<20}{:<20}", "navfuse", "", ""),
        "PGM / RUN BY / DATE",
    );
    if let Some(k) = gps.iono {
        let four = |tag: &str, v: [f64; 4]| {
            let mut t = format!("{tag} ");
            for x in v {
                t.push_str(&d12(x));
            }
            t
        };
        header(&mut s, &four("GPSA", k.alpha), "IONOSPHERIC CORR");
        header(&mut s, &four("GPSB", k.beta), "IONOSPHERIC CORR");
    }
    header(&mut s, "", "END OF HEADER");
    let sow = |t: f64| {
        let w = (t / SECONDS_PER_WEEK).floor();
        (w, t - w * SECONDS_PER_WEEK)
    };
    for (i, o) in gps.orbits.iter().enumerate() {
        let ura = gps.ura_m.get(i).copied().unwrap_or(0.0);
        let (week, toe) = sow(o.t_oe);
        let rows = [
            [0.0, o.crs, o.delta_n, o.m0],
            [o.cuc, o.e, o.cus, o.sqrt_a],
            [toe, o.cic, o.omega0, o.cis],
            [o.i0, o.crc, o.argp, o.omega_dot],
            [o.idot, 1.0, week, 0.0],
            [ura, o.health as f64, o.tgd, 0.0],
            [toe, 4.0, 0.0, 0.0],
        ];
        record(
            &mut s,
            &format!("G{:02}", o.prn),
            o.t_oc,
            [o.af0, o.af1, o.af2],
            &rows,
        );
    }
    for e in other {
        let o = &e.orbit;
        let (shift, week_off) = match e.sys {
            'C' => (BDT_MINUS_GPST, BDT_WEEK_OFFSET),
            _ => (0.0, 0.0),
        };
        let (week, toe) = sow(o.t_oe + shift);
        let health = o.health as f64;
        let (line5, line6, line7) = match e.sys {
            'E' => (
                [o.idot, 517.0, week - week_off, 0.0],
                [e.accuracy_m, health, o.tgd, o.tgd],
                [toe, 0.0, 0.0, 0.0],
            ),
            'C' => (
                [o.idot, 0.0, week - week_off, 0.0],
                [e.accuracy_m, health, o.tgd, o.tgd],
                [toe, 0.0, 0.0, 0.0],
            ),
            _ => (
                [o.idot, 1.0, week, 0.0],
                [e.accuracy_m, health, o.tgd, 0.0],
                [toe, 4.0, 0.0, 0.0],
            ),
        };
        let rows = [
            [0.0, o.crs, o.delta_n, o.m0],
            [o.cuc, o.e, o.cus, o.sqrt_a],
            [toe, o.cic, o.omega0, o.cis],
            [o.i0, o.crc, o.argp, o.omega_dot],
            line5,
            line6,
            line7,
        ];
        record(
            &mut s,
            &format!("{}{:02}", e.sys, o.prn),
            o.t_oc + shift,
            [o.af0, o.af1, o.af2],
            &rows,
        );
    }
    s
}

/// GLONASS records of a RINEX 3.04 navigation file (Table A10), to be
/// appended after [`nav3_text`]'s records: epoch t_b in UTC (GPS − leap
/// seconds of [`crate::time::gps_minus_utc`]), −τ_n, +γ_n, message frame
/// time (t_b's UTC second of week); X, Ẋ, Ẍ, health; Y, Ẏ, Ÿ, frequency
/// number; Z, Ż, Z̈, age — km, km/s, km/s². Read back by
/// [`crate::rinex_glonass`].
pub fn glonass3_records(ephs: &[GlonassEph]) -> String {
    let mut s = String::with_capacity(330 * ephs.len());
    for e in ephs {
        let t_utc = e.t_b - crate::time::gps_minus_utc(e.t_b);
        let tk = t_utc.rem_euclid(SECONDS_PER_WEEK);
        let (p, v, a) = (e.pos_m / 1e3, e.vel_mps / 1e3, e.acc_mps2 / 1e3);
        let c = calendar_from_gps(t_utc, TimeSystem::Gpst, 0);
        let _ = write!(
            s,
            "R{:02} {:4} {:02} {:02} {:02} {:02} {:02}",
            e.slot, c.year, c.month, c.day, c.hour, c.minute, c.second as u32
        );
        for x in [-e.tau_n, e.gamma_n, tk] {
            s.push_str(&d19(x));
        }
        s.push('\n');
        for r in [
            [p.x, v.x, a.x, f64::from(e.health)],
            [p.y, v.y, a.y, f64::from(e.freq_ch)],
            [p.z, v.z, a.z, f64::from(e.age_days)],
        ] {
            s.push_str("    ");
            for x in r {
                s.push_str(&d19(x));
            }
            s.push('\n');
        }
    }
    s
}

#[cfg(test)]
#[path = "rinex_write_tests.rs"]
mod tests;
