//! Raw GNSS from a UBX log: UBX-RXM-RAWX epochs (code, carrier, Doppler,
//! C/N0 of the signals in the table below) and UBX-RXM-SFRBX navigation
//! data (GPS LNAV [`crate::gps_lnav`], Galileo I/NAV [`crate::galileo_inav`],
//! BeiDou D1/D2 [`crate::beidou_d1d2`], GLONASS strings
//! [`crate::glonass_str`]) read into the same structures as a RINEX
//! observation and navigation file ([`ObsFile`] with RINEX 2 types for GPS;
//! [`GnssObs`] with RINEX 3 codes for Galileo, BeiDou and GLONASS;
//! [`NavData`] and [`GnssEph`] records as [`crate::rinex_nav3`] gives
//! them), so a single `.ubx` log is self-contained for single-point
//! positioning and, with its second frequencies, for dual-frequency RTK
//! (the RINEX path of `navfuse_pipeline::raw_input` reads both alike); and
//! the inverse writers ([`write_ubx_gnss`], [`write_ubx_multi`]) for
//! simulated logs and tests.
//!
//! Signals read (`gnssId`/`sigId` of the u-blox F9 interface description,
//! UBX-RXM-RAWX and its table of GNSS signal identifiers; RINEX 3.04
//! Table 4 observation codes; each signal's four values are code, phase,
//! Doppler, C/N0):
//!
//! | system (`gnssId`) | `sigId` | signal | read as |
//! |---|---|---|---|
//! | GPS (0) | 0 | L1 C/A | `C1 L1 D1 S1` |
//! | GPS (0) | 3 | L2 CL | `C2 L2 D2 S2` (RINEX 3 `C2L…`) |
//! | GPS (0) | 4 | L2 CM | `C2 L2 D2 S2` (RINEX 3 `C2S…`; only without L2 CL) |
//! | Galileo (2) | 0 | E1 C | `C1C L1C D1C S1C` |
//! | Galileo (2) | 1 | E1 B | `C1B L1B D1B S1B` |
//! | Galileo (2) | 5 | E5b I | `C7I L7I D7I S7I` |
//! | Galileo (2) | 6 | E5b Q | `C7Q L7Q D7Q S7Q` |
//! | BeiDou (3) | 0, 1 | B1I D1, D2 | `C2I L2I D2I S2I` (RINEX 3.02+ B1I) |
//! | BeiDou (3) | 2, 3 | B2I D1, D2 | `C7I L7I D7I S7I` |
//! | GLONASS (6) | 0 | L1OF (slots 1–24) | `C1C L1C D1C S1C` |
//!
//! GPS L2C goes into the RINEX 2 names that `crate::rinex::rinex2_name`
//! gives a RINEX 3 file's `C2L`/`C2S`, so the RTK input takes a log's
//! second frequencies (GPS L2C, Galileo E5b, BeiDou B2I) exactly as it
//! takes a RINEX file's. Every other signal (GPS L5, Galileo E5a, BeiDou
//! B1C/B2a, GLONASS L2OF, QZSS, SBAS, …) and satellite numbers out of
//! range are counted in [`UbxGnssReport::other_signal_meas`], not read.
//!
//! Conventions: RAWX `prMes` [m] → code, `cpMes` [cycles of the signal] →
//! phase, `doMes` [Hz] (positive for an approaching satellite, as RINEX) →
//! Doppler, `cno` [dB-Hz] → C/N0; a pseudorange or phase whose `trkStat`
//! valid bit is clear is left blank. The phase's LLI: bit 1 (half-cycle
//! ambiguity) when `trkStat` bit 2 (half cycle valid) is clear; bit 0 (loss
//! of lock) when its `locktime` restarted ([`lost_lock`]: RAWX has no
//! loss-of-lock flag), for every signal alike. Epoch time: RAWX week and
//! `rcvTow` (receiver time, GPS seconds), as a RINEX observation time tag.
//! Ephemerides are collected over the whole log (as a navigation file
//! holds the day's records); the broadcast week (GPS 10 bits, GST 12,
//! BDT 13) is resolved with the week of the latest RAWX epoch, so
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
use std::collections::HashMap;
use std::io::Read;

