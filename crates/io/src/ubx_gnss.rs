//! Raw GNSS from a UBX log: UBX-RXM-RAWX epochs (GPS L1 C/A, Galileo E1,
//! BeiDou B1I code, carrier, Doppler) and UBX-RXM-SFRBX navigation data
//! (GPS LNAV [`crate::gps_lnav`], Galileo I/NAV [`crate::galileo_inav`],
//! BeiDou D1/D2 [`crate::beidou_d1d2`]) read into the same structures as a
//! RINEX observation and navigation file ([`ObsFile`] with RINEX 2 codes
//! `C1`, `L1`, `D1`, `S1` for GPS; [`GnssObs`] with RINEX 3 codes for
//! Galileo and BeiDou; [`NavData`] and [`GnssEph`] records as
//! [`crate::rinex_nav3`] gives them), so a single `.ubx` log is
//! self-contained for single-point positioning; and the inverse writers
//! ([`write_ubx_gnss`], [`write_ubx_multi`]) for simulated logs and tests.
//!
//! Conventions carried over unchanged: RAWX `prMes` [m] → `C1`, `cpMes`
//! [cycles] → `L1`, `doMes` [Hz] (positive for an approaching satellite, as
//! RINEX) → `D1`, `cno` [dB-Hz] → `S1`; a pseudorange or phase whose `trkStat` valid bit is clear
//! is left blank. Galileo: `sigId` 0 (E1 C) → `C1C L1C D1C S1C`, 1 (E1 B)
//! → `C1B L1B D1B S1B`; BeiDou: `sigId` 0/1 (B1I D1/D2) → `C2I L2I D2I S2I`
//! (RINEX 3.02+ B1I codes). Epoch time: RAWX week and `rcvTow` (receiver
//! time, GPS seconds), as a RINEX observation time tag. Ephemerides are
//! collected over
//! the whole log (as a navigation file holds the day's records); the
//! broadcast week (GPS 10 bits, GST 12, BDT 13) is resolved with the week of the latest RAWX epoch, so
//! subframes before the first epoch wait for it (at most
//! [`MAX_PENDING_SUBFRAMES`]; more are rejected and counted).

use crate::beidou_d1d2::{self as bds, BdsAssembler};
use crate::error::{ReadError, RecordStats};
use crate::galileo_inav::{self as gal, InavAssembler};
use crate::glonass_str::{self as glo, GloAssembler};
use crate::gps_lnav::{decode_subframe, encode_ephemeris, encode_iono, Assembler};
use crate::rinex::{GnssObs, NavData, ObsEpoch, ObsFile, ObsValue, SatObs};
use crate::rinex_nav3::GnssEph;
use crate::ubx::{encode, RawxMeas, RxmRawx, RxmSfrbx, UbxMessage, UbxReader, SFRBX_MAX_WORDS};
use navfuse_core::gnss::glonass::GlonassEph;
use navfuse_core::gnss::orbit_gnss::BDT_MINUS_GPST;
use navfuse_core::gnss::SECONDS_PER_WEEK;
use std::io::Read;

/// Subframes held until the first RAWX epoch gives the week.
pub const MAX_PENDING_SUBFRAMES: usize = 4096;
/// RAWX/SFRBX `gnssId` of GPS, Galileo and BeiDou, and `sigId` of GPS L1 C/A.
const GNSS_GPS: u8 = 0;
const GNSS_GAL: u8 = 2;
const GNSS_BDS: u8 = 3;
const GNSS_GLO: u8 = 6;
const SIG_L1CA: u8 = 0;
/// RINEX 3 codes written for Galileo (E1 C, then E1 B) and BeiDou (B1I):
/// code, phase, Doppler, C/N0 per signal.
const GAL_CODES: [&str; 8] = ["C1C", "L1C", "D1C", "S1C", "C1B", "L1B", "D1B", "S1B"];
const BDS_CODES: [&str; 4] = ["C2I", "L2I", "D2I", "S2I"];
/// GLONASS L1OF (u-blox sigId 0, C/A code) as RINEX 3 codes.
const GLO_CODES: [&str; 4] = ["C1C", "L1C", "D1C", "S1C"];

