//! GPS L1 C/A navigation message (LNAV) subframes 1–3 ↔ broadcast
//! ephemeris ([`KeplerOrbit`]), IS-GPS-200 §20.3.2–20.3.3 (word layout
//! Figure 20-1, scale factors Tables 20-I and 20-III, parity Table 20-XIV).
//!
//! A subframe is 10 words of 30 bits in the low bits of a `u32`, as
//! UBX-RXM-SFRBX reports them (u-blox: the two most significant bits are
//! padding; the receiver has already removed the D30* inversion of the data
//! bits, so bits 29..6 are the source data d1..d24 and bits 5..0 the parity
//! D25..D30 as transmitted). [`decode_subframe`] checks the parity of every
//! word, [`Assembler`] joins subframes 1, 2 and 3 of one satellite with
//! matching issue of data (IODC low 8 bits = IODE of subframes 2 and 3)
//! into a [`KeplerOrbit`], and [`encode_ephemeris`] writes the three
//! subframes of an orbit (the simulator's UBX streams and round-trip tests).
//!
//! Angles are broadcast in semicircles and converted with the ICD's
//! π = 3.1415926535898; times are GPS seconds since the GPS epoch
//! (`week · 604800 + seconds of week`).

use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::spp::URA_UPPER_M;
use navfuse_core::gnss::{KeplerOrbit, SECONDS_PER_WEEK};

/// π as IS-GPS-200 defines it for semicircle conversion (deliberately the
/// ICD's 14 digits, not `core::f64::consts::PI`).
#[allow(clippy::approx_constant)]
pub const GPS_PI: f64 = 3.141_592_653_589_8;
/// TLM preamble (IS-GPS-200 §20.3.3.1).
pub const PREAMBLE: u32 = 0x8B;

/// Why a subframe was not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LnavError {
    /// Word `n` (1-based) fails the Table 20-XIV parity check.
    Parity(usize),
    /// Word 1 does not start with the 0x8B preamble.
    Preamble,
    /// Subframe ID outside 1–5.
    SubframeId(u8),
    /// A field does not fit its bits when encoding (name).
    Range(&'static str),
}

impl core::fmt::Display for LnavError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LnavError::Parity(n) => write!(f, "GPS LNAV word {n}: parity check failed"),
            LnavError::Preamble => write!(f, "GPS LNAV word 1: no 0x8B preamble"),
            LnavError::SubframeId(i) => write!(f, "GPS LNAV: subframe ID {i} outside 1-5"),
            LnavError::Range(n) => write!(f, "GPS LNAV: {n} does not fit its field"),
        }
    }
}

/// Bit masks of Table 20-XIV over `[D29*, D30*, d1..d24]` (bit 25 = D29*,
/// bit 24 = D30*, bit 23 − i = d_{i+1}): parity bit k is the XOR of the
/// masked bits. Written out from the table's equations.
const PARITY_TERMS: [(bool, bool, &[u8]); 6] = [
    (
        true,
        false,
        &[1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23],
    ),
    (
        false,
        true,
        &[2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24],
    ),
    (
        true,
        false,
        &[1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22],
    ),
    (
        false,
        true,
        &[2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23],
    ),
    (
        false,
        true,
        &[1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24],
    ),
    (
        true,
        false,
        &[3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24],
    ),
];

/// Parity bits D25..D30 (6 bits, D25 the most significant) of source data
/// `d` (24 bits, d1 the most significant) after a word ending in D29*, D30*.
pub fn parity(d: u32, d29s: bool, d30s: bool) -> u32 {
    let bit = |i: u8| (d >> (24 - i as u32)) & 1;
    let mut p = 0u32;
    for (star29, star30, terms) in PARITY_TERMS {
        let mut x = u32::from(star29 && d29s) ^ u32::from(star30 && d30s);
        for &i in terms {
            x ^= bit(i);
        }
        p = (p << 1) | x;
    }
    p
}

/// The 24 source-data bits of a 30-bit word.
fn data(w: u32) -> u32 {
    (w >> 6) & 0x00FF_FFFF
}