/// Subframes held until the first RAWX epoch gives the week.
pub const MAX_PENDING_SUBFRAMES: usize = 4096;
/// RAWX/SFRBX `gnssId` of GPS, Galileo, BeiDou and GLONASS.
const GNSS_GPS: u8 = 0;
const GNSS_GAL: u8 = 2;
const GNSS_BDS: u8 = 3;
const GNSS_GLO: u8 = 6;
/// RAWX `sigId`s read (u-blox F9 interface description, UBX-RXM-RAWX and
/// its signal identifier table): GPS L1 C/A, L2 CL, L2 CM; Galileo E1 C,
/// E1 B, E5b I, E5b Q; BeiDou B1I D1, D2, B2I D1, D2; GLONASS L1OF.
const SIG_GPS_L1CA: u8 = 0;
const SIG_GPS_L2CL: u8 = 3;
const SIG_GPS_L2CM: u8 = 4;
const SIG_GAL_E1C: u8 = 0;
const SIG_GAL_E1B: u8 = 1;
const SIG_GAL_E5BI: u8 = 5;
const SIG_GAL_E5BQ: u8 = 6;
const SIG_BDS_B1I: u8 = 0;
const SIG_BDS_B2I: u8 = 2;
const SIG_GLO_L1OF: u8 = 0;
/// RINEX 2 GPS types of the log's [`ObsFile`]: L1 C/A, then L2C (CL or CM,
/// as `navfuse_io::rinex::rinex2_name` names RINEX 3 `C2L`/`C2S`).
const GPS_TYPES: [&str; 8] = ["C1", "L1", "D1", "S1", "C2", "L2", "D2", "S2"];
/// RINEX 3 codes written for Galileo (E1 C, E1 B, E5b I, E5b Q) and BeiDou
/// (B1I, B2I): code, phase, Doppler, C/N0 per signal.
const GAL_CODES: [&str; 16] = [
    "C1C", "L1C", "D1C", "S1C", "C1B", "L1B", "D1B", "S1B", "C7I", "L7I", "D7I", "S7I", "C7Q",
    "L7Q", "D7Q", "S7Q",
];
const BDS_CODES: [&str; 8] = ["C2I", "L2I", "D2I", "S2I", "C7I", "L7I", "D7I", "S7I"];
/// GLONASS L1OF (u-blox sigId 0, C/A code) as RINEX 3 codes.
const GLO_CODES: [&str; 4] = ["C1C", "L1C", "D1C", "S1C"];
/// Largest RAWX `locktime` [ms] (the interface description's maximum).
pub const MAX_LOCK_TIME_MS: u16 = 64_500;
/// Lock-time slack [ms] of the loss-of-lock test ([`lost_lock`]).
pub const LOCK_TIME_SLACK_MS: f64 = 10.0;

/// Where a RAWX signal goes: system letter, offset of its four values
/// (code, phase, Doppler, C/N0) in the satellite's row, rank (lower wins
/// when two signals fill the same four), and whether it is a second
/// frequency. None: not read (other signals, satellite numbers out of
/// range).
fn signal_slot(gnss_id: u8, sig_id: u8, sv_id: u8) -> Option<(char, usize, u8, bool)> {
    let s = match gnss_id {
        GNSS_GPS if (1..=32).contains(&sv_id) => match sig_id {
            SIG_GPS_L1CA => ('G', 0, 0, false),
            SIG_GPS_L2CL => ('G', 4, 0, true),
            SIG_GPS_L2CM => ('G', 4, 1, true),
            _ => return None,
        },
        GNSS_GAL if (1..=gal::MAX_SVID).contains(&sv_id) => match sig_id {
            SIG_GAL_E1C => ('E', 0, 0, false),
            SIG_GAL_E1B => ('E', 4, 0, false),
            SIG_GAL_E5BI => ('E', 8, 0, true),
            SIG_GAL_E5BQ => ('E', 12, 0, true),
            _ => return None,
        },
        // D1 (MEO/IGSO) and D2 (GEO) of one band share their codes.
        GNSS_BDS if (1..=bds::MAX_PRN).contains(&sv_id) => match sig_id {
            0 | 1 => ('C', 0, sig_id - SIG_BDS_B1I, false),
            2 | 3 => ('C', 4, sig_id - SIG_BDS_B2I, true),
            _ => return None,
        },
        // svId 255: slot unknown (not used).
        GNSS_GLO if (1..=24).contains(&sv_id) && sig_id == SIG_GLO_L1OF => ('R', 0, 0, false),
        _ => return None,
    };
    Some(s)
}

/// Whether a carrier with lock time `lock_ms` at epoch `t` [s] lost lock
/// since the signal's previous carrier `prev` (epoch, lock time), or, for
/// a signal without one, since the previous RAWX epoch `prev_epoch`: its
/// lock time is 0, or shorter (by more than [`LOCK_TIME_SLACK_MS`]) than
/// the lock time continuous tracking would have reached (the previous lock
/// time plus the time between, at most [`MAX_LOCK_TIME_MS`]; for a new
/// signal the time since the previous epoch). RAWX has no loss-of-lock
/// flag: the lock time restarting is how a u-blox receiver reports one.
pub fn lost_lock(prev: Option<(f64, u16)>, prev_epoch: Option<f64>, t: f64, lock_ms: u16) -> bool {
    let expect = match (prev, prev_epoch) {
        (Some((t0, l0)), _) => f64::from(l0) + (t - t0) * 1e3,
        (None, Some(tp)) => (t - tp) * 1e3,
        (None, None) => 0.0,
    };
    lock_ms == 0
        || f64::from(lock_ms) + LOCK_TIME_SLACK_MS < expect.min(f64::from(MAX_LOCK_TIME_MS))
}

