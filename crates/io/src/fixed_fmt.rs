//! Fast fixed-point formatting of `f64`, byte-identical to the standard
//! library's `{:W.P}` / `{:0W.P}` (profiled: `core::fmt`'s exact float
//! formatting, with its big-number fallback, was a tenth of a 100 Hz
//! `navfuse run`).
//!
//! Method: `y = |x|·10^P` in `f64` differs from the exact decimal value by
//! at most half an ulp of `y` (10^P is exact for P ≤ 22); while `y < 2^52`
//! its fractional part is exact, so rounding `y` to the nearest integer
//! gives the correctly rounded digits unless that fraction lies within the
//! rounding error of ½. Those near-ties (and exact ties, which the standard
//! library breaks to even), non-finite values and `y ≥ 2^52` go to the
//! standard formatter. The sign follows `x.is_sign_negative()`, as the
//! standard library prints it (`-0.00` for −0.001).

use core::fmt;

/// Powers of ten exact in `f64`, for precisions 0…15.
const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];
const POW10_U: [u64; 16] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
    10_000_000_000,
    100_000_000_000,
    1_000_000_000_000,
    10_000_000_000_000,
    100_000_000_000_000,
    1_000_000_000_000_000,
];

/// The digits of `{:.prec}` of `x` without padding into `out`, returning
/// the length; `None` where the standard formatter must decide (module
/// documentation). At most 1 + 16 + 1 + 15 = 33 bytes.
pub fn fixed_into(out: &mut [u8; 40], x: f64, prec: usize) -> Option<usize> {
    if prec >= POW10.len() || !x.is_finite() {
        return None;
    }
    let y = x.abs() * POW10[prec];
    // 2^52: below it `y − ⌊y⌋` is exact (y is finite here).
    if y >= 4_503_599_627_370_496.0 {
        return None;
    }
    let fl = y as u64;
    let frac = y - fl as f64;
    // Rounding error of the product ≤ ½ ulp(y) ≤ y·2⁻⁵³; a margin of 4×.
    if (frac - 0.5).abs() <= y * 4.5e-16 {
        return None;
    }
    let scaled = if frac > 0.5 { fl + 1 } else { fl };
    let mut n = 0;
    if x.is_sign_negative() {
        out[0] = b'-';
        n = 1;
    }
    let p10 = POW10_U[prec];
    let (mut int, mut fr) = (scaled / p10, scaled % p10);
    // Integer part, at most 16 digits.
    let mut digits = [b'0'; 20];
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (int % 10) as u8;
        int /= 10;
        if int == 0 {
            break;
        }
    }
    let len = digits.len() - i;
    out[n..n + len].copy_from_slice(&digits[i..]);
    n += len;
    if prec > 0 {
        out[n] = b'.';
        n += 1;
        for k in (0..prec).rev() {
            out[n + k] = b'0' + (fr % 10) as u8;
            fr /= 10;
        }
        n += prec;
    }
    Some(n)
}

/// `{:W.P}` (right-aligned in `width` with spaces) or, with `zero`,
/// `{:0W.P}` (sign first, then zeros) of an `f64`, as a `Display` value
/// byte-identical to the standard library's.
#[derive(Clone, Copy, Debug)]
pub struct Fixed {
    pub x: f64,
    pub prec: usize,
    pub width: usize,
    pub zero: bool,
}

/// `{:.prec}`.
pub fn fx(x: f64, prec: usize) -> Fixed {
    Fixed {
        x,
        prec,
        width: 0,
        zero: false,
    }
}

/// `{:width.prec}`.
pub fn fxw(x: f64, width: usize, prec: usize) -> Fixed {
    Fixed {
        x,
        prec,
        width,
        zero: false,
    }
}

/// `{:0width.prec}`.
pub fn fx0(x: f64, width: usize, prec: usize) -> Fixed {
    Fixed {
        x,
        prec,
        width,
        zero: true,
    }
}

const SPACES: &str = "                                        ";
const ZEROS: &str = "0000000000000000000000000000000000000000";

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut buf = [0u8; 40];
        let Some(n) = fixed_into(&mut buf, self.x, self.prec) else {
            let (w, p) = (self.width, self.prec);
            return if self.zero {
                write!(f, "{:0w$.p$}", self.x)
            } else {
                write!(f, "{:w$.p$}", self.x)
            };
        };
        let s = core::str::from_utf8(&buf[..n]).map_err(|_| fmt::Error)?;
        let pad = self.width.saturating_sub(n);
        if pad == 0 {
            return f.write_str(s);
        }
        if pad > SPACES.len() {
            let (w, p) = (self.width, self.prec);
            return if self.zero {
                write!(f, "{:0w$.p$}", self.x)
            } else {
                write!(f, "{:w$.p$}", self.x)
            };
        }
        if self.zero {
            let (sign, digits) = match s.strip_prefix('-') {
                Some(rest) => ("-", rest),
                None => ("", s),
            };
            f.write_str(sign)?;
            f.write_str(&ZEROS[..pad])?;
            f.write_str(digits)
        } else {
            f.write_str(&SPACES[..pad])?;
            f.write_str(s)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(x: f64, w: usize, p: usize) {
        assert_eq!(
            format!("{}", fxw(x, w, p)),
            format!("{x:w$.p$}"),
            "{x:e} {w} {p}"
        );
        assert_eq!(
            format!("{}", fx0(x, w, p)),
            format!("{x:0w$.p$}"),
            "{x:e} {w} {p}"
        );
        assert_eq!(format!("{}", fx(x, p)), format!("{x:.p$}"), "{x:e} {p}");
    }

    #[test]
    fn edge_cases_match_std() {
        let xs = [
            0.0,
            -0.0,
            0.5,
            1.5,
            2.5,
            -2.5,
            0.125,
            0.375,
            -0.001,
            -1e-12,
            1e-300,
            9.999_999_5,
            0.000_000_000_5,
            4.5e15,
            4.503_599_627_370_495e15,
            1e300,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            123_456.789_012_345,
            2_000_000_000.123_456,
            -0.049_999_999_999_999_996,
        ];
        for &x in &xs {
            for p in 0..=16 {
                for w in [0, 3, 8, 14, 45] {
                    check(x, w, p);
                }
            }
        }
    }

    #[test]
    fn halfway_decimals_match_std() {
        // k + 0.5 at every precision: exact ties and their neighbours.
        for p in 0..=9usize {
            for k in 0..2000u64 {
                let x = (k as f64 + 0.5) / 10f64.powi(p as i32);
                for y in [
                    x,
                    f64::from_bits(x.to_bits() + 1),
                    f64::from_bits(x.to_bits() - 1),
                    -x,
                ] {
                    check(y, 0, p);
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn random_values_match_std(m in -1.0f64..1.0, e in -12i32..16, p in 0usize..13, w in 0usize..20) {
            let x = m * 10f64.powi(e);
            check(x, w, p);
        }

        #[test]
        fn random_bits_match_std(bits in any::<u64>(), p in 0usize..13) {
            check(f64::from_bits(bits), 0, p);
        }
    }
}
