//! u-blox UBX binary protocol (u-blox 8 / M8 and F9 interface descriptions,
//! "UBX protocol"): frame parser with checksum, decoders and encoders for
//! NAV-PVT, RXM-RAWX, ESF-RAW, ESF-MEAS and NAV-RELPOSNED, and conversion of
//! NAV-PVT to [`GnssFix`] and ESF data to SI units.
//!
//! Frame: `0xB5 0x62 class id len(u16 LE) payload ck_a ck_b`, the checksum
//! being the 8-bit Fletcher sum over class, id, length and payload. All
//! numbers little-endian. The parser resynchronises on the next `0xB5 0x62`
//! after garbage or a bad frame; payloads are capped at
//! [`MAX_PAYLOAD`] bytes (memory stays bounded whatever arrives). Every frame
//! is counted used (decoded), skipped (valid checksum, a message type not
//! decoded here) or rejected by reason; garbage bytes between frames are
//! counted in [`UbxReader::garbage_bytes`]. For errors the "line" is the
//! 1-based frame number.

use crate::error::{ReadError, RecordStats};
use crate::time::{gps_from_calendar, Calendar, TimeSystem};
use navfuse_core::types::{GnssFix, Vec3};
use std::io::Read;
use std::sync::Arc;

/// Largest payload accepted (RXM-RAWX with 255 measurements is 8176 bytes).
pub const MAX_PAYLOAD: usize = 8192;

pub const REASON_CHECKSUM: &str = "bad checksum";
pub const REASON_TOO_LONG: &str = "payload longer than MAX_PAYLOAD";
pub const REASON_BAD_PAYLOAD: &str = "payload does not match the message layout";
pub const REASON_TRUNCATED: &str = "truncated frame at end of input";

/// 8-bit Fletcher checksum over `bytes` (class, id, length, payload).
pub fn checksum(bytes: &[u8]) -> (u8, u8) {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    (a, b)
}

/// UBX-NAV-PVT (0x01 0x07): navigation position velocity time solution.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NavPvt {
    /// GPS time of week of the epoch [ms].
    pub itow_ms: u32,
    pub year: u16,
    pub month: u8,
    pub day: u8,
    pub hour: u8,
    pub min: u8,
    pub sec: u8,
    /// Validity flags (bit 0 date, 1 time, 2 fully resolved).
    pub valid: u8,
    pub t_acc_ns: u32,
    /// Fraction of second [ns], −1e9..1e9.
    pub nano_ns: i32,
    /// 0 no fix, 2 2-D, 3 3-D, 4 GNSS+DR, 5 time only.
    pub fix_type: u8,
    /// Bit 0 gnssFixOK, 1 diffSoln, 6–7 carrSoln (1 float, 2 fixed).
    pub flags: u8,
    pub flags2: u8,
    pub num_sv: u8,
    /// Longitude, latitude [1e-7 deg].
    pub lon_e7: i32,
    pub lat_e7: i32,
    /// Height above ellipsoid, above MSL [mm].
    pub height_mm: i32,
    pub hmsl_mm: i32,
    pub h_acc_mm: u32,
    pub v_acc_mm: u32,
    /// NED velocity [mm/s].
    pub vel_n_mms: i32,
    pub vel_e_mms: i32,
    pub vel_d_mms: i32,
    pub g_speed_mms: i32,
    /// Heading of motion [1e-5 deg].
    pub head_mot_e5: i32,
    pub s_acc_mms: u32,
    pub head_acc_e5: u32,
    /// Position DOP [0.01].
    pub p_dop: u16,
    pub flags3: u16,
    pub head_veh_e5: i32,
    pub mag_dec_e2: i16,
    pub mag_acc_e2: u16,
}

/// One RXM-RAWX measurement.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct RawxMeas {
    /// Pseudorange [m].
    pub pr_mes: f64,
    /// Carrier phase [cycles].
    pub cp_mes: f64,
    /// Doppler [Hz].
    pub do_mes: f32,
    /// 0 GPS, 1 SBAS, 2 Galileo, 3 BeiDou, 5 QZSS, 6 GLONASS.
    pub gnss_id: u8,
    pub sv_id: u8,
    pub sig_id: u8,
    pub freq_id: u8,
    /// Carrier lock time [ms].
    pub locktime_ms: u16,
    pub cno_dbhz: u8,
    pub pr_stdev: u8,
    pub cp_stdev: u8,
    pub do_stdev: u8,
    /// Bit 0 pr valid, 1 cp valid, 2 half cycle valid, 3 half cycle subtracted.
    pub trk_stat: u8,
}

