//! Multi-antenna carrier-phase records (CP-ATT, seed 003; issue 17) as CSV:
//! one row per satellite per epoch, the fields of
//! [`CarrierPhaseSat`](navfuse_core::types::CarrierPhaseSat).
//!
//! ```text
//! # comment lines start with '#'
//! t_gps_s,prn,last_in_epoch,los_e,los_n,los_u,sigma_m,sd1_m,sd2_m,sd3_m
//! 1235000000,12,0,0.1034,0.2210,0.9697,0.002,0.71302,-1834.20931,93.4411
//! ```
//!
//! - `t_gps_s`: GPS seconds since 1980-01-06 (or the run's time axis), the
//!   epoch time, non-decreasing down the file;
//! - `prn`: 1…255, once per epoch; rows of an epoch in the DD order the
//!   estimator uses (decreasing elevation);
//! - `last_in_epoch`: 1 on the epoch's last row, else 0 (an epoch also
//!   ends where the time changes);
//! - `los_e, los_n, los_u`: ENU unit line of sight master → satellite
//!   (norm within 1e-3 of 1);
//! - `sigma_m`: undifferenced phase σ [m], > 0;
//! - `sdK_m`, K = 1…n (n ≤ 4 from the header): single difference
//!   `φ_master − φ_slave,K` [m] of baseline K, finite.
//!
//! The header is required and its columns are exactly these, in this order.
//! [`CpCsvWriter`] writes floats in Rust's shortest round-trip form, so a
//! written file reads back bit for bit.

use crate::error::{ReadError, RecordStats};
use crate::kfgins::next_data_line;
use crate::text::{in_range, LineSource, Sep};
use navfuse_core::types::{CarrierPhaseSat, MAX_CP_BASELINES};
use navfuse_core::Vec3;
use std::io::{BufRead, Write};

/// Every column: 7 fixed ones, then up to 4 single differences.
const ALL: [&str; 11] = [
    "t_gps_s",
    "prn",
    "last_in_epoch",
    "los_e",
    "los_n",
    "los_u",
    "sigma_m",
    "sd1_m",
    "sd2_m",
    "sd3_m",
    "sd4_m",
];
/// Number of columns before the single differences.
const N_FIXED: usize = 7;

/// The header line for `n_baselines` single-difference columns.
pub fn header(n_baselines: usize) -> String {
    let n = n_baselines.clamp(1, MAX_CP_BASELINES);
    ALL[..N_FIXED + n].join(",")
}

/// Streaming reader of carrier-phase CSV → [`CarrierPhaseSat`].
pub struct CpCsvReader<R> {
    src: LineSource<R>,
    n_baselines: Option<usize>,
    /// Time and PRNs of the current epoch (duplicate check, no allocation).
    t: f64,
    prns: [bool; 256],
    done: bool,
}