/// What a log held besides what was used.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct UbxGnssReport {
    /// RAWX epochs read.
    pub rawx_epochs: u64,
    /// Measurements of other systems or signals (not used here).
    pub other_signal_meas: u64,
    /// Galileo E1 and BeiDou B1I measurements read into [`UbxGnss::gnss`].
    pub galileo_meas: u64,
    pub beidou_meas: u64,
    /// GLONASS L1OF measurements kept (slots 1–24; the frequency channel
    /// comes from the satellite's ephemeris).
    pub glonass_meas: u64,
    /// GPS subframes that failed parity/preamble (counted, not used).
    pub subframes_bad: u64,
    /// Galileo page pairs failing the even/odd order or CRC, or of the
    /// wrong length; alert pages (no data) separately.
    pub galileo_pages_bad: u64,
    pub galileo_alert_pages: u64,
    /// BeiDou subframes with a bad preamble, FraID, page number or length.
    pub beidou_subframes_bad: u64,
    /// GLONASS strings with a bad length or string number.
    pub glonass_strings_bad: u64,
    /// Subframes of other systems (SBAS, QZSS: not used here).
    pub subframes_other_system: u64,
    /// Subframes dropped because no RAWX week came within the pending cap.
    pub subframes_without_week: u64,
    /// GPS ephemerides assembled.
    pub ephemerides: u64,
    /// Galileo and BeiDou ephemerides assembled.
    pub ephemerides_galileo: u64,
    pub ephemerides_beidou: u64,
    /// GLONASS ephemerides assembled (strings 1–4).
    pub ephemerides_glonass: u64,
    /// Other UBX messages in the log.
    pub other_messages: u64,
}

/// Everything a UBX log gives for raw GNSS processing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UbxGnss {
    /// GPS L1 C/A epochs (one per RAWX message).
    pub obs: ObsFile,
    /// Galileo E1 and BeiDou B1I observations, epoch by epoch parallel to
    /// `obs.epochs` (GPS is in `obs` only), with their RINEX 3 codes.
    pub gnss: GnssObs,
    /// GPS ephemerides, URA and the Klobuchar coefficients (subframe 4 page 18).
    pub nav: NavData,
    /// Galileo and BeiDou ephemerides, as the RINEX 3 reader gives them.
    pub other: Vec<GnssEph>,
    /// GLONASS ephemerides (strings 1–4), as [`crate::rinex_glonass`]
    /// gives them (not used by the SPP yet: its measurements are counted
    /// in `other_signal_meas`).
    pub glonass: Vec<GlonassEph>,
    /// The last GLONASS string 5's time-scale parameters (τ_c, τ_GPS, N_4).
    pub glonass_time: Option<glo::GloTimeParams>,
    pub report: UbxGnssReport,
    pub stats: RecordStats,
}

/// The decoders' state while reading.
#[derive(Default)]
struct Decoders {
    gps: Assembler,
    gal: InavAssembler,
    bds: BdsAssembler,
    glo: GloAssembler,
}

