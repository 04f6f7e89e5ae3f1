//! Raw GNSS from a UBX log: UBX-RXM-RAWX epochs (GPS L1 C/A code, carrier,
//! Doppler) and UBX-RXM-SFRBX subframes (GPS LNAV, [`crate::gps_lnav`])
//! read into the same structures as a RINEX observation and navigation file
//! ([`ObsFile`] with RINEX 2 codes `C1`, `L1`, `D1`, `S1`; [`NavData`]), so a
//! single `.ubx` log is self-contained for single-point positioning; and the
//! inverse writer ([`write_ubx_gnss`]) for simulated logs and tests.
//!
//! Conventions carried over unchanged: RAWX `prMes` [m] → `C1`, `cpMes`
//! [cycles] → `L1`, `doMes` [Hz] (positive for an approaching satellite, as
//! RINEX) → `D1`, `cno` [dB-Hz] → `S1`; a pseudorange or phase whose `trkStat` valid bit is clear
//! is left blank. Epoch time: RAWX week and `rcvTow` (receiver time, GPS
//! seconds), as a RINEX observation time tag. Ephemerides are collected over
//! the whole log (as a navigation file holds the day's records); the 10-bit
//! broadcast week is resolved with the week of the latest RAWX epoch, so
//! subframes before the first epoch wait for it (at most
//! [`MAX_PENDING_SUBFRAMES`]; more are rejected and counted).

use crate::error::{ReadError, RecordStats};
use crate::gps_lnav::{decode_subframe, encode_ephemeris, encode_iono, Assembler};
use crate::rinex::{NavData, ObsEpoch, ObsFile, ObsValue};
use crate::ubx::{encode, RawxMeas, RxmRawx, RxmSfrbx, UbxMessage, UbxReader, SFRBX_MAX_WORDS};
use navfuse_core::gnss::SECONDS_PER_WEEK;
use std::io::Read;

/// Subframes held until the first RAWX epoch gives the week.
pub const MAX_PENDING_SUBFRAMES: usize = 4096;
/// RAWX `gnssId` of GPS and `sigId` of L1 C/A.
const GNSS_GPS: u8 = 0;
const SIG_L1CA: u8 = 0;

/// What a log held besides what was used.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct UbxGnssReport {
    /// RAWX epochs read.
    pub rawx_epochs: u64,
    /// Measurements of other systems or signals (not used here).
    pub other_signal_meas: u64,
    /// GPS subframes that failed parity/preamble (counted, not used).
    pub subframes_bad: u64,
    /// Subframes of other systems (not used here).
    pub subframes_other_system: u64,
    /// Subframes dropped because no RAWX week came within the pending cap.
    pub subframes_without_week: u64,
    /// Ephemerides assembled.
    pub ephemerides: u64,
    /// Other UBX messages in the log.
    pub other_messages: u64,
}

/// Read a UBX log's GPS raw observations and broadcast navigation data.
/// `name` names the source in errors. Frames with bad checksums are the
/// reader's business ([`UbxReader`], counted in its stats).
pub fn read_ubx_gnss<R: Read>(
    rdr: R,
    name: &str,
) -> Result<(ObsFile, NavData, UbxGnssReport, RecordStats), ReadError> {
    let mut r = UbxReader::new(rdr, name);
    let mut obs = ObsFile {
        version: 3.0,
        marker: name.to_string(),
        // S1: the measurement's C/N0 [dB-Hz] (RINEX 3.05 §5.7: signal
        // strength as C/N0 in dB-Hz), which the tight filter's weights use.
        types: vec!["C1".into(), "L1".into(), "D1".into(), "S1".into()],
        ..Default::default()
    };
    let mut nav = NavData::default();
    let mut rep = UbxGnssReport::default();
    let mut asm = Assembler::default();
    let mut week: Option<u16> = None;
    let mut pending: Vec<RxmSfrbx> = Vec::new();
    for msg in r.by_ref() {
        match msg? {
            UbxMessage::RxmRawx(x) => {
                rep.rawx_epochs += 1;
                week = Some(x.week);
                for m in pending.drain(..) {
                    subframe(&m, x.week, &mut asm, &mut nav, &mut rep);
                }
                let mut ep = ObsEpoch {
                    t: f64::from(x.week) * SECONDS_PER_WEEK + x.rcv_tow,
                    flag: 0,
                    sats: Vec::with_capacity(x.meas.len()),
                };
                for m in &x.meas {
                    if m.gnss_id != GNSS_GPS || m.sig_id != SIG_L1CA || !(1..=32).contains(&m.sv_id)
                    {
                        rep.other_signal_meas += 1;
                        continue;
                    }
                    let v = |ok: bool, value: f64| {
                        (ok && value.is_finite() && value != 0.0)
                            .then_some(ObsValue { value, lli: 0 })
                    };
                    let lli = u8::from(m.trk_stat & 0x04 == 0 && m.trk_stat & 0x02 != 0) << 1;
                    ep.sats.push((
                        m.sv_id,
                        vec![
                            v(m.trk_stat & 0x01 != 0, m.pr_mes),
                            v(m.trk_stat & 0x02 != 0, m.cp_mes).map(|o| ObsValue { lli, ..o }),
                            v(true, f64::from(m.do_mes)),
                            v(true, f64::from(m.cno_dbhz)),
                        ],
                    ));
                }
                obs.epochs.push(ep);
            }
            UbxMessage::RxmSfrbx(m) => {
                if m.gnss_id != GNSS_GPS || usize::from(m.num_words) != SFRBX_MAX_WORDS {
                    rep.subframes_other_system += 1;
                } else if let Some(w) = week {
                    subframe(&m, w, &mut asm, &mut nav, &mut rep);
                } else if pending.len() < MAX_PENDING_SUBFRAMES {
                    pending.push(m);
                } else {
                    rep.subframes_without_week += 1;
                }
            }
            _ => rep.other_messages += 1,
        }
    }
    rep.subframes_without_week += pending.len() as u64;
    nav.iono = asm.iono;
    Ok((obs, nav, rep, r.stats().clone()))
}