/// What a log held besides what was used.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct UbxGnssReport {
    /// RAWX epochs read.
    pub rawx_epochs: u64,
    /// Measurements of other systems or signals (not used here: GPS L5,
    /// Galileo E5a, BeiDou B1C/B2a, GLONASS L2OF, QZSS, SBAS, …), and a
    /// GPS L2 CM measurement of a satellite whose L2 CL is read (one L2C
    /// per satellite).
    pub other_signal_meas: u64,
    /// GPS L1 C/A measurements read into [`UbxGnss::obs`].
    pub gps_meas: u64,
    /// Galileo E1 and BeiDou B1I measurements read into [`UbxGnss::gnss`].
    pub galileo_meas: u64,
    pub beidou_meas: u64,
    /// Second-frequency measurements read: GPS L2C (into [`UbxGnss::obs`]),
    /// Galileo E5b and BeiDou B2I (into [`UbxGnss::gnss`]).
    pub gps_l2_meas: u64,
    pub galileo_e5b_meas: u64,
    pub beidou_b2i_meas: u64,
    /// Carriers flagged as lost lock (LLI bit 0) from their lock time
    /// ([`lost_lock`]), all signals.
    pub loss_of_lock: u64,
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
    /// GPS L1 C/A and L2C epochs (one per RAWX message; RINEX 2 types
    /// `C1 L1 D1 S1 C2 L2 D2 S2`).
    pub obs: ObsFile,
    /// Galileo E1 + E5b, BeiDou B1I + B2I and GLONASS L1OF observations,
    /// epoch by epoch parallel to
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
            types: GPS_TYPES.iter().map(|c| c.to_string()).collect(),
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
    // Per (gnssId, svId, sigId): the epoch and lock time of its last
    // carrier, and the previous epoch's time (loss of lock, lost_lock).
    let mut locks: HashMap<(u8, u8, u8), (f64, u16)> = HashMap::new();
    let mut prev_epoch_t: Option<f64> = None;
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
                // Per satellite row: the rank of the signal in each group
                // of four values (u8::MAX: empty).
                let mut ranks: Vec<(char, u8, [u8; 4])> = Vec::new();
                for m in &x.meas {
                    let Some((sys, off, rank, second)) = signal_slot(m.gnss_id, m.sig_id, m.sv_id)
                    else {
                        out.report.other_signal_meas += 1;
                        continue;
                    };
                    let v = |ok: bool, value: f64| {
                        (ok && value.is_finite() && value != 0.0)
                            .then_some(ObsValue { value, lli: 0 })
                    };
                    let cp_ok = m.trk_stat & 0x02 != 0;
                    let key = (m.gnss_id, m.sv_id, m.sig_id);
                    let mut lli = u8::from(m.trk_stat & 0x04 == 0 && cp_ok) << 1;
                    let cp = v(cp_ok, m.cp_mes);
                    if cp.is_some() {
                        let prev = locks.insert(key, (ep.t, m.locktime_ms));
                        if lost_lock(prev, prev_epoch_t, ep.t, m.locktime_ms) {
                            lli |= 1;
                            out.report.loss_of_lock += 1;
                        }
                    }
                    let vals = [
                        v(m.trk_stat & 0x01 != 0, m.pr_mes),
                        cp.map(|o| ObsValue { lli, ..o }),
                        v(true, f64::from(m.do_mes)),
                        v(true, f64::from(m.cno_dbhz)),
                    ];
                    let n = match sys {
                        'G' => GPS_TYPES.len(),
                        'E' => GAL_CODES.len(),
                        'C' => BDS_CODES.len(),
                        _ => GLO_CODES.len(),
                    };
                    let g = off / 4;
                    let r = match ranks
                        .iter()
                        .position(|(s, p, _)| *s == sys && *p == m.sv_id)
                    {
                        Some(r) => r,
                        None => {
                            ranks.push((sys, m.sv_id, [u8::MAX; 4]));
                            ranks.len() - 1
                        }
                    };
                    let held = ranks[r].2[g];
                    if held <= rank {
                        // A better (or the same) signal already fills these.
                        out.report.other_signal_meas += 1;
                        continue;
                    }
                    ranks[r].2[g] = rank;
                    if held != u8::MAX {
                        // The worse signal it replaces is not used.
                        out.report.other_signal_meas += 1;
                    } else {
                        let c = &mut out.report;
                        *match (sys, second) {
                            ('G', true) => &mut c.gps_l2_meas,
                            ('G', false) => &mut c.gps_meas,
                            ('E', false) => &mut c.galileo_meas,
                            ('E', true) => &mut c.galileo_e5b_meas,
                            ('C', false) => &mut c.beidou_meas,
                            ('C', true) => &mut c.beidou_b2i_meas,
                            _ => &mut c.glonass_meas,
                        } += 1;
                    }
                    let row: &mut Vec<Option<ObsValue>> = if sys == 'G' {
                        let k = match ep.sats.iter().position(|(p, _)| *p == m.sv_id) {
                            Some(k) => k,
                            None => {
                                ep.sats.push((m.sv_id, vec![None; n]));
                                ep.sats.len() - 1
                            }
                        };
                        &mut ep.sats[k].1
                    } else {
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
                        &mut others[k].2
                    };
                    row[off..off + 4].copy_from_slice(&vals);
                }
                prev_epoch_t = Some(ep.t);
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