/// UBX-RXM-RAWX (0x02 0x15): raw measurements (carrier phase).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct RxmRawx {
    /// Receiver time of week [s].
    pub rcv_tow: f64,
    pub week: u16,
    pub leap_s: i8,
    pub rec_stat: u8,
    pub version: u8,
    pub meas: Vec<RawxMeas>,
}

/// UBX-RXM-SFRBX (0x02 0x13): one broadcast navigation data subframe of one
/// signal (GPS L1 C/A: 10 words of 30 bits, decoded by
/// [`crate::gps_lnav`]). Fixed size: the signals the message serves carry at
/// most 10 words.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct RxmSfrbx {
    /// 0 GPS, 1 SBAS, 2 Galileo, 3 BeiDou, 5 QZSS, 6 GLONASS.
    pub gnss_id: u8,
    pub sv_id: u8,
    /// GLONASS frequency slot + 7.
    pub freq_id: u8,
    pub num_words: u8,
    pub chn: u8,
    pub version: u8,
    /// The first `num_words` are valid.
    pub words: [u32; SFRBX_MAX_WORDS],
}

/// Most words an RXM-SFRBX message carries (u-blox: "up to 10, for
/// currently supported signals").
pub const SFRBX_MAX_WORDS: usize = 10;

/// One ESF data word: 24-bit value and 6-bit type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct EsfData {
    /// Data type (5 gyro z, 12 gyro temperature, 13 gyro y, 14 gyro x,
    /// 16/17/18 accel x/y/z, …).
    pub data_type: u8,
    /// Raw 24-bit field (signed for the IMU types, see [`EsfData::si`]).
    pub value: u32,
}

impl EsfData {
    fn word(self) -> u32 {
        (self.value & 0x00FF_FFFF) | (u32::from(self.data_type & 0x3F) << 24)
    }
    fn from_word(w: u32) -> Self {
        EsfData {
            data_type: ((w >> 24) & 0x3F) as u8,
            value: w & 0x00FF_FFFF,
        }
    }
    /// Signed 24-bit value.
    pub fn signed(self) -> i32 {
        ((self.value << 8) as i32) >> 8
    }
    /// The value in SI units for the IMU types: gyro [rad/s] (2⁻¹² deg/s
    /// per LSB), accelerometer [m/s²] (2⁻¹⁰ m/s² per LSB), gyro
    /// temperature [°C] (0.01 per LSB). `None` for other types.
    pub fn si(self) -> Option<f64> {
        let v = f64::from(self.signed());
        match self.data_type {
            5 | 13 | 14 => Some((v / 4096.0).to_radians()),
            16..=18 => Some(v / 1024.0),
            12 => Some(v * 0.01),
            _ => None,
        }
    }
}

/// UBX-ESF-RAW (0x10 0x03): raw sensor data, each with its sensor time tag.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct EsfRaw {
    /// (data, sensor time tag).
    pub data: Vec<(EsfData, u32)>,
}

/// UBX-ESF-MEAS (0x10 0x02): external sensor measurements.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct EsfMeas {
    pub time_tag: u32,
    /// Flags; bits 11–15 carry the number of data words, bit 3 calibTtagValid.
    pub flags: u16,
    pub id: u16,
    pub data: Vec<EsfData>,
    pub calib_ttag: Option<u32>,
}

/// UBX-NAV-RELPOSNED (0x01 0x3C, version 1 layout of F9): moving-base
/// relative position (heading from the base→rover vector).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NavRelPosNed {
    pub version: u8,
    pub ref_station_id: u16,
    pub itow_ms: u32,
    /// Relative position NED [cm] and its high-precision part [0.1 mm].
    pub rel_pos_n_cm: i32,
    pub rel_pos_e_cm: i32,
    pub rel_pos_d_cm: i32,
    pub rel_pos_length_cm: i32,
    /// Heading of the vector [1e-5 deg].
    pub rel_pos_heading_e5: i32,
    pub rel_pos_hp_n: i8,
    pub rel_pos_hp_e: i8,
    pub rel_pos_hp_d: i8,
    pub rel_pos_hp_length: i8,
    /// Accuracies [0.1 mm], heading accuracy [1e-5 deg].
    pub acc_n: u32,
    pub acc_e: u32,
    pub acc_d: u32,
    pub acc_length: u32,
    pub acc_heading_e5: u32,
    pub flags: u32,
}

