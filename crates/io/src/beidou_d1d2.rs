//! BeiDou B1I navigation messages D1 (MEO/IGSO: subframes 1–3) and D2
//! (GEO: subframe 1, pages 1 and 3–10) ↔ broadcast ephemeris ([`GnssEph`],
//! the record [`crate::rinex_nav3`] reads from RINEX 3), BDS-SIS-ICD-B1I
//! 3.0 (Feb. 2019): D1 frame structure and bit allocation §5.2.2–§5.2.3
//! (Figures 5-4 to 5-6), D1 parameters §5.2.4 (SOW, WN, URAI, SatH1, AODC,
//! t_oc, TGD, clock, AODE, ephemeris Table 5-9/5-10), D2 structure and
//! subframe 1 pages §5.3.2–§5.3.3, BCH(15,11) §5.1.3, BDT §3.
//!
//! UBX-RXM-SFRBX (gnssId 3) delivers a subframe as 10 words of 30 bits in
//! the low bits of each `u32` (u-blox interface description, "BeiDou
//! D1/D2"; RTKLIB `ublox.c:decode_cnav` reads the same layout), already
//! de-interleaved: word 1 is the 11-bit preamble 11100010010, 4 reserved
//! bits, FraID (3), the 8 MSBs of SOW and 4 BCH parity bits; words 2–10 are
//! 22 information bits followed by 8 BCH parity bits. Only the information
//! bits are read: the receiver has already BCH-decoded the words (the
//! parity bits are not checked here; [`encode_d1`]/[`encode_d2`] write them
//! per §5.1.3, g(X) = X⁴ + X + 1, so our streams look as transmitted).
//! Field positions below count information bits only (0 = the preamble's
//! first bit; 26 in word 1, 22 in each later word), which makes every
//! field contiguous.
//!
//! Joining: D1 subframes 1–3 of one frame (SOW 6 s apart) with t_oc = t_oe;
//! D2 pages 1, 3–10 of subframe 1 of consecutive frames (SOW 3 s apart,
//! page p at SOW₁ + 3(p − 1)) with t_oc = t_oe — the checks RTKLIB's
//! `decode_bds_d1/d2` make; AODE (subframe 1 / page 4) and t_oe then tell a
//! new ephemeris from a repeat. D2 (GEO) is used for C01–C05 and C59–C63
//! ([`OrbitKind::beidou`]), D1 for the others.
//!
//! Time: BDT = GPST − 14 s and BDT week 0 = GPS week 1356 (§3.2: BDT
//! started 2006-01-01 00:00:00 UTC); times become GPS seconds.

use crate::gps_lnav::{ura_index, GPS_PI};
use crate::rinex_nav3::{GnssEph, BDT_WEEK_OFFSET};
use navfuse_core::gnss::orbit_gnss::{OrbitKind, BDT_MINUS_GPST};
use navfuse_core::gnss::spp::URA_UPPER_M;
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};

/// Words of a subframe in RXM-SFRBX.
pub const NUM_WORDS: usize = 10;
/// Frame synchronisation preamble 11100010010 (§5.2.3.1 / §5.3.3.1).
pub const PREAMBLE: u64 = 0b111_0001_0010;
/// Highest BeiDou PRN (C01–C63).
pub const MAX_PRN: u8 = 63;
/// BDT week numbers are 13 bits (§5.2.4.3): they repeat every 8192 weeks.
const BDT_WEEK_MODULUS: i64 = 8192;
/// TGD1/TGD2 LSB: 0.1 ns (§5.2.4.8).
const TGD_LSB_S: f64 = 0.1e-9;

/// Why a subframe or ephemeris was not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BdsError {
    /// RXM-SFRBX `numWords` is not 10.
    WordCount(usize),
    /// Word 1 does not start with the preamble.
    Preamble,
    /// FraID outside 1–5.
    SubframeId(u8),
    /// D2 subframe 1 page number outside 1–10.
    PageNumber(u8),
    /// A field does not fit its bits when encoding (name).
    Range(&'static str),
}

impl core::fmt::Display for BdsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BdsError::WordCount(n) => write!(f, "BeiDou D1/D2: {n} words, 10 expected"),
            BdsError::Preamble => write!(f, "BeiDou D1/D2 word 1: no 11100010010 preamble"),
            BdsError::SubframeId(i) => write!(f, "BeiDou D1/D2: subframe ID {i} outside 1-5"),
            BdsError::PageNumber(p) => write!(f, "BeiDou D2: page number {p} outside 1-10"),
            BdsError::Range(n) => write!(f, "BeiDou D1/D2: {n} does not fit its field"),
        }
    }
}

impl std::error::Error for BdsError {}

/// (word index, bit from the word's MSB of its 30) of information bit `j`.
fn position(j: u32) -> (usize, u32) {
    if j < 26 {
        (0, j)
    } else {
        (1 + ((j - 26) / 22) as usize, (j - 26) % 22)
    }
}

/// Unsigned field of `len` information bits from `start`.
fn getu(w: &[u32; NUM_WORDS], start: u32, len: u32) -> u64 {
    (start..start + len).fold(0u64, |v, j| {
        let (k, r) = position(j);
        (v << 1) | u64::from((w[k] >> (29 - r)) & 1)
    })
}