/// Write `obs` (GPS `C1 L1 D1 S1` as L1 C/A, and `C2 L2 D2 S2` where
/// present as L2 CL, `sigId` 3; the phase's LLI as the lock time and
/// half-cycle bit of `rawx_meas`) as RXM-RAWX epochs and
/// `nav` as RXM-SFRBX subframes 1–3 per ephemeris (issue of data = its
/// index mod 256) plus subframe 4 page 18 for the ionosphere, sent after the
/// first epoch (the reader's week), transmitted at that epoch's time.
/// Errors: a field that does not fit its LNAV bits (names it).
pub fn write_ubx_gnss(obs: &ObsFile, nav: &NavData) -> Result<Vec<u8>, String> {
    write_ubx_multi(obs, &GnssObs::default(), nav, &[], &[])
}

/// Lock times of the writer's carriers: per (gnssId, svId, sigId) the
/// epoch and lock time [ms] of its last written carrier.
type LockTimes = HashMap<(u8, u8, u8), (f64, u16)>;

/// One RAWX measurement at epoch `t` from a code/phase/Doppler/C/N0
/// quadruple. The carrier's lock time: 0 when its LLI bit 0 (loss of lock)
/// is set, else the previous lock time of the signal plus the time since
/// (at most [`MAX_LOCK_TIME_MS`]; a carrier without a previous one:
/// the maximum, tracked long before), so that [`lost_lock`] gives the LLI
/// back; LLI bit 1 (half-cycle ambiguity) clears `trkStat` bit 2.
fn rawx_meas(
    gnss_id: u8,
    sv_id: u8,
    sig_id: u8,
    q: [Option<ObsValue>; 4],
    t: f64,
    locks: &mut LockTimes,
) -> RawxMeas {
    let [c, l, d, sn] = q;
    let mut locktime_ms = 0;
    let mut half = 0x04;
    if let Some(l) = l {
        let key = (gnss_id, sv_id, sig_id);
        locktime_ms = if l.lli & 1 != 0 {
            0
        } else {
            match locks.get(&key) {
                Some(&(t0, l0)) => (f64::from(l0) + ((t - t0) * 1e3).round())
                    .clamp(1.0, f64::from(MAX_LOCK_TIME_MS))
                    as u16,
                None => MAX_LOCK_TIME_MS,
            }
        };
        locks.insert(key, (t, locktime_ms));
        if l.lli & 2 != 0 {
            half = 0;
        }
    }
    RawxMeas {
        pr_mes: c.map_or(0.0, |o| o.value),
        cp_mes: l.map_or(0.0, |o| o.value),
        do_mes: d.map_or(0.0, |o| o.value as f32),
        gnss_id,
        sv_id,
        sig_id,
        locktime_ms,
        // S1 when the observations carry it, else 45 dB-Hz
        // (a strong open-sky signal).
        cno_dbhz: sn.map_or(45, |o| o.value.round().clamp(1.0, 255.0) as u8),
        trk_stat: u8::from(c.is_some()) | u8::from(l.is_some()) << 1 | half,
        ..Default::default()
    }
}

