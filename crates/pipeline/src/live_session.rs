//! The bookkeeping of a live session (`navfuse live`): turns the source
//! threads' messages ([`navfuse_io::live_source::Msg`]) into sequencer
//! events, and counts everything the run summary reports — records per
//! type used/skipped/rejected by reason, gaps in each stream's time stamps,
//! reconnects, notes — then writes that summary as text and JSON.

use crate::live::{jnum, stats_json, LiveDriver};
use navfuse_core::types::{Event, ImuSample};
use navfuse_io::live::{GapCounter, GpsdAssembler, GpsdLine, ImuLineParser, Sequencer};
use navfuse_io::live_source::Msg;
use navfuse_io::live_ubx::UBX_PVT_LATENCY_S;
use navfuse_io::RecordStats;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::time::Instant;

/// At most this many notes are kept for the summary (bounded memory on a
/// run of days; the rest are counted).
const MAX_NOTES: usize = 20;

/// What the inputs of a live session did.
pub struct Inputs {
    imu: ImuLineParser,
    gpsd: GpsdAssembler,
    gpsd_stats: RecordStats,
    nmea_stats: RecordStats,
    /// Gaps in the IMU samples' and the fixes' time stamps.
    pub imu_gaps: GapCounter,
    pub gnss_gaps: GapCounter,
    /// New connections after a lost one, by source.
    pub reconnects: Vec<(&'static str, u64)>,
    notes: Vec<String>,
    notes_dropped: u64,
    /// The GNSS source has ended.
    pub gnss_ended: bool,
    samples: Vec<ImuSample>,
    /// A UBX source ([`navfuse_io::live_ubx`]): frames (summed over
    /// connections), converter items, and the odometer / heading events
    /// (counted, and sequenced for the estimator: [`Sequencer::push_aid`]).
    ubx_frames: RecordStats,
    ubx_items: Option<RecordStats>,
    pub ubx_odometer: u64,
    pub ubx_heading: u64,
}

impl Inputs {
    /// IMU lines stamped in GPS week `gps_week`, nominal rate `imu_rate` [Hz].
    pub fn new(gps_week: u32, imu_rate: f64) -> Self {
        Inputs {
            imu: ImuLineParser::new(gps_week, Some(imu_rate)),
            gpsd: GpsdAssembler::new(),
            gpsd_stats: RecordStats::default(),
            nmea_stats: RecordStats::default(),
            imu_gaps: GapCounter::default(),
            gnss_gaps: GapCounter::default(),
            reconnects: Vec::new(),
            notes: Vec::new(),
            notes_dropped: 0,
            gnss_ended: false,
            samples: Vec::with_capacity(2),
            ubx_frames: RecordStats::default(),
            ubx_items: None,
            ubx_odometer: 0,
            ubx_heading: 0,
        }
    }

    fn note(&mut self, s: String) {
        if self.notes.len() < MAX_NOTES {
            self.notes.push(s);
        } else {
            self.notes_dropped += 1;
        }
    }

    /// IMU line counts.
    pub fn imu_stats(&self) -> &RecordStats {
        self.ubx_items.as_ref().unwrap_or(&self.imu.stats)
    }

    /// GNSS record counts and their source (`NMEA` or `gpsd`).
    pub fn gnss_stats(&self) -> (&RecordStats, &'static str) {
        if self.ubx_items.is_some() {
            (&self.ubx_frames, "UBX frames")
        } else if self.nmea_stats.lines > 0 {
            (&self.nmea_stats, "NMEA")
        } else {
            (&self.gpsd_stats, "gpsd")
        }
    }

    fn push_held_gpsd(&mut self, seq: &mut Sequencer, now: f64) {
        while let Some(f) = self.gpsd.pop() {
            self.gnss_gaps.push(f.t);
            seq.push_gnss(f, now);
        }
    }

