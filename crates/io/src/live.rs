//! Pieces of live mode (`navfuse live`) that do not depend on threads or
//! sockets, so they can be tested and fuzzed: the gpsd JSON client protocol
//! ([`GpsdAssembler`]), a lenient IMU line parser ([`ImuLineParser`]), the
//! time-ordering of two asynchronous streams ([`Sequencer`]), the counters
//! of [`crate::live_stats`] and a reader that follows a file being
//! written ([`FollowReader`]).
//!
//! **Ordering contract.** The estimator must see exactly the event sequence a
//! batch run over the same data sees (`navfuse kf-gins`, KF-GINS's
//! `gi_engine`): events in time order, a GNSS fix handed over before the IMU
//! sample whose interval contains it, with [`GNSS_LEAD`] of tolerance — fix
//! `g` goes before IMU sample `s` iff `g.t ≤ s.t + GNSS_LEAD`. The live streams arrive
//! asynchronously, so the [`Sequencer`] holds an event until the other
//! stream has shown that nothing earlier can still come (its latest received
//! time has reached the event's time, or it has ended), or until the event
//! has waited `max_wait` seconds of wall-clock time — then it is released
//! anyway and counted, since live output cannot wait forever. Nothing is
//! dropped silently: an event older than one already released is counted
//! as `late`, with its stream.

use crate::error::RecordStats;
use crate::imu::{Assembler, ImuForm, RawImu};
pub use crate::live_stats::{GapCounter, LatencyHistogram};
use crate::text::parse_finite;
use crate::time::{gps_from_calendar, gps_seconds, parse_date_time, TimeSystem};
use navfuse_core::types::{Event, GnssFix, ImuSample, Vec3};
use std::collections::VecDeque;
use std::io::{self, Read};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------- gpsd JSON

pub const REASON_JSON: &str = "not a JSON object";
pub const REASON_TPV_FIELD: &str = "TPV without a usable field";
pub const REASON_TPV_NOFIX: &str = "TPV without a 2-D/3-D fix";
pub const REASON_GPSD_TIME: &str = "time not increasing";

/// What one gpsd line became.
#[derive(Clone, Debug, PartialEq)]
pub enum GpsdLine {
    /// A class this client does not use (VERSION, DEVICES, WATCH, SKY, …).
    Ignored,
    /// A report held until its epoch is complete (TPV waiting for GST, …).
    Held,
    /// A line that is not usable: reason (counted) and message.
    Rejected(&'static str, String),
}

/// gpsd time `2025-07-08T19:34:18.250Z` (UTC) → GPS seconds.
pub fn gps_from_iso8601(s: &str) -> Option<f64> {
    let s = s.strip_suffix('Z')?;
    let (d, t) = s.split_once('T')?;
    let c = parse_date_time(d, t).ok()?;
    gps_from_calendar(&c, TimeSystem::Utc).ok()
}

#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    t: f64,
    fix: Option<GnssFix>,
    /// σ N, E, D from GST.
    gst: Option<Vec3>,
}

/// Turns the gpsd JSON stream (`?WATCH={"enable":true,"json":true}`) into
/// [`GnssFix`]es: one per epoch, from the TPV report (lat, lon, `altHAE`
/// (else `alt`), fix status) and the GST report of the same time (σ: `lat`
/// → north, `lon` → east, `alt` → down).
///
/// An epoch is complete when both TPV (with a 2-D/3-D fix) and GST of its
/// time are in; it is also closed, without GST, when a report of a later
/// time arrives (σ then from TPV's 95 % figures `epy`, `epx`, `epv` halved,
/// else 10 m). Repeated TPVs of one time are merged (gpsd may report an epoch
/// more than once). Quality: gpsd `status` 3 (RTK fixed) → RTKLIB Q 1,
/// 4 (RTK float) → 2, 2 (DGPS) → 4, otherwise 5; `num_sats` is 0 (TPV does
/// not carry it). Velocity is not taken (NMEA sources have no vertical
/// velocity; see [`crate::nmea`]).
#[derive(Debug, Default)]
pub struct GpsdAssembler {
    pending: Option<Pending>,
    emitted_t: f64,
    out: VecDeque<GnssFix>,
    have_emitted: bool,
}