/// One GPS subframe into the assembler; a new ephemeris goes to `nav`.
fn subframe(
    m: &RxmSfrbx,
    week: u16,
    asm: &mut Assembler,
    nav: &mut NavData,
    rep: &mut UbxGnssReport,
) {
    let mut w = [0u32; 10];
    w.copy_from_slice(&m.words[..10]);
    match decode_subframe(&w) {
        Ok(sf) => {
            if let Some(e) = asm.push(m.sv_id, &sf, week) {
                nav.orbits.push(e.orbit);
                nav.ura_m.push(e.ura_m);
                rep.ephemerides += 1;
            }
        }
        Err(_) => rep.subframes_bad += 1,
    }
}

/// Write `obs` (GPS `C1`, `L1`, `D1` where present) as RXM-RAWX epochs and
/// `nav` as RXM-SFRBX subframes 1–3 per ephemeris (issue of data = its
/// index mod 256) plus subframe 4 page 18 for the ionosphere, sent after the
/// first epoch (the reader's week), transmitted at that epoch's time.
/// Errors: a field that does not fit its LNAV bits (names it).
pub fn write_ubx_gnss(obs: &ObsFile, nav: &NavData) -> Result<Vec<u8>, String> {
    let idx = |c: &str| obs.index(c);
    let (ic, il, id, is) = (idx("C1"), idx("L1"), idx("D1"), idx("S1"));
    let mut out = Vec::new();
    for (k, ep) in obs.epochs.iter().enumerate() {
        let week = (ep.t / SECONDS_PER_WEEK).floor();
        let tow = ep.t - week * SECONDS_PER_WEEK;
        let meas = ep
            .sats
            .iter()
            .map(|(prn, vals)| {
                let get = |i: Option<usize>| i.and_then(|i| vals.get(i).copied().flatten());
                let (c, l, d, sn) = (get(ic), get(il), get(id), get(is));
                RawxMeas {
                    pr_mes: c.map_or(0.0, |o| o.value),
                    cp_mes: l.map_or(0.0, |o| o.value),
                    do_mes: d.map_or(0.0, |o| o.value as f32),
                    gnss_id: GNSS_GPS,
                    sv_id: *prn,
                    sig_id: SIG_L1CA,
                    // S1 when the observations carry it, else 45 dB-Hz
                    // (a strong open-sky signal).
                    cno_dbhz: sn.map_or(45, |o| o.value.round().clamp(1.0, 255.0) as u8),
                    trk_stat: u8::from(c.is_some()) | u8::from(l.is_some()) << 1 | 0x04,
                    ..Default::default()
                }
            })
            .collect();
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
            let mut put = |sv: u8, w: [u32; 10]| {
                let mut words = [0u32; SFRBX_MAX_WORDS];
                words.copy_from_slice(&w);
                out.extend(encode(&UbxMessage::RxmSfrbx(RxmSfrbx {
                    gnss_id: GNSS_GPS,
                    sv_id: sv,
                    num_words: 10,
                    version: 2,
                    words,
                    ..Default::default()
                })));
            };
            for (j, o) in nav.orbits.iter().enumerate() {
                let ura = nav.ura_m.get(j).copied().unwrap_or(0.0);
                let sfs = encode_ephemeris(o, (j % 256) as u8, ura, tx)
                    .map_err(|e| format!("PRN {} t_oe {}: {e}", o.prn, o.t_oe))?;
                for w in sfs {
                    put(o.prn, w);
                }
            }
            if let Some(k) = &nav.iono {
                put(1, encode_iono(k, tx).map_err(|e| e.to_string())?);
            }
        }
    }
    Ok(out)
}