/// Unsigned field of `len` bits starting at data bit `start` (1-based, MSB
/// first) of word `n` (1-based).
fn get(w: &[u32; 10], n: usize, start: u32, len: u32) -> u32 {
    (data(w[n - 1]) >> (25 - start - len)) & ((1u32 << len) - 1)
}

fn sext(v: u32, len: u32) -> i64 {
    let s = 64 - len;
    ((v as i64) << s) >> s
}

/// 32-bit field split as 8 MSB at bits 17–24 of word `n` and 24 LSB in word `n + 1`.
fn get32(w: &[u32; 10], n: usize) -> u32 {
    (get(w, n, 17, 8) << 24) | data(w[n])
}

/// A decoded subframe 1, 2 or 3 (4 and 5 carry almanac pages, not used here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Subframe {
    /// Subframe ID (1–5).
    pub id: u8,
    /// Time of week at the start of the *next* subframe [s] (HOW TOW count × 6).
    pub tow_next_s: f64,
    /// The raw words (parity checked).
    pub words: [u32; 10],
}

/// Check parity and the preamble and read the HOW of one subframe.
pub fn decode_subframe(words: &[u32; 10]) -> Result<Subframe, LnavError> {
    let (mut d29, mut d30) = (false, false);
    for (k, &w) in words.iter().enumerate() {
        if parity(data(w), d29, d30) != w & 0x3F {
            return Err(LnavError::Parity(k + 1));
        }
        d29 = (w >> 1) & 1 == 1;
        d30 = w & 1 == 1;
    }
    if get(words, 1, 1, 8) != PREAMBLE {
        return Err(LnavError::Preamble);
    }
    let id = get(words, 2, 20, 3) as u8;
    if !(1..=5).contains(&id) {
        return Err(LnavError::SubframeId(id));
    }
    Ok(Subframe {
        id,
        tow_next_s: f64::from(get(words, 2, 1, 17)) * 6.0,
        words: *words,
    })
}

/// A broadcast ephemeris with what [`KeplerOrbit`] does not hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LnavEphemeris {
    pub orbit: KeplerOrbit,
    /// Issue of data (IODE; IODC's low 8 bits).
    pub iode: u8,
    /// The URA index's upper bound [m] (IS-GPS-200 §20.3.3.3.1.3; NaN for
    /// index 15, "no accuracy prediction"): the value a RINEX file writes as
    /// "SV accuracy" falls in the same interval.
    pub ura_m: f64,
}

/// URA index (0–15) of an accuracy in metres: the first interval whose
/// upper bound holds it; 15 for NaN or beyond 6144 m.
pub fn ura_index(ura_m: f64) -> u32 {
    URA_UPPER_M
        .iter()
        .position(|&b| b >= ura_m)
        .map_or(15, |n| n as u32)
}

/// SV ID of subframe 4 page 18 (ionosphere and UTC), IS-GPS-200 Table 20-V.
const SV_ID_IONO_UTC: u32 = 56;

/// Parameters of subframe 1.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sf1 {
    wn10: u32,
    ura: u32,
    health: u32,
    iodc: u32,
    tgd: f64,
    toc: f64,
    af: [f64; 3],
}

fn sf1(w: &[u32; 10]) -> Sf1 {
    Sf1 {
        wn10: get(w, 3, 1, 10),
        ura: get(w, 3, 13, 4),
        health: get(w, 3, 17, 6),
        iodc: (get(w, 3, 23, 2) << 8) | get(w, 8, 1, 8),
        tgd: sext(get(w, 7, 17, 8), 8) as f64 * 2f64.powi(-31),
        toc: f64::from(get(w, 8, 9, 16)) * 16.0,
        af: [
            sext(get(w, 10, 1, 22), 22) as f64 * 2f64.powi(-31),
            sext(get(w, 9, 9, 16), 16) as f64 * 2f64.powi(-43),
            sext(get(w, 9, 1, 8), 8) as f64 * 2f64.powi(-55),
        ],
    }
}

