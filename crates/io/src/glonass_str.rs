//! GLONASS L1OF navigation strings 1–4 (immediate information) ↔
//! [`GlonassEph`], GLONASS ICD Edition 5.1 (2008): string structure §4.3
//! (Figure 4.6, 85 bits: idle bit, string number m, data, 8-bit Hamming
//! code), content and bit allocation of strings 1–4 Table 4.5, scale
//! factors and ranges Table 4.4 (x: 27 bits of 2⁻¹¹ km, ẋ: 24 of 2⁻²⁰
//! km/s, ẍ: 5 of 2⁻³⁰ km/s², t_b: 7 bits of 15 min, γ_n: 11 of 2⁻⁴⁰, τ_n:
//! 22 of 2⁻³⁰ s, E_n: 5 bits of days, n: 5 bits), sign–magnitude numbers
//! (§4.4: the MSB is the sign).
//!
//! UBX-RXM-SFRBX (gnssId 6) delivers one string as 4 words (u-blox
//! interface description "GLONASS"; RTKLIB `ublox.c:decode_glostr`): the
//! string's 85 bits from bit 31 of word 0 (idle bit first), and a frame
//! identifier in the upper 16 bits of word 3; `freqId` is the frequency
//! channel + 7. The Hamming code is not checked here (the receiver has
//! verified the string; [`encode_strings`] writes it as zeros).
//! [`GloAssembler`] joins strings 1–4 of one satellite and one frame
//! (their frame identifiers equal) whose string 4 slot number is the
//! satellite's; string 5 sets its time-scale parameters (N^A, τ_c, N_4,
//! τ_GPS: [`GloTimeParams`]).
//!
//! Time: t_b is the index of a 15-min interval of the Moscow day (Moscow
//! time = UTC(SU) plus 3 h, ICD 5.1 §3.3.3); the day is that of the
//! reception (the t_b within ±12 h of it, as RTKLIB), and UTC becomes GPS
//! time with [`crate::time::gps_minus_utc`].

use navfuse_core::gnss::glonass::GlonassEph;
use navfuse_core::Vec3;

/// Words of one string in RXM-SFRBX.
pub const NUM_WORDS: usize = 4;
/// Highest slot number (5 bits; 1–24 allocated).
pub const MAX_SLOT: u8 = 24;
/// Moscow time − UTC [s] (ICD 5.1 §3.3.3).
const MOSCOW_MINUS_UTC_S: f64 = 10_800.0;

/// Why a string or ephemeris was not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GloError {
    /// RXM-SFRBX `numWords` is not 4.
    WordCount(usize),
    /// String number m outside 1–15.
    StringNumber(u8),
    /// A field does not fit its bits when encoding (name).
    Range(&'static str),
}

impl core::fmt::Display for GloError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            GloError::WordCount(n) => write!(f, "GLONASS string: {n} words, 4 expected"),
            GloError::StringNumber(m) => write!(f, "GLONASS string number {m} outside 1-15"),
            GloError::Range(n) => write!(f, "GLONASS string: {n} does not fit its field"),
        }
    }
}

impl std::error::Error for GloError {}

fn join(w: &[u32]) -> u128 {
    w.iter().fold(0u128, |a, &x| (a << 32) | u128::from(x))
}

fn getu(w: u128, start: u32, len: u32) -> u64 {
    ((w >> (128 - start - len)) & ((1u128 << len) - 1)) as u64
}

/// Sign–magnitude field (ICD 5.1 §4.4).
fn getsm(w: u128, start: u32, len: u32) -> f64 {
    let v = getu(w, start, len);
    let mag = (v & ((1u64 << (len - 1)) - 1)) as f64;
    if v >> (len - 1) == 1 {
        -mag
    } else {
        mag
    }
}

fn put(w: &mut u128, start: u32, len: u32, v: u64) {
    let mask = ((1u128 << len) - 1) << (128 - start - len);
    *w = (*w & !mask) | ((u128::from(v) << (128 - start - len)) & mask);
}