    /// Handle one message; `secs` maps an arrival instant to the
    /// sequencer's clock [s]; `now` is the current time on it.
    pub fn handle(
        &mut self,
        msg: Msg,
        seq: &mut Sequencer,
        secs: &dyn Fn(Instant) -> f64,
        now: f64,
    ) {
        match msg {
            Msg::ImuLine(b, at) => {
                self.samples.clear();
                let mut samples = std::mem::take(&mut self.samples);
                if let Err((_, m)) = self.imu.push_line(&b, &mut samples) {
                    let line = self.imu.stats.lines;
                    self.note(format!("imu line {line}: {m}"));
                }
                for s in &samples {
                    self.imu_gaps.push(s.t);
                    seq.push_imu(*s, secs(at));
                }
                self.samples = samples;
            }
            Msg::ImuEnd => {
                self.imu.finish();
                seq.end_imu();
            }
            Msg::ImuNote(m) | Msg::GnssNote(m) => self.note(m),
            Msg::GpsdLine(b, at) => {
                self.gpsd_stats.lines += 1;
                match self.gpsd.push_line(&b) {
                    GpsdLine::Ignored => self.gpsd_stats.skipped += 1,
                    GpsdLine::Held => self.gpsd_stats.used += 1,
                    GpsdLine::Rejected(r, m) => {
                        self.gpsd_stats.reject(r);
                        let line = self.gpsd_stats.lines;
                        self.note(format!("gpsd line {line}: {r}: {m}"));
                    }
                }
                self.push_held_gpsd(seq, secs(at));
                seq.gnss_time_seen(self.gpsd.horizon());
            }
            Msg::Fix(f, at) => {
                self.gnss_gaps.push(f.t);
                seq.push_gnss(f, secs(at));
            }
            Msg::GnssStats(s) => add_stats(&mut self.nmea_stats, s),
            Msg::UbxEvent(e, at) => self.ubx_event(e, seq, secs(at)),
            Msg::UbxStats { frames, items } => {
                add_stats(&mut self.ubx_frames, frames);
                self.ubx_items = Some(items);
            }
            Msg::GnssEnd => {
                self.gnss_ended = true;
                self.gpsd.flush();
                self.push_held_gpsd(seq, now);
                seq.end_gnss();
            }
            Msg::Reconnect(what) => {
                if what == "gpsd" {
                    // A held epoch will not be completed by the new connection.
                    self.gpsd.flush();
                    self.push_held_gpsd(seq, now);
                }
                match self.reconnects.iter_mut().find(|r| r.0 == what) {
                    Some(r) => r.1 += 1,
                    None => self.reconnects.push((what, 1)),
                }
            }
        }
    }

    /// One event of a UBX source: IMU and GNSS to the sequencer (an IMU
    /// sample also shows that no fix older than [`UBX_PVT_LATENCY_S`]
    /// before it can still come), odometer and heading counted and queued
    /// in front of the IMU sample whose interval contains them.
    fn ubx_event(&mut self, e: Event, seq: &mut Sequencer, at: f64) {
        match e {
            Event::Imu(s) => {
                self.imu_gaps.push(s.t);
                seq.push_imu(s, at);
                seq.gnss_time_seen(s.t - UBX_PVT_LATENCY_S);
            }
            Event::Gnss(f) => {
                self.gnss_gaps.push(f.t);
                seq.push_gnss(f, at);
            }
            Event::Odometer(_) => {
                self.ubx_odometer += 1;
                seq.push_aid(e, at);
            }
            Event::Heading(_) => {
                self.ubx_heading += 1;
                seq.push_aid(e, at);
            }
            _ => {}
        }
    }

    /// The run summary as JSON (one object; see `docs/live.md`).
    pub fn summary_json(&self, drv: &LiveDriver, seq: &Sequencer, end: &End) -> Value {
        let q = &seq.stats;
        let (gnss, label) = self.gnss_stats();
        let stats = |s: &RecordStats| -> Value {
            serde_json::from_str(&stats_json(s)).unwrap_or(Value::Null)
        };
        let gaps = |g: &GapCounter| json!({"gaps": g.gaps, "missing_s": g.gap_s, "longest_s": g.longest_s});
        let ms = |x: f64| -> Value { jnum(x * 1e3, 4).parse().unwrap_or(Value::Null) };
        let reconnects: serde_json::Map<String, Value> = self
            .reconnects
            .iter()
            .map(|(k, n)| (k.to_string(), json!(n)))
            .collect();
        json!({
            "estimator": drv.est.name(),
            "wall_s": end.wall_s,
            "stopped_by": end.stopped_by,
            "imu": stats(self.imu_stats()),
            "gnss": stats(gnss),
            "gnss_source": label,
            "imu_gaps": gaps(&self.imu_gaps),
            "gnss_gaps": gaps(&self.gnss_gaps),
            "reconnects": reconnects,
            "realigns": drv.est.realigns(),
            "imu_in": q.imu_in, "imu_out": q.imu_out, "imu_late": q.imu_late,
            "gnss_in": q.gnss_in, "gnss_out": q.gnss_out, "gnss_late": q.gnss_late,
            "imu_released_by_timeout": q.imu_released_by_timeout,
            "gnss_released_by_timeout": q.gnss_released_by_timeout,
            "released_by_bound": q.released_by_bound,
            "solutions": drv.n_sol,
            "imu_without_solution": drv.n_imu_nosol,
            "latency_p50_ms": ms(drv.lat.quantile(0.5)),
            "latency_p99_ms": ms(drv.lat.quantile(0.99)),
            "latency_max_ms": ms(drv.lat.max()),
            "latency_n": drv.lat.count(),
            "ubx_odometer_events": self.ubx_odometer,
            "ubx_heading_events": self.ubx_heading,
            "aid_in": q.aid_in, "aid_out": q.aid_out, "aid_late": q.aid_late,
            "aid_dropped_bound": q.aid_dropped_bound,
            "aiding": drv.est.aiding_json(),
            "sigma_model": drv.est.sigma_model(),
        })
    }