fn putu(w: &mut [u32; NUM_WORDS], start: u32, len: u32, v: u64) {
    for (i, j) in (start..start + len).enumerate() {
        let (k, r) = position(j);
        let bit = ((v >> (len - 1 - i as u32)) & 1) as u32;
        w[k] = (w[k] & !(1 << (29 - r))) | (bit << (29 - r));
    }
}

/// BCH(15,11) parity of 11 information bits (§5.1.3: g(X) = X⁴ + X + 1;
/// the remainder of info(X)·X⁴).
fn bch4(info: u32) -> u32 {
    let mut r = info << 4;
    for i in (4..15).rev() {
        if (r >> i) & 1 == 1 {
            r ^= 0b10011 << (i - 4);
        }
    }
    r & 0xF
}

/// Set the BCH parity bits of every word from its information bits.
fn set_parity(w: &mut [u32; NUM_WORDS]) {
    // Word 1: bits 15–25 are one codeword, parity in bits 26–29.
    w[0] = (w[0] & !0xF) | bch4((w[0] >> 4) & 0x7FF);
    for x in w.iter_mut().skip(1) {
        let info = (*x >> 8) & 0x3F_FFFF;
        *x = (*x & !0xFF) | (bch4(info >> 11) << 4) | bch4(info & 0x7FF);
    }
}

/// A subframe (word 1 checked), with its header fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BdsSubframe {
    /// FraID (1–5).
    pub fra_id: u8,
    /// Seconds of the BDT week at the subframe's start.
    pub sow: u32,
    /// D2 subframe 1 page number (1–10); 0 otherwise.
    pub page: u8,
    /// The 30-bit words.
    pub words: [u32; NUM_WORDS],
}

/// Check word 1 and read the header of one subframe; `geo` selects the D2
/// layout (page number of subframe 1 at information bits 38–41).
pub fn decode_subframe(words: &[u32], geo: bool) -> Result<BdsSubframe, BdsError> {
    if words.len() != NUM_WORDS {
        return Err(BdsError::WordCount(words.len()));
    }
    let mut w = [0u32; NUM_WORDS];
    for (d, s) in w.iter_mut().zip(words) {
        *d = s & 0x3FFF_FFFF;
    }
    if getu(&w, 0, 11) != PREAMBLE {
        return Err(BdsError::Preamble);
    }
    let fra_id = getu(&w, 15, 3) as u8;
    if !(1..=5).contains(&fra_id) {
        return Err(BdsError::SubframeId(fra_id));
    }
    let page = if geo && fra_id == 1 {
        let p = getu(&w, 38, 4) as u8;
        if !(1..=10).contains(&p) {
            return Err(BdsError::PageNumber(p));
        }
        p
    } else {
        0
    };
    Ok(BdsSubframe {
        fra_id,
        sow: getu(&w, 18, 20) as u32,
        page,
        words: w,
    })
}

/// The broadcast parameters that are scaled numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum P {
    Toc,
    Tgd1,
    Tgd2,
    A0,
    A1,
    A2,
    DeltaN,
    Cuc,
    M0,
    E,
    Cus,
    Crc,
    Crs,
    SqrtA,
    Toe,
    I0,
    Cic,
    OmegaDot,
    Cis,
    Idot,
    Omega0,
    Argp,
}

/// (two's complement, LSB, semicircles) of a parameter (§5.2.4 Tables
/// 5-8/5-10 for D1; D2 uses the same scales, §5.3.3).
fn spec(p: P) -> (bool, f64, bool) {
    let e = |x: i32| 2f64.powi(x);
    match p {
        P::Toc | P::Toe => (false, 8.0, false),
        P::Tgd1 | P::Tgd2 => (true, TGD_LSB_S, false),
        P::A0 => (true, e(-33), false),
        P::A1 => (true, e(-50), false),
        P::A2 => (true, e(-66), false),
        P::DeltaN | P::OmegaDot | P::Idot => (true, e(-43), true),
        P::M0 | P::I0 | P::Omega0 | P::Argp => (true, e(-31), true),
        P::E => (false, e(-33), false),
        P::SqrtA => (false, e(-19), false),
        P::Cuc | P::Cus | P::Cic | P::Cis => (true, e(-31), false),
        P::Crc | P::Crs => (true, e(-6), false),
    }
}

