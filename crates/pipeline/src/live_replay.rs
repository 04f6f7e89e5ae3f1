//! A replay server for soak tests of `navfuse live`: plays recordings in a
//! loop over loopback TCP — IMU as KF-GINS text lines on one port, GNSS as
//! NMEA (GGA + RMC + GST, [`NmeaWriter::write_fix`]) on another — paced at
//! `speed` × real time, drops each connection at chosen records (the client
//! must reconnect), and counts everything it sent.
//!
//! **Time across loops.** A recording played again would send time stamps
//! that go backwards. Instead each pass is shifted so the stream stays
//! monotonic: pass `k` starts [`LOOP_GAP_S`] after the last record of pass
//! `k − 1` (IMU or GNSS). The gap is real missing time in the stream (the
//! recordings are at different places, so the vehicle "jumps"): the client
//! must see it as a gap and align again, as after a sensor restart. Times
//! are GPS seconds; IMU lines carry the time of week of `week` (tow may grow
//! past one week: the live parser accepts tow < 10⁶ s, i.e. 8 days of replay).

use crate::ToolError;
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_io::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::nmea::NmeaWriter;
use std::io::{BufReader, BufWriter, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Missing time between two passes [s]: longer than the live ESKF's
/// realignment threshold ([`crate::live_align::REALIGN_GAP_S`]), since the
/// passes are different places.
pub const LOOP_GAP_S: f64 = 10.0;

/// One recording: IMU samples and GNSS fixes, GPS seconds.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    pub name: String,
    pub imu: Vec<ImuSample>,
    pub gnss: Vec<GnssFix>,
}

impl Recording {
    /// KF-GINS text files (`tow Δθ Δv` IMU, `tow lat lon h σn σe σd` GNSS) of GPS week `week`.
    pub fn kfgins(name: &str, imu: &Path, gnss: &Path, week: u32) -> Result<Self, ToolError> {
        let open = |p: &Path| {
            std::fs::File::open(p)
                .map(BufReader::new)
                .map_err(|e| ToolError(format!("{}: {e}", p.display())))
        };
        let opt = KfGinsImuOptions {
            week,
            ..Default::default()
        };
        let imu_name = imu.display().to_string();
        let imu = KfGinsImuReader::new(open(imu)?, &imu_name, opt)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ToolError(e.to_string()))?;
        let gnss_name = gnss.display().to_string();
        let gnss = KfGinsGnssReader::new(open(gnss)?, &gnss_name, week)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ToolError(e.to_string()))?;
        Ok(Recording {
            name: name.into(),
            imu,
            gnss,
        })
    }

    /// The demo drive (`navfuse demo`'s embedded scenario, seed 1).
    pub fn demo() -> Result<Self, ToolError> {
        let sc = navfuse_sim::Scenario::from_toml(crate::demo::DEMO_SCENARIO, "demo")
            .map_err(|e| ToolError(e.to_string()))?;
        let run =
            navfuse_sim::simulate(&sc, 1, None, None).map_err(|e| ToolError(e.to_string()))?;
        Ok(Recording {
            name: "demo".into(),
            imu: run.imu,
            gnss: run.gnss,
        })
    }

    fn span(&self) -> Option<(f64, f64)> {
        let first = self
            .imu
            .first()?
            .t
            .min(self.gnss.first().map_or(f64::INFINITY, |f| f.t));
        let last = self
            .imu
            .last()?
            .t
            .max(self.gnss.last().map_or(f64::NEG_INFINITY, |f| f.t));
        Some((first, last))
    }
}

/// One pass of a recording in the replayed stream: add `offset` [s].
#[derive(Clone, Copy, Debug)]
pub struct Pass {
    pub recording: usize,
    pub offset: f64,
}

/// The passes filling at least `duration_s` of stream, cycling through the
/// recordings, each starting [`LOOP_GAP_S`] after the previous one ended;
/// the first pass keeps its time of week but is moved into GPS week `week`.
/// Also returns the stream's length [s].
pub fn schedule(
    recs: &[Recording],
    duration_s: f64,
    week: u32,
) -> Result<(Vec<Pass>, f64), ToolError> {
    let spans: Vec<(f64, f64)> = recs
        .iter()
        .map(|r| {
            r.span()
                .ok_or_else(|| ToolError(format!("{}: no data", r.name)))
        })
        .collect::<Result<_, _>>()?;
    if spans.is_empty() {
        return Err("replay: no recording".into());
    }
    let week_s = f64::from(week) * navfuse_io::time::SECONDS_PER_WEEK;
    let t0 = week_s + spans[0].0.rem_euclid(navfuse_io::time::SECONDS_PER_WEEK);
    let mut passes = Vec::new();
    let mut end = t0 - LOOP_GAP_S;
    let mut k = 0;
    while passes.is_empty() || end - t0 < duration_s {
        let r = k % recs.len();
        let offset = end + LOOP_GAP_S - spans[r].0;
        passes.push(Pass {
            recording: r,
            offset,
        });
        end = spans[r].1 + offset;
        k += 1;
    }
    Ok((passes, end - t0))
}