impl<R: BufRead> CpCsvReader<R> {
    pub fn new(rdr: R, file: &str) -> Self {
        CpCsvReader {
            src: LineSource::new(rdr, file),
            n_baselines: None,
            t: f64::NEG_INFINITY,
            prns: [false; 256],
            done: false,
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    /// Single-difference columns of the header (after the first record).
    pub fn n_baselines(&self) -> Option<usize> {
        self.n_baselines
    }

    fn read(&mut self) -> Result<Option<CarrierPhaseSat>, ReadError> {
        loop {
            let min = self.n_baselines.map_or(0, |n| N_FIXED + n);
            if !next_data_line(&mut self.src, min, Sep::Byte(b','), Some(b'#'))? {
                return Ok(None);
            }
            if self.n_baselines.is_some() {
                break;
            }
            let s = &self.src;
            let n = s.n_fields();
            let want_max = N_FIXED + MAX_CP_BASELINES;
            if n <= N_FIXED || n > want_max {
                return Err(s.err(
                    "<header>",
                    format!(
                        "expected `{}` with 1 to {MAX_CP_BASELINES} sdK_m columns, got {n} columns",
                        header(1)
                    ),
                ));
            }
            for (i, want) in ALL.iter().take(n).enumerate() {
                let got = s.text(i, "<header>")?;
                if got != *want {
                    return Err(s.err(
                        "<header>",
                        format!("column {}: expected `{want}`, got {got:?}", i + 1),
                    ));
                }
            }
            self.src.stats.skipped += 1;
            self.n_baselines = Some(n - N_FIXED);
        }
        let s = &self.src;
        let nb = self.n_baselines.expect("header read");
        s.expect_fields(&ALL[..N_FIXED + nb], false)?;
        let t = s.f64(0, "t_gps_s")?;
        if t < self.t {
            return Err(s.err("t_gps_s", format!("time goes back: {t} after {}", self.t)));
        }
        let prn = s.f64(1, "prn")?;
        if prn.fract() != 0.0 || !(1.0..=255.0).contains(&prn) {
            return Err(s.err("prn", format!("not a PRN 1…255: {prn}")));
        }
        let prn = prn as u8;
        let last = match s.text(2, "last_in_epoch")? {
            "0" => false,
            "1" => true,
            v => return Err(s.err("last_in_epoch", format!("expected 0 or 1, got {v:?}"))),
        };
        let los = Vec3::new(s.f64(3, "los_e")?, s.f64(4, "los_n")?, s.f64(5, "los_u")?);
        if (los.norm() - 1.0).abs() > 1e-3 {
            return Err(s.err(
                "los_e",
                format!("line of sight is not a unit vector (norm {})", los.norm()),
            ));
        }
        let sigma = s.f64(6, "sigma_m")?;
        in_range(sigma, 1e-9, 10.0, "phase sigma [m]").map_err(|m| s.err("sigma_m", m))?;
        let mut sd = [0.0; MAX_CP_BASELINES];
        for (k, v) in sd[..nb].iter_mut().enumerate() {
            *v = s.f64(N_FIXED + k, ALL[N_FIXED + k])?;
        }
        if t != self.t {
            self.t = t;
            self.prns = [false; 256];
        }
        if std::mem::replace(&mut self.prns[prn as usize], true) {
            return Err(s.err("prn", format!("PRN {prn} twice in the epoch at {t}")));
        }
        if last {
            // The next row starts a new epoch, even at the same time stamp.
            self.prns = [false; 256];
        }
        Ok(Some(CarrierPhaseSat {
            t,
            prn,
            n_baselines: nb as u8,
            last_in_epoch: last,
            los_enu: los,
            sigma_m: sigma,
            sd_phase_m: sd,
        }))
    }
}

impl<R: BufRead> Iterator for CpCsvReader<R> {
    type Item = Result<CarrierPhaseSat, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

/// Writer of carrier-phase CSV (the module's format).
pub struct CpCsvWriter<W: Write> {
    w: W,
    n_baselines: usize,
}

impl<W: Write> CpCsvWriter<W> {
    /// Writes the header for `n_baselines` (1…4) single-difference columns.
    pub fn new(mut w: W, n_baselines: usize) -> std::io::Result<Self> {
        writeln!(w, "{}", header(n_baselines))?;
        Ok(CpCsvWriter {
            w,
            n_baselines: n_baselines.clamp(1, MAX_CP_BASELINES),
        })
    }

    /// One row; the record's first `n_baselines` single differences.
    pub fn write(&mut self, r: &CarrierPhaseSat) -> std::io::Result<()> {
        write!(
            self.w,
            "{},{},{},{},{},{},{}",
            r.t, r.prn, r.last_in_epoch as u8, r.los_enu.x, r.los_enu.y, r.los_enu.z, r.sigma_m
        )?;
        for v in &r.sd_phase_m[..self.n_baselines] {
            write!(self.w, ",{v}")?;
        }
        writeln!(self.w)
    }

    pub fn into_inner(self) -> W {
        self.w
    }
}

#[cfg(test)]
#[path = "carrier_phase_tests.rs"]
mod tests;