/// RINEX 3 code quadruples written as RAWX signals: (system, `gnssId`,
/// `sigId` (BeiDou GEO: +1, D2), the code quadruples in preference order:
/// the first with a code or a phase is written).
type SignalCodes = (char, u8, u8, &'static [[&'static str; 4]]);
const SIGNALS: [SignalCodes; 7] = [
    (
        'E',
        GNSS_GAL,
        SIG_GAL_E1C,
        &[["C1C", "L1C", "D1C", "S1C"], ["C1X", "L1X", "D1X", "S1X"]],
    ),
    ('E', GNSS_GAL, SIG_GAL_E1B, &[["C1B", "L1B", "D1B", "S1B"]]),
    ('E', GNSS_GAL, SIG_GAL_E5BI, &[["C7I", "L7I", "D7I", "S7I"]]),
    (
        'E',
        GNSS_GAL,
        SIG_GAL_E5BQ,
        &[["C7Q", "L7Q", "D7Q", "S7Q"], ["C7X", "L7X", "D7X", "S7X"]],
    ),
    (
        'C',
        GNSS_BDS,
        SIG_BDS_B1I,
        &[["C2I", "L2I", "D2I", "S2I"], ["C1I", "L1I", "D1I", "S1I"]],
    ),
    (
        'C',
        GNSS_BDS,
        SIG_BDS_B2I,
        &[["C7I", "L7I", "D7I", "S7I"], ["C7X", "L7X", "D7X", "S7X"]],
    ),
    ('R', GNSS_GLO, SIG_GLO_L1OF, &[GLO_CODES]),
];