fn q_sm(v: f64, lsb: f64, len: u32, name: &'static str) -> Result<u64, GloError> {
    let x = (v / lsb).round();
    if !x.is_finite() || x.abs() >= 2f64.powi(len as i32 - 1) {
        return Err(GloError::Range(name));
    }
    Ok((u64::from(x < 0.0) << (len - 1)) | x.abs() as u64)
}

/// One string: number, frame identifier, the 128 bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GloString {
    pub m: u8,
    pub frame: u16,
    pub bits: u128,
}

/// Read one string (RXM-SFRBX words).
pub fn decode_string(words: &[u32]) -> Result<GloString, GloError> {
    if words.len() != NUM_WORDS {
        return Err(GloError::WordCount(words.len()));
    }
    let bits = join(words);
    let m = getu(bits, 1, 4) as u8;
    if m == 0 {
        return Err(GloError::StringNumber(m));
    }
    Ok(GloString {
        m,
        frame: (words[3] >> 16) as u16,
        bits,
    })
}

/// String 5 (non-immediate information, ICD 5.1 Table 4.5/4.4): the
/// time-scale parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GloTimeParams {
    /// Calendar day number within the four-year interval N^A (11 bits).
    pub day_na: u16,
    /// τ_c: GLONASS time scale correction to UTC(SU) [s] (32 bits, 2⁻³¹ s).
    pub tau_c: f64,
    /// N_4: four-year interval number since 1996 (5 bits).
    pub n4: u8,
    /// τ_GPS: GPS − GLONASS time fractional difference [s] (22 bits, 2⁻³⁰ s).
    pub tau_gps: f64,
}

/// String 5's parameters (any slot broadcasts the same system values).
pub fn decode_time_params(s: &GloString) -> Option<GloTimeParams> {
    (s.m == 5).then(|| GloTimeParams {
        day_na: getu(s.bits, 5, 11) as u16,
        tau_c: getsm(s.bits, 16, 32) * 2f64.powi(-31),
        n4: getu(s.bits, 49, 5) as u8,
        tau_gps: getsm(s.bits, 54, 22) * 2f64.powi(-30),
    })
}

/// Joins strings 1–4 per slot. Fixed size, no allocation.
#[derive(Clone, Debug)]
pub struct GloAssembler {
    last: [[Option<GloString>; 4]; MAX_SLOT as usize],
    /// (t_b index, frame) of the last ephemeris emitted per slot.
    emitted: [Option<(u64, u16)>; MAX_SLOT as usize],
    /// The last string 5's time parameters.
    pub time: Option<GloTimeParams>,
}

impl Default for GloAssembler {
    fn default() -> Self {
        GloAssembler {
            last: [[None; 4]; MAX_SLOT as usize],
            emitted: [None; MAX_SLOT as usize],
            time: None,
        }
    }
}

/// Scale factors (ICD 5.1 Table 4.4), SI.
const LSB_POS_M: f64 = 1e3 / 2048.0; // 2^-11 km
const LSB_VEL_MPS: f64 = 1e3 / 1_048_576.0; // 2^-20 km/s
const LSB_ACC_MPS2: f64 = 1e3 / 1_073_741_824.0; // 2^-30 km/s²

