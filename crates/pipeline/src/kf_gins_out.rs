//! The fast writer of KF-GINS's three output files (`KF_GINS_Navresult.nav`,
//! `KF_GINS_IMU_ERR.txt`, `KF_GINS_STD.txt`) in KF-GINS's number layout.

use crate::error::{PipelineError, Result};
use navfuse_core::estimators::eskf::{ImuErrors, I_ATT, I_BA, I_BG, I_POS, I_SA, I_SG, I_VEL, NX};
use navfuse_core::types::NavSolution;
use navfuse_io::atomic::AtomicFile;
use std::path::{Path, PathBuf};

/// What one output line of the three files needs.
pub(crate) struct OutRow {
    pub sol: NavSolution,
    pub err: ImuErrors,
    /// Diagonal of the error-state covariance.
    pub p_diag: [f64; NX],
}

impl OutRow {
    pub const BATCH: usize = 1024;
}

/// An output file written in chunks from a reused buffer, whole or not at
/// all ([`AtomicFile`]: it appears under its name at [`OutFile::finish`]).
pub(crate) struct OutFile {
    path: PathBuf,
    file: AtomicFile,
    pub buf: Vec<u8>,
}

impl OutFile {
    const CHUNK: usize = 1 << 18;

    pub fn create(dir: &Path, name: &str) -> Result<Self> {
        let path = dir.join(name);
        let file = AtomicFile::create(&path).map_err(PipelineError::io(&path, "cannot write: "))?;
        Ok(OutFile {
            path,
            file,
            buf: Vec::with_capacity(Self::CHUNK + 4096),
        })
    }

    /// Write the buffer out (the file stays uncommitted).
    pub fn write_out(&mut self) -> Result<()> {
        use std::io::Write as _;
        self.file
            .write_all(&self.buf)
            .map_err(PipelineError::io(&self.path, "cannot write: "))?;
        self.buf.clear();
        Ok(())
    }

    #[inline]
    pub fn flush_if_full(&mut self) -> Result<()> {
        if self.buf.len() >= Self::CHUNK {
            self.write_out()?;
        }
        Ok(())
    }

    pub fn finish(mut self) -> Result<()> {
        self.write_out()?;
        self.file
            .commit()
            .map_err(PipelineError::io(&self.path, "cannot write: "))
    }
}

/// KF-GINS number layout: fixed 9 decimals, left-aligned in 15 columns, then a space.
#[inline]
pub(crate) fn put(buf: &mut Vec<u8>, x: f64) {
    let mut tmp = [b' '; 32];
    match fixed9_into(&mut tmp, x) {
        // Fixed-length copies (no memmove call for the common widths).
        Some(n) if n <= 15 => buf.extend_from_slice(&tmp[..16]),
        Some(n) if n <= 23 => buf.extend_from_slice(&tmp[..n + 1]),
        _ => {
            let start = buf.len();
            buf.extend_from_slice(format!("{x:.9}").as_bytes());
            while buf.len() - start < 15 {
                buf.push(b' ');
            }
            buf.push(b' ');
        }
    }
}

/// Fast `{:.9}` for |x| < 9e9 (falls back to `format!` beyond, and for NaN).
#[cfg(test)]
fn fixed9(buf: &mut Vec<u8>, x: f64) {
    let mut tmp = [b' '; 32];
    match fixed9_into(&mut tmp, x) {
        Some(n) => buf.extend_from_slice(&tmp[..n]),
        None => buf.extend_from_slice(format!("{x:.9}").as_bytes()),
    }
}

/// "00" … "99".
const PAIRS: [[u8; 2]; 100] = {
    let mut t = [[0u8; 2]; 100];
    let mut i = 0;
    while i < 100 {
        t[i] = [b'0' + (i / 10) as u8, b'0' + (i % 10) as u8];
        i += 1;
    }
    t
};

/// `{:.9}` of `x` (rounded half away from zero at 1e-9, i.e. as
/// `(|x|·1e9).round()`; `-0.000000000` printed without the sign) into `out`,
/// returning its length; `None` for NaN and |x| ≥ 9e9. Writes at most 21
/// bytes and leaves the rest of `out` untouched.
#[inline(always)]
fn fixed9_into(out: &mut [u8; 32], x: f64) -> Option<usize> {
    if x.is_nan() || x.abs() >= 9.0e9 {
        return None;
    }
    // round(|x|·1e9) half away from zero, exactly as f64::round (without the
    // libm call): y < 9e18 fits u64; below 2^52 `y − ⌊y⌋` is exact, above y
    // is an integer.
    let y = x.abs() * 1e9;
    let fl = y as u64;
    let scaled = if y - fl as f64 >= 0.5 { fl + 1 } else { fl };
    let mut n = 0;
    if x < 0.0 && scaled != 0 {
        out[0] = b'-';
        n = 1;
    }
    let int = scaled / 1_000_000_000;
    let frac = (scaled % 1_000_000_000) as u32;
    // Integer part (< 9e9, at most 10 digits), two digits at a time.
    let mut digits = [b'0'; 10];
    let mut i = digits.len();
    let mut v = int;
    while v >= 100 {
        i -= 2;
        digits[i..i + 2].copy_from_slice(&PAIRS[(v % 100) as usize]);
        v /= 100;
    }
    if v >= 10 {
        i -= 2;
        digits[i..i + 2].copy_from_slice(&PAIRS[v as usize]);
    } else {
        i -= 1;
        digits[i] = b'0' + v as u8;
    }
    let len = digits.len() - i;
    out[n..n + len].copy_from_slice(&digits[i..]);
    n += len;
    out[n] = b'.';
    n += 1;
    // Nine decimals as 4 + 5 digits (independent chains).
    let (hi, lo) = (frac / 100_000, frac % 100_000);
    let f: &mut [u8; 9] = (&mut out[n..n + 9])
        .try_into()
        .unwrap_or_else(|_| unreachable!());
    f[0..2].copy_from_slice(&PAIRS[(hi / 100) as usize]);
    f[2..4].copy_from_slice(&PAIRS[(hi % 100) as usize]);
    let (l1, l2) = (lo / 1000, lo % 1000);
    f[4..6].copy_from_slice(&PAIRS[l1 as usize]);
    f[6..8].copy_from_slice(&PAIRS[(l2 / 10) as usize]);
    f[8] = b'0' + (l2 % 10) as u8;
    Some(n + 9)
}