impl NavRelPosNed {
    /// Relative position NED [m] (cm part + 0.1 mm part).
    pub fn rel_pos_ned_m(&self) -> Vec3 {
        Vec3::new(
            f64::from(self.rel_pos_n_cm) * 1e-2 + f64::from(self.rel_pos_hp_n) * 1e-4,
            f64::from(self.rel_pos_e_cm) * 1e-2 + f64::from(self.rel_pos_hp_e) * 1e-4,
            f64::from(self.rel_pos_d_cm) * 1e-2 + f64::from(self.rel_pos_hp_d) * 1e-4,
        )
    }
    /// Heading [rad].
    pub fn heading(&self) -> f64 {
        (f64::from(self.rel_pos_heading_e5) * 1e-5).to_radians()
    }
}

/// A decoded UBX message.
#[derive(Clone, Debug, PartialEq)]
pub enum UbxMessage {
    NavPvt(NavPvt),
    RxmRawx(RxmRawx),
    RxmSfrbx(RxmSfrbx),
    EsfRaw(EsfRaw),
    EsfMeas(EsfMeas),
    NavRelPosNed(NavRelPosNed),
}

/// Little-endian cursor over a payload.
struct Rd<'a>(&'a [u8], usize);

impl Rd<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.0[self.1..self.1 + N]);
        self.1 += N;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn i8(&mut self) -> i8 {
        self.u8() as i8
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn i16(&mut self) -> i16 {
        i16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn skip(&mut self, n: usize) {
        self.1 += n;
    }
}

/// Decode a payload of `class`/`id`. `Ok(None)` for message types not decoded
/// here; `Err` when the payload length does not fit the layout.
pub fn decode(class: u8, id: u8, p: &[u8]) -> Result<Option<UbxMessage>, String> {
    let bad = |want: &str| {
        format!(
            "class 0x{class:02X} id 0x{id:02X}: length {} (expected {want})",
            p.len()
        )
    };
    let mut r = Rd(p, 0);
    Ok(Some(match (class, id) {
        (0x01, 0x07) => {
            if p.len() != 92 {
                return Err(bad("92"));
            }
            let m = NavPvt {
                itow_ms: r.u32(),
                year: r.u16(),
                month: r.u8(),
                day: r.u8(),
                hour: r.u8(),
                min: r.u8(),
                sec: r.u8(),
                valid: r.u8(),
                t_acc_ns: r.u32(),
                nano_ns: r.i32(),
                fix_type: r.u8(),
                flags: r.u8(),
                flags2: r.u8(),
                num_sv: r.u8(),
                lon_e7: r.i32(),
                lat_e7: r.i32(),
                height_mm: r.i32(),
                hmsl_mm: r.i32(),
                h_acc_mm: r.u32(),
                v_acc_mm: r.u32(),
                vel_n_mms: r.i32(),
                vel_e_mms: r.i32(),
                vel_d_mms: r.i32(),
                g_speed_mms: r.i32(),
                head_mot_e5: r.i32(),
                s_acc_mms: r.u32(),
                head_acc_e5: r.u32(),
                p_dop: r.u16(),
                flags3: r.u16(),
                head_veh_e5: {
                    r.skip(4);
                    r.i32()
                },
                mag_dec_e2: r.i16(),
                mag_acc_e2: r.u16(),
            };
            UbxMessage::NavPvt(m)
        }
        (0x02, 0x15) => {
            if p.len() < 16 {
                return Err(bad("16 + 32·numMeas"));
            }
            let rcv_tow = r.f64();
            let week = r.u16();
            let leap_s = r.i8();
            let n = r.u8() as usize;
            let rec_stat = r.u8();
            let version = r.u8();
            r.skip(2);
            if p.len() != 16 + 32 * n {
                return Err(bad(&format!("{} for numMeas {n}", 16 + 32 * n)));
            }
            let mut meas = Vec::with_capacity(n);
            for _ in 0..n {
                let mut m = RawxMeas {
                    pr_mes: r.f64(),
                    cp_mes: r.f64(),
                    do_mes: r.f32(),
                    gnss_id: r.u8(),
                    sv_id: r.u8(),
                    sig_id: r.u8(),
                    freq_id: r.u8(),
                    locktime_ms: r.u16(),
                    cno_dbhz: r.u8(),
                    pr_stdev: r.u8(),
                    cp_stdev: r.u8(),
                    do_stdev: r.u8(),
                    trk_stat: r.u8(),
                };
                r.skip(1);
                m.pr_stdev &= 0x0F;
                m.cp_stdev &= 0x0F;
                m.do_stdev &= 0x0F;
                meas.push(m);
            }
            UbxMessage::RxmRawx(RxmRawx {
                rcv_tow,
                week,
                leap_s,
                rec_stat,
                version,
                meas,
            })
        }
        (0x02, 0x13) => {
            if p.len() < 8 {
                return Err(bad("8 + 4·numWords"));
            }
            let mut m = RxmSfrbx {
                gnss_id: r.u8(),
                sv_id: r.u8(),
                ..Default::default()
            };
            r.skip(1);
            m.freq_id = r.u8();
            m.num_words = r.u8();
            m.chn = r.u8();
            m.version = r.u8();
            r.skip(1);
            let n = usize::from(m.num_words);
            if n > SFRBX_MAX_WORDS || p.len() != 8 + 4 * n {
                return Err(bad(&format!(
                    "8 + 4·numWords with numWords {n} ≤ {SFRBX_MAX_WORDS}"
                )));
            }
            for w in m.words.iter_mut().take(n) {
                *w = r.u32();
            }
            UbxMessage::RxmSfrbx(m)
        }
        (0x10, 0x03) => {
            if p.len() < 4 || (p.len() - 4) & 7 != 0 {
                return Err(bad("4 + 8·N"));
            }
            r.skip(4);
            let n = (p.len() - 4) / 8;
            let data = (0..n)
                .map(|_| (EsfData::from_word(r.u32()), r.u32()))
                .collect();
            UbxMessage::EsfRaw(EsfRaw { data })
        }
        (0x10, 0x02) => {
            if p.len() < 8 {
                return Err(bad("8 + 4·numMeas [+ 4]"));
            }
            let time_tag = r.u32();
            let flags = r.u16();
            let id_ = r.u16();
            let n = usize::from(flags >> 11);
            let calib = flags & 0x08 != 0;
            if p.len() != 8 + 4 * n + if calib { 4 } else { 0 } {
                return Err(bad("8 + 4·numMeas (+ 4 with calibTtagValid)"));
            }
            let data = (0..n).map(|_| EsfData::from_word(r.u32())).collect();
            let calib_ttag = calib.then(|| r.u32());
            UbxMessage::EsfMeas(EsfMeas {
                time_tag,
                flags,
                id: id_,
                data,
                calib_ttag,
            })
        }
        (0x01, 0x3C) => {
            if p.len() != 64 {
                return Err(bad("64 (version 1)"));
            }
            let version = r.u8();
            r.skip(1);
            let m = NavRelPosNed {
                version,
                ref_station_id: r.u16(),
                itow_ms: r.u32(),
                rel_pos_n_cm: r.i32(),
                rel_pos_e_cm: r.i32(),
                rel_pos_d_cm: r.i32(),
                rel_pos_length_cm: r.i32(),
                rel_pos_heading_e5: r.i32(),
                rel_pos_hp_n: {
                    r.skip(4);
                    r.i8()
                },
                rel_pos_hp_e: r.i8(),
                rel_pos_hp_d: r.i8(),
                rel_pos_hp_length: r.i8(),
                acc_n: r.u32(),
                acc_e: r.u32(),
                acc_d: r.u32(),
                acc_length: r.u32(),
                acc_heading_e5: r.u32(),
                flags: {
                    r.skip(4);
                    r.u32()
                },
            };
            UbxMessage::NavRelPosNed(m)
        }
        _ => return Ok(None),
    }))
}

/// Encode a message as a complete frame (sync, header, payload, checksum).
pub fn encode(m: &UbxMessage) -> Vec<u8> {
    let mut p: Vec<u8> = Vec::with_capacity(100);
    macro_rules! put {
        ($($e:expr),* $(,)?) => { $( p.extend_from_slice(&$e.to_le_bytes()); )* };
    }
    let (class, id) = match m {
        UbxMessage::NavPvt(m) => {
            put!(
                m.itow_ms,
                m.year,
                m.month,
                m.day,
                m.hour,
                m.min,
                m.sec,
                m.valid,
                m.t_acc_ns,
                m.nano_ns,
                m.fix_type,
                m.flags,
                m.flags2,
                m.num_sv,
                m.lon_e7,
                m.lat_e7,
                m.height_mm,
                m.hmsl_mm,
                m.h_acc_mm,
                m.v_acc_mm,
                m.vel_n_mms,
                m.vel_e_mms,
                m.vel_d_mms,
                m.g_speed_mms,
                m.head_mot_e5,
                m.s_acc_mms,
                m.head_acc_e5,
                m.p_dop,
                m.flags3,
                0u32,
                m.head_veh_e5,
                m.mag_dec_e2,
                m.mag_acc_e2
            );
            (0x01, 0x07)
        }
        UbxMessage::RxmRawx(m) => {
            let n = m.meas.len().min(255);
            put!(m.rcv_tow, m.week, m.leap_s, n as u8, m.rec_stat, m.version, 0u16);
            for x in &m.meas[..n] {
                put!(
                    x.pr_mes,
                    x.cp_mes,
                    x.do_mes,
                    x.gnss_id,
                    x.sv_id,
                    x.sig_id,
                    x.freq_id,
                    x.locktime_ms,
                    x.cno_dbhz,
                    x.pr_stdev & 0x0F,
                    x.cp_stdev & 0x0F,
                    x.do_stdev & 0x0F,
                    x.trk_stat,
                    0u8
                );
            }
            (0x02, 0x15)
        }
        UbxMessage::RxmSfrbx(m) => {
            let n = usize::from(m.num_words).min(SFRBX_MAX_WORDS);
            put!(m.gnss_id, m.sv_id, 0u8, m.freq_id, n as u8, m.chn, m.version, 0u8);
            for w in &m.words[..n] {
                put!(*w);
            }
            (0x02, 0x13)
        }
        UbxMessage::EsfRaw(m) => {
            put!(0u32);
            for (d, tag) in m.data.iter().take((MAX_PAYLOAD - 4) / 8) {
                put!(d.word(), *tag);
            }
            (0x10, 0x03)
        }
        UbxMessage::EsfMeas(m) => {
            let n = m.data.len().min(31);
            let flags = (m.flags & 0x07F7)
                | ((n as u16) << 11)
                | if m.calib_ttag.is_some() { 0x08 } else { 0 };
            put!(m.time_tag, flags, m.id);
            for d in &m.data[..n] {
                put!(d.word());
            }
            if let Some(c) = m.calib_ttag {
                put!(c);
            }
            (0x10, 0x02)
        }
        UbxMessage::NavRelPosNed(m) => {
            put!(
                m.version,
                0u8,
                m.ref_station_id,
                m.itow_ms,
                m.rel_pos_n_cm,
                m.rel_pos_e_cm,
                m.rel_pos_d_cm,
                m.rel_pos_length_cm,
                m.rel_pos_heading_e5,
                0u32,
                m.rel_pos_hp_n,
                m.rel_pos_hp_e,
                m.rel_pos_hp_d,
                m.rel_pos_hp_length,
                m.acc_n,
                m.acc_e,
                m.acc_d,
                m.acc_length,
                m.acc_heading_e5,
                0u32,
                m.flags
            );
            (0x01, 0x3C)
        }
    };
    frame(class, id, &p)
}

/// A complete frame around `payload`.
pub fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(payload.len() + 8);
    f.extend_from_slice(&[0xB5, 0x62, class, id]);
    f.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    f.extend_from_slice(payload);
    let (a, b) = checksum(&f[2..]);
    f.extend_from_slice(&[a, b]);
    f
}