/// A parameter's location: parts (subframe/page index, start, length),
/// most significant part first.
type Loc = (P, &'static [(usize, u32, u32)]);

/// D1: index 0–2 = subframes 1–3 (§5.2.3, Figures 5-4 to 5-6).
const D1: [Loc; 22] = [
    (P::Toc, &[(0, 61, 17)]),
    (P::Tgd1, &[(0, 78, 10)]),
    (P::Tgd2, &[(0, 88, 10)]),
    (P::A2, &[(0, 162, 11)]),
    (P::A0, &[(0, 173, 24)]),
    (P::A1, &[(0, 197, 22)]),
    (P::DeltaN, &[(1, 38, 16)]),
    (P::Cuc, &[(1, 54, 18)]),
    (P::M0, &[(1, 72, 32)]),
    (P::E, &[(1, 104, 32)]),
    (P::Cus, &[(1, 136, 18)]),
    (P::Crc, &[(1, 154, 18)]),
    (P::Crs, &[(1, 172, 18)]),
    (P::SqrtA, &[(1, 190, 32)]),
    (P::Toe, &[(1, 222, 2), (2, 38, 15)]),
    (P::I0, &[(2, 53, 32)]),
    (P::Cic, &[(2, 85, 18)]),
    (P::OmegaDot, &[(2, 103, 24)]),
    (P::Cis, &[(2, 127, 18)]),
    (P::Idot, &[(2, 145, 14)]),
    (P::Omega0, &[(2, 159, 32)]),
    (P::Argp, &[(2, 191, 32)]),
];

/// D2 subframe 1: index p − 1 = page p (§5.3.3, pages 1 and 3–10).
const D2: [Loc; 22] = [
    (P::Toc, &[(0, 65, 17)]),
    (P::Tgd1, &[(0, 82, 10)]),
    (P::Tgd2, &[(0, 92, 10)]),
    (P::A0, &[(2, 80, 24)]),
    (P::A1, &[(2, 104, 4), (3, 42, 18)]),
    (P::A2, &[(3, 60, 11)]),
    (P::DeltaN, &[(3, 76, 16)]),
    (P::Cuc, &[(3, 92, 14), (4, 42, 4)]),
    (P::M0, &[(4, 46, 32)]),
    (P::Cus, &[(4, 78, 18)]),
    (P::E, &[(4, 96, 10), (5, 42, 22)]),
    (P::SqrtA, &[(5, 64, 32)]),
    (P::Cic, &[(5, 96, 10), (6, 42, 8)]),
    (P::Cis, &[(6, 50, 18)]),
    (P::Toe, &[(6, 68, 17)]),
    (P::I0, &[(6, 85, 21), (7, 42, 11)]),
    (P::Crc, &[(7, 53, 18)]),
    (P::Crs, &[(7, 71, 18)]),
    (P::OmegaDot, &[(7, 89, 19), (8, 42, 5)]),
    (P::Omega0, &[(8, 47, 32)]),
    (P::Argp, &[(8, 79, 27), (9, 42, 5)]),
    (P::Idot, &[(9, 47, 14)]),
];

/// Integer fields: (index, start, length) of SatH1, AODC, URAI, WN, AODE.
struct Ints {
    sath1: (usize, u32, u32),
    aodc: (usize, u32, u32),
    urai: (usize, u32, u32),
    wn: (usize, u32, u32),
    aode: (usize, u32, u32),
}

const D1_INTS: Ints = Ints {
    sath1: (0, 38, 1),
    aodc: (0, 39, 5),
    urai: (0, 44, 4),
    wn: (0, 48, 13),
    aode: (0, 219, 5),
};

const D2_INTS: Ints = Ints {
    sath1: (0, 42, 1),
    aodc: (0, 43, 5),
    urai: (0, 48, 4),
    wn: (0, 52, 13),
    aode: (3, 71, 5),
};

fn read(frames: &[[u32; NUM_WORDS]], (p, parts): &Loc) -> f64 {
    let mut v = 0u64;
    let mut n = 0u32;
    for &(k, s, l) in *parts {
        v = (v << l) | getu(&frames[k], s, l);
        n += l;
    }
    let (signed, lsb, semi) = spec(*p);
    let x = if signed {
        let sh = 64 - n;
        (((v << sh) as i64) >> sh) as f64
    } else {
        v as f64
    };
    x * lsb * if semi { GPS_PI } else { 1.0 }
}

fn write(
    frames: &mut [[u32; NUM_WORDS]],
    (p, parts): &Loc,
    value: f64,
    name: &'static str,
) -> Result<(), BdsError> {
    let (signed, lsb, semi) = spec(*p);
    let n: u32 = parts.iter().map(|x| x.2).sum();
    if matches!(p, P::M0 | P::Omega0 | P::Argp) {
        // Angles of a circle: wrapped after rounding, as GPS and Galileo.
        let mut v = u64::from(crate::gps_lnav::angle_field_32(value).ok_or(BdsError::Range(name))?);
        for &(k, s, l) in parts.iter().rev() {
            putu(&mut frames[k], s, l, v & ((1u64 << l) - 1));
            v >>= l;
        }
        return Ok(());
    }
    let x = (value / if semi { GPS_PI } else { 1.0 } / lsb).round();
    let (lo, hi) = if signed {
        (-(2f64.powi(n as i32 - 1)), 2f64.powi(n as i32 - 1))
    } else {
        (0.0, 2f64.powi(n as i32))
    };
    if !x.is_finite() || x < lo || x >= hi {
        return Err(BdsError::Range(name));
    }
    let mut v = (x as i64 as u64) & ((1u64 << n) - 1);
    for &(k, s, l) in parts.iter().rev() {
        putu(&mut frames[k], s, l, v & ((1u64 << l) - 1));
        v >>= l;
    }
    Ok(())
}

fn get_int(frames: &[[u32; NUM_WORDS]], (k, s, l): (usize, u32, u32)) -> u64 {
    getu(&frames[k], s, l)
}

/// The orbit parameter `p` of `o` (TGD2 from `tgd2`).
fn value(o: &KeplerOrbit, tgd2: f64, p: P, toc_sow: f64, toe_sow: f64) -> (f64, &'static str) {
    // M0, Ω0 and ω are angles of a circle: written in [−π, π) (±1
    // semicircle, the range of their 32-bit fields).
    let wrap = |v: f64| v - (v / (2.0 * GPS_PI) + 0.5).floor() * 2.0 * GPS_PI;
    match p {
        P::Toc => (toc_sow, "t_oc"),
        P::Tgd1 => (o.tgd, "TGD1"),
        P::Tgd2 => (tgd2, "TGD2"),
        P::A0 => (o.af0, "a0"),
        P::A1 => (o.af1, "a1"),
        P::A2 => (o.af2, "a2"),
        P::DeltaN => (o.delta_n, "Δn"),
        P::Cuc => (o.cuc, "C_uc"),
        P::M0 => (wrap(o.m0), "M0"),
        P::E => (o.e, "e"),
        P::Cus => (o.cus, "C_us"),
        P::Crc => (o.crc, "C_rc"),
        P::Crs => (o.crs, "C_rs"),
        P::SqrtA => (o.sqrt_a, "√A"),
        P::Toe => (toe_sow, "t_oe"),
        P::I0 => (o.i0, "i0"),
        P::Cic => (o.cic, "C_ic"),
        P::OmegaDot => (o.omega_dot, "Ω̇"),
        P::Cis => (o.cis, "C_is"),
        P::Idot => (o.idot, "IDOT"),
        P::Omega0 => (wrap(o.omega0), "Ω0"),
        P::Argp => (wrap(o.argp), "ω"),
    }
}

/// A decoded D1/D2 ephemeris with what [`GnssEph`] does not hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BdsEphemeris {
    /// As the RINEX 3 reader gives it: `tgd` = TGD1 (B1I), `accuracy_m` =
    /// the URA interval's upper bound of URAI (the LNAV table; NaN for
    /// URAI 15), `health` = SatH1, t_oe/t_oc in GPS seconds.
    pub eph: GnssEph,
    /// Age of data, ephemeris and clock (5 bits each, §5.2.4.11/§5.2.4.6).
    pub aode: u8,
    pub aodc: u8,
    /// URA index (§5.2.4.5).
    pub urai: u8,
    /// TGD2 (B2I) [s].
    pub tgd2: f64,
}