/// [`write_ubx_gnss`] with Galileo and BeiDou: the observations of
/// `gnss` (epochs parallel to `obs.epochs`; E1 C (else X) → `sigId` 0,
/// E1 B → 1, E5b I → 5, E5b Q (else X) → 6, B1I → 0 and B2I (else X) → 2,
/// each +1 for a GEO's D2, GLONASS `1C` → 0) as further RAWX
/// measurements, and the
/// records of `other` as I/NAV page pairs (word types in E1-B order 2, 4,
/// 1, 3, 5, IOD_nav = index mod 1024, health ≠ 0 → E1-B HS 1) or D1
/// subframes 1–3 / D2 pages 1–10 (AODE = index mod 32), and `glonass` as
/// strings 1–4 (frame identifier = index), all sent after the first epoch.
/// Errors: a field that does not fit its bits (names it), an epoch of
/// more than 255 measurements (RAWX `numMeas`; they were cut before).
pub fn write_ubx_multi(
    obs: &ObsFile,
    gnss: &GnssObs,
    nav: &NavData,
    other: &[GnssEph],
    glonass: &[GlonassEph],
) -> Result<Vec<u8>, String> {
    let idx = |c: &str| obs.index(c);
    // GPS L1 C/A, then L2C as L2 CL (P2, the P(Y) code, is no u-blox
    // signal: not written).
    let gps = [
        (SIG_GPS_L1CA, ["C1", "L1", "D1", "S1"].map(idx)),
        (SIG_GPS_L2CL, ["C2", "L2", "D2", "S2"].map(idx)),
    ];
    let mut locks = LockTimes::new();
    let mut out = Vec::new();
    for (k, ep) in obs.epochs.iter().enumerate() {
        let week = (ep.t / SECONDS_PER_WEEK).floor();
        let tow = ep.t - week * SECONDS_PER_WEEK;
        let mut meas: Vec<RawxMeas> = Vec::new();
        for (prn, vals) in &ep.sats {
            for (sig, ix) in gps {
                let q = ix.map(|i| {
                    i.and_then(|i| vals.get(i).copied().flatten())
                        .filter(|o| o.value != 0.0)
                });
                // L1 C/A as before: always (its pseudorange may be blank).
                if sig != SIG_GPS_L1CA && q[0].is_none() && q[1].is_none() {
                    continue;
                }
                meas.push(rawx_meas(GNSS_GPS, *prn, sig, q, ep.t, &mut locks));
            }
        }
        for (sys, prn, vals) in gnss.epochs.get(k).into_iter().flatten() {
            for (s, gid, sig, alternatives) in SIGNALS {
                if *sys != s {
                    continue;
                }
                let Some(q) = alternatives.iter().find_map(|codes| {
                    let q = codes.map(|c| {
                        gnss.index(s, c)
                            .and_then(|i| vals.get(i).copied().flatten())
                            .filter(|o| o.value != 0.0)
                    });
                    (q[0].is_some() || q[1].is_some()).then_some(q)
                }) else {
                    continue;
                };
                let sig = sig + u8::from(s == 'C' && bds::is_geo(*prn));
                meas.push(rawx_meas(gid, *prn, sig, q, ep.t, &mut locks));
            }
        }
        if meas.len() > usize::from(u8::MAX) {
            return Err(format!(
                "epoch {}: {} measurements, more than RAWX numMeas holds (255)",
                ep.t,
                meas.len()
            ));
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

    fn ov(value: f64, lli: u8) -> Option<ObsValue> {
        Some(ObsValue { value, lli })
    }

    /// Four epochs of both signals of each system: GPS L1 C/A + L2C
    /// (G05, G12), Galileo E1 C + E1 B + E5b I + E5b Q (E11, E24), BeiDou
    /// B1I + B2I (C03 a GEO: D2; C11: D1), GLONASS L1OF (R07); every
    /// carrier acquired at the first epoch (LLI 1), a slip on G05's L2 only
    /// at epoch 2, a half-cycle flag on E11's E5b Q at epoch 1, C11's B2I
    /// code without its carrier at epoch 3.
    fn dual_obs() -> (ObsFile, GnssObs) {
        let t0 = 2_300.0 * SECONDS_PER_WEEK + 345_600.25;
        let types: Vec<String> = GPS_TYPES.iter().map(|c| c.to_string()).collect();
        let codes = |c: &[&str]| c.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let sys_codes = vec![
            ('E', codes(&GAL_CODES)),
            ('C', codes(&BDS_CODES)),
            ('R', codes(&GLO_CODES)),
        ];
        let mut epochs = Vec::new();
        let mut gepochs = Vec::new();
        for k in 0..4 {
            let kf = k as f64;
            let acq = u8::from(k == 0);
            // One satellite's signals: (code, phase, Doppler, C/N0, LLI).
            let row = |n: usize, base: f64, lli: &dyn Fn(usize) -> u8| {
                let mut v = Vec::new();
                for j in 0..n {
                    let pr = base + 1234.5678901 * j as f64 + 812.3456789 * kf;
                    v.push(ov(pr, 0));
                    v.push(ov(pr / 0.19 + 0.123_456_7 * j as f64, lli(j)));
                    v.push(ov(-1234.567 + 11.0 * j as f64 - 0.25 * kf, 0));
                    v.push(ov(40.0 + j as f64 + kf, 0));
                }
                v
            };
            let g05 = row(2, 2.1e7, &|j| acq | u8::from(k == 2 && j == 1));
            let g12 = row(2, 2.3e7, &|_| acq);
            epochs.push(ObsEpoch {
                t: t0 + kf,
                flag: 0,
                sats: vec![(5, g05), (12, g12)],
            });
            let e11 = row(4, 2.4e7, &|j| acq | if k == 1 && j == 3 { 2 } else { 0 });
            let e24 = row(4, 2.5e7, &|_| acq);
            let c03 = row(2, 3.7e7, &|_| acq);
            let mut c11 = row(2, 2.2e7, &|_| acq);
            if k == 3 {
                c11[5] = None;
            }
            let r07 = row(1, 2.0e7, &|_| acq);
            gepochs.push(vec![
                ('E', 11, e11),
                ('E', 24, e24),
                ('C', 3, c03),
                ('C', 11, c11),
                ('R', 7, r07),
            ]);
        }
        let o = ObsFile {
            version: 3.04,
            types,
            epochs,
            ..ObsFile::default()
        };
        (
            o,
            GnssObs {
                sys_codes,
                epochs: gepochs,
            },
        )
    }

    /// RAWX round trip of both signals of each system: written by
    /// [`write_ubx_multi`], read by [`read_ubx_gnss`]. Expected: the same
    /// satellites and values per epoch within the RAWX fields' resolution
    /// (code and phase f64: exact; Doppler f32: 2⁻²³ relative; C/N0 whole
    /// dB-Hz: exact here), the same LLI bits (loss of lock through the
    /// lock time, half cycle through `trkStat`), each signal under its
    /// `sigId` (GPS 0, 3; Galileo 0, 1, 5, 6; BeiDou 0 and 2 for a MEO, 1
    /// and 3 for a GEO; GLONASS 0) and counted as read, nothing as other.
    #[test]
    fn dual_frequency_rawx_round_trip() {
        let (o, g) = dual_obs();
        let b = write_ubx_multi(&o, &g, &NavData::default(), &[], &[]).unwrap();
        let mut sigs = std::collections::BTreeSet::new();
        for m in UbxReader::new(&b[..], "t") {
            if let UbxMessage::RxmRawx(x) = m.unwrap() {
                sigs.extend(x.meas.iter().map(|m| (m.gnss_id, m.sv_id, m.sig_id)));
            }
        }
        let want = [
            (0, 5, 0),
            (0, 5, 3),
            (0, 12, 0),
            (0, 12, 3),
            (2, 11, 0),
            (2, 11, 1),
            (2, 11, 5),
            (2, 11, 6),
            (2, 24, 0),
            (2, 24, 1),
            (2, 24, 5),
            (2, 24, 6),
            (3, 3, 1),
            (3, 3, 3),
            (3, 11, 0),
            (3, 11, 2),
            (6, 7, 0),
        ];
        assert_eq!(sigs.into_iter().collect::<Vec<_>>(), want);
        let u = read_ubx_gnss(&b[..], "t").unwrap();
        let r = &u.report;
        assert_eq!(r.rawx_epochs, 4);
        assert_eq!((r.gps_meas, r.gps_l2_meas), (8, 8));
        assert_eq!((r.galileo_meas, r.galileo_e5b_meas), (16, 16));
        assert_eq!(
            (r.beidou_meas, r.beidou_b2i_meas, r.glonass_meas),
            (8, 8, 4)
        );
        assert_eq!(r.other_signal_meas, 0);
        // 17 carriers acquired at epoch 0, one slip.
        assert_eq!(r.loss_of_lock, 18);
        let close = |a: Option<ObsValue>, b: Option<ObsValue>, code: &str| match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                let tol = if code.starts_with('D') {
                    a.value.abs() * f64::from(f32::EPSILON)
                } else {
                    0.0
                };
                a.lli == b.lli && (a.value - b.value).abs() <= tol
            }
            _ => false,
        };
        assert_eq!(u.obs.types, o.types);
        assert_eq!(u.obs.epochs.len(), 4);
        for (a, b) in o.epochs.iter().zip(&u.obs.epochs) {
            assert_eq!(a.t, b.t);
            assert_eq!(a.sats.len(), b.sats.len());
            for ((pa, va), (pb, vb)) in a.sats.iter().zip(&b.sats) {
                assert_eq!(pa, pb);
                for (j, code) in o.types.iter().enumerate() {
                    assert!(
                        close(va[j], vb[j], code),
                        "G{pa} {code} {:?} {:?}",
                        va[j],
                        vb[j]
                    );
                }
            }
        }
        for (ea, eb) in g.epochs.iter().zip(&u.gnss.epochs) {
            assert_eq!(ea.len(), eb.len());
            for (sys, prn, va) in ea {
                let (_, _, vb) = eb
                    .iter()
                    .find(|(s, p, _)| s == sys && p == prn)
                    .unwrap_or_else(|| panic!("{sys}{prn} missing"));
                let codes = &g.sys_codes.iter().find(|(s, _)| s == sys).unwrap().1;
                for (code, x) in codes.iter().zip(va) {
                    let y = u.gnss.index(*sys, code).and_then(|i| vb[i]);
                    assert!(close(*x, y, code), "{sys}{prn} {code} {x:?} {y:?}");
                }
            }
        }
    }

    /// An epoch of more measurements than RAWX `numMeas` holds (200 GPS
    /// satellites with L1 and L2: 400) is an error naming the epoch and the
    /// count, not a silently cut epoch; 127 satellites (254) are written.
    #[test]
    fn too_many_measurements_is_an_error() {
        let (mut o, _) = dual_obs();
        let row = o.epochs[0].sats[0].1.clone();
        o.epochs.truncate(1);
        o.epochs[0].sats = (1..=127).map(|p| (p, row.clone())).collect();
        let b = write_ubx_multi(&o, &GnssObs::default(), &NavData::default(), &[], &[]).unwrap();
        let u = read_ubx_gnss(&b[..], "t").unwrap();
        // PRN 33–127 are no GPS satellites: counted, not read.
        assert_eq!((u.report.gps_meas, u.report.gps_l2_meas), (32, 32));
        assert_eq!(u.report.other_signal_meas, 2 * 95);
        o.epochs[0].sats = (1..=200).map(|p| (p, row.clone())).collect();
        let e =
            write_ubx_multi(&o, &GnssObs::default(), &NavData::default(), &[], &[]).unwrap_err();
        assert!(e.contains("400 measurements") && e.contains("255"), "{e}");
    }

    fn meas(gnss_id: u8, sv_id: u8, sig_id: u8, pr: f64, lock: u16) -> RawxMeas {
        RawxMeas {
            pr_mes: pr,
            cp_mes: pr / 0.2,
            do_mes: 100.0,
            gnss_id,
            sv_id,
            sig_id,
            locktime_ms: lock,
            cno_dbhz: 40,
            trk_stat: 0x07,
            ..Default::default()
        }
    }

    fn log(epochs: &[Vec<RawxMeas>]) -> Vec<u8> {
        let mut b = Vec::new();
        for (k, m) in epochs.iter().enumerate() {
            b.extend(encode(&UbxMessage::RxmRawx(RxmRawx {
                rcv_tow: 1000.0 + k as f64,
                week: 2300,
                version: 1,
                meas: m.clone(),
                ..Default::default()
            })));
        }
        b
    }

    /// Signals not read are counted: GPS L5 I (sigId 6), Galileo E5a I
    /// (3), BeiDou B2a (7), GLONASS L2OF (2), QZSS, a GPS svId 40; an L2
    /// CM next to its satellite's L2 CL (either order) is not used (the CL
    /// is); an L2 CM alone is read as L2C.
    #[test]
    fn other_signals_counted_and_l2_cl_preferred() {
        let b = log(&[vec![
            meas(0, 3, 0, 2.0e7, 5000),
            meas(0, 3, 4, 2.0e7 + 4.0, 5000),
            meas(0, 3, 3, 2.0e7 + 3.0, 5000),
            meas(0, 8, 0, 2.1e7, 5000),
            meas(0, 8, 3, 2.1e7 + 3.0, 5000),
            meas(0, 8, 4, 2.1e7 + 4.0, 5000),
            meas(0, 9, 4, 2.2e7 + 4.0, 5000),
            meas(0, 9, 6, 2.2e7 + 6.0, 5000),
            meas(0, 40, 0, 2.2e7, 5000),
            meas(2, 4, 3, 2.3e7, 5000),
            meas(3, 20, 7, 2.3e7, 5000),
            meas(6, 2, 2, 2.3e7, 5000),
            meas(5, 1, 0, 3.8e7, 5000),
        ]]);
        let u = read_ubx_gnss(&b[..], "t").unwrap();
        // L5, CM ×2, svId 40, E5a, B2a, L2OF, QZSS.
        assert_eq!(u.report.other_signal_meas, 8);
        assert_eq!((u.report.gps_meas, u.report.gps_l2_meas), (2, 3));
        let c2 = u.obs.index("C2").unwrap();
        let got: Vec<(u8, f64)> = u.obs.epochs[0]
            .sats
            .iter()
            .map(|(p, v)| (*p, v[c2].unwrap().value))
            .collect();
        assert_eq!(got, [(3, 2.0e7 + 3.0), (8, 2.1e7 + 3.0), (9, 2.2e7 + 4.0)]);
        assert!(u.gnss.epochs[0].is_empty());
    }

    /// Loss of lock from the lock time ([`lost_lock`]), per signal: G03 L1
    /// tracked 5 s, 6 s, then 0.3 s (slip), 1.3 s, absent for one epoch,
    /// 3.3 s (continuous over the gap: no slip), then 3.0 s (slip); G03 L2
    /// acquired at epoch 1 (lock 0.5 s < 1 s since the previous epoch:
    /// slip) and continuous after; G07 at the first epoch with lock 0
    /// (slip) and a saturated lock time staying saturated (no slip).
    #[test]
    fn loss_of_lock_follows_the_lock_time() {
        let l1 = [
            Some(5000),
            Some(6000),
            Some(300),
            Some(1300),
            None,
            Some(3300),
            Some(3000),
        ];
        let l2 = [
            None,
            Some(500),
            Some(1500),
            Some(2500),
            Some(3500),
            Some(4500),
            Some(5500),
        ];
        let g7 = [
            Some(0),
            Some(1000),
            Some(64_500),
            Some(64_500),
            Some(64_500),
            Some(64_500),
            Some(64_500),
        ];
        let epochs: Vec<Vec<RawxMeas>> = (0..7)
            .map(|k| {
                let mut v = Vec::new();
                if let Some(l) = l1[k] {
                    v.push(meas(0, 3, 0, 2.0e7, l));
                }
                if let Some(l) = l2[k] {
                    v.push(meas(0, 3, 3, 2.0e7, l));
                }
                if let Some(l) = g7[k] {
                    v.push(meas(0, 7, 0, 2.1e7, l));
                }
                v
            })
            .collect();
        let u = read_ubx_gnss(&log(&epochs)[..], "t").unwrap();
        let lli = |k: usize, prn: u8, t: &str| {
            let i = u.obs.index(t).unwrap();
            u.obs.epochs[k]
                .sats
                .iter()
                .find(|(p, _)| *p == prn)
                .and_then(|(_, v)| v[i])
                .map(|o| o.lli & 1)
        };
        let got1: Vec<_> = (0..7).map(|k| lli(k, 3, "L1")).collect();
        let got2: Vec<_> = (0..7).map(|k| lli(k, 3, "L2")).collect();
        let got7: Vec<_> = (0..7).map(|k| lli(k, 7, "L1")).collect();
        assert_eq!(
            got1,
            [Some(0), Some(0), Some(1), Some(0), None, Some(0), Some(1)]
        );
        assert_eq!(
            got2,
            [None, Some(1), Some(0), Some(0), Some(0), Some(0), Some(0)]
        );
        assert_eq!(
            got7,
            [
                Some(1),
                Some(0),
                Some(0),
                Some(0),
                Some(0),
                Some(0),
                Some(0)
            ]
        );
        assert_eq!(u.report.loss_of_lock, 4);
        // The half-cycle bit stays where it was: trkStat bit 2 set here.
        assert!(u.obs.epochs[0].sats[0].1[1].unwrap().lli & 2 == 0);
    }

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