impl NavPvt {
    /// GPS seconds of the epoch from the UTC date/time + nano (needs the
    /// valid-date and valid-time flags).
    pub fn gps_time(&self) -> Option<f64> {
        if self.valid & 0x03 != 0x03 {
            return None;
        }
        let c = Calendar {
            year: i32::from(self.year),
            month: self.month,
            day: self.day,
            hour: self.hour,
            minute: self.min,
            second: f64::from(self.sec),
        };
        let t = gps_from_calendar(&c, TimeSystem::Utc).ok()?;
        Some(t + f64::from(self.nano_ns) * 1e-9)
    }

    /// The solution as a [`GnssFix`] when it is a valid 3-D fix (gnssFixOK,
    /// fixType 3 or 4, date and time valid). σ: `hAcc/√2` north and east
    /// (hAcc is a horizontal, 2-axis figure), `vAcc` down, `sAcc` per
    /// velocity axis. Quality in RTKLIB's convention: carrSoln fixed → 1,
    /// float → 2, diffSoln → 4, else 5.
    pub fn to_fix(&self) -> Option<GnssFix> {
        if self.flags & 1 == 0 || !(self.fix_type == 3 || self.fix_type == 4) {
            return None;
        }
        let t = self.gps_time()?;
        let lat = f64::from(self.lat_e7) * 1e-7;
        let lon = f64::from(self.lon_e7) * 1e-7;
        if lat.abs() > 90.0 || lon.abs() > 180.0 {
            return None;
        }
        let sh = f64::from(self.h_acc_mm) * 1e-3 / std::f64::consts::SQRT_2;
        let sv = f64::from(self.s_acc_mms) * 1e-3;
        let quality = match (self.flags >> 6) & 3 {
            2 => 1,
            1 => 2,
            _ if self.flags & 2 != 0 => 4,
            _ => 5,
        };
        Some(GnssFix {
            t,
            lat: lat.to_radians(),
            lon: lon.to_radians(),
            h: f64::from(self.height_mm) * 1e-3,
            std_ned: Vec3::new(sh, sh, f64::from(self.v_acc_mm) * 1e-3),
            v_n: Some(
                Vec3::new(
                    f64::from(self.vel_n_mms),
                    f64::from(self.vel_e_mms),
                    f64::from(self.vel_d_mms),
                ) * 1e-3,
            ),
            std_v_n: Some(Vec3::repeat(sv)),
            quality,
            num_sats: self.num_sv,
        })
    }
}

