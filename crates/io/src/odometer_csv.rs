//! Wheel-speed / odometer CSV by column map (issue 17) →
//! [`OdometerSample`]s of the vehicle reference point (wheel 0).
//!
//! ```text
//! t,v_rl,v_rr,gear_r
//! 1235000000.00,8.31,8.35,0
//! ```
//!
//! The column map ([`OdoCsvConfig`]) names the time column and one value
//! column, or the wheels of one axle. What a value is ([`OdoQuantity`]):
//!
//! - `Speed`: the wheel / vehicle speed at the row's time (instantaneous,
//!   `dt = 0`);
//! - `Distance`: a cumulative distance (odometer reading, or a tick count
//!   with `unit` = metres per tick); the speed is `Δs / Δt` over the
//!   interval from the previous row, `dt = Δt`;
//! - `Increment`: the distance travelled since the previous row; the speed
//!   is `Δs / Δt` likewise.
//!
//! Several wheel columns are averaged: for two wheels on one axle of a rigid
//! body the mean of their forward speeds is the axle centre's speed exactly
//! (`v_c = (v_l + v_r)/2`, the yaw-rate terms `±ω·b/2` cancel), so the
//! sample is the axle centre's, whose lever arm goes in `[filter.odometer]`.
//!
//! Sign: values are signed (negative when reversing), unless a `reverse`
//! column is named: then values are magnitudes and a non-zero `reverse`
//! makes the speed negative. `unit` scales a value to m/s or m (1/3.6 for
//! km/h, metres per tick for ticks).
//!
//! Every line is accounted for (used, skipped, rejected by reason): a row
//! whose time does not increase is rejected ([`REASON_TIME`]); for distances
//! and increments an interval longer than [`MAX_INTERVAL_S`] is rejected
//! ([`REASON_GAP`]) and its row starts a new interval, as does the first
//! row (used, no sample). A malformed field is an error naming
//! `file:line:field`.

use crate::csv_imu::Col;
use crate::error::{ReadError, RecordStats};
use crate::kfgins::next_data_line;
use crate::text::{LineSource, Sep};
use navfuse_core::types::OdometerSample;
use std::io::BufRead;

/// Rejection reason: a row whose time does not increase.
pub const REASON_TIME: &str = "odometer: time duplicate or going backwards";
/// Rejection reason: an interval longer than [`MAX_INTERVAL_S`].
pub const REASON_GAP: &str = "odometer: interval over 1 s (a gap: starts a new interval)";
/// Longest interval a distance difference is turned into a mean speed over
/// [s]. The ESKF's odometer model takes the mean over `dt` at first order in
/// the forward acceleration (constant over `dt`); a car's acceleration
/// changes within a second (gear change, braking onset), and CAN odometer
/// messages come at 10–100 Hz, so a longer interval is a gap in the log.
pub const MAX_INTERVAL_S: f64 = 1.0;
/// Largest plausible |speed| [m/s] (540 km/h): beyond any road vehicle; a
/// larger value is a unit or column mistake, reported as an error.
pub const MAX_SPEED_MPS: f64 = 150.0;
/// At most this many wheel columns (the four wheels of a car).
pub const MAX_WHEELS: usize = 4;

/// What the value columns hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OdoQuantity {
    /// Speed [unit → m/s] at the row's time.
    Speed,
    /// Cumulative distance [unit → m].
    Distance,
    /// Distance since the previous row [unit → m].
    Increment,
}

/// The column map of an odometer CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct OdoCsvConfig {
    /// Time column [s], on the IMU file's time axis.
    pub time: Col,
    pub quantity: OdoQuantity,
    /// One column (vehicle) or 2–4 wheel columns of one axle (their mean).
    pub values: Vec<Col>,
    /// Optional direction column: non-zero = reversing (values are then magnitudes).
    pub reverse: Option<Col>,
    /// Factor from a value to m/s (speed) or m (distance).
    pub unit: f64,
    pub header: bool,
    pub delimiter: u8,
    pub comment: Option<u8>,
}

impl OdoCsvConfig {
    /// Speed in m/s in column `value`, time in column `time`, header line, commas.
    pub fn speed(time: Col, value: Col) -> Self {
        OdoCsvConfig {
            time,
            quantity: OdoQuantity::Speed,
            values: vec![value],
            reverse: None,
            unit: 1.0,
            header: true,
            delimiter: b',',
            comment: Some(b'#'),
        }
    }

    /// Why the map cannot be used, if it cannot.
    pub fn check(&self) -> Result<(), String> {
        if self.values.is_empty() || self.values.len() > MAX_WHEELS {
            return Err(format!(
                "1 to {MAX_WHEELS} value columns expected, got {}",
                self.values.len()
            ));
        }
        if !(self.unit.is_finite() && self.unit > 0.0) {
            return Err(format!("unit {}: must be finite and > 0", self.unit));
        }
        Ok(())
    }
}

/// Resolved column indices and names: time, values…, reverse.
struct Resolved {
    idx: Vec<usize>,
    names: Vec<String>,
}