/// Read a UBX log's raw observations and broadcast navigation data (GPS,
/// Galileo, BeiDou). `name` names the source in errors. Frames with bad
/// checksums are the reader's business ([`UbxReader`], counted in its stats).
pub fn read_ubx_gnss<R: Read>(rdr: R, name: &str) -> Result<UbxGnss, ReadError> {
    let mut r = UbxReader::new(rdr, name);
    let mut out = UbxGnss {
        obs: ObsFile {
            version: 3.0,
            marker: name.to_string(),
            // S1: the measurement's C/N0 [dB-Hz] (RINEX 3.05 §5.7: signal
            // strength as C/N0 in dB-Hz), which the tight filter's weights use.
            types: vec!["C1".into(), "L1".into(), "D1".into(), "S1".into()],
            ..Default::default()
        },
        gnss: GnssObs {
            sys_codes: vec![
                ('C', BDS_CODES.iter().map(|c| c.to_string()).collect()),
                ('E', GAL_CODES.iter().map(|c| c.to_string()).collect()),
                ('R', GLO_CODES.iter().map(|c| c.to_string()).collect()),
            ],
            epochs: Vec::new(),
        },
        ..Default::default()
    };
    let mut dec = Decoders::default();
    let mut week: Option<u16> = None;
    let mut rx_t = 0.0;
    let mut pending: Vec<RxmSfrbx> = Vec::new();
    for msg in r.by_ref() {
        match msg? {
            UbxMessage::RxmRawx(x) => {
                out.report.rawx_epochs += 1;
                week = Some(x.week);
                rx_t = f64::from(x.week) * SECONDS_PER_WEEK + x.rcv_tow;
                for m in pending.drain(..) {
                    subframe(&m, x.week, rx_t, &mut dec, &mut out);
                }
                let mut ep = ObsEpoch {
                    t: f64::from(x.week) * SECONDS_PER_WEEK + x.rcv_tow,
                    flag: 0,
                    sats: Vec::with_capacity(x.meas.len()),
                };
                let mut others: Vec<SatObs> = Vec::new();
                for m in &x.meas {
                    let v = |ok: bool, value: f64| {
                        (ok && value.is_finite() && value != 0.0)
                            .then_some(ObsValue { value, lli: 0 })
                    };
                    let lli = u8::from(m.trk_stat & 0x04 == 0 && m.trk_stat & 0x02 != 0) << 1;
                    let vals = [
                        v(m.trk_stat & 0x01 != 0, m.pr_mes),
                        v(m.trk_stat & 0x02 != 0, m.cp_mes).map(|o| ObsValue { lli, ..o }),
                        v(true, f64::from(m.do_mes)),
                        v(true, f64::from(m.cno_dbhz)),
                    ];
                    // (system, number of codes, offset of this signal's four).
                    let slot = match (m.gnss_id, m.sig_id) {
                        (GNSS_GPS, SIG_L1CA) if (1..=32).contains(&m.sv_id) => {
                            ep.sats.push((m.sv_id, vals.to_vec()));
                            continue;
                        }
                        (GNSS_GAL, s @ (0 | 1)) if (1..=gal::MAX_SVID).contains(&m.sv_id) => {
                            out.report.galileo_meas += 1;
                            ('E', GAL_CODES.len(), 4 * usize::from(s))
                        }
                        (GNSS_BDS, 0 | 1) if (1..=bds::MAX_PRN).contains(&m.sv_id) => {
                            out.report.beidou_meas += 1;
                            ('C', BDS_CODES.len(), 0)
                        }
                        // svId 255: slot unknown (not used).
                        (GNSS_GLO, 0) if (1..=24).contains(&m.sv_id) => {
                            out.report.glonass_meas += 1;
                            ('R', GLO_CODES.len(), 0)
                        }
                        _ => {
                            out.report.other_signal_meas += 1;
                            continue;
                        }
                    };
                    let (sys, n, off) = slot;
                    let k = match others
                        .iter()
                        .position(|(s, p, _)| *s == sys && *p == m.sv_id)
                    {
                        Some(k) => k,
                        None => {
                            others.push((sys, m.sv_id, vec![None; n]));
                            others.len() - 1
                        }
                    };
                    others[k].2[off..off + 4].copy_from_slice(&vals);
                }
                out.obs.epochs.push(ep);
                out.gnss.epochs.push(others);
            }
            UbxMessage::RxmSfrbx(m) => {
                if !matches!(m.gnss_id, GNSS_GPS | GNSS_GAL | GNSS_BDS | GNSS_GLO) {
                    out.report.subframes_other_system += 1;
                } else if let Some(w) = week {
                    subframe(&m, w, rx_t, &mut dec, &mut out);
                } else if pending.len() < MAX_PENDING_SUBFRAMES {
                    pending.push(m);
                } else {
                    out.report.subframes_without_week += 1;
                }
            }
            _ => out.report.other_messages += 1,
        }
    }
    out.report.subframes_without_week += pending.len() as u64;
    out.nav.iono = dec.gps.iono;
    out.glonass_time = dec.glo.time;
    out.stats = r.stats().clone();
    Ok(out)
}