fn num_field(v: &serde_json::Value, k: &str) -> Option<f64> {
    v.get(k).and_then(|x| x.as_f64()).filter(|x| x.is_finite())
}

impl GpsdAssembler {
    pub fn new() -> Self {
        Self::default()
    }

    /// Fixes ready to be used, in time order.
    pub fn pop(&mut self) -> Option<GnssFix> {
        self.out.pop_front()
    }

    /// Latest GNSS time seen (a fix of an earlier time cannot come any more).
    pub fn horizon(&self) -> f64 {
        match self.pending {
            Some(p) => p.t,
            None if self.have_emitted => self.emitted_t,
            None => f64::NEG_INFINITY,
        }
    }

    fn close(&mut self) {
        if let Some(p) = self.pending.take() {
            if let Some(mut f) = p.fix {
                f.std_ned = p.gst.unwrap_or(f.std_ned);
                self.emitted_t = f.t;
                self.have_emitted = true;
                self.out.push_back(f);
            }
        }
    }

    /// Flush a held epoch (at end of stream or a reconnect).
    pub fn flush(&mut self) {
        self.close();
    }

    fn complete(&mut self) {
        if self
            .pending
            .is_some_and(|p| p.fix.is_some() && p.gst.is_some())
        {
            self.close();
        }
    }

    /// Start (or continue) the epoch of time `t`; false if `t` is in the past.
    fn epoch(&mut self, t: f64) -> bool {
        if self.have_emitted && t <= self.emitted_t {
            return false;
        }
        match self.pending {
            Some(p) if (p.t - t).abs() < 5e-4 => {}
            Some(p) if t < p.t => return false,
            _ => {
                self.close();
                self.pending = Some(Pending {
                    t,
                    ..Default::default()
                });
            }
        }
        true
    }

    /// Feed one line of the gpsd stream. Fixes appear through [`Self::pop`].
    pub fn push_line(&mut self, line: &[u8]) -> GpsdLine {
        let Ok(v) = serde_json::from_slice::<serde_json::Value>(line) else {
            return GpsdLine::Rejected(REASON_JSON, "not valid JSON".into());
        };
        let Some(class) = v.get("class").and_then(|c| c.as_str()) else {
            return GpsdLine::Rejected(REASON_JSON, "no \"class\"".into());
        };
        let time = || {
            v.get("time")
                .and_then(|t| t.as_str())
                .and_then(gps_from_iso8601)
        };
        match class {
            "TPV" => {
                let mode = v.get("mode").and_then(|m| m.as_u64()).unwrap_or(0);
                if mode < 2 {
                    return GpsdLine::Rejected(REASON_TPV_NOFIX, format!("mode {mode}"));
                }
                let Some(t) = time() else {
                    return GpsdLine::Rejected(
                        REASON_TPV_FIELD,
                        "`time` missing or invalid".into(),
                    );
                };
                let (Some(lat), Some(lon)) = (num_field(&v, "lat"), num_field(&v, "lon")) else {
                    return GpsdLine::Rejected(REASON_TPV_FIELD, "`lat`/`lon` missing".into());
                };
                let Some(h) = num_field(&v, "altHAE").or_else(|| num_field(&v, "alt")) else {
                    return GpsdLine::Rejected(REASON_TPV_FIELD, "`altHAE`/`alt` missing".into());
                };
                if lat.abs() > 90.0 || lon.abs() > 180.0 {
                    return GpsdLine::Rejected(REASON_TPV_FIELD, "lat/lon out of range".into());
                }
                if !self.epoch(t) {
                    return GpsdLine::Rejected(REASON_GPSD_TIME, format!("TPV at {t}"));
                }
                let ep = |k: &str| num_field(&v, k).map_or(10.0, |e| e / 2.0);
                let quality = match v.get("status").and_then(|s| s.as_u64()) {
                    Some(3) => 1,
                    Some(4) => 2,
                    Some(2) => 4,
                    _ => 5,
                };
                if let Some(p) = self.pending.as_mut() {
                    p.fix = Some(GnssFix {
                        t: p.t,
                        lat: lat.to_radians(),
                        lon: lon.to_radians(),
                        h,
                        std_ned: Vec3::new(ep("epy"), ep("epx"), ep("epv")),
                        v_n: None,
                        std_v_n: None,
                        quality,
                        num_sats: 0,
                    });
                }
                self.complete();
                GpsdLine::Held
            }
            "GST" => {
                let Some(t) = time() else {
                    return GpsdLine::Rejected(REASON_TPV_FIELD, "GST `time` missing".into());
                };
                let sd = |k| num_field(&v, k).filter(|x| *x >= 0.0);
                let (Some(n), Some(e), Some(d)) = (sd("lat"), sd("lon"), sd("alt")) else {
                    return GpsdLine::Rejected(REASON_TPV_FIELD, "GST σ missing".into());
                };
                if !self.epoch(t) {
                    return GpsdLine::Rejected(REASON_GPSD_TIME, format!("GST at {t}"));
                }
                if let Some(p) = self.pending.as_mut() {
                    p.gst = Some(Vec3::new(n, e, d));
                }
                self.complete();
                GpsdLine::Held
            }
            _ => GpsdLine::Ignored,
        }
    }
}