/// Streaming reader of an odometer CSV (see the module doc).
pub struct OdoCsvReader<R> {
    src: LineSource<R>,
    cfg: OdoCsvConfig,
    res: Option<Resolved>,
    /// Time [s] and cumulative distance [m] of the previous row.
    prev: Option<(f64, f64)>,
    done: bool,
}

impl<R: BufRead> OdoCsvReader<R> {
    pub fn new(rdr: R, file: &str, cfg: OdoCsvConfig) -> Self {
        OdoCsvReader {
            src: LineSource::new(rdr, file),
            cfg,
            res: None,
            prev: None,
            done: false,
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    fn resolve(&self) -> Result<Resolved, ReadError> {
        let s = &self.src;
        let c = &self.cfg;
        c.check().map_err(|m| s.err("<config>", m))?;
        let mut cols: Vec<(&Col, String)> = vec![(&c.time, "time".into())];
        for (k, v) in c.values.iter().enumerate() {
            cols.push((v, format!("value{}", k + 1)));
        }
        if let Some(r) = &c.reverse {
            cols.push((r, "reverse".into()));
        }
        let (mut idx, mut names) = (Vec::new(), Vec::new());
        for (col, default) in cols {
            match col {
                Col::Index(i) => {
                    idx.push(*i);
                    let n = if c.header {
                        s.text_named(*i, &default).unwrap_or(&default).to_string()
                    } else {
                        default
                    };
                    names.push(n);
                }
                Col::Name(n) => {
                    if !c.header {
                        return Err(s.err(
                            n.clone(),
                            "column given by name but the configuration has no header line",
                        ));
                    }
                    let mut found = None;
                    for i in 0..s.n_fields() {
                        if s.text_named(i, "<header>")? == n {
                            found = Some(i);
                            break;
                        }
                    }
                    idx.push(
                        found.ok_or_else(|| s.err(n.clone(), "column not found in the header"))?,
                    );
                    names.push(n.clone());
                }
            }
        }
        Ok(Resolved { idx, names })
    }

    fn read(&mut self) -> Result<Option<OdometerSample>, ReadError> {
        let sep = Sep::Byte(self.cfg.delimiter);
        loop {
            let min = self
                .res
                .as_ref()
                .map_or(0, |r| r.idx.iter().max().map_or(0, |m| m + 1));
            if !next_data_line(&mut self.src, min, sep, self.cfg.comment)? {
                return Ok(None);
            }
            if self.res.is_none() {
                self.res = Some(self.resolve()?);
                if self.cfg.header {
                    self.src.stats.skipped += 1;
                    continue;
                }
            }
            let r = self.res.as_ref().expect("resolved");
            let s = &self.src;
            let t = s.f64_named(r.idx[0], &r.names[0])?;
            let nv = self.cfg.values.len();
            let mut sum = 0.0;
            for k in 1..=nv {
                sum += s.f64_named(r.idx[k], &r.names[k])?;
            }
            let value = sum / nv as f64 * self.cfg.unit;
            let reverse = match self.cfg.reverse {
                Some(_) => Some(s.f64_named(r.idx[nv + 1], &r.names[nv + 1])? != 0.0),
                None => None,
            };
            let signed = |v: f64| match reverse {
                Some(true) => -v.abs(),
                Some(false) => v.abs(),
                None => v,
            };
            let speed_err = |v: f64| {
                s.err(
                    r.names[1].clone(),
                    format!("speed {v} m/s beyond ±{MAX_SPEED_MPS} m/s (unit or column?)"),
                )
            };
            if let Some((t0, _)) = self.prev {
                if t <= t0 {
                    self.src.stats.reject(REASON_TIME);
                    continue;
                }
            }
            let (speed, dt) = match self.cfg.quantity {
                OdoQuantity::Speed => {
                    self.prev = Some((t, 0.0));
                    (signed(value), 0.0)
                }
                OdoQuantity::Distance | OdoQuantity::Increment => {
                    let prev = self.prev;
                    // Cumulative distance of this row (increments summed).
                    let d = match (self.cfg.quantity, prev) {
                        (OdoQuantity::Increment, Some((_, d0))) => d0 + signed(value),
                        (OdoQuantity::Increment, None) => 0.0,
                        _ => value,
                    };
                    self.prev = Some((t, d));
                    let Some((t0, d0)) = prev else {
                        // The first row only starts the interval.
                        self.src.stats.used += 1;
                        continue;
                    };
                    let dt = t - t0;
                    if dt > MAX_INTERVAL_S {
                        self.src.stats.reject(REASON_GAP);
                        continue;
                    }
                    let ds = match (self.cfg.quantity, reverse) {
                        (OdoQuantity::Distance, Some(_)) => signed(d - d0),
                        _ => d - d0,
                    };
                    (ds / dt, dt)
                }
            };
            if !speed.is_finite() || speed.abs() > MAX_SPEED_MPS {
                return Err(speed_err(speed));
            }
            return Ok(Some(OdometerSample {
                t,
                dt,
                speed_mps: speed,
                std_mps: 0.0,
                wheel: 0,
            }));
        }
    }
}

impl<R: BufRead> Iterator for OdoCsvReader<R> {
    type Item = Result<OdometerSample, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

#[cfg(test)]
#[path = "odometer_csv_tests.rs"]
mod tests;