/// Joins subframes 1–3 per PRN into ephemerides. Fixed size (32 PRNs), no
/// allocation.
#[derive(Clone, Debug, Default)]
pub struct Assembler {
    /// Per PRN 1–32: the last subframe 1, 2 and 3 seen.
    last: [[Option<Subframe>; 3]; 32],
    /// IODE of the last ephemeris emitted per PRN.
    emitted: [Option<(u32, u32)>; 32],
    /// Klobuchar coefficients of the last subframe 4 page 18.
    pub iono: Option<Klobuchar>,
}

impl Assembler {
    /// Add one decoded subframe of `prn`; `week` the full GPS week of the
    /// reception (e.g. RXM-RAWX's), which resolves the 10-bit broadcast
    /// week. Returns a new ephemeris when subframes 1–3 with one issue of
    /// data are complete and differ from the last one emitted.
    /// Subframe 4 page 18 sets [`Assembler::iono`].
    pub fn push(&mut self, prn: u8, sf: &Subframe, week: u16) -> Option<LnavEphemeris> {
        if sf.id == 4 && get(&sf.words, 3, 3, 6) == SV_ID_IONO_UTC {
            self.iono = Some(decode_iono(&sf.words));
            return None;
        }
        if !(1..=32).contains(&prn) || !(1..=3).contains(&sf.id) {
            return None;
        }
        let k = usize::from(prn - 1);
        self.last[k][usize::from(sf.id - 1)] = Some(*sf);
        let [Some(s1), Some(s2), Some(s3)] = self.last[k] else {
            return None;
        };
        let (w1, w2, w3) = (&s1.words, &s2.words, &s3.words);
        let p1 = sf1(w1);
        let (iode2, iode3) = (get(w2, 3, 1, 8), get(w3, 10, 1, 8));
        if iode2 != iode3 || iode2 != p1.iodc & 0xFF {
            return None;
        }
        let toe_sow = f64::from(get(w2, 10, 1, 16)) * 16.0;
        if self.emitted[k] == Some((iode2, p1.toc as u32)) {
            return None;
        }
        // The broadcast week is the transmission week modulo 1024.
        let wn = i64::from(week) - ((i64::from(week) - i64::from(p1.wn10)).rem_euclid(1024));
        let tx_sow = s1.tow_next_s - 6.0;
        // t_oe/t_oc may lie in the week before or after transmission.
        let full = |sow: f64| {
            let mut t = wn as f64 * SECONDS_PER_WEEK + sow;
            if sow - tx_sow > SECONDS_PER_WEEK / 2.0 {
                t -= SECONDS_PER_WEEK;
            } else if sow - tx_sow < -SECONDS_PER_WEEK / 2.0 {
                t += SECONDS_PER_WEEK;
            }
            t
        };
        let sc = |v: i64, e: i32| v as f64 * 2f64.powi(e) * GPS_PI;
        let orbit = KeplerOrbit {
            prn,
            health: p1.health,
            t_oe: full(toe_sow),
            t_oc: full(p1.toc),
            sqrt_a: f64::from(get32(w2, 8)) * 2f64.powi(-19),
            e: f64::from(get32(w2, 6)) * 2f64.powi(-33),
            i0: sc(i64::from(get32(w3, 5) as i32), -31),
            idot: sc(sext(get(w3, 10, 9, 14), 14), -43),
            omega0: sc(i64::from(get32(w3, 3) as i32), -31),
            omega_dot: sc(sext(get(w3, 9, 1, 24), 24), -43),
            argp: sc(i64::from(get32(w3, 7) as i32), -31),
            m0: sc(i64::from(get32(w2, 4) as i32), -31),
            delta_n: sc(sext(get(w2, 4, 1, 16), 16), -43),
            cuc: sext(get(w2, 6, 1, 16), 16) as f64 * 2f64.powi(-29),
            cus: sext(get(w2, 8, 1, 16), 16) as f64 * 2f64.powi(-29),
            crc: sext(get(w3, 7, 1, 16), 16) as f64 * 2f64.powi(-5),
            crs: sext(get(w2, 3, 9, 16), 16) as f64 * 2f64.powi(-5),
            cic: sext(get(w3, 3, 1, 16), 16) as f64 * 2f64.powi(-29),
            cis: sext(get(w3, 5, 1, 16), 16) as f64 * 2f64.powi(-29),
            af0: p1.af[0],
            af1: p1.af[1],
            af2: p1.af[2],
            tgd: p1.tgd,
        };
        self.emitted[k] = Some((iode2, p1.toc as u32));
        Some(LnavEphemeris {
            orbit,
            iode: iode2 as u8,
            ura_m: URA_UPPER_M
                .get(p1.ura as usize)
                .copied()
                .unwrap_or(f64::NAN),
        })
    }
}