// ---------------------------------------------------------------- IMU lines

pub const REASON_IMU_FIELDS: &str = "IMU line: wrong number of fields";
pub const REASON_IMU_NUMBER: &str = "IMU line: not a finite number";
pub const REASON_IMU_TOW: &str = "IMU line: time of week out of range";

/// Parses KF-GINS IMU text lines (`tow Δθx Δθy Δθz Δvx Δvy Δvz`, body FRD,
/// rad and m/s; whitespace or commas) one at a time, never failing: a bad
/// line is a counted rejection naming the field. Intervals as in
/// [`crate::imu`] (same `dt` rule as the batch reader, so batch and live
/// produce identical samples).
pub struct ImuLineParser {
    week: u32,
    asm: Assembler,
    pub stats: RecordStats,
}

const IMU_NAMES: [&str; 7] = [
    "tow", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z",
];

impl ImuLineParser {
    pub fn new(week: u32, nominal_rate_hz: Option<f64>) -> Self {
        ImuLineParser {
            week,
            asm: Assembler::new(ImuForm::Increment, nominal_rate_hz),
            stats: RecordStats::default(),
        }
    }

    /// Parse one line; samples are appended to `out` (0, 1 or 2 of them).
    /// On a rejection returns `Err((reason, message))` (already counted).
    pub fn push_line(
        &mut self,
        line: &[u8],
        out: &mut Vec<ImuSample>,
    ) -> Result<(), (&'static str, String)> {
        self.stats.lines += 1;
        let line = line.trim_ascii();
        if line.is_empty() || line[0] == b'#' || line[0] == b'%' {
            self.stats.skipped += 1;
            return Ok(());
        }
        let r = self.parse(line);
        let raw = match r {
            Ok(raw) => raw,
            Err((reason, msg)) => {
                self.stats.reject(reason);
                return Err((reason, msg));
            }
        };
        match self.asm.push(raw) {
            Err(reason) => {
                self.stats.reject(reason);
                Err((reason, format!("record at tow {}", raw.tow)))
            }
            Ok(None) => Ok(()),
            Ok(Some(s)) => {
                out.push(s);
                self.stats.used += 1;
                if let Some(q) = self.asm.take_queued() {
                    out.push(q);
                    self.stats.used += 1;
                }
                Ok(())
            }
        }
    }

    /// At end of input: a record still held back is counted as rejected.
    pub fn finish(&mut self) {
        if let Some(reason) = self.asm.finish() {
            self.stats.reject(reason);
        }
    }

    fn parse(&self, line: &[u8]) -> Result<RawImu, (&'static str, String)> {
        let s = std::str::from_utf8(line)
            .map_err(|_| (REASON_IMU_NUMBER, "not valid UTF-8".to_string()))?;
        let mut v = [0.0f64; 7];
        let mut n = 0;
        for tok in s
            .split(|c: char| c == ',' || c.is_ascii_whitespace())
            .filter(|t| !t.is_empty())
        {
            if n == 7 {
                return Err((REASON_IMU_FIELDS, "more than 7 fields".into()));
            }
            v[n] = parse_finite(tok)
                .map_err(|m| (REASON_IMU_NUMBER, format!("field `{}`: {m}", IMU_NAMES[n])))?;
            n += 1;
        }
        if n < 7 {
            return Err((
                REASON_IMU_FIELDS,
                format!("field `{}`: missing ({n} fields)", IMU_NAMES[n]),
            ));
        }
        if !(0.0..1.0e6).contains(&v[0]) {
            return Err((
                REASON_IMU_TOW,
                format!("field `tow`: {} outside [0, 1e6)", v[0]),
            ));
        }
        Ok(RawImu {
            t: gps_seconds(self.week, v[0]),
            week: self.week,
            tow: v[0],
            gyro: Vec3::new(v[1], v[2], v[3]),
            acc: Vec3::new(v[4], v[5], v[6]),
        })
    }
}