/// Joins D1 subframes 1–3 and D2 subframe 1 pages per PRN. Fixed size, no
/// allocation.
#[derive(Clone, Debug)]
pub struct BdsAssembler {
    /// Per PRN 1–63: D1 subframes 1–3, or D2 pages 1–10.
    last: [[Option<BdsSubframe>; 10]; MAX_PRN as usize],
    /// (AODE, t_oe) of the last ephemeris emitted per PRN.
    emitted: [Option<(u64, u64)>; MAX_PRN as usize],
}

impl Default for BdsAssembler {
    fn default() -> Self {
        BdsAssembler {
            last: [[None; 10]; MAX_PRN as usize],
            emitted: [None; MAX_PRN as usize],
        }
    }
}

impl BdsAssembler {
    /// Add one subframe of `prn` (decoded with `geo` =
    /// [`is_geo`]`(prn)`); `gps_week` the GPS week of the reception, which
    /// resolves the 13-bit BDT week. Returns a new ephemeris when a
    /// consistent set is complete (module docs) and differs from the last
    /// one emitted. Almanac subframes (4, 5) and D2's other subframes are
    /// ignored.
    pub fn push(&mut self, prn: u8, sf: &BdsSubframe, gps_week: u16) -> Option<BdsEphemeris> {
        if !(1..=MAX_PRN).contains(&prn) {
            return None;
        }
        let k = usize::from(prn - 1);
        let geo = is_geo(prn);
        let slot = if geo {
            if sf.fra_id != 1 || !(1..=10).contains(&sf.page) {
                return None;
            }
            usize::from(sf.page - 1)
        } else {
            if !(1..=3).contains(&sf.fra_id) {
                return None;
            }
            usize::from(sf.fra_id - 1)
        };
        self.last[k][slot] = Some(*sf);
        let (n, step, loc, ints): (usize, u32, &[Loc; 22], &Ints) = if geo {
            (10, 3, &D2, &D2_INTS)
        } else {
            (3, 6, &D1, &D1_INTS)
        };
        let mut frames = [[0u32; NUM_WORDS]; 10];
        let first = self.last[k][0]?;
        for (i, (f, s)) in frames.iter_mut().zip(&self.last[k]).enumerate().take(n) {
            if geo && i == 1 {
                continue; // D2 page 2: ionosphere, not part of the ephemeris
            }
            let s = (*s)?;
            if u64::from(s.sow) != u64::from(first.sow) + u64::from(step) * i as u64 {
                return None;
            }
            *f = s.words;
        }
        let toc_sow = read(&frames, &loc[0]);
        let toe_loc = loc.iter().find(|(p, _)| *p == P::Toe)?;
        let toe_sow = read(&frames, toe_loc);
        if toc_sow != toe_sow {
            return None;
        }
        let aode = get_int(&frames, ints.aode);
        if self.emitted[k] == Some((aode, toe_sow as u64)) {
            return None;
        }
        // BDT week nearest the receiver's, then t_oe within half a week of
        // the transmission (SOW of the first subframe/page).
        let wn13 = get_int(&frames, ints.wn) as i64;
        let ref_bdt = i64::from(gps_week) - BDT_WEEK_OFFSET as i64;
        let bdt_week = wn13
            + BDT_WEEK_MODULUS * ((ref_bdt - wn13) as f64 / BDT_WEEK_MODULUS as f64).round() as i64;
        let tx = f64::from(first.sow);
        let to_gps = |sow: f64| {
            let mut t = (bdt_week as f64 + BDT_WEEK_OFFSET) * SECONDS_PER_WEEK + sow;
            if sow - tx > SECONDS_PER_WEEK / 2.0 {
                t -= SECONDS_PER_WEEK;
            } else if sow - tx < -SECONDS_PER_WEEK / 2.0 {
                t += SECONDS_PER_WEEK;
            }
            t - BDT_MINUS_GPST
        };
        let mut o = KeplerOrbit {
            prn,
            health: get_int(&frames, ints.sath1) as u32,
            t_oe: to_gps(toe_sow),
            t_oc: to_gps(toc_sow),
            ..Default::default()
        };
        let mut tgd2 = 0.0;
        for l in loc {
            let v = read(&frames, l);
            match l.0 {
                P::Toc | P::Toe => {}
                P::Tgd1 => o.tgd = v,
                P::Tgd2 => tgd2 = v,
                P::A0 => o.af0 = v,
                P::A1 => o.af1 = v,
                P::A2 => o.af2 = v,
                P::DeltaN => o.delta_n = v,
                P::Cuc => o.cuc = v,
                P::M0 => o.m0 = v,
                P::E => o.e = v,
                P::Cus => o.cus = v,
                P::Crc => o.crc = v,
                P::Crs => o.crs = v,
                P::SqrtA => o.sqrt_a = v,
                P::I0 => o.i0 = v,
                P::Cic => o.cic = v,
                P::OmegaDot => o.omega_dot = v,
                P::Cis => o.cis = v,
                P::Idot => o.idot = v,
                P::Omega0 => o.omega0 = v,
                P::Argp => o.argp = v,
            }
        }
        self.emitted[k] = Some((aode, toe_sow as u64));
        let urai = get_int(&frames, ints.urai) as u8;
        Some(BdsEphemeris {
            eph: GnssEph {
                sys: 'C',
                kind: OrbitKind::beidou(prn),
                orbit: o,
                accuracy_m: URA_UPPER_M
                    .get(usize::from(urai))
                    .copied()
                    .unwrap_or(f64::NAN),
            },
            aode: aode as u8,
            aodc: get_int(&frames, ints.aodc) as u8,
            urai,
            tgd2,
        })
    }
}