/// One subframe / page pair / string into its system's assembler; a new
/// ephemeris goes to `out.nav` (GPS), `out.other` or `out.glonass`.
fn subframe(m: &RxmSfrbx, week: u16, rx_t: f64, dec: &mut Decoders, out: &mut UbxGnss) {
    let rep = &mut out.report;
    let n = usize::from(m.num_words).min(SFRBX_MAX_WORDS);
    let words = &m.words[..n];
    match m.gnss_id {
        GNSS_GPS => {
            let Ok(w) = <[u32; 10]>::try_from(words) else {
                rep.subframes_bad += 1;
                return;
            };
            match decode_subframe(&w) {
                Ok(sf) => {
                    if let Some(e) = dec.gps.push(m.sv_id, &sf, week) {
                        out.nav.orbits.push(e.orbit);
                        out.nav.ura_m.push(e.ura_m);
                        rep.ephemerides += 1;
                    }
                }
                Err(_) => rep.subframes_bad += 1,
            }
        }
        GNSS_GAL => match gal::decode_pages(words) {
            Ok(word) => {
                if let Some(e) = dec.gal.push(m.sv_id, word, week) {
                    out.other.push(e.eph);
                    rep.ephemerides_galileo += 1;
                }
            }
            Err(gal::InavError::AlertPage) => rep.galileo_alert_pages += 1,
            Err(_) => rep.galileo_pages_bad += 1,
        },
        GNSS_GLO => match glo::decode_string(words) {
            Ok(s) => {
                if let Some(e) = dec.glo.push(m.sv_id, m.freq_id, &s, rx_t) {
                    out.glonass.push(e);
                    rep.ephemerides_glonass += 1;
                }
            }
            Err(_) => rep.glonass_strings_bad += 1,
        },
        _ => match bds::decode_subframe(words, bds::is_geo(m.sv_id)) {
            Ok(sf) => {
                if let Some(e) = dec.bds.push(m.sv_id, &sf, week) {
                    out.other.push(e.eph);
                    rep.ephemerides_beidou += 1;
                }
            }
            Err(_) => rep.beidou_subframes_bad += 1,
        },
    }
}

/// Write `obs` (GPS `C1`, `L1`, `D1` where present) as RXM-RAWX epochs and
/// `nav` as RXM-SFRBX subframes 1–3 per ephemeris (issue of data = its
/// index mod 256) plus subframe 4 page 18 for the ionosphere, sent after the
/// first epoch (the reader's week), transmitted at that epoch's time.
/// Errors: a field that does not fit its LNAV bits (names it).
pub fn write_ubx_gnss(obs: &ObsFile, nav: &NavData) -> Result<Vec<u8>, String> {
    write_ubx_multi(obs, &GnssObs::default(), nav, &[], &[])
}

/// One RAWX measurement from a code/phase/Doppler/C/N0 quadruple.
fn rawx_meas(gnss_id: u8, sv_id: u8, sig_id: u8, q: [Option<ObsValue>; 4]) -> RawxMeas {
    let [c, l, d, sn] = q;
    RawxMeas {
        pr_mes: c.map_or(0.0, |o| o.value),
        cp_mes: l.map_or(0.0, |o| o.value),
        do_mes: d.map_or(0.0, |o| o.value as f32),
        gnss_id,
        sv_id,
        sig_id,
        // S1 when the observations carry it, else 45 dB-Hz
        // (a strong open-sky signal).
        cno_dbhz: sn.map_or(45, |o| o.value.round().clamp(1.0, 255.0) as u8),
        trk_stat: u8::from(c.is_some()) | u8::from(l.is_some()) << 1 | 0x04,
        ..Default::default()
    }
}