impl GloAssembler {
    /// Add string `s` of satellite `slot` (RXM-SFRBX `svId`), frequency
    /// channel from `freq_id` (SFRBX `freqId` = k + 7), received at GPS
    /// time `rx_t` [s]. Returns a new ephemeris when strings 1–4 of one
    /// frame are present, string 4's n is `slot`, and (t_b, frame) differs
    /// from the last one emitted. Other strings (5, almanac) are ignored.
    pub fn push(&mut self, slot: u8, freq_id: u8, s: &GloString, rx_t: f64) -> Option<GlonassEph> {
        if let Some(p) = decode_time_params(s) {
            self.time = Some(p);
            return None;
        }
        // freqId = k + 7 with k in −7…+13 (RINEX's range; ICD 5.1 §3.3.1.1: −7…+6).
        if !(1..=MAX_SLOT).contains(&slot)
            || !(1..=4).contains(&s.m)
            || !rx_t.is_finite()
            || freq_id > 20
        {
            return None;
        }
        let k = usize::from(slot - 1);
        self.last[k][usize::from(s.m - 1)] = Some(*s);
        let [Some(s1), Some(s2), Some(s3), Some(s4)] = self.last[k] else {
            return None;
        };
        if [s2, s3, s4].iter().any(|x| x.frame != s1.frame)
            || getu(s4.bits, 70, 5) != u64::from(slot)
        {
            return None;
        }
        let tb = getu(s2.bits, 9, 7);
        if self.emitted[k] == Some((tb, s1.frame)) || !(1..=96).contains(&tb) {
            return None;
        }
        // t_b: Moscow time of day → UTC of the reception's UTC day (the one
        // within ±12 h), then GPS time.
        let leap = crate::time::gps_minus_utc(rx_t);
        let rx_utc = rx_t - leap;
        let day = (rx_utc / 86_400.0).floor() * 86_400.0;
        let tod = rx_utc - day;
        let mut toe = tb as f64 * 900.0 - MOSCOW_MINUS_UTC_S;
        while toe < tod - 43_200.0 {
            toe += 86_400.0;
        }
        while toe > tod + 43_200.0 {
            toe -= 86_400.0;
        }
        let t_b = day + toe + leap;
        let axis = |w: u128| {
            (
                getsm(w, 50, 27) * LSB_POS_M,
                getsm(w, 21, 24) * LSB_VEL_MPS,
                getsm(w, 45, 5) * LSB_ACC_MPS2,
            )
        };
        let (x, y, z) = (axis(s1.bits), axis(s2.bits), axis(s3.bits));
        self.emitted[k] = Some((tb, s1.frame));
        Some(GlonassEph {
            slot,
            freq_ch: freq_id as i8 - 7, // freq_id ≤ 20 checked above
            health: getu(s2.bits, 5, 1) as u32,
            age_days: getu(s4.bits, 32, 5) as u8,
            t_b,
            pos_m: Vec3::new(x.0, y.0, z.0),
            vel_mps: Vec3::new(x.1, y.1, z.1),
            acc_mps2: Vec3::new(x.2, y.2, z.2),
            tau_n: getsm(s4.bits, 5, 22) * 2f64.powi(-30),
            gamma_n: getsm(s3.bits, 6, 11) * 2f64.powi(-40),
        })
    }
}