/// Whether `prn` broadcasts D2 (GEO: C01–C05, C59–C63).
pub fn is_geo(prn: u8) -> bool {
    OrbitKind::beidou(prn) == OrbitKind::BeiDouGeo
}

/// Common part of the encoders: the frames (subframes or pages) with
/// headers, integer fields and every scaled parameter written.
#[allow(clippy::too_many_arguments)]
fn encode(
    e: &BdsEphemeris,
    sow1: u32,
    n: usize,
    step: u32,
    loc: &[Loc; 22],
    ints: &Ints,
    geo: bool,
) -> Result<Vec<[u32; NUM_WORDS]>, BdsError> {
    let o = &e.eph.orbit;
    if !(1..=MAX_PRN).contains(&o.prn) {
        return Err(BdsError::Range("PRN"));
    }
    if e.aode > 31 || e.aodc > 31 {
        return Err(BdsError::Range("AODE/AODC"));
    }
    // BDT seconds of week of t_oe/t_oc and the transmission week.
    let bdt = |t: f64| t + BDT_MINUS_GPST;
    let sow = |t: f64| bdt(t) - (bdt(t) / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
    let mut week = (bdt(o.t_oe) / SECONDS_PER_WEEK).floor() - BDT_WEEK_OFFSET;
    let tx = f64::from(sow1);
    if tx - sow(o.t_oe) > SECONDS_PER_WEEK / 2.0 {
        week -= 1.0;
    } else if tx - sow(o.t_oe) < -SECONDS_PER_WEEK / 2.0 {
        week += 1.0;
    }
    if week < 0.0 {
        return Err(BdsError::Range("BDT week"));
    }
    let last_sow = u64::from(sow1) + u64::from(step) * (n as u64 - 1);
    if last_sow >= SECONDS_PER_WEEK as u64 {
        return Err(BdsError::Range("SOW"));
    }
    let mut frames = vec![[0u32; NUM_WORDS]; n];
    for (i, f) in frames.iter_mut().enumerate() {
        putu(f, 0, 11, PREAMBLE);
        putu(f, 15, 3, 1 + if geo { 0 } else { i as u64 });
        putu(f, 18, 20, u64::from(sow1) + u64::from(step) * i as u64);
        if geo {
            putu(f, 38, 4, i as u64 + 1);
        }
    }
    let put = |frames: &mut [[u32; NUM_WORDS]], (k, s, l): (usize, u32, u32), v: u64| {
        putu(&mut frames[k], s, l, v)
    };
    put(&mut frames, ints.sath1, u64::from(o.health & 1));
    put(&mut frames, ints.aodc, u64::from(e.aodc));
    put(&mut frames, ints.urai, u64::from(e.urai.min(15)));
    put(
        &mut frames,
        ints.wn,
        (week as i64).rem_euclid(BDT_WEEK_MODULUS) as u64,
    );
    put(&mut frames, ints.aode, u64::from(e.aode));
    for l in loc {
        let (v, name) = value(o, e.tgd2, l.0, sow(o.t_oc), sow(o.t_oe));
        write(&mut frames, l, v, name)?;
    }
    for f in frames.iter_mut() {
        set_parity(f);
    }
    Ok(frames)
}

/// D1 subframes 1–3 of ephemeris `e` (MEO/IGSO), subframe 1 starting at
/// BDT second of week `sow1` (a multiple of 30 s in the real signal;
/// subframes 2 and 3 follow at +6 s, +12 s). Values are quantised to their
/// broadcast resolution; a value outside its field is an error naming it.
pub fn encode_d1(e: &BdsEphemeris, sow1: u32) -> Result<[[u32; NUM_WORDS]; 3], BdsError> {
    let v = encode(e, sow1, 3, 6, &D1, &D1_INTS, false)?;
    Ok([v[0], v[1], v[2]])
}

/// D2 subframe 1 pages 1–10 of ephemeris `e` (GEO), page 1 at BDT second
/// of week `sow1`, page p at `sow1` + 3(p − 1) s (one page per 3 s frame);
/// page 2 (ionosphere) is written with zero coefficients.
pub fn encode_d2(e: &BdsEphemeris, sow1: u32) -> Result<[[u32; NUM_WORDS]; 10], BdsError> {
    let v = encode(e, sow1, 10, 3, &D2, &D2_INTS, true)?;
    let mut out = [[0u32; NUM_WORDS]; 10];
    out.copy_from_slice(&v);
    Ok(out)
}

/// A [`BdsEphemeris`] for `e` (a RINEX-style record): URAI from its
/// accuracy ([`ura_index`]), TGD2 zero.
pub fn from_eph(e: &GnssEph, aode: u8) -> BdsEphemeris {
    BdsEphemeris {
        eph: *e,
        aode,
        aodc: aode,
        urai: ura_index(e.accuracy_m) as u8,
        tgd2: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rinex_nav3::parse_nav_gnss;
    use navfuse_core::gnss::orbit_gnss::{clock_offset, position_ecef};

    fn rinex_line(v: &[f64]) -> String {
        v.iter()
            .map(|&x| {
                let s = format!("{x:.12E}");
                let (m, e) = s.split_once('E').unwrap();
                let e: i32 = e.parse().unwrap();
                format!("{m:>15}E{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
            })
            .collect()
    }

    /// BeiDou RINEX 3 records (BDT epoch and week, week 678 = GPS 2034),
    /// values made on the D1/D2 grid here (integer multiples of the
    /// §5.2.4 scale factors, 12-digit RINEX mantissa), for a MEO (C11) and
    /// a GEO (C01).
    fn rinex_records() -> Vec<GnssEph> {
        let w = |x: i64, e: i32| x as f64 * 2f64.powi(e);
        let sc = |x: i64, e: i32| w(x, e) * GPS_PI;
        let mut text = String::from(
            "     3.04           N: GNSS NAV DATA    C: BEIDOU           RINEX VERSION / TYPE\n                                                            END OF HEADER\n",
        );
        for (prn, sqrt_a, i0, e) in [
            (
                11,
                w(2_769_572_560, -19),
                sc(591_283_200, -31),
                w(4_471_234, -33),
            ),
            (
                1,
                w(3_404_372_213, -19),
                sc(8_910_511, -31),
                w(1_534_902, -33),
            ),
        ] {
            let v = [
                w(4_541_781, -33),       // a0
                w(344_512, -50),         // a1
                w(-3, -66),              // a2
                1.0,                     // AODE
                w(-41_947, -6),          // Crs
                sc(3_625, -43),          // Δn
                sc(-1_467_719_872, -31), // M0
                w(54_259, -31),          // Cuc
                e,                       // e
                w(11_448, -31),          // Cus
                sqrt_a,                  // √A
                172_800.0,               // Toe (BDT)
                w(40, -31),              // Cic
                sc(1_516_981_137, -31),  // Ω0
                w(-96, -31),             // Cis
                i0,                      // i0
                w(-41_924, -6),          // Crc
                sc(-1_616_329_118, -31), // ω
                sc(-2_468, -43),         // Ω̇
                sc(-4_880, -43),         // IDOT
                0.0,
                678.0, // BDT week
                0.0,
                2.0, // SV accuracy
                0.0,
                -58.0 * TGD_LSB_S,
                -102.0 * TGD_LSB_S,
                172_800.0,
                1.0,
            ];
            text += &format!("C{prn:02} 2019 01 01 00 00 00{}\n", rinex_line(&v[..3]));
            for row in v[3..].chunks(4) {
                text += &format!("    {}\n", rinex_line(row));
            }
        }
        parse_nav_gnss(&text, "t.rnx").unwrap().ephs
    }

    fn decode_all(prn: u8, frames: &[[u32; NUM_WORDS]], week: u16) -> Option<BdsEphemeris> {
        let mut a = BdsAssembler::default();
        let mut got = None;
        for f in frames {
            let sf = decode_subframe(f, is_geo(prn)).unwrap();
            if let Some(e) = a.push(prn, &sf, week) {
                got = Some(e);
            }
        }
        got
    }

    /// Must-show 5 (BeiDou): RINEX record → D1 (MEO) / D2 (GEO) subframes
    /// (our encoder) → decoder gives the RINEX path's satellite position and
    /// clock (< 1 mm, < 1e-12 s) over ±2 h, and re-encodes to the same bits.
    #[test]
    fn decoded_ephemeris_matches_the_rinex_path() {
        for r in rinex_records() {
            let b = from_eph(&r, 1);
            let geo = is_geo(r.orbit.prn);
            // Transmission 30 s... before t_oe's BDT second of week.
            let frames: Vec<[u32; NUM_WORDS]> = if geo {
                encode_d2(&b, 172_770).unwrap().to_vec()
            } else {
                encode_d1(&b, 172_770).unwrap().to_vec()
            };
            let g = decode_all(r.orbit.prn, &frames, 2034).expect("ephemeris");
            assert_eq!((g.eph.sys, g.eph.kind), (r.sys, r.kind));
            assert_eq!((g.aode, g.urai, g.eph.accuracy_m), (1, 0, 2.4));
            assert_eq!(
                (g.eph.orbit.t_oe, g.eph.orbit.t_oc),
                (r.orbit.t_oe, r.orbit.t_oc)
            );
            assert!((g.eph.orbit.tgd - r.orbit.tgd).abs() < 1e-20);
            let mut worst = 0.0f64;
            for dt in [-7200.0, -600.0, 0.0, 3600.0, 7200.0] {
                let t = r.orbit.t_oe + dt;
                let d = (position_ecef(&g.eph.orbit, g.eph.kind, t)
                    - position_ecef(&r.orbit, r.kind, t))
                .norm();
                worst = worst.max(d);
                let c =
                    clock_offset(&g.eph.orbit, g.eph.kind, t) - clock_offset(&r.orbit, r.kind, t);
                assert!(c.abs() < 1e-12, "C{:02} {dt} s: clock {c} s", r.orbit.prn);
            }
            assert!(worst < 1e-3, "C{:02}: {worst} m", r.orbit.prn);
            let again: Vec<[u32; NUM_WORDS]> = if geo {
                encode_d2(&g, 172_770).unwrap().to_vec()
            } else {
                encode_d1(&g, 172_770).unwrap().to_vec()
            };
            assert_eq!(again, frames);
        }
    }

    /// The information-bit positions agree with the absolute positions of
    /// the ICD figures over the 300-bit subframe (parity bits included), as
    /// RTKLIB's `decode_bds_d1/d2` read them: a field split across words
    /// reads the same both ways.
    #[test]
    fn field_positions_agree_with_the_absolute_layout() {
        let abs = |w: &[u32; 10], parts: &[(u32, u32)]| {
            parts.iter().fold(0u64, |v, &(s, l)| {
                (s..s + l).fold(v, |v, b| {
                    (v << 1) | u64::from((w[(b / 30) as usize] >> (29 - b % 30)) & 1)
                })
            })
        };
        let rs = rinex_records();
        let d1 = encode_d1(&from_eph(&rs[0], 17), 172_770).unwrap();
        assert_eq!(abs(&d1[0], &[(18, 8), (30, 12)]), 172_770);
        assert_eq!(abs(&d1[0], &[(287, 5)]), 17); // AODE
        assert_eq!(abs(&d1[0], &[(60, 13)]), 678); // WN
        assert_eq!(abs(&d1[0], &[(98, 10)]), (-58i64 as u64) & 0x3FF); // TGD1
        assert_eq!(abs(&d1[0], &[(257, 5), (270, 17)]), 344_512); // a1
        assert_eq!(abs(&d1[0], &[(225, 7), (240, 17)]), 4_541_781); // a0
        let toe = (abs(&d1[1], &[(290, 2)]) << 15) | abs(&d1[2], &[(42, 10), (60, 5)]);
        assert_eq!(toe * 8, 172_800);
        assert_eq!(abs(&d1[1], &[(250, 12), (270, 20)]), 2_769_572_560); // √A
        assert_eq!(
            abs(&d1[2], &[(251, 11), (270, 21)]),
            -1_616_329_118i64 as u64 & 0xFFFF_FFFF
        ); // ω
        let d2 = encode_d2(&from_eph(&rs[1], 17), 172_770).unwrap();
        assert_eq!(abs(&d2[0], &[(42, 4)]), 1);
        assert_eq!(abs(&d2[6], &[(42, 4)]), 7);
        assert_eq!(abs(&d2[0], &[(64, 13)]), 678);
        assert_eq!(abs(&d2[3], &[(91, 5)]), 17); // AODE, page 4
        assert_eq!(abs(&d2[6], &[(80, 2), (90, 15)]) * 8, 172_800); // toe, page 7
        assert_eq!(abs(&d2[5], &[(76, 6), (90, 22), (120, 4)]), 3_404_372_213); // √A, page 6
        let omg = (abs(&d2[8], &[(99, 13), (120, 14)]) << 5) | abs(&d2[9], &[(46, 5)]);
        assert_eq!(omg, -1_616_329_118i64 as u64 & 0xFFFF_FFFF); // ω, pages 9-10
        let a1 = (abs(&d2[2], &[(132, 4)]) << 18) | abs(&d2[3], &[(46, 6), (60, 12)]);
        assert_eq!(a1, 344_512); // a1, pages 3-4
    }

    #[test]
    fn bch_parity_follows_the_generator() {
        // Every single-bit information vector's codeword is divisible by
        // g(X) = X^4 + X + 1, and so is a sum of them (linearity).
        let rem = |c: u32| {
            let mut r = c;
            for i in (4..15).rev() {
                if (r >> i) & 1 == 1 {
                    r ^= 0b10011 << (i - 4);
                }
            }
            r & 0xF
        };
        for info in [1u32, 2, 0x400, 0x7FF, 0x555] {
            assert_eq!(rem((info << 4) | bch4(info)), 0, "{info:#x}");
        }
        assert_eq!(bch4(0), 0);
        assert_eq!(bch4(1), 0b0011); // X^4 mod g = X + 1
    }

    #[test]
    fn inconsistent_sets_do_not_join_and_repeats_are_not_new() {
        let rs = rinex_records();
        let meo = from_eph(&rs[0], 1);
        let a = encode_d1(&meo, 172_770).unwrap();
        let b = encode_d1(&meo, 172_800).unwrap(); // the next frame
        let mut asm = BdsAssembler::default();
        let prn = rs[0].orbit.prn;
        let d = |f: &[u32; 10]| decode_subframe(f, false).unwrap();
        assert!(asm.push(prn, &d(&a[0]), 2034).is_none());
        assert!(asm.push(prn, &d(&a[1]), 2034).is_none());
        // Subframe 3 of another frame: SOW not 12 s after subframe 1.
        assert!(asm.push(prn, &d(&b[2]), 2034).is_none());
        assert!(asm.push(prn, &d(&a[2]), 2034).is_some());
        // The next frame repeats the ephemeris: not new.
        for f in &b {
            assert!(asm.push(prn, &d(f), 2034).is_none());
        }
        // t_oc ≠ t_oe: not joined.
        let mut odd = meo;
        odd.eph.orbit.t_oc += 8.0;
        let c = encode_d1(&odd, 172_770).unwrap();
        assert!(decode_all(prn, &c, 2034).is_none());
        // A GEO page set missing page 7 does not join.
        let geo = from_eph(&rs[1], 1);
        let p = encode_d2(&geo, 172_770).unwrap();
        let mut missing = p.to_vec();
        missing.remove(6);
        assert!(decode_all(1, &missing, 2034).is_none());
        assert!(decode_all(1, &p, 2034).is_some());
    }

    #[test]
    fn header_errors_are_typed() {
        let rs = rinex_records();
        let a = encode_d1(&from_eph(&rs[0], 1), 172_770).unwrap();
        let mut bad = a[0];
        bad[0] ^= 1 << 29;
        assert_eq!(decode_subframe(&bad, false), Err(BdsError::Preamble));
        assert_eq!(
            decode_subframe(&a[0][..9], false),
            Err(BdsError::WordCount(9))
        );
        let mut id = a[0];
        putu(&mut id, 15, 3, 7);
        assert_eq!(decode_subframe(&id, false), Err(BdsError::SubframeId(7)));
        let mut pg = encode_d2(&from_eph(&rs[1], 1), 172_770).unwrap()[0];
        putu(&mut pg, 38, 4, 12);
        assert_eq!(decode_subframe(&pg, true), Err(BdsError::PageNumber(12)));
        let mut big = from_eph(&rs[0], 1);
        big.eph.orbit.af0 = 0.01; // 24 bits of 2^-33 s hold ±0.98 ms
        assert_eq!(encode_d1(&big, 172_770), Err(BdsError::Range("a0")));
    }

    #[test]
    fn bdt_week_and_time_offset() {
        let rs = rinex_records();
        // RINEX BDT week 678 + 1356 = GPS 2034, BDT = GPST − 14 s.
        assert_eq!(
            rs[0].orbit.t_oe,
            2034.0 * SECONDS_PER_WEEK + 172_800.0 + 14.0
        );
        let frames = encode_d1(&from_eph(&rs[0], 1), 172_770).unwrap();
        assert_eq!(getu(&frames[0], 48, 13), 678);
        // 8192 weeks later the same 13-bit week resolves 8192 weeks later.
        let g = decode_all(rs[0].orbit.prn, &frames, 2034 + 8192).unwrap();
        assert_eq!(
            g.eph.orbit.t_oe,
            rs[0].orbit.t_oe + 8192.0 * SECONDS_PER_WEEK
        );
    }

    proptest::proptest! {
        /// Arbitrary subframes (half with a valid preamble and IDs, so the
        /// field decoding is reached) never panic the decoder or the
        /// assembler, for any PRN (GEO or not) and week.
        #[test]
        fn arbitrary_subframes_never_panic(w in proptest::prelude::any::<[u32; 10]>(),
                                           fix in proptest::prelude::any::<bool>(),
                                           prn in proptest::prelude::any::<u8>(),
                                           week in proptest::prelude::any::<u16>()) {
            let mut w = w.map(|x| x & 0x3FFF_FFFF);
            if fix {
                putu(&mut w, 0, 11, PREAMBLE);
                putu(&mut w, 15, 3, u64::from(week % 3) + 1);
                putu(&mut w, 38, 4, u64::from(prn % 10) + 1);
            }
            let geo = is_geo(prn);
            let r = decode_subframe(&w, geo);
            proptest::prop_assert!(!fix || r.is_ok());
            if let Ok(sf) = r {
                let mut a = BdsAssembler::default();
                for i in 0..10u32 {
                    let s = BdsSubframe { fra_id: if geo { 1 } else { (i % 3) as u8 + 1 },
                                          page: (i + 1) as u8, sow: sf.sow.wrapping_add(3 * i), ..sf };
                    let _ = a.push(prn, &s, week);
                }
            }
        }
    }
}