/// Streaming UBX reader over any byte source.
pub struct UbxReader<R> {
    rdr: R,
    file: Arc<str>,
    buf: Vec<u8>,
    start: usize,
    eof: bool,
    frames: u64,
    garbage: u64,
    stats: RecordStats,
    last_reject: Option<ReadError>,
}

impl<R: Read> UbxReader<R> {
    pub fn new(rdr: R, file: &str) -> Self {
        UbxReader {
            rdr,
            file: Arc::from(file),
            buf: Vec::with_capacity(2 * MAX_PAYLOAD),
            start: 0,
            eof: false,
            frames: 0,
            garbage: 0,
            stats: RecordStats::default(),
            last_reject: None,
        }
    }

    /// Frame accounting (`lines` counts frames).
    pub fn stats(&self) -> &RecordStats {
        &self.stats
    }

    /// Bytes outside any frame (noise, NMEA interleaved, resync).
    pub fn garbage_bytes(&self) -> u64 {
        self.garbage
    }

    /// The last rejected frame as an error naming the frame number.
    pub fn last_rejection(&self) -> Option<&ReadError> {
        self.last_reject.as_ref()
    }

    /// Ensure `n` bytes are buffered from `start`; false at EOF.
    fn fill(&mut self, n: usize) -> Result<bool, ReadError> {
        while self.buf.len() - self.start < n {
            if self.eof {
                return Ok(false);
            }
            if self.start > 0 {
                self.buf.drain(..self.start);
                self.start = 0;
            }
            let old = self.buf.len();
            self.buf.resize(old + 4096, 0);
            let got = loop {
                match self.rdr.read(&mut self.buf[old..]) {
                    Ok(k) => break k,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(e) => {
                        self.buf.truncate(old);
                        self.eof = true;
                        return Err(ReadError::new(
                            &self.file,
                            self.frames + 1,
                            "<frame>",
                            format!("I/O error: {e}"),
                        ));
                    }
                }
            };
            self.buf.truncate(old + got);
            if got == 0 {
                self.eof = true;
            }
        }
        Ok(true)
    }