pub(crate) fn write_nav_line(buf: &mut Vec<u8>, s: &NavSolution) {
    let r2d = 180.0 / std::f64::consts::PI;
    let yaw = s.rpy.z * r2d;
    put(buf, 0.0);
    put(buf, s.t);
    put(buf, s.lat * r2d);
    put(buf, s.lon * r2d);
    put(buf, s.h);
    for v in s.v_n.iter() {
        put(buf, *v);
    }
    put(buf, s.rpy.x * r2d);
    put(buf, s.rpy.y * r2d);
    // KF-GINS writes yaw in [0, 360).
    put(buf, if yaw < 0.0 { yaw + 360.0 } else { yaw });
    buf.push(b'\n');
}

const DEG_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

pub(crate) fn write_err_line(buf: &mut Vec<u8>, t: f64, e: &ImuErrors) {
    put(buf, t);
    for v in e.bg.iter() {
        put(buf, v * DEG_H);
    }
    for v in e.ba.iter() {
        put(buf, v * 1e5);
    }
    for v in e.sg.iter() {
        put(buf, v * 1e6);
    }
    for v in e.sa.iter() {
        put(buf, v * 1e6);
    }
    buf.push(b'\n');
}

pub(crate) fn write_std_line(buf: &mut Vec<u8>, t: f64, p_diag: &[f64; NX]) {
    let sd = |i: usize| p_diag[i].max(0.0).sqrt();
    put(buf, t);
    for (i0, k) in [
        (I_POS, 1.0),
        (I_VEL, 1.0),
        (I_ATT, 180.0 / std::f64::consts::PI),
        (I_BG, DEG_H),
        (I_BA, 1e5),
        (I_SG, 1e6),
        (I_SA, 1e6),
    ] {
        for i in i0..i0 + 3 {
            put(buf, sd(i) * k);
        }
    }
    buf.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed9_matches_std_formatting() {
        for x in [
            0.0,
            -0.0,
            1.5,
            -105.147447742,
            243262.014636,
            1e-10,
            -3.4e-9,
            357.9999999996,
        ] {
            let mut b = Vec::new();
            fixed9(&mut b, x);
            let mut want = format!("{x:.9}");
            if want == "-0.000000000" {
                want = "0.000000000".into();
            }
            assert_eq!(String::from_utf8(b).unwrap(), want, "x = {x}");
        }
        let mut b = Vec::new();
        put(&mut b, 1.0);
        assert_eq!(b.len(), 16);
        // Against the previous formatter's definition, `(|x|·1e9).round()`,
        // over many magnitudes and ties.
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for k in 0..200_000u32 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let mant = (s >> 11) as f64 / (1u64 << 53) as f64;
            let x = match k % 4 {
                0 => (mant - 0.5) * 10f64.powi((k % 19) as i32 - 9),
                1 => ((s % 2_000_000_001) as f64 - 1e9) * 1e-9 + 0.5e-9,
                2 => (mant - 0.5) * 1.7e10,
                _ => f64::from_bits(s) % 8.9e9,
            };
            if !x.is_finite() {
                continue;
            }
            let scaled = (x.abs() * 1e9).round() as u64;
            let mut want = String::new();
            if x < 0.0 && scaled != 0 {
                want.push('-');
            }
            want += &format!("{}.{:09}", scaled / 1_000_000_000, scaled % 1_000_000_000);
            if x.abs() >= 9.0e9 {
                want = format!("{x:.9}");
            }
            let mut b = Vec::new();
            fixed9(&mut b, x);
            assert_eq!(String::from_utf8(b).unwrap(), want, "x = {x:e}");
            let mut p = Vec::new();
            put(&mut p, x);
            assert!(p.len() >= 16 && p.starts_with(want.as_bytes()));
            assert!(p[want.len()..].iter().all(|&c| c == b' '));
        }
    }
}
