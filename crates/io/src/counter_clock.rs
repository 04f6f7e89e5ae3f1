//! An IMU's own counter mapped to GPS time, `t_gps = a + b·counter`,
//! estimated from the recording itself with an RTKLIB time-tag file.
//!
//! Each log line's counter is paired with the time its last byte was
//! received ([`TagFile::receive_time_at`]). Receive time = sample time +
//! latency, latency ≥ 0 with jitter (serial transfer, OS buffering, the
//! PC's tick resolution), so the line is the *lower envelope* of the pairs
//! (the one-way-delay skew estimate of Moon, Skelly & Towsley, "Estimation
//! and removal of clock skew from network delay measurements", INFOCOM
//! 1999). Robust form used here: the pairs are cut into blocks of
//! consecutive lines, each block contributes its minimum-latency pair, and
//! a Theil–Sen line (median of pairwise slopes) is put through the block
//! minima, its offset the median of their residuals. A few corrupted
//! counters spoil only their own blocks.
//!
//! What it cannot know: the minimum latency itself. The fitted times are
//! sample time + minimum latency (minus the tick truncation); an IMU time
//! offset has to be estimated downstream. The rate is relative to the PC
//! tick, which the tag file uses as its clock.

use crate::error::ReadError;
use crate::tag::TagFile;
use std::path::Path;
use std::sync::Arc;

/// Linear counter → GPS time map: `t = t_ref + s_per_count·(c − c_ref)`
/// (c unwrapped), i.e. `a = t_ref − s_per_count·c_ref`, `b = s_per_count`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CounterClock {
    /// Reference counter value (unwrapped) [counts].
    pub c_ref: f64,
    /// GPS seconds at `c_ref`.
    pub t_ref: f64,
    /// Fitted seconds per count.
    pub s_per_count: f64,
    /// Nominal seconds per count (1e-3 for a millisecond counter).
    pub nominal_s_per_count: f64,
    /// Counter modulus (2³² for a u32 counter); None = never wraps.
    pub modulus: Option<f64>,
}

impl CounterClock {
    /// The line through two (counter, GPS time) points; `nominal` seconds
    /// per count, counter modulus `modulus`.
    pub fn from_two_points(
        c0: f64,
        t0: f64,
        c1: f64,
        t1: f64,
        nominal: f64,
        modulus: Option<f64>,
    ) -> Self {
        CounterClock {
            c_ref: c0,
            t_ref: t0,
            s_per_count: (t1 - t0) / (c1 - c0),
            nominal_s_per_count: nominal,
            modulus,
        }
    }
    /// `a` of `t = a + b·c` [s].
    pub fn a(&self) -> f64 {
        self.t_ref - self.s_per_count * self.c_ref
    }
    /// `b` of `t = a + b·c` [s/count].
    pub fn b(&self) -> f64 {
        self.s_per_count
    }
    /// Counter rate error [ppm]: positive = the counter runs slow (each count
    /// lasts longer than nominal).
    pub fn drift_ppm(&self) -> f64 {
        (self.s_per_count / self.nominal_s_per_count - 1.0) * 1e6
    }
    /// GPS seconds of an unwrapped counter value.
    pub fn gps_seconds(&self, c_unwrapped: f64) -> f64 {
        self.t_ref + self.s_per_count * (c_unwrapped - self.c_ref)
    }
}

/// Undo counter wrap-around: a drop by more than half the modulus is a wrap.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CounterUnwrap {
    last: Option<f64>,
    offset: f64,
}

impl CounterUnwrap {
    /// The unwrapped value of raw counter `c` (in stream order).
    pub fn unwrap(&mut self, c: f64, modulus: Option<f64>) -> f64 {
        if let (Some(m), Some(l)) = (modulus, self.last) {
            if l - c > m / 2.0 {
                self.offset += m;
            } else if c - l > m / 2.0 && self.offset >= m {
                self.offset -= m; // a late line from before the wrap
            }
        }
        self.last = Some(c);
        c + self.offset
    }
}