    fn reject(&mut self, reason: &'static str, msg: String) {
        self.stats.lines += 1;
        self.frames += 1;
        self.stats.reject(reason);
        self.last_reject = Some(ReadError::new(&self.file, self.frames, "<frame>", msg));
    }

    fn step(&mut self) -> Result<Option<Option<UbxMessage>>, ReadError> {
        // Find the sync pair.
        loop {
            if !self.fill(2)? {
                let rest = (self.buf.len() - self.start) as u64;
                self.garbage += rest;
                self.start = self.buf.len();
                return Ok(None);
            }
            if self.buf[self.start] == 0xB5 && self.buf[self.start + 1] == 0x62 {
                break;
            }
            self.start += 1;
            self.garbage += 1;
        }
        if !self.fill(6)? {
            self.reject(REASON_TRUNCATED, "frame header cut off".into());
            self.start = self.buf.len();
            return Ok(Some(None));
        }
        let s = self.start;
        let (class, id) = (self.buf[s + 2], self.buf[s + 3]);
        let len = usize::from(u16::from_le_bytes([self.buf[s + 4], self.buf[s + 5]]));
        if len > MAX_PAYLOAD {
            self.reject(REASON_TOO_LONG, format!("length {len} > {MAX_PAYLOAD}"));
            self.start += 2; // resync after this sync pair
            return Ok(Some(None));
        }
        if !self.fill(len + 8)? {
            self.reject(
                REASON_TRUNCATED,
                format!("frame of {} bytes cut off", len + 8),
            );
            self.start = self.buf.len();
            return Ok(Some(None));
        }
        let s = self.start;
        let (a, b) = checksum(&self.buf[s + 2..s + 6 + len]);
        if (a, b) != (self.buf[s + 6 + len], self.buf[s + 7 + len]) {
            self.reject(
                REASON_CHECKSUM,
                format!("class 0x{class:02X} id 0x{id:02X}: checksum mismatch"),
            );
            self.start += 2;
            return Ok(Some(None));
        }
        self.start += len + 8;
        let res = decode(class, id, &self.buf[s + 6..s + 6 + len]);
        match res {
            Ok(Some(m)) => {
                self.stats.lines += 1;
                self.frames += 1;
                self.stats.used += 1;
                Ok(Some(Some(m)))
            }
            Ok(None) => {
                self.stats.lines += 1;
                self.frames += 1;
                self.stats.skipped += 1;
                Ok(Some(None))
            }
            Err(msg) => {
                self.reject(REASON_BAD_PAYLOAD, msg);
                Ok(Some(None))
            }
        }
    }
}