/// What the server sent (shared with the threads while they run).
#[derive(Debug, Default)]
pub struct Sent {
    pub imu_lines: AtomicU64,
    pub gnss_fixes: AtomicU64,
    pub gnss_lines: AtomicU64,
    /// Connections accepted after the first, per stream.
    pub imu_reconnects: AtomicU64,
    pub gnss_reconnects: AtomicU64,
}

/// Options of [`serve`].
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Stream seconds per wall-clock second.
    pub speed: f64,
    /// Stream length to play at least [s] (whole passes).
    pub duration_s: f64,
    /// GPS week of the IMU lines' time of week.
    pub week: u32,
    /// Close the IMU connection after these many lines sent (ascending).
    pub imu_drops: Vec<u64>,
    /// Close the GNSS connection after these many fixes sent (ascending).
    pub gnss_drops: Vec<u64>,
}

/// A running replay: its ports, counters and threads.
pub struct Replay {
    pub imu_port: u16,
    pub gnss_port: u16,
    pub sent: Arc<Sent>,
    /// Stream length [s] and passes played.
    pub duration_s: f64,
    pub passes: usize,
    threads: Vec<JoinHandle<Result<(), String>>>,
}

impl Replay {
    /// Wait until both streams are sent; the connections are then closed.
    pub fn join(self) -> Result<Arc<Sent>, ToolError> {
        for t in self.threads {
            t.join()
                .map_err(|_| ToolError("replay thread panicked".into()))?
                .map_err(ToolError)?;
        }
        Ok(self.sent)
    }
}

/// Paces sends: the record of stream time `t` is due at `start + (t − t0) / speed`.
#[derive(Clone, Copy)]
struct Pace {
    start: Instant,
    t0: f64,
    speed: f64,
}

impl Pace {
    fn wait_for(&self, t: f64) {
        let due = Duration::from_secs_f64(((t - self.t0) / self.speed).max(0.0));
        let el = self.start.elapsed();
        if due > el {
            std::thread::sleep((due - el).min(Duration::from_millis(20)));
        }
    }
    fn due(&self, t: f64) -> bool {
        self.start.elapsed().as_secs_f64() * self.speed >= t - self.t0
    }
}

/// One stream's connection: accepts a (new) client when needed.
struct Conn {
    l: TcpListener,
    w: Option<BufWriter<TcpStream>>,
    accepted: u64,
}

impl Conn {
    fn get(&mut self, reconnects: &AtomicU64) -> Result<&mut BufWriter<TcpStream>, String> {
        if self.w.is_none() {
            let (s, _) = self.l.accept().map_err(|e| format!("replay accept: {e}"))?;
            s.set_nodelay(true).ok();
            if self.accepted > 0 {
                reconnects.fetch_add(1, Ordering::Relaxed);
            }
            self.accepted += 1;
            self.w = Some(BufWriter::with_capacity(1 << 16, s));
        }
        Ok(self.w.as_mut().expect("just set"))
    }
    /// Flush what is buffered and wait until stream time `t` is due.
    fn wait_until(&mut self, pace: &Pace, t: f64) -> Result<(), String> {
        while !pace.due(t) {
            if let Some(w) = self.w.as_mut() {
                w.flush().map_err(|e| format!("replay: {e}"))?;
            }
            pace.wait_for(t);
        }
        Ok(())
    }
    /// Flush and close (the client sees end of stream after every byte).
    fn close(&mut self) -> Result<(), String> {
        if let Some(mut w) = self.w.take() {
            w.flush().map_err(|e| format!("replay: {e}"))?;
        }
        Ok(())
    }
}