// ---------------------------------------------------------------- sequencer

/// A fix goes before an IMU sample stamped up to this much [s] earlier
/// (the batch order of `navfuse kf-gins`, which hands a fix over before the
/// IMU sample whose interval contains it, with 1 ms of tolerance).
pub const GNSS_LEAD: f64 = 1e-3;

/// Counters of the [`Sequencer`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SequencerStats {
    pub imu_in: u64,
    pub gnss_in: u64,
    pub imu_out: u64,
    pub gnss_out: u64,
    /// Released before the other stream reached their time (waited `max_wait`).
    pub imu_released_by_timeout: u64,
    pub gnss_released_by_timeout: u64,
    /// Released because the queue reached its bound.
    pub released_by_bound: u64,
    /// Arrived older than an event already released: not given to the estimator.
    pub imu_late: u64,
    pub gnss_late: u64,
    /// Aiding events (odometer, heading, …: [`Sequencer::push_aid`]) queued,
    /// released, and not given to the estimator: older than an IMU sample
    /// already released (`aid_late`), or dropped at the queue bound.
    pub aid_in: u64,
    pub aid_out: u64,
    pub aid_late: u64,
    pub aid_dropped_bound: u64,
}

/// The two input streams of the [`Sequencer`].
#[derive(Clone, Copy)]
enum Stream {
    Imu,
    Gnss,
}

/// Merges the IMU and GNSS streams into one time-ordered event stream (see
/// the module doc). `now` is wall-clock seconds from any fixed origin.
pub struct Sequencer {
    imu: VecDeque<(ImuSample, f64)>,
    gnss: VecDeque<(GnssFix, f64)>,
    /// Aiding events in time order (released in front of the IMU sample
    /// whose interval contains them).
    aid: VecDeque<(Event, f64)>,
    imu_horizon: f64,
    gnss_horizon: f64,
    gnss_last: f64,
    imu_ended: bool,
    gnss_ended: bool,
    last_imu_out: f64,
    last_gnss_out: f64,
    max_wait: f64,
    bound: usize,
    pub stats: SequencerStats,
}

impl Sequencer {
    /// `max_wait` [s] of wall-clock an event may wait for the other stream;
    /// `bound` events per queue at most.
    pub fn new(max_wait: f64, bound: usize) -> Self {
        Sequencer {
            imu: VecDeque::new(),
            gnss: VecDeque::new(),
            aid: VecDeque::new(),
            imu_horizon: f64::NEG_INFINITY,
            gnss_horizon: f64::NEG_INFINITY,
            gnss_last: f64::NEG_INFINITY,
            imu_ended: false,
            gnss_ended: false,
            last_imu_out: f64::NEG_INFINITY,
            last_gnss_out: f64::NEG_INFINITY,
            max_wait,
            bound: bound.max(1),
            stats: SequencerStats::default(),
        }
    }

    /// A new IMU sample (arrival at `now`). Returns false when it is late
    /// (counted, not queued).
    pub fn push_imu(&mut self, s: ImuSample, now: f64) -> bool {
        self.stats.imu_in += 1;
        // Late: a released fix should have come after it.
        if s.t + GNSS_LEAD < self.last_gnss_out || s.t < self.imu_horizon {
            self.stats.imu_late += 1;
            return false;
        }
        self.imu_horizon = s.t;
        self.imu.push_back((s, now));
        true
    }