/// RINEX 3 code quadruples written as RAWX signals: (system, `gnssId`,
/// `sigId` (BeiDou GEO: +1, D2), code, phase, Doppler, C/N0).
const SIGNALS: [(char, u8, u8, [&str; 4]); 6] = [
    ('E', GNSS_GAL, 0, ["C1C", "L1C", "D1C", "S1C"]),
    ('E', GNSS_GAL, 0, ["C1X", "L1X", "D1X", "S1X"]),
    ('E', GNSS_GAL, 1, ["C1B", "L1B", "D1B", "S1B"]),
    ('C', GNSS_BDS, 0, ["C2I", "L2I", "D2I", "S2I"]),
    ('C', GNSS_BDS, 0, ["C1I", "L1I", "D1I", "S1I"]),
    ('R', GNSS_GLO, 0, GLO_CODES),
];

/// [`write_ubx_gnss`] with Galileo and BeiDou: the observations of
/// `gnss` (epochs parallel to `obs.epochs`; E1 C/X → `sigId` 0, E1 B → 1,
/// B1I → 0, or 1 for a GEO's D2) as further RAWX measurements, and the
/// records of `other` as I/NAV page pairs (word types in E1-B order 2, 4,
/// 1, 3, 5, IOD_nav = index mod 1024, health ≠ 0 → E1-B HS 1) or D1
/// subframes 1–3 / D2 pages 1–10 (AODE = index mod 32), and `glonass` as
/// strings 1–4 (frame identifier = index), all sent after the first epoch.
/// Errors: a field that does not fit its bits (names it).
pub fn write_ubx_multi(
    obs: &ObsFile,
    gnss: &GnssObs,
    nav: &NavData,
    other: &[GnssEph],
    glonass: &[GlonassEph],
) -> Result<Vec<u8>, String> {
    let idx = |c: &str| obs.index(c);
    let (ic, il, id, is) = (idx("C1"), idx("L1"), idx("D1"), idx("S1"));
    let mut out = Vec::new();
    for (k, ep) in obs.epochs.iter().enumerate() {
        let week = (ep.t / SECONDS_PER_WEEK).floor();
        let tow = ep.t - week * SECONDS_PER_WEEK;
        let mut meas: Vec<RawxMeas> = ep
            .sats
            .iter()
            .map(|(prn, vals)| {
                let get = |i: Option<usize>| i.and_then(|i| vals.get(i).copied().flatten());
                rawx_meas(
                    GNSS_GPS,
                    *prn,
                    SIG_L1CA,
                    [get(ic), get(il), get(id), get(is)],
                )
            })
            .collect();
        for (sys, prn, vals) in gnss.epochs.get(k).into_iter().flatten() {
            for (s, gid, sig, codes) in SIGNALS {
                if *sys != s {
                    continue;
                }
                let q = codes.map(|c| {
                    gnss.index(s, c)
                        .and_then(|i| vals.get(i).copied().flatten())
                        .filter(|o| o.value != 0.0)
                });
                if q[0].is_none() && q[1].is_none() {
                    continue;
                }
                let sig = sig + u8::from(s == 'C' && bds::is_geo(*prn));
                meas.push(rawx_meas(gid, *prn, sig, q));
            }
        }
        out.extend(encode(&UbxMessage::RxmRawx(RxmRawx {
            rcv_tow: tow,
            week: week as u16,
            leap_s: 0,
            rec_stat: 0,
            version: 1,
            meas,
        })));
        if k == 0 {
            let tx = (tow / 6.0).floor() * 6.0;
            let mut put_f = |gnss_id: u8, sv: u8, freq_id: u8, w: &[u32]| {
                let mut words = [0u32; SFRBX_MAX_WORDS];
                words[..w.len()].copy_from_slice(w);
                out.extend(encode(&UbxMessage::RxmSfrbx(RxmSfrbx {
                    gnss_id,
                    sv_id: sv,
                    freq_id,
                    num_words: w.len() as u8,
                    version: 2,
                    words,
                    ..Default::default()
                })));
            };
            for (j, e) in glonass.iter().enumerate() {
                let s = glo::encode_strings(e, j as u16)
                    .map_err(|x| format!("R{:02} t_b {}: {x}", e.slot, e.t_b))?;
                let freq_id = u8::try_from(i16::from(e.freq_ch) + 7)
                    .map_err(|_| format!("R{:02}: frequency channel {}", e.slot, e.freq_ch))?;
                for w in &s {
                    put_f(GNSS_GLO, e.slot, freq_id, w);
                }
            }
            let mut put = |gnss_id: u8, sv: u8, w: &[u32]| put_f(gnss_id, sv, 0, w);
            for (j, o) in nav.orbits.iter().enumerate() {
                let ura = nav.ura_m.get(j).copied().unwrap_or(0.0);
                let sfs = encode_ephemeris(o, (j % 256) as u8, ura, tx)
                    .map_err(|e| format!("PRN {} t_oe {}: {e}", o.prn, o.t_oe))?;
                for w in sfs {
                    put(GNSS_GPS, o.prn, &w);
                }
            }
            if let Some(k) = &nav.iono {
                put(GNSS_GPS, 1, &encode_iono(k, tx).map_err(|e| e.to_string())?);
            }
            // BDT second of week of the transmission.
            // (A D2 page set spans 27 s: kept inside the week.)
            let bdt_sow = ((tx + BDT_MINUS_GPST).rem_euclid(SECONDS_PER_WEEK) as u32)
                .min(SECONDS_PER_WEEK as u32 - 30);
            for (j, e) in other.iter().enumerate() {
                let what = |err: &dyn std::fmt::Display| {
                    format!("{}{:02} t_oe {}: {err}", e.sys, e.orbit.prn, e.orbit.t_oe)
                };
                match e.sys {
                    'E' => {
                        let h = if e.orbit.health != 0 { 1 << 1 } else { 0 };
                        let p = gal::encode_ephemeris(e, (j % 1024) as u16, h, 0.0, tx)
                            .map_err(|x| what(&x))?;
                        for i in gal::E1B_ORDER {
                            put(GNSS_GAL, e.orbit.prn, &p[i]);
                        }
                    }
                    'C' => {
                        let b = bds::from_eph(e, (j % 32) as u8);
                        let frames: Vec<[u32; 10]> = if bds::is_geo(e.orbit.prn) {
                            bds::encode_d2(&b, bdt_sow).map(|f| f.to_vec())
                        } else {
                            bds::encode_d1(&b, bdt_sow).map(|f| f.to_vec())
                        }
                        .map_err(|x| what(&x))?;
                        for f in &frames {
                            put(GNSS_BDS, e.orbit.prn, f);
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GLONASS ephemeris written as RXM-SFRBX strings next to a RAWX
    /// epoch comes back from the reader unchanged (values on the grid),
    /// with its frequency channel from `freqId`.
    #[test]
    fn glonass_strings_through_the_log() {
        let text =
            "     3.04           N: GNSS NAV DATA    R: GLONASS          RINEX VERSION / TYPE
                                                            END OF HEADER
R07 2012 09 07 00 15 00-1.199999824166E-04 9.094947017729E-13 0.000000000000E+00
     7.003008789062E+03 7.835416793823E-01 0.000000000000E+00 0.000000000000E+00
    -1.220662695312E+04 2.804252624512E+00 1.862645149231E-09-3.000000000000E+00
     2.128076562500E+04 1.352515220642E+00-5.587935447693E-09 3.000000000000E+00
";
        let r = crate::rinex_glonass::parse_nav_glonass(text, "t").unwrap();
        let obs = ObsFile {
            types: vec!["C1".into()],
            epochs: vec![ObsEpoch {
                t: r[0].t_b + 30.0,
                flag: 0,
                sats: Vec::new(),
            }],
            ..ObsFile::default()
        };
        let b = write_ubx_multi(&obs, &GnssObs::default(), &NavData::default(), &[], &r).unwrap();
        let u = read_ubx_gnss(&b[..], "t").unwrap();
        assert_eq!(u.report.ephemerides_glonass, 1);
        let g = u.glonass[0];
        assert_eq!((g.slot, g.freq_ch, g.t_b), (7, -3, r[0].t_b));
        let d = (g.position_ecef(g.t_b + 900.0) - r[0].position_ecef(g.t_b + 900.0)).norm();
        assert!(d < 1e-3, "{d} m");
    }
}