/// The quality of a fit.
#[derive(Clone, Debug, PartialEq)]
pub struct ClockFit {
    /// Pairs (line counter, receive time) used.
    pub pairs: usize,
    pub blocks: usize,
    /// Robust σ (1.4826·MAD) of the block minima about the line [s].
    pub sigma_s: f64,
    /// 1σ of the drift from `sigma_s` and the span (LS formula) [ppm].
    pub drift_sigma_ppm: f64,
    /// Median and 99th percentile of receive time − fitted time over all pairs [s].
    pub latency_median_s: f64,
    pub latency_p99_s: f64,
    /// Whether the tag's file positions count `\r\n` line ends the file no
    /// longer has (see [`fit_csv_counter`]).
    pub crlf_stripped: bool,
}

/// Lines per block: at least 20 lines, at most 1000 blocks. A block must
/// span several tag records (≈ 16 ms apart with a Windows tick) so one of
/// them carries close to the minimum latency; 20 lines at 100 Hz = 0.2 s ≈
/// 12 records. More blocks only cost O(K²) slope pairs.
fn block_len(n: usize) -> usize {
    (n / 1000).max(20)
}

fn median(v: &mut [f64]) -> f64 {
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
}

/// Fit the lower envelope of `(counter_unwrapped, receive_gps_s)` pairs
/// (counter increasing). `nominal` seconds per count.
pub fn fit_pairs(
    pairs: &[(f64, f64)],
    nominal: f64,
    modulus: Option<f64>,
) -> Result<(CounterClock, ClockFit), String> {
    let bl = block_len(pairs.len());
    if pairs.len() < 2 * bl {
        return Err(format!(
            "{} counter/receive-time pairs, need at least {}",
            pairs.len(),
            2 * bl
        ));
    }
    let c_ref = pairs[0].0;
    let t_ref0 = pairs[0].1;
    let mut slope = nominal;
    let mut mins: Vec<(f64, f64)> = Vec::new();
    // Two passes: block minima of y − slope·x depend slightly on the slope.
    for _ in 0..2 {
        mins = pairs
            .chunks(bl)
            .filter(|c| c.len() * 2 >= bl)
            .map(|c| {
                *c.iter()
                    .min_by(|p, q| {
                        let r = |p: &(f64, f64)| (p.1 - t_ref0) - slope * (p.0 - c_ref);
                        r(p).total_cmp(&r(q))
                    })
                    .expect("non-empty block")
            })
            .collect();
        let mut slopes = Vec::with_capacity(mins.len() * mins.len() / 2);
        for (i, p) in mins.iter().enumerate() {
            for q in &mins[i + 1..] {
                if q.0 > p.0 {
                    slopes.push(((q.1 - t_ref0) - (p.1 - t_ref0)) / (q.0 - p.0));
                }
            }
        }
        if slopes.is_empty() {
            return Err("the counter does not increase".to_string());
        }
        slope = median(&mut slopes);
    }
    let mut res: Vec<f64> = mins
        .iter()
        .map(|p| (p.1 - t_ref0) - slope * (p.0 - c_ref))
        .collect();
    let off = median(&mut res.clone());
    for r in res.iter_mut() {
        *r = (*r - off).abs();
    }
    let sigma = 1.4826 * median(&mut res);
    let clock = CounterClock {
        c_ref,
        t_ref: t_ref0 + off,
        s_per_count: slope,
        nominal_s_per_count: nominal,
        modulus,
    };
    let mut lat: Vec<f64> = pairs.iter().map(|p| p.1 - clock.gps_seconds(p.0)).collect();
    lat.sort_unstable_by(f64::total_cmp);
    let span_s = (pairs[pairs.len() - 1].0 - c_ref) * nominal;
    let k = mins.len() as f64;
    let fit = ClockFit {
        pairs: pairs.len(),
        blocks: mins.len(),
        sigma_s: sigma,
        drift_sigma_ppm: sigma / (span_s * (k / 12.0).sqrt()) * 1e6,
        latency_median_s: lat[lat.len() / 2],
        latency_p99_s: lat[(lat.len() * 99) / 100],
        crlf_stripped: false,
    };
    Ok((clock, fit))
}