    /// A new GNSS fix. Returns false when it is late (counted, not queued).
    pub fn push_gnss(&mut self, f: GnssFix, now: f64) -> bool {
        self.stats.gnss_in += 1;
        // Late: it should have gone before an IMU sample already released.
        if f.t <= self.last_imu_out + GNSS_LEAD || f.t <= self.gnss_last {
            self.stats.gnss_late += 1;
            return false;
        }
        self.gnss_last = f.t;
        self.gnss_horizon = self.gnss_horizon.max(f.t);
        self.gnss.push_back((f, now));
        true
    }

    /// A new aiding event (odometer, heading, magnetometer; not IMU or
    /// GNSS). It goes to the estimator just before the first IMU sample
    /// stamped at or after it, as `navfuse run` hands it over (the batch
    /// order: aiding events in `(t_{k−1}, t_k]` before sample `k`); one older
    /// than an IMU sample already released is late (counted, not queued).
    /// Queued in time order; at `bound` queued the oldest is dropped
    /// (counted): only a source sending aiding without IMU fills the queue.
    pub fn push_aid(&mut self, e: Event, now: f64) -> bool {
        self.stats.aid_in += 1;
        let t = e.t();
        if !t.is_finite() || t <= self.last_imu_out {
            self.stats.aid_late += 1;
            return false;
        }
        if self.aid.len() >= self.bound {
            self.aid.pop_front();
            self.stats.aid_dropped_bound += 1;
        }
        // Sources interleave (ESF wheel ticks, RELPOSNED): stable insertion.
        let at = self.aid.partition_point(|(a, _)| a.t() <= t);
        self.aid.insert(at, (e, now));
        true
    }

    /// Aiding events queued.
    pub fn queued_aid(&self) -> usize {
        self.aid.len()
    }

    /// Raise the GNSS horizon without a fix: the source has shown that no
    /// fix *before* `t` can still come (a fix at `t` itself still may).
    pub fn gnss_time_seen(&mut self, t: f64) {
        if t > self.gnss_horizon {
            self.gnss_horizon = t;
        }
    }

    pub fn end_imu(&mut self) {
        self.imu_ended = true;
    }
    pub fn end_gnss(&mut self) {
        self.gnss_ended = true;
    }
    pub fn imu_ended(&self) -> bool {
        self.imu_ended
    }
    pub fn is_empty(&self) -> bool {
        self.imu.is_empty() && self.gnss.is_empty()
    }
    /// Queued IMU samples and GNSS fixes.
    pub fn queued(&self) -> (usize, usize) {
        (self.imu.len(), self.gnss.len())
    }

    /// Whether the head of `stream` may go out: when ordering is safe (`ok`),
    /// or forced after waiting `max_wait` or with `bound` events queued; a
    /// forced release is counted by its cause.
    fn may_release(&mut self, ok: bool, waited: f64, queued: usize, stream: Stream) -> bool {
        let timeout = waited >= self.max_wait;
        let bound = queued >= self.bound;
        if ok {
            return true;
        }
        if bound && !timeout {
            self.stats.released_by_bound += 1;
        } else if timeout {
            match stream {
                Stream::Imu => self.stats.imu_released_by_timeout += 1,
                Stream::Gnss => self.stats.gnss_released_by_timeout += 1,
            }
        }
        timeout || bound
    }

    /// The next event that may be released now, with its arrival time.
    pub fn pop(&mut self, now: f64) -> Option<(Event, f64)> {
        let imu_first = match (self.imu.front(), self.gnss.front()) {
            (None, None) => return None,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (Some((i, _)), Some((g, _))) => i.t + GNSS_LEAD < g.t,
        };
        if imu_first {
            let (s, arr) = *self.imu.front().expect("checked");
            // Aiding events inside the interval ending at the next sample go
            // first: no IMU sample before them can still come.
            if self.aid.front().is_some_and(|(a, _)| a.t() <= s.t) {
                let (a, arr) = self.aid.pop_front().expect("checked");
                self.stats.aid_out += 1;
                return Some((a, arr));
            }
            // No fix with g.t ≤ s.t + lead may still come.
            let ok = self.gnss_ended
                || !self.gnss.is_empty()
                || self.gnss_last >= s.t + GNSS_LEAD
                || self.gnss_horizon > s.t + GNSS_LEAD;
            let queued = self.imu.len();
            if !self.may_release(ok, now - arr, queued, Stream::Imu) {
                return None;
            }
            self.imu.pop_front();
            self.stats.imu_out += 1;
            self.last_imu_out = s.t;
            Some((Event::Imu(s), arr))
        } else {
            let (f, arr) = *self.gnss.front().expect("checked");
            // No IMU sample with s.t + lead < f.t may still come.
            let ok = self.imu_ended || !self.imu.is_empty() || self.imu_horizon + GNSS_LEAD >= f.t;
            let queued = self.gnss.len();
            if !self.may_release(ok, now - arr, queued, Stream::Gnss) {
                return None;
            }
            self.gnss.pop_front();
            self.stats.gnss_out += 1;
            self.last_gnss_out = f.t;
            Some((Event::Gnss(f), arr))
        }
    }
}