/// Strings 1–4 of `e` in frame `frame` as RXM-SFRBX words (t_k = t_b −
/// 30 s as the frame time, Hamming bits zero); errors name a field out of
/// range, or a t_b not on the 15-min grid of the Moscow day.
pub fn encode_strings(e: &GlonassEph, frame: u16) -> Result<[[u32; NUM_WORDS]; 4], GloError> {
    if !(1..=MAX_SLOT).contains(&e.slot) {
        return Err(GloError::Range("slot"));
    }
    let leap = crate::time::gps_minus_utc(e.t_b);
    let moscow = (e.t_b - leap + MOSCOW_MINUS_UTC_S).rem_euclid(86_400.0);
    let tb = moscow / 900.0;
    if (tb - tb.round()).abs() > 1e-6 || tb.round() < 1.0 {
        return Err(GloError::Range("t_b (15 min grid)"));
    }
    let tb = tb.round() as u64;
    let tk = (moscow - 30.0).rem_euclid(86_400.0);
    let mut w = [0u128; 4];
    for (i, x) in w.iter_mut().enumerate() {
        put(x, 1, 4, i as u64 + 1);
    }
    let comps = [
        (e.pos_m.x, e.vel_mps.x, e.acc_mps2.x),
        (e.pos_m.y, e.vel_mps.y, e.acc_mps2.y),
        (e.pos_m.z, e.vel_mps.z, e.acc_mps2.z),
    ];
    for (x, (p, v, a)) in w.iter_mut().zip(comps) {
        put(x, 21, 24, q_sm(v, LSB_VEL_MPS, 24, "velocity")?);
        put(x, 45, 5, q_sm(a, LSB_ACC_MPS2, 5, "acceleration")?);
        put(x, 50, 27, q_sm(p, LSB_POS_M, 27, "position")?);
    }
    put(&mut w[0], 9, 5, (tk / 3600.0).floor() as u64);
    put(&mut w[0], 14, 6, ((tk % 3600.0) / 60.0).floor() as u64);
    put(&mut w[0], 20, 1, u64::from(tk % 60.0 >= 30.0));
    put(&mut w[1], 5, 1, u64::from(e.health != 0));
    put(&mut w[1], 9, 7, tb);
    put(
        &mut w[2],
        6,
        11,
        q_sm(e.gamma_n, 2f64.powi(-40), 11, "γ_n")?,
    );
    put(&mut w[3], 5, 22, q_sm(e.tau_n, 2f64.powi(-30), 22, "τ_n")?);
    put(&mut w[3], 32, 5, u64::from(e.age_days.min(31)));
    put(&mut w[3], 70, 5, u64::from(e.slot));
    Ok(w.map(|x| {
        let mut o = [0u32; NUM_WORDS];
        for (i, v) in o.iter_mut().enumerate() {
            *v = (x >> (96 - 32 * i)) as u32;
        }
        o[3] = (o[3] & 0xFFFF) | (u32::from(frame) << 16);
        o
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rinex_glonass::parse_nav_glonass;

    /// The ICD example state as a RINEX 3 record, on the broadcast grid
    /// (position a multiple of 2⁻¹¹ km, velocity of 2⁻²⁰ km/s, the
    /// accelerations of 2⁻³⁰ km/s²; τ_n, γ_n on theirs), t_b 03:15 Moscow.
    fn rinex() -> GlonassEph {
        let text =
            "     3.04           N: GNSS NAV DATA    R: GLONASS          RINEX VERSION / TYPE
                                                            END OF HEADER
R07 2012 09 07 00 15 00-1.199999824166E-04 9.094947017729E-13 0.000000000000E+00
     7.003008789062E+03 7.835416793823E-01 0.000000000000E+00 0.000000000000E+00
    -1.220662695312E+04 2.804252624512E+00 1.862645149231E-09 1.000000000000E+00
     2.128076562500E+04 1.352515220642E+00-5.587935447693E-09 3.000000000000E+00
";
        parse_nav_glonass(text, "t.rnx").unwrap()[0]
    }

    /// Round trip through strings 1–4 and the position/clock the RINEX
    /// record gives over ±15 min (< 1 mm; the values are on the grid, the
    /// RINEX mantissa keeps 13 digits).
    #[test]
    fn strings_round_trip_and_match_the_rinex_path() {
        let r = rinex();
        let s = encode_strings(&r, 0x1234).unwrap();
        let mut a = GloAssembler::default();
        let mut got = None;
        for w in &s {
            let st = decode_string(w).unwrap();
            assert_eq!(st.frame, 0x1234);
            got = a.push(7, 8, &st, r.t_b + 20.0).or(got);
        }
        let g = got.expect("ephemeris after strings 1-4");
        assert_eq!((g.slot, g.freq_ch, g.health, g.age_days), (7, 1, 0, 3));
        assert_eq!(g.t_b, r.t_b);
        // RINEX keeps 13 significant digits of τ_n.
        assert!((g.tau_n - r.tau_n).abs() < 1e-15);
        assert!((g.gamma_n - r.gamma_n).abs() < 1e-24);
        for dt in [-900.0, 0.0, 600.0, 900.0] {
            let t = r.t_b + dt;
            let d = (g.position_ecef(t) - r.position_ecef(t)).norm();
            assert!(d < 1e-3, "{dt} s: {d} m");
            assert!((g.clock_offset(t) - r.clock_offset(t)).abs() < 1e-15);
        }
        // Re-encoding gives the same strings; the same frame again is not new.
        assert_eq!(encode_strings(&g, 0x1234).unwrap(), s);
        assert!(a
            .push(7, 8, &decode_string(&s[3]).unwrap(), r.t_b)
            .is_none());
        // Near midnight the reception day decides: received 11 h later
        // still gives the same t_b; 13 h later the next day's.
        let mut b = GloAssembler::default();
        let mut g2 = None;
        for w in &s {
            g2 = b
                .push(7, 8, &decode_string(w).unwrap(), r.t_b + 11.0 * 3600.0)
                .or(g2);
        }
        assert_eq!(g2.unwrap().t_b, r.t_b);
    }

    #[test]
    fn mismatched_frames_slots_and_bad_input() {
        let r = rinex();
        let s = encode_strings(&r, 1).unwrap();
        let other = encode_strings(&r, 2).unwrap();
        let mut a = GloAssembler::default();
        for w in [s[0], s[1], s[2], other[3]] {
            assert!(a.push(7, 8, &decode_string(&w).unwrap(), r.t_b).is_none());
        }
        // String 4's slot (7) must be the satellite's.
        let mut b = GloAssembler::default();
        for w in &s {
            assert!(b.push(8, 8, &decode_string(w).unwrap(), r.t_b).is_none());
        }
        assert_eq!(decode_string(&s[0][..3]), Err(GloError::WordCount(3)));
        assert_eq!(decode_string(&[0; 4]), Err(GloError::StringNumber(0)));
        let mut off = r;
        off.t_b += 60.0;
        assert_eq!(
            encode_strings(&off, 1),
            Err(GloError::Range("t_b (15 min grid)"))
        );
        let mut far = r;
        far.pos_m.x = 1e11;
        assert_eq!(encode_strings(&far, 1), Err(GloError::Range("position")));
    }

    /// String 5: N^A, τ_c, N_4, τ_GPS at their Table 4.5 positions.
    #[test]
    fn string_5_time_parameters() {
        let mut w = 0u128;
        put(&mut w, 1, 4, 5);
        put(&mut w, 5, 11, 1234);
        put(
            &mut w,
            16,
            32,
            q_sm(-1.5e-8, 2f64.powi(-31), 32, "τc").unwrap(),
        );
        put(&mut w, 49, 5, 7);
        put(
            &mut w,
            54,
            22,
            q_sm(2.0e-9, 2f64.powi(-30), 22, "τGPS").unwrap(),
        );
        let words: [u32; 4] = core::array::from_fn(|i| (w >> (96 - 32 * i)) as u32);
        let s = decode_string(&words).unwrap();
        let mut a = GloAssembler::default();
        assert!(a.push(3, 7, &s, 1e9).is_none());
        let p = a.time.unwrap();
        assert_eq!((p.day_na, p.n4), (1234, 7));
        assert!((p.tau_c + 1.5e-8).abs() <= 2f64.powi(-32));
        assert!((p.tau_gps - 2.0e-9).abs() <= 2f64.powi(-31));
    }

    /// Sign–magnitude: −0 and +0 both read 0, the MSB is the sign.
    #[test]
    fn sign_magnitude_fields() {
        let mut w = 0u128;
        put(&mut w, 10, 5, 0b1_0011);
        assert_eq!(getsm(w, 10, 5), -3.0);
        put(&mut w, 10, 5, 0b1_0000);
        assert_eq!(getsm(w, 10, 5), 0.0);
        assert_eq!(q_sm(-3.0, 1.0, 5, "x"), Ok(0b1_0011));
        assert_eq!(q_sm(16.0, 1.0, 5, "x"), Err(GloError::Range("x")));
    }

    proptest::proptest! {
        /// Arbitrary strings never panic the decoder or assembler.
        #[test]
        fn arbitrary_strings_never_panic(w in proptest::prelude::any::<[u32; 4]>(),
                                         slot in proptest::prelude::any::<u8>(),
                                         f in proptest::prelude::any::<u8>(),
                                         t in proptest::prelude::any::<f64>()) {
            if let Ok(s) = decode_string(&w) {
                let mut a = GloAssembler::default();
                for m in 1..=4u128 {
                    let bits = (s.bits & !(0xFu128 << 123)) | (m << 123);
                    let _ = a.push(slot, f, &GloString { m: m as u8, bits, ..s }, t);
                }
            }
        }
    }
}