/// Scale exponents of α0..α3 and β0..β3 (IS-GPS-200 Table 20-X).
const IONO_EXP: [i32; 8] = [-30, -27, -24, -24, 11, 14, 16, 16];
/// Data-bit positions (word, start) of α0..α3, β0..β3 in page 18 (8 bits each).
const IONO_POS: [(usize, u32); 8] = [
    (3, 9),
    (3, 17),
    (4, 1),
    (4, 9),
    (4, 17),
    (5, 1),
    (5, 9),
    (5, 17),
];

fn decode_iono(w: &[u32; 10]) -> Klobuchar {
    let c: [f64; 8] = core::array::from_fn(|i| {
        let (n, st) = IONO_POS[i];
        sext(get(w, n, st, 8), 8) as f64 * 2f64.powi(IONO_EXP[i])
    });
    Klobuchar {
        alpha: [c[0], c[1], c[2], c[3]],
        beta: [c[4], c[5], c[6], c[7]],
    }
}

/// Subframe 4 page 18 carrying the Klobuchar coefficients `k` (the UTC
/// parameters zero), transmitted from time of week `tow_s` (a multiple of 6 s).
pub fn encode_iono(k: &Klobuchar, tow_s: f64) -> Result<[u32; 10], LnavError> {
    let mut w = Writer { d: [0; 10] };
    w.put(1, 1, 8, PREAMBLE);
    w.put(2, 1, 17, ((tow_s / 6.0).round() as u32 + 1) % 100_800);
    w.put(2, 20, 3, 4);
    w.put(3, 1, 2, 1); // data ID
    w.put(3, 3, 6, SV_ID_IONO_UTC);
    let c = [
        k.alpha[0], k.alpha[1], k.alpha[2], k.alpha[3], k.beta[0], k.beta[1], k.beta[2], k.beta[3],
    ];
    for (i, v) in c.iter().enumerate() {
        let (n, st) = IONO_POS[i];
        w.put(
            n,
            st,
            8,
            q_signed(*v, IONO_EXP[i], 8, "Klobuchar coefficient")?,
        );
    }
    Ok(w.finish())
}

/// Builds words from source-data fields, then parity.
struct Writer {
    d: [u32; 10],
}

impl Writer {
    fn put(&mut self, n: usize, start: u32, len: u32, v: u32) {
        let mask = ((1u32 << len) - 1) << (25 - start - len);
        self.d[n - 1] = (self.d[n - 1] & !mask) | ((v << (25 - start - len)) & mask);
    }
    fn put32(&mut self, n: usize, v: u32) {
        self.put(n, 17, 8, v >> 24);
        self.d[n] = v & 0x00FF_FFFF;
    }
    /// The 10 words with parity; the last two data bits of words 2 and 10
    /// are chosen so that D29 = D30 = 0 (IS-GPS-200 §20.3.5.2).
    fn finish(mut self) -> [u32; 10] {
        let mut out = [0u32; 10];
        let (mut d29, mut d30) = (false, false);
        for (k, slot) in out.iter_mut().enumerate() {
            if k == 1 || k == 9 {
                let base = self.d[k] & !3;
                self.d[k] = (0..4u32)
                    .map(|t| base | t)
                    .find(|&d| parity(d, d29, d30) & 3 == 0)
                    .unwrap_or(base);
            }
            let w = (self.d[k] << 6) | parity(self.d[k], d29, d30);
            d29 = (w >> 1) & 1 == 1;
            d30 = w & 1 == 1;
            *slot = w;
        }
        out
    }
}