    /// The run summary as text (stderr).
    pub fn summary_text(&self, drv: &LiveDriver, seq: &Sequencer, end: &End) -> String {
        let q = &seq.stats;
        let (gnss, label) = self.gnss_stats();
        let mut e = String::new();
        let stop = end
            .stopped_by
            .map_or(String::new(), |s| format!(", stopped by {s}"));
        let _ = writeln!(
            e,
            "live: estimator {} ({:.1} s wall{stop})",
            drv.est.name(),
            end.wall_s
        );
        let _ = writeln!(e, "  IMU input: {}", self.imu_stats());
        if self.ubx_items.is_some() {
            let _ = writeln!(
                e,
                "  UBX aiding events: odometer {}, heading {}; sequenced {} in / {} out / {} late / {} dropped at the queue bound",
                self.ubx_odometer, self.ubx_heading, q.aid_in, q.aid_out, q.aid_late, q.aid_dropped_bound
            );
            let a = drv.est.aiding_json();
            if !a.is_null() {
                let _ = writeln!(e, "  aiding updates: {}", a["used_rejected"]);
            }
        }
        let open = if self.gnss_ended {
            ""
        } else {
            " (source still open)"
        };
        let _ = writeln!(e, "  GNSS input ({label}): {gnss}{open}");
        let g = |g: &GapCounter| {
            format!(
                "{} ({:.1} s missing, longest interval {:.2} s)",
                g.gaps, g.gap_s, g.longest_s
            )
        };
        let _ = writeln!(
            e,
            "  gaps: IMU {}, GNSS {}",
            g(&self.imu_gaps),
            g(&self.gnss_gaps)
        );
        let _ = writeln!(
            e,
            "  sequencer: IMU {} in / {} out / {} late, GNSS {} in / {} out / {} late; released by timeout: IMU {}, GNSS {}; by queue bound {}",
            q.imu_in, q.imu_out, q.imu_late, q.gnss_in, q.gnss_out, q.gnss_late,
            q.imu_released_by_timeout, q.gnss_released_by_timeout, q.released_by_bound
        );
        let _ = writeln!(
            e,
            "  solutions: {} written ({} at GNSS events); {} IMU samples without a solution (estimator not initialised or aligning); realignments after gaps {}",
            drv.n_sol, drv.n_gnss_sol, drv.n_imu_nosol, drv.est.realigns()
        );
        let lat = &drv.lat;
        let _ = writeln!(
            e,
            "  latency (IMU line read → solution written): p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms over {} samples",
            lat.quantile(0.5) * 1e3,
            lat.quantile(0.99) * 1e3,
            lat.max() * 1e3,
            lat.count()
        );
        if !self.reconnects.is_empty() {
            let _ = writeln!(e, "  reconnects: {:?}", self.reconnects);
        }
        if !drv.outside.is_empty() {
            let _ = writeln!(
                e,
                "  not handed to the estimator (kf-gins time window): {:?}",
                drv.outside
            );
        }
        for w in drv.est.warnings() {
            let _ = writeln!(e, "  estimator: {w}");
        }
        for n in &self.notes {
            let _ = writeln!(e, "  note: {n}");
        }
        if self.notes_dropped > 0 {
            let _ = writeln!(e, "  ({} more notes not shown)", self.notes_dropped);
        }
        e
    }
}

/// Add the counts of `s` to `n`.
fn add_stats(n: &mut RecordStats, s: RecordStats) {
    n.lines += s.lines;
    n.used += s.used;
    n.skipped += s.skipped;
    for (r, k) in s.rejected {
        for _ in 0..k {
            n.reject(r);
        }
    }
}

/// How a live session ended.
#[derive(Clone, Debug, Default)]
pub struct End {
    /// Wall-clock length of the run [s].
    pub wall_s: f64,
    /// `Some("SIGINT")`/`Some("SIGTERM")` when stopped by a signal; None at end of input.
    pub stopped_by: Option<&'static str>,
}