/// Start serving `recs` on two loopback ports (IMU, GNSS).
pub fn serve(recs: Vec<Recording>, opt: ReplayOptions) -> Result<Replay, ToolError> {
    if !(opt.speed.is_finite() && opt.speed > 0.0) {
        return Err(format!("replay speed {}: must be > 0", opt.speed).into());
    }
    let (passes, duration_s) = schedule(&recs, opt.duration_s, opt.week)?;
    let bind = || TcpListener::bind("127.0.0.1:0").map_err(|e| ToolError(format!("bind: {e}")));
    let (li, lg) = (bind()?, bind()?);
    let port = |l: &TcpListener| {
        l.local_addr()
            .map(|a| a.port())
            .map_err(|e| ToolError(e.to_string()))
    };
    let (imu_port, gnss_port) = (port(&li)?, port(&lg)?);
    let recs = Arc::new(recs);
    let passes = Arc::new(passes);
    let sent = Arc::new(Sent::default());
    let pace = Pace {
        start: Instant::now(),
        t0: recs[0].span().map_or(0.0, |s| s.0) + passes[0].offset,
        speed: opt.speed,
    };
    let week_s = f64::from(opt.week) * navfuse_io::time::SECONDS_PER_WEEK;
    let imu_thread = {
        let (recs, passes, sent, drops) =
            (recs.clone(), passes.clone(), sent.clone(), opt.imu_drops);
        std::thread::spawn(move || {
            let mut c = Conn {
                l: li,
                w: None,
                accepted: 0,
            };
            let mut drops = drops.into_iter().peekable();
            let mut line = String::with_capacity(160);
            for p in passes.iter() {
                for s in &recs[p.recording].imu {
                    let t = s.t + p.offset;
                    c.wait_until(&pace, t)?;
                    use std::fmt::Write as _;
                    line.clear();
                    let (a, v) = (s.dtheta_b, s.dvel_b);
                    let _ = writeln!(
                        line,
                        "{:.6} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e} {:.12e}",
                        t - week_s,
                        a.x,
                        a.y,
                        a.z,
                        v.x,
                        v.y,
                        v.z
                    );
                    c.get(&sent.imu_reconnects)?
                        .write_all(line.as_bytes())
                        .map_err(|e| format!("replay imu: {e}"))?;
                    let n = sent.imu_lines.fetch_add(1, Ordering::Relaxed) + 1;
                    if drops.next_if_eq(&n).is_some() {
                        c.close()?;
                    }
                }
            }
            c.close()
        })
    };
    let gnss_thread = {
        let (recs, passes, sent, drops) =
            (recs.clone(), passes.clone(), sent.clone(), opt.gnss_drops);
        std::thread::spawn(move || {
            let mut c = Conn {
                l: lg,
                w: None,
                accepted: 0,
            };
            let mut drops = drops.into_iter().peekable();
            let mut buf = Vec::with_capacity(512);
            for p in passes.iter() {
                for f in &recs[p.recording].gnss {
                    let mut f = *f;
                    f.t += p.offset;
                    c.wait_until(&pace, f.t)?;
                    buf.clear();
                    NmeaWriter::new(&mut buf)
                        .write_fix(&f)
                        .map_err(|e| format!("replay gnss: {e}"))?;
                    c.get(&sent.gnss_reconnects)?
                        .write_all(&buf)
                        .map_err(|e| format!("replay gnss: {e}"))?;
                    let lines = buf.iter().filter(|b| **b == b'\n').count() as u64;
                    sent.gnss_lines.fetch_add(lines, Ordering::Relaxed);
                    let n = sent.gnss_fixes.fetch_add(1, Ordering::Relaxed) + 1;
                    if drops.next_if_eq(&n).is_some() {
                        c.close()?;
                    }
                }
            }
            c.close()
        })
    };
    Ok(Replay {
        imu_port,
        gnss_port,
        sent,
        duration_s,
        passes: passes.len(),
        threads: vec![imu_thread, gnss_thread],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(name: &str, t0: f64, n: usize) -> Recording {
        Recording {
            name: name.into(),
            imu: (0..n)
                .map(|k| ImuSample {
                    t: t0 + k as f64 * 0.01,
                    dt: 0.01,
                    ..Default::default()
                })
                .collect(),
            gnss: (0..n / 100)
                .map(|k| GnssFix {
                    t: t0 + k as f64 + 0.005,
                    ..Default::default()
                })
                .collect(),
        }
    }

    /// Passes cycle through the recordings, each starting LOOP_GAP_S after
    /// the previous one's last record, so the stream never goes back.
    #[test]
    fn schedule_is_monotonic_with_gaps() {
        let recs = [rec("a", 1000.0, 500), rec("b", 7.0, 300)];
        let (p, len) = schedule(&recs, 20.0, 0).unwrap();
        assert_eq!(p.iter().map(|p| p.recording).collect::<Vec<_>>(), [0, 1, 0]);
        assert_eq!(p[0].offset, 0.0);
        let (p2, _) = schedule(&recs, 20.0, 3).unwrap();
        assert_eq!(p2[0].offset, 3.0 * 604_800.0);
        // Pass 1 starts LOOP_GAP_S after pass 0's last IMU sample (1004.99).
        assert!((recs[1].imu[0].t + p[1].offset - (1004.99 + LOOP_GAP_S)).abs() < 1e-9);
        let end1 = recs[1].imu.last().unwrap().t + p[1].offset;
        assert!((recs[0].imu[0].t + p[2].offset - (end1 + LOOP_GAP_S)).abs() < 1e-9);
        assert!(len >= 20.0);
    }
}