fn q_signed(v: f64, e: i32, len: u32, name: &'static str) -> Result<u32, LnavError> {
    let x = (v / 2f64.powi(e)).round();
    let lim = 2f64.powi(len as i32 - 1);
    if !x.is_finite() || x < -lim || x >= lim {
        return Err(LnavError::Range(name));
    }
    Ok((x as i64 as u32)
        & if len == 32 {
            u32::MAX
        } else {
            (1u32 << len) - 1
        })
}

/// An angle [rad] as its 32-bit two's-complement field of 2⁻³¹ semicircles
/// (M_0, Ω_0, ω: IS-GPS-200 Table 20-III; the same scale in Galileo I/NAV
/// and BeiDou D1/D2): rounded, then wrapped modulo one revolution, so an
/// angle just below +π that rounds to +1 semicircle is written as −1 (the
/// same direction) instead of being refused, and any angle outside ±π is
/// brought in. `None` when not finite.
pub(crate) fn angle_field_32(angle: f64) -> Option<u32> {
    let x = (angle / GPS_PI * 2f64.powi(31)).round();
    if !x.is_finite() || x.abs() >= 2f64.powi(62) {
        return None;
    }
    Some((x as i64).rem_euclid(1i64 << 32) as u32)
}

fn q_angle(angle: f64, name: &'static str) -> Result<u32, LnavError> {
    angle_field_32(angle).ok_or(LnavError::Range(name))
}

fn q_unsigned(v: f64, e: i32, len: u32, name: &'static str) -> Result<u32, LnavError> {
    let x = (v / 2f64.powi(e)).round();
    if !x.is_finite() || x < 0.0 || x >= 2f64.powi(len as i32) {
        return Err(LnavError::Range(name));
    }
    Ok(x as u64 as u32)
}