/// Where the counter is in a CSV log.
#[derive(Clone, Debug, PartialEq)]
pub struct CounterColumn {
    /// 0-based field index.
    pub index: usize,
    pub delimiter: u8,
    pub comment: Option<u8>,
    /// Nominal seconds per count (1e-3 for milliseconds).
    pub nominal_s_per_count: f64,
    /// Counter modulus (2³² for a u32 ms counter, ≈ 49.7 days).
    pub modulus: Option<f64>,
}

impl CounterColumn {
    /// A u32 millisecond counter in field `index` of a comma-separated file.
    pub fn ms_u32(index: usize) -> Self {
        CounterColumn {
            index,
            delimiter: b',',
            comment: Some(b'#'),
            nominal_s_per_count: 1e-3,
            modulus: Some(4_294_967_296.0),
        }
    }
}

/// Fit the counter clock of the CSV log `path` from its tag file: one pass
/// over the lines with their byte positions. Lines whose counter does not
/// parse or does not increase are left out (the reader proper reports
/// them).
///
/// Line ends: RTKLIB's positions count the bytes as received. A log saved
/// with `\r\n` and converted to `\n` later (git on Windows) has positions one
/// byte short per line. The file holds no `\r` and the tag's last position
/// equals its length plus its line count → the positions are mapped back.
/// When neither length matches exactly (one file truncated), the mapping
/// whose drift is smaller is kept: a 1-byte-per-line error in positions is a
/// rate error of 1/line length (≈ 2 %), far beyond any crystal (≤ 100 ppm).
pub fn fit_csv_counter(
    path: &Path,
    col: &CounterColumn,
    tag: &TagFile,
) -> Result<(CounterClock, ClockFit), ReadError> {
    let (mut rdr, name) = crate::open(path)?;
    let file: Arc<str> = Arc::from(name.as_str());
    // (counter, offset of the line end exclusive, line index)
    let mut lines: Vec<(f64, u64, u64)> = Vec::new();
    let mut buf = Vec::with_capacity(256);
    let (mut pos, mut nl, mut has_cr) = (0u64, 0u64, false);
    let mut unwrap = CounterUnwrap::default();
    let mut last = f64::NEG_INFINITY;
    loop {
        buf.clear();
        let fill = crate::text::fill_line(&mut rdr, &mut buf, crate::text::MAX_LINE_BYTES)
            .map_err(|e| ReadError::new(&file, nl + 1, "<line>", format!("I/O error: {e}")))?;
        match fill {
            crate::text::Fill::Eof => break,
            crate::text::Fill::TooLong => {
                return Err(ReadError::new(
                    &file,
                    nl + 1,
                    "<line>",
                    crate::text::too_long_msg(),
                ))
            }
            crate::text::Fill::Line => {}
        }
        pos += buf.len() as u64;
        let idx = nl;
        if buf.last() == Some(&b'\n') {
            nl += 1;
        } else {
            continue; // an unterminated last line: no complete receive time
        }
        has_cr |= buf.contains(&b'\r');
        let line = &buf[..buf.len() - 1];
        let first = line.iter().find(|b| !b.is_ascii_whitespace());
        if first.is_none() || first.copied() == col.comment {
            continue;
        }
        let Some(field) = line.split(|&b| b == col.delimiter).nth(col.index) else {
            continue;
        };
        let Some(c) = std::str::from_utf8(field)
            .ok()
            .and_then(|s| s.trim().parse::<f64>().ok())
        else {
            continue;
        };
        let c = unwrap.unwrap(c, col.modulus);
        if c > last && c.is_finite() {
            lines.push((c, pos, idx));
            last = c;
        }
    }
    let fit_with = |crlf: bool| -> Result<(CounterClock, ClockFit), String> {
        let pairs: Vec<(f64, f64)> = lines
            .iter()
            .filter_map(|&(c, end, i)| {
                let end = if crlf { end + i + 1 } else { end };
                tag.receive_time_at(end - 1).map(|t| (c, t))
            })
            .collect();
        let (clock, mut fit) = fit_pairs(&pairs, col.nominal_s_per_count, col.modulus)?;
        fit.crlf_stripped = crlf;
        Ok((clock, fit))
    };
    let end = tag.end_pos();
    let result = if has_cr || end == pos {
        fit_with(false)
    } else if end == pos + nl {
        fit_with(true)
    } else {
        match (fit_with(false), fit_with(true)) {
            (Ok(a), Ok(b)) => Ok(if a.0.drift_ppm().abs() <= b.0.drift_ppm().abs() {
                a
            } else {
                b
            }),
            (a, b) => a.or(b),
        }
    };
    result.map_err(|m| ReadError::new(&file, 0, "<counter clock>", m))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [0, 1) (xorshift).
    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// 100 Hz samples, counter 150 ppm slow, latency 4 ms + exponential
    /// jitter (mean 10 ms), received on a 15.625 ms tick (floored), and 0.1 %
    /// wild counters.
    fn synthetic(n: usize, seed: u64) -> (Vec<(f64, f64)>, CounterClock) {
        let truth = CounterClock {
            c_ref: 1000.0,
            t_ref: 1.4e9,
            s_per_count: 1e-3 * (1.0 + 150e-6),
            nominal_s_per_count: 1e-3,
            modulus: None,
        };
        let mut s = seed;
        let mut v = Vec::new();
        for k in 0..n {
            let c = 1000.0 + 10.0 * k as f64;
            let t = truth.gps_seconds(c) + 0.004 - 0.010 * (1.0 - rng(&mut s)).ln();
            let tick = 0.015625 * ((t - 1.4e9) / 0.015625).floor() + 1.4e9;
            let c_obs = if rng(&mut s) < 0.001 {
                c + 5000.0 * (rng(&mut s) - 0.5)
            } else {
                c
            };
            v.push((c_obs, tick));
        }
        (v, truth)
    }

    #[test]
    fn lower_envelope_recovers_drift_and_offset() {
        let (pairs, truth) = synthetic(60_000, 7);
        let (clock, fit) = fit_pairs(&pairs, 1e-3, None).unwrap();
        // Drift: the tick floor and the jitter are stationary, so the envelope's
        // slope is unbiased; 600 s span, σ of block minima ~ ms → ≲ 1 ppm.
        assert!(
            (clock.drift_ppm() - 150.0).abs() < 2.0,
            "{} ± {}",
            clock.drift_ppm(),
            fit.drift_sigma_ppm
        );
        assert!(fit.drift_sigma_ppm < 2.0, "{fit:?}");
        // Offset: minimum latency 4 ms minus up to one tick (15.6 ms) of floor.
        let d = clock.gps_seconds(1000.0) - truth.gps_seconds(1000.0);
        assert!((-0.0156..0.005).contains(&d), "{d}");
        assert!(
            fit.latency_median_s > 0.0 && fit.latency_p99_s > fit.latency_median_s,
            "{fit:?}"
        );
    }

    #[test]
    fn unwrap_handles_a_u32_wrap_and_late_lines() {
        let m = Some(4_294_967_296.0);
        let mut u = CounterUnwrap::default();
        assert_eq!(u.unwrap(4_294_967_290.0, m), 4_294_967_290.0);
        assert_eq!(u.unwrap(4.0, m), 4_294_967_300.0);
        assert_eq!(
            u.unwrap(4_294_967_295.0, m),
            4_294_967_295.0,
            "a late pre-wrap line"
        );
        assert_eq!(u.unwrap(14.0, m), 4_294_967_310.0);
        let mut u = CounterUnwrap::default();
        assert_eq!(u.unwrap(10.0, None), 10.0);
        assert_eq!(u.unwrap(5.0, None), 5.0);
    }

    #[test]
    fn too_few_pairs_or_a_constant_counter_is_an_error() {
        assert!(fit_pairs(&[(1.0, 1.0); 10], 1e-3, None).is_err());
        assert!(fit_pairs(&[(1.0, 1.0); 100], 1e-3, None).is_err());
    }
}