// ---------------------------------------------------------------- follow

/// Reads a file that another process is still writing: at end of file it
/// waits and retries, and reports end of input only after `idle` without
/// new bytes.
pub struct FollowReader<R> {
    inner: R,
    idle: Duration,
    poll: Duration,
}

impl<R: Read> FollowReader<R> {
    pub fn new(inner: R, idle: Duration) -> Self {
        FollowReader {
            inner,
            idle,
            poll: Duration::from_millis(20),
        }
    }
}

impl<R: Read> Read for FollowReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let start = Instant::now();
        loop {
            let n = self.inner.read(buf)?;
            if n > 0 || buf.is_empty() {
                return Ok(n);
            }
            if start.elapsed() >= self.idle {
                return Ok(0);
            }
            std::thread::sleep(self.poll);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn imu(t: f64) -> ImuSample {
        ImuSample {
            t,
            dt: 0.01,
            ..Default::default()
        }
    }
    fn fix(t: f64) -> GnssFix {
        GnssFix {
            t,
            ..Default::default()
        }
    }

    fn drain(q: &mut Sequencer, now: f64) -> Vec<(char, f64)> {
        let mut v = Vec::new();
        while let Some((e, _)) = q.pop(now) {
            v.push(match e {
                Event::Imu(s) => ('i', s.t),
                Event::Gnss(g) => ('g', g.t),
                other => ('o', other.t()),
            });
        }
        v
    }

    #[test]
    fn sequencer_orders_like_a_batch_merge_whatever_the_arrival_order() {
        // Batch order (as `navfuse kf-gins`): a fix before the first IMU
        // sample with s.t + lead ≥ g.t.
        let imus: Vec<f64> = (1..=20).map(|k| k as f64 * 0.1).collect();
        let fixes = [0.5, 1.0, 1.25, 1.4995, 2.0];
        let mut want: Vec<(char, f64)> = Vec::new();
        let mut g = 0;
        for &t in &imus {
            while g < fixes.len() && fixes[g] <= t + GNSS_LEAD {
                want.push(('g', fixes[g]));
                g += 1;
            }
            want.push(('i', t));
        }
        want.extend(fixes[g..].iter().map(|&t| ('g', t)));
        // Several arrival interleavings: GNSS early, GNSS late, alternating.
        for lag in [0usize, 3, 7, 20] {
            let mut q = Sequencer::new(1e9, 1 << 20);
            let mut got = Vec::new();
            let mut gi = 0;
            for (k, &t) in imus.iter().enumerate() {
                q.push_imu(imu(t), 0.0);
                if k >= lag {
                    while gi < fixes.len() && fixes[gi] <= imus[k - lag] + 1e-9 {
                        q.push_gnss(fix(fixes[gi]), 0.0);
                        gi += 1;
                    }
                }
                got.extend(drain(&mut q, 0.0));
            }
            q.end_imu();
            got.extend(drain(&mut q, 0.0));
            while gi < fixes.len() {
                q.push_gnss(fix(fixes[gi]), 0.0);
                gi += 1;
            }
            q.end_gnss();
            got.extend(drain(&mut q, 0.0));
            assert_eq!(got, want, "lag {lag}");
            assert_eq!(q.stats.imu_released_by_timeout, 0);
        }
    }

    #[test]
    fn sequencer_times_out_and_counts_late_events() {
        let mut q = Sequencer::new(0.5, 100);
        q.push_imu(imu(1.0), 0.0);
        assert!(q.pop(0.1).is_none(), "waits for GNSS");
        assert!(q.pop(0.6).is_some(), "released after max_wait");
        assert_eq!(q.stats.imu_released_by_timeout, 1);
        assert!(!q.push_gnss(fix(0.9), 0.7), "older than released");
        assert!(
            !q.push_gnss(fix(1.0005), 0.7),
            "belonged before the released sample"
        );
        assert_eq!(q.stats.gnss_late, 2);
        assert!(
            q.push_gnss(fix(1.002), 0.7),
            "after the released sample's lead"
        );
    }

    #[test]
    fn gpsd_epochs_from_tpv_and_gst() {
        let mut a = GpsdAssembler::new();
        let lines = [
            r#"{"class":"VERSION","release":"3.22"}"#,
            r#"{"class":"TPV","mode":3,"status":3,"time":"2025-07-08T19:34:18.250Z","lat":40.1,"lon":-105.15,"altHAE":1601.474,"epx":1.0,"epy":2.0,"epv":3.0}"#,
            r#"{"class":"TPV","mode":3,"status":3,"time":"2025-07-08T19:34:18.250Z","lat":40.1,"lon":-105.15,"altHAE":1601.474}"#,
            r#"{"class":"GST","time":"2025-07-08T19:34:18.250Z","lat":0.01,"lon":0.02,"alt":0.03}"#,
            r#"{"class":"TPV","mode":3,"time":"2025-07-08T19:34:18.500Z","lat":40.1,"lon":-105.15,"alt":1601.0,"epx":1.0,"epy":2.0,"epv":3.0}"#,
            r#"{"class":"TPV","mode":1,"time":"2025-07-08T19:34:18.750Z"}"#,
            r#"{"class":"TPV","mode":3,"time":"2025-07-08T19:34:18.000Z","lat":40.1,"lon":-105.15,"alt":1601.0}"#,
            "garbage{",
        ];
        let res: Vec<GpsdLine> = lines.iter().map(|l| a.push_line(l.as_bytes())).collect();
        assert_eq!(res[0], GpsdLine::Ignored);
        assert!(matches!(res[5], GpsdLine::Rejected(REASON_TPV_NOFIX, _)));
        assert!(matches!(res[6], GpsdLine::Rejected(REASON_GPSD_TIME, _)));
        assert!(matches!(res[7], GpsdLine::Rejected(REASON_JSON, _)));
        let f1 = a.pop().unwrap();
        assert_eq!(f1.std_ned, Vec3::new(0.01, 0.02, 0.03));
        assert_eq!(f1.quality, 1);
        assert!((f1.h - 1601.474).abs() < 1e-12);
        let t = gps_from_iso8601("2025-07-08T19:34:18.250Z").unwrap();
        assert_eq!(f1.t, t);
        // 2025-07-08 is GPS week 2374, tow 2·86400 + 19:34:18.25 + 18 s.
        assert!((t - gps_seconds(2374, 2.0 * 86400.0 + 70458.25 + 18.0)).abs() < 1e-6);
        assert!(a.pop().is_none(), "second epoch has no GST yet");
        a.flush();
        let f2 = a.pop().unwrap();
        assert_eq!(f2.std_ned, Vec3::new(1.0, 0.5, 1.5));
        assert_eq!(f2.quality, 5);
    }

    #[test]
    fn imu_lines_never_fail() {
        let mut p = ImuLineParser::new(2374, Some(100.0));
        let mut out = Vec::new();
        assert!(p.push_line(b"1.00 0 0 0 0 0 -0.098", &mut out).is_ok());
        assert!(p.push_line(b"1.01,0,0,0,0,0,x", &mut out).is_err());
        assert!(p.push_line(b"1.01 0 0 0 0 0", &mut out).is_err());
        assert!(p.push_line(b"1.00 0 0 0 0 0 0", &mut out).is_err());
        assert!(p.push_line(b"", &mut out).is_ok());
        assert!(p.push_line(b"1.02 0 0 0 0 0 -0.098\r", &mut out).is_ok());
        assert_eq!(out.len(), 2);
        assert!((out[1].dt - 0.02).abs() < 1e-9);
        assert!(p.stats.is_balanced(), "{}", p.stats);
        assert_eq!(p.stats.rejected_total(), 3);
    }
}