impl<R: Read> Iterator for UbxReader<R> {
    type Item = Result<UbxMessage, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.step() {
                Ok(None) => return None,
                Ok(Some(Some(m))) => return Some(Ok(m)),
                Ok(Some(None)) => {}
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn round_trip(m: UbxMessage) {
        let bytes = encode(&m);
        let mut r = UbxReader::new(&bytes[..], "t.ubx");
        let got: Vec<_> = r.by_ref().map(|x| x.unwrap()).collect();
        assert_eq!(got, vec![m]);
        assert_eq!(r.stats().used, 1);
        assert_eq!(r.garbage_bytes(), 0);
    }

    fn esf() -> impl Strategy<Value = EsfData> {
        (0u8..64, 0u32..(1 << 24)).prop_map(|(t, v)| EsfData {
            data_type: t,
            value: v,
        })
    }

    prop_compose! {
        fn nav_pvt()(a in any::<[u32; 8]>(), b in any::<[i32; 12]>(), c in any::<[u8; 12]>(),
                     d in any::<[u16; 4]>(), e in any::<i16>()) -> NavPvt {
            NavPvt { itow_ms: a[0], year: d[0], month: c[0], day: c[1], hour: c[2], min: c[3],
                sec: c[4], valid: c[5], t_acc_ns: a[1], nano_ns: b[0], fix_type: c[6],
                flags: c[7], flags2: c[8], num_sv: c[9], lon_e7: b[1], lat_e7: b[2],
                height_mm: b[3], hmsl_mm: b[4], h_acc_mm: a[2], v_acc_mm: a[3],
                vel_n_mms: b[5], vel_e_mms: b[6], vel_d_mms: b[7], g_speed_mms: b[8],
                head_mot_e5: b[9], s_acc_mms: a[4], head_acc_e5: a[5], p_dop: d[1],
                flags3: d[2], head_veh_e5: b[10], mag_dec_e2: e, mag_acc_e2: d[3] }
        }
    }

    prop_compose! {
        fn rawx_meas()(pr in -1e8f64..1e8, cp in -1e9f64..1e9, dop in -1e4f32..1e4,
                       b in any::<[u8; 10]>(), lt in any::<u16>()) -> RawxMeas {
            RawxMeas { pr_mes: pr, cp_mes: cp, do_mes: dop, gnss_id: b[0], sv_id: b[1],
                sig_id: b[2], freq_id: b[3], locktime_ms: lt, cno_dbhz: b[4],
                pr_stdev: b[5] & 0x0F, cp_stdev: b[6] & 0x0F, do_stdev: b[7] & 0x0F,
                trk_stat: b[8] }
        }
    }

    proptest! {
        #[test]
        fn nav_pvt_round_trip(m in nav_pvt()) {
            round_trip(UbxMessage::NavPvt(m));
        }

        #[test]
        fn rxm_rawx_round_trip(tow in 0.0f64..604800.0, week in any::<u16>(), leap in any::<i8>(),
                               st in any::<[u8; 2]>(), meas in proptest::collection::vec(rawx_meas(), 0..40)) {
            round_trip(UbxMessage::RxmRawx(RxmRawx { rcv_tow: tow, week, leap_s: leap,
                rec_stat: st[0], version: st[1], meas }));
        }

        #[test]
        fn rxm_sfrbx_round_trip(h in any::<[u8; 5]>(), n in 0usize..=10, w in any::<[u32; 10]>()) {
            let mut words = [0u32; SFRBX_MAX_WORDS];
            words[..n].copy_from_slice(&w[..n]);
            round_trip(UbxMessage::RxmSfrbx(RxmSfrbx { gnss_id: h[0], sv_id: h[1], freq_id: h[2],
                num_words: n as u8, chn: h[3], version: h[4], words }));
        }

        #[test]
        fn esf_raw_round_trip(data in proptest::collection::vec((esf(), any::<u32>()), 0..60)) {
            round_trip(UbxMessage::EsfRaw(EsfRaw { data }));
        }

        #[test]
        fn esf_meas_round_trip(tt in any::<u32>(), fl in any::<u16>(), id in any::<u16>(),
                               data in proptest::collection::vec(esf(), 0..32), cal in any::<Option<u32>>()) {
            let flags = (fl & 0x07F7) | ((data.len() as u16) << 11) | if cal.is_some() { 8 } else { 0 };
            round_trip(UbxMessage::EsfMeas(EsfMeas { time_tag: tt, flags, id, data, calib_ttag: cal }));
        }

        #[test]
        fn nav_relposned_round_trip(a in any::<[i32; 5]>(), b in any::<[u32; 7]>(), c in any::<[i8; 4]>(),
                                    v in any::<u8>(), id in any::<u16>()) {
            round_trip(UbxMessage::NavRelPosNed(NavRelPosNed { version: v, ref_station_id: id,
                itow_ms: b[0], rel_pos_n_cm: a[0], rel_pos_e_cm: a[1], rel_pos_d_cm: a[2],
                rel_pos_length_cm: a[3], rel_pos_heading_e5: a[4], rel_pos_hp_n: c[0],
                rel_pos_hp_e: c[1], rel_pos_hp_d: c[2], rel_pos_hp_length: c[3], acc_n: b[1],
                acc_e: b[2], acc_d: b[3], acc_length: b[4], acc_heading_e5: b[5], flags: b[6] }));
        }
    }

    #[test]
    fn checksum_matches_a_known_frame() {
        // UBX-CFG-MSG poll frame as u-blox documents it: B5 62 06 01 02 00 01 07 11 3A.
        let f = frame(0x06, 0x01, &[0x01, 0x07]);
        assert_eq!(
            f,
            [0xB5, 0x62, 0x06, 0x01, 0x02, 0x00, 0x01, 0x07, 0x11, 0x3A]
        );
    }

    #[test]
    fn resyncs_after_garbage_and_bad_frames() {
        let pvt = NavPvt {
            year: 2025,
            month: 7,
            day: 8,
            hour: 19,
            min: 34,
            sec: 18,
            valid: 0x07,
            nano_ns: 250_000_000,
            fix_type: 3,
            flags: 0x81,
            num_sv: 20,
            lat_e7: 401_000_000,
            lon_e7: -1_051_500_000,
            height_mm: 1_600_123,
            h_acc_mm: 14,
            v_acc_mm: 30,
            vel_n_mms: 1000,
            s_acc_mms: 50,
            ..Default::default()
        };
        let good = encode(&UbxMessage::NavPvt(pvt));
        let mut bad = good.clone();
        bad[20] ^= 0xFF;
        let mut bytes = b"$GPGGA,junk\r\n".to_vec();
        bytes.extend(&bad);
        bytes.extend(frame(0x0A, 0x04, b"unknown")); // MON-VER: skipped
        bytes.extend(&good);
        bytes.extend(frame(0x01, 0x07, &[0; 10])); // wrong length
        bytes.extend(&good[..30]); // cut off
        let mut r = UbxReader::new(&bytes[..], "t.ubx");
        let got: Vec<_> = r.by_ref().map(|x| x.unwrap()).collect();
        assert_eq!(got.len(), 1);
        let st = r.stats();
        assert_eq!(st.rejected_for(REASON_CHECKSUM), 1);
        assert_eq!(st.rejected_for(REASON_BAD_PAYLOAD), 1);
        assert_eq!(st.rejected_for(REASON_TRUNCATED), 1);
        assert_eq!(st.skipped, 1);
        assert!(st.is_balanced());
        let UbxMessage::NavPvt(p) = &got[0] else {
            panic!()
        };
        let f = p.to_fix().unwrap();
        assert_eq!(f.quality, 1);
        assert!((f.lat.to_degrees() - 40.1).abs() < 1e-12);
        assert!((f.h - 1600.123).abs() < 1e-9);
        assert_eq!(f.v_n.unwrap().x, 1.0);
        let t = crate::time::gps_from_calendar(
            &Calendar {
                year: 2025,
                month: 7,
                day: 8,
                hour: 19,
                minute: 34,
                second: 18.25,
            },
            TimeSystem::Utc,
        )
        .unwrap();
        assert!((f.t - t).abs() < 1e-6);
    }

    #[test]
    fn esf_scaling() {
        let g = EsfData {
            data_type: 14,
            value: (-4096i32 as u32) & 0xFF_FFFF,
        };
        assert!((g.si().unwrap() + 1f64.to_radians()).abs() < 1e-15);
        let a = EsfData {
            data_type: 18,
            value: 1024 * 9,
        };
        assert_eq!(a.si(), Some(9.0));
        assert_eq!(
            EsfData {
                data_type: 7,
                value: 1
            }
            .si(),
            None
        );
    }
}