/// Subframes 1, 2 and 3 of `o` with issue of data `iode` (8 bits; IODC =
/// `iode`) and accuracy `ura_m` ([`ura_index`]), transmitted from time of week `tow_sf1_s` (subframe 1 start, a
/// multiple of 6 s; subframes 2 and 3 follow at +6 and +12 s). Values are
/// quantised to their broadcast resolution.
pub fn encode_ephemeris(
    o: &KeplerOrbit,
    iode: u8,
    ura_m: f64,
    tow_sf1_s: f64,
) -> Result<[[u32; 10]; 3], LnavError> {
    let sow = |t: f64| t - (t / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
    // The broadcast week is the transmission week: t_oe's, or its
    // neighbour when the transmission is more than half a week away.
    let mut week = (o.t_oe / SECONDS_PER_WEEK).floor();
    if tow_sf1_s - sow(o.t_oe) > SECONDS_PER_WEEK / 2.0 {
        week -= 1.0;
    } else if tow_sf1_s - sow(o.t_oe) < -SECONDS_PER_WEEK / 2.0 {
        week += 1.0;
    }
    let semi = |v: f64| v / GPS_PI;
    let mut out = [[0u32; 10]; 3];
    for (i, sf) in out.iter_mut().enumerate() {
        let mut w = Writer { d: [0; 10] };
        w.put(1, 1, 8, PREAMBLE);
        let tow_next = ((tow_sf1_s / 6.0).round() as u32 + i as u32 + 1) % 100_800;
        w.put(2, 1, 17, tow_next);
        w.put(2, 20, 3, i as u32 + 1);
        match i {
            0 => {
                w.put(3, 1, 10, (week as i64).rem_euclid(1024) as u32);
                w.put(3, 11, 2, 1); // C/A code on L2
                w.put(3, 13, 4, ura_index(ura_m));
                w.put(3, 17, 6, o.health & 0x3F);
                w.put(3, 23, 2, 0); // IODC MSBs
                w.put(7, 17, 8, q_signed(o.tgd, -31, 8, "T_GD")?);
                w.put(8, 1, 8, u32::from(iode));
                w.put(8, 9, 16, q_unsigned(sow(o.t_oc), 4, 16, "t_oc")?);
                w.put(9, 1, 8, q_signed(o.af2, -55, 8, "a_f2")?);
                w.put(9, 9, 16, q_signed(o.af1, -43, 16, "a_f1")?);
                w.put(10, 1, 22, q_signed(o.af0, -31, 22, "a_f0")?);
            }
            1 => {
                w.put(3, 1, 8, u32::from(iode));
                w.put(3, 9, 16, q_signed(o.crs, -5, 16, "C_rs")?);
                w.put(4, 1, 16, q_signed(semi(o.delta_n), -43, 16, "Δn")?);
                w.put32(4, q_angle(o.m0, "M_0")?);
                w.put(6, 1, 16, q_signed(o.cuc, -29, 16, "C_uc")?);
                w.put32(6, q_unsigned(o.e, -33, 32, "e")?);
                w.put(8, 1, 16, q_signed(o.cus, -29, 16, "C_us")?);
                w.put32(8, q_unsigned(o.sqrt_a, -19, 32, "√A")?);
                w.put(10, 1, 16, q_unsigned(sow(o.t_oe), 4, 16, "t_oe")?);
            }
            _ => {
                w.put(3, 1, 16, q_signed(o.cic, -29, 16, "C_ic")?);
                w.put32(3, q_angle(o.omega0, "Ω_0")?);
                w.put(5, 1, 16, q_signed(o.cis, -29, 16, "C_is")?);
                w.put32(5, q_signed(semi(o.i0), -31, 32, "i_0")?);
                w.put(7, 1, 16, q_signed(o.crc, -5, 16, "C_rc")?);
                w.put32(7, q_angle(o.argp, "ω")?);
                w.put(9, 1, 24, q_signed(semi(o.omega_dot), -43, 24, "Ω̇")?);
                w.put(10, 1, 8, u32::from(iode));
                w.put(10, 9, 14, q_signed(semi(o.idot), -43, 14, "IDOT")?);
            }
        }
        *sf = w.finish();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GPS ephemeris with realistic magnitudes (PRN 3 of brdc1820.10n
    /// style values), week 1590.
    fn orbit() -> KeplerOrbit {
        let week = 1590.0 * SECONDS_PER_WEEK;
        KeplerOrbit {
            prn: 3,
            health: 0,
            t_oe: week + 352_800.0,
            t_oc: week + 352_800.0,
            sqrt_a: 5153.6543,
            e: 0.012_345,
            i0: 0.9634,
            idot: -3.1e-10,
            omega0: -2.123,
            omega_dot: -8.1e-9,
            argp: 1.234,
            m0: -0.567,
            delta_n: 4.5e-9,
            cuc: -1.2e-6,
            cus: 8.3e-6,
            crc: 210.5,
            crs: -23.4,
            cic: 1.1e-7,
            cis: -5.6e-8,
            af0: 1.23e-4,
            af1: -2.3e-12,
            af2: 0.0,
            tgd: -4.66e-9,
        }
    }

    /// Angles at and beyond ±π are written (wrapped), not refused, and
    /// decode to the same direction: the simulator's orbits are not
    /// wrapped, and an angle just below +π rounds to +1 semicircle.
    /// The ephemeris the [`Assembler`] builds from encoded subframes
    /// (PRN 3) received in GPS week `week`.
    fn assemble(sfs: &[[u32; 10]], week: u16) -> KeplerOrbit {
        let mut a = Assembler::default();
        let mut got = None;
        for w in sfs {
            got = a.push(3, &decode_subframe(w).unwrap(), week);
        }
        got.unwrap().orbit
    }

    #[test]
    fn angles_at_and_beyond_pi_are_wrapped_not_refused() {
        let mut o = orbit();
        o.m0 = GPS_PI - 1e-12;
        o.omega0 = 3.0 * GPS_PI + 0.25;
        o.argp = -GPS_PI;
        let sfs = encode_ephemeris(&o, 77, 2.0, 352_794.0).unwrap();
        let g = assemble(&sfs, 1590);
        let same = |x: f64, y: f64| {
            let d = (x - y).rem_euclid(2.0 * GPS_PI);
            d.min(2.0 * GPS_PI - d) < 2f64.powi(-31) * GPS_PI
        };
        assert!(same(g.m0, o.m0) && same(g.omega0, o.omega0) && same(g.argp, o.argp));
        assert_eq!(angle_field_32(GPS_PI - 1e-12), Some(1u32 << 31));
        assert_eq!(angle_field_32(f64::NAN), None);
    }

    #[test]
    fn encode_then_decode_recovers_the_orbit_to_its_broadcast_resolution() {
        let o = orbit();
        let sfs = encode_ephemeris(&o, 77, 2.0, 352_794.0).unwrap();
        let mut a = Assembler::default();
        let mut got = None;
        for (i, w) in sfs.iter().enumerate() {
            let sf = decode_subframe(w).unwrap();
            assert_eq!(sf.id as usize, i + 1);
            assert_eq!(sf.tow_next_s, 352_794.0 + 6.0 * (i as f64 + 1.0));
            got = a.push(3, &sf, 1590);
        }
        let e = got.expect("ephemeris after subframes 1-3");
        assert_eq!((e.iode, e.ura_m), (77, 2.4));
        let g = e.orbit;
        // Within ±2 h the positions agree to the broadcast resolution: half
        // an LSB of the angles (2^-32 semicircles ≈ 2 cm at GPS orbit
        // radius) and of the rates (Δn, Ω̇, IDOT: 2^-44 sc/s × 7200 s ≈
        // 3 cm), a few of them adding up; clocks to half an LSB of a_f0
        // (2^-32 s) plus a_f1's over 2 h (2^-44 × 7200 s): 6.4e-10 s.
        for dt in [-7200.0, 0.0, 7200.0] {
            let t = o.t_oe + dt;
            let d = (g.position_ecef(t) - o.position_ecef(t)).norm();
            assert!(d < 0.15, "{dt} s: {d} m");
            assert!((g.clock_offset(t) - o.clock_offset(t)).abs() < 6.5e-10);
        }
        // A broadcast (already quantised) ephemeris survives exactly.
        let again = encode_ephemeris(&g, 78, 2.0, 352_794.0).unwrap();
        let mut b = Assembler::default();
        let mut g2 = None;
        for w in &again {
            g2 = b.push(3, &decode_subframe(w).unwrap(), 1590);
        }
        assert_eq!(g2.map(|e| e.orbit), Some(g));
        assert_eq!((g.t_oe, g.t_oc), (o.t_oe, o.t_oc));
        assert!((g.tgd - o.tgd).abs() < 2f64.powi(-31));
        // The same issue of data again is not a new ephemeris.
        let sf = decode_subframe(&sfs[0]).unwrap();
        assert!(a.push(3, &sf, 1590).is_none());
    }

    #[test]
    fn a_flipped_bit_fails_parity_and_mismatched_issues_do_not_join() {
        let o = orbit();
        let sfs = encode_ephemeris(&o, 77, 2.0, 352_794.0).unwrap();
        for word in 0..10 {
            for bit in [0u32, 7, 29] {
                let mut w = sfs[1];
                w[word] ^= 1 << bit;
                assert_eq!(decode_subframe(&w), Err(LnavError::Parity(word + 1)));
            }
        }
        let other = encode_ephemeris(&o, 78, 2.0, 352_794.0).unwrap();
        let mut a = Assembler::default();
        a.push(3, &decode_subframe(&sfs[0]).unwrap(), 1590);
        a.push(3, &decode_subframe(&sfs[1]).unwrap(), 1590);
        assert!(a
            .push(3, &decode_subframe(&other[2]).unwrap(), 1590)
            .is_none());
    }

    #[test]
    fn words_2_and_10_end_in_zero_parity_bits() {
        let sfs = encode_ephemeris(&orbit(), 5, 2.0, 6.0).unwrap();
        for sf in sfs {
            assert_eq!(sf[1] & 3, 0);
            assert_eq!(sf[9] & 3, 0);
        }
    }

    #[test]
    fn broadcast_week_resolves_across_the_1024_rollover_and_week_ends() {
        // t_oe at the start of week 2048 (10-bit week 0), sent late in week 2047.
        let mut o = orbit();
        o.t_oe = 2048.0 * SECONDS_PER_WEEK + 0.0;
        o.t_oc = o.t_oe;
        let sfs = encode_ephemeris(&o, 9, 2.0, 604_200.0).unwrap();
        let g = assemble(&sfs, 2047);
        // Broadcast week 2047 mod 1024 = 1023; t_oe (0 s of week) lies more
        // than half a week after the transmission: the next week, 2048.
        assert_eq!(get(&sfs[0], 3, 1, 10), 1023);
        assert_eq!(g.t_oe, o.t_oe);
    }

    proptest::proptest! {
        /// Arbitrary words (half of the time with preamble, subframe ID and
        /// parity set right, so the field decoding is reached) never panic the decoder or the
        /// assembler, for any PRN and week.
        #[test]
        fn arbitrary_subframes_never_panic(w in proptest::prelude::any::<[u32; 10]>(),
                                           fix in proptest::prelude::any::<bool>(),
                                           prn in proptest::prelude::any::<u8>(),
                                           week in proptest::prelude::any::<u16>()) {
            let mut w = w.map(|x| x & 0x3FFF_FFFF);
            if fix {
                w[0] = (w[0] & !(0xFF << 22)) | (PREAMBLE << 22);
                w[1] = (w[1] & !(0x7 << 8)) | ((u32::from(week % 5) + 1) << 8);
                let (mut d29, mut d30) = (false, false);
                for x in w.iter_mut() {
                    *x = (*x & !0x3F) | parity(data(*x), d29, d30);
                    d29 = (*x >> 1) & 1 == 1;
                    d30 = *x & 1 == 1;
                }
            }
            let mut a = Assembler::default();
            let r = decode_subframe(&w);
            proptest::prop_assert!(!fix || r.is_ok());
            if let Ok(sf) = r {
                for id in 1..=3u8 {
                    let _ = a.push(prn, &Subframe { id, ..sf }, week);
                }
            }
        }
    }

    #[test]
    fn iono_page_round_trips_and_sets_the_assembler() {
        // Coefficients on their broadcast grid (typical 2010 values).
        let k = Klobuchar {
            alpha: [1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8],
            beta: [90112.0, 0.0, -196608.0, -65536.0],
        };
        let w = encode_iono(&k, 600.0).unwrap();
        let sf = decode_subframe(&w).unwrap();
        assert_eq!(sf.id, 4);
        let mut a = Assembler::default();
        assert!(a.push(3, &sf, 1590).is_none());
        let got = a.iono.unwrap();
        for i in 0..4 {
            // Half an LSB of each coefficient.
            assert!((got.alpha[i] - k.alpha[i]).abs() <= 2f64.powi(IONO_EXP[i] - 1));
            assert!((got.beta[i] - k.beta[i]).abs() <= 2f64.powi(IONO_EXP[i + 4] - 1));
        }
    }

    #[test]
    fn ura_index_follows_the_icd_intervals() {
        assert_eq!(ura_index(0.0), 0);
        assert_eq!(ura_index(2.4), 0);
        assert_eq!(ura_index(2.8), 1);
        assert_eq!(ura_index(6144.0), 14);
        assert_eq!(ura_index(7000.0), 15);
        assert_eq!(ura_index(f64::NAN), 15);
    }

    #[test]
    fn out_of_range_fields_are_errors() {
        let mut o = orbit();
        o.af0 = 1.0; // 1 s does not fit 22 bits of 2^-31 s
        assert_eq!(
            encode_ephemeris(&o, 1, 2.0, 0.0),
            Err(LnavError::Range("a_f0"))
        );
    }
}
