//! The input side of `navfuse live`: one thread per source reading lines
//! (blocking I/O) and sending them, stamped with their arrival time, over a
//! bounded channel (a slow consumer back-pressures the readers instead of
//! growing memory).
//!
//! Sources: stdin, a file (the IMU file is followed while it is written), a
//! serial device (any character device, configured beforehand, e.g. with
//! `stty`), TCP, and gpsd (JSON over TCP).
//!
//! **Reconnection.** A TCP connection or a serial device that ends or fails
//! is opened again with exponential backoff ([`Backoff`]: 0.1 s, doubling, at
//! most 5 s between attempts) until it answers again; each new connection is
//! reported ([`Msg::Reconnect`]) and counted by the caller. A source that has
//! not answered for `reconnect_for` seconds of wall-clock time ends (its
//! stream then ends as at end of file); `f64::INFINITY` retries forever.
//! gpsd is a local daemon and is retried for as long as the run lasts.

use crate::nmea::{NmeaOptions, NmeaReader};
use crate::RecordStats;
use navfuse_core::types::{Event, GnssFix};
use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::sync::mpsc::SyncSender;
use std::time::{Duration, Instant};

/// A message from a source thread.
pub enum Msg {
    /// One IMU line and its arrival time.
    ImuLine(Vec<u8>, Instant),
    /// The IMU source ended (end of file, or gave up reconnecting).
    ImuEnd,
    /// Something worth a line in the summary.
    ImuNote(String),
    /// One gpsd JSON line and its arrival time.
    GpsdLine(Vec<u8>, Instant),
    /// One NMEA fix and its arrival time.
    Fix(GnssFix, Instant),
    /// An NMEA connection's reader counts (sent when the connection ends).
    GnssStats(RecordStats),
    GnssNote(String),
    GnssEnd,
    /// A lost source was opened again (`imu`, `nmea`, `gpsd`, `ubx`).
    Reconnect(&'static str),
    /// One event of a UBX source ([`crate::live_ubx`]) and its arrival time.
    UbxEvent(Event, Instant),
    /// A UBX source's counts so far: frames (per connection, summed by the
    /// receiver) and the converter's items (cumulative, replaces the last).
    UbxStats {
        frames: RecordStats,
        items: RecordStats,
    },
}

/// Exponential backoff between reconnection attempts: starts at
/// [`Backoff::FIRST`], doubles, never more than [`Backoff::MAX`] (a sensor
/// or a link that comes back is found within 5 s; a dead one costs one
/// attempt per 5 s).
#[derive(Clone, Copy, Debug)]
pub struct Backoff {
    next: Duration,
}

impl Backoff {
    pub const FIRST: Duration = Duration::from_millis(100);
    pub const MAX: Duration = Duration::from_secs(5);

    pub fn new() -> Self {
        Backoff { next: Self::FIRST }
    }
    /// The wait before the next attempt (and double the one after it).
    pub fn next_wait(&mut self) -> Duration {
        let w = self.next;
        self.next = (self.next * 2).min(Self::MAX);
        w
    }
    /// After a successful connection: start again from [`Backoff::FIRST`].
    pub fn reset(&mut self) {
        self.next = Self::FIRST;
    }
}

impl Default for Backoff {
    fn default() -> Self {
        Self::new()
    }
}

/// Open with `open` and read with `serve` until `serve` returns, again and
/// again with [`Backoff`]; gives up after `give_up_after` seconds without a
/// successful open. `serve` returns false to stop (receiver gone). Every
/// open after the first is reported as `Msg::Reconnect(what)`.
pub(crate) fn reconnecting<S>(
    what: &'static str,
    give_up_after: f64,
    tx: &SyncSender<Msg>,
    note: impl Fn(String) -> Msg,
    mut open: impl FnMut() -> io::Result<S>,
    mut serve: impl FnMut(S) -> bool,
) {
    let mut backoff = Backoff::new();
    let mut last_ok = Instant::now();
    let mut opened_before = false;
    loop {
        match open() {
            Ok(s) => {
                if opened_before && tx.send(Msg::Reconnect(what)).is_err() {
                    return;
                }
                opened_before = true;
                backoff.reset();
                if !serve(s) {
                    return;
                }
                last_ok = Instant::now();
            }
            Err(e) => {
                if last_ok.elapsed().as_secs_f64() > give_up_after {
                    let _ = tx.send(note(format!("{what}: giving up: {e}")));
                    return;
                }
            }
        }
        std::thread::sleep(backoff.next_wait());
    }
}

pub(crate) fn connect(addr: &str) -> io::Result<TcpStream> {
    let s = TcpStream::connect(addr)?;
    s.set_nodelay(true).ok();
    Ok(s)
}

/// Whether `path` is a character device (a serial port).
pub(crate) fn is_char_device(path: &str) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::metadata(path).is_ok_and(|m| m.file_type().is_char_device())
}

/// Read lines from `r`, sending each with its arrival time. Returns at EOF
/// (`Ok(true)`) or when the receiver is gone (`Ok(false)`).
fn pump_lines(
    r: impl Read,
    tx: &SyncSender<Msg>,
    mk: impl Fn(Vec<u8>, Instant) -> Msg,
) -> io::Result<bool> {
    let mut r = BufReader::with_capacity(1 << 16, r);
    let mut buf = Vec::with_capacity(256);
    loop {
        buf.clear();
        // Bound a line's length without holding it: a line longer than
        // 64 KiB is skipped to its newline and stands for one rejected line
        // (the placeholder fails to parse and is counted with its reason),
        // so memory is bounded by the channel's capacity × 64 KiB at most
        // and by a few bytes per line for endless lines.
        match crate::text::fill_line(&mut r, &mut buf, LIVE_MAX_LINE)? {
            crate::text::Fill::Eof => return Ok(true),
            crate::text::Fill::Line => {}
            crate::text::Fill::TooLong => {
                crate::text::skip_line(&mut r)?;
                buf.clear();
                buf.extend_from_slice(b"<line longer than 65536 bytes>\n");
            }
        }
        if tx.send(mk(buf.clone(), Instant::now())).is_err() {
            return Ok(false);
        }
    }
}

/// Longest live line kept [bytes]: 64 KiB, a hundred times a gpsd JSON
/// report or an IMU line.
const LIVE_MAX_LINE: usize = 1 << 16;

/// Pump lines, turning an error into a note; false when the receiver is gone.
fn pump_noting(
    r: impl Read,
    tx: &SyncSender<Msg>,
    mk: impl Fn(Vec<u8>, Instant) -> Msg,
    note: impl Fn(String) -> Msg,
    name: &str,
) -> bool {
    match pump_lines(r, tx, mk) {
        Ok(go_on) => go_on,
        Err(e) => tx.send(note(format!("{name}: {e}"))).is_ok(),
    }
}

/// Start the IMU source `spec`: `-` (stdin), `tcp:HOST:PORT`, a serial
/// device, or a file (followed until `idle` s pass without new bytes).
pub fn spawn_imu(spec: &str, idle: f64, reconnect_for: f64, tx: SyncSender<Msg>) {
    let spec = spec.to_string();
    std::thread::spawn(move || {
        let mk = Msg::ImuLine;
        if spec == "-" {
            pump_noting(io::stdin().lock(), &tx, mk, Msg::ImuNote, "imu stdin");
        } else if let Some(addr) = spec.strip_prefix("tcp:") {
            let serve = |s| pump_noting(s, &tx, mk, Msg::ImuNote, addr);
            reconnecting(
                "imu",
                reconnect_for,
                &tx,
                Msg::ImuNote,
                || connect(addr),
                serve,
            );
        } else if is_char_device(&spec) {
            let open = || std::fs::File::open(&spec);
            let serve = |f| pump_noting(f, &tx, mk, Msg::ImuNote, &spec);
            reconnecting("imu", reconnect_for, &tx, Msg::ImuNote, open, serve);
        } else {
            match std::fs::File::open(&spec) {
                Ok(f) => {
                    let r = crate::live::FollowReader::new(f, Duration::from_secs_f64(idle));
                    pump_noting(r, &tx, mk, Msg::ImuNote, &spec);
                }
                Err(e) => {
                    let _ = tx.send(Msg::ImuNote(format!("imu {spec}: {e}")));
                }
            }
        }
        let _ = tx.send(Msg::ImuEnd);
    });
}

/// Fixes from NMEA `r`; false when the receiver is gone.
fn nmea_source(r: impl BufRead, name: &str, tx: &SyncSender<Msg>) -> bool {
    let mut rd = NmeaReader::new(r, name, NmeaOptions::default());
    for f in rd.by_ref() {
        let m = match f {
            Ok(f) => Msg::Fix(f, Instant::now()),
            Err(e) => Msg::GnssNote(e.to_string()),
        };
        if tx.send(m).is_err() {
            return false;
        }
    }
    if let Some(e) = rd.last_rejection() {
        let _ = tx.send(Msg::GnssNote(format!("last rejected NMEA line: {e}")));
    }
    tx.send(Msg::GnssStats(rd.stats().clone())).is_ok()
}

/// Check a `--gnss` spec: `gpsd[:HOST:PORT]`, `nmea:-`, `nmea:PATH`,
/// `nmea-tcp:HOST:PORT` or `none`.
pub fn check_gnss_spec(spec: &str) -> Result<(), String> {
    if spec == "none"
        || spec == "gpsd"
        || spec.starts_with("gpsd:")
        || spec.starts_with("nmea:")
        || spec.starts_with("nmea-tcp:")
    {
        Ok(())
    } else {
        Err(format!(
            "--gnss {spec:?}: expected gpsd[:HOST:PORT], nmea:-, nmea:PATH, nmea-tcp:HOST:PORT or none"
        ))
    }
}

/// Start the GNSS source `spec` (see [`check_gnss_spec`]).
pub fn spawn_gnss(spec: &str, reconnect_for: f64, tx: SyncSender<Msg>) -> Result<(), String> {
    check_gnss_spec(spec)?;
    let spec = spec.to_string();
    if spec == "none" {
        let _ = tx.send(Msg::GnssEnd);
        return Ok(());
    }
    std::thread::spawn(move || {
        if spec == "gpsd" || spec.starts_with("gpsd:") {
            let addr = spec.strip_prefix("gpsd:").unwrap_or("127.0.0.1:2947");
            let serve = |mut s: TcpStream| {
                if s.write_all(b"?WATCH={\"enable\":true,\"json\":true};\n")
                    .is_err()
                {
                    return true;
                }
                // A held epoch will not be completed by the next connection:
                // the caller flushes it on the `Reconnect` that precedes it.
                pump_noting(s, &tx, Msg::GpsdLine, Msg::GnssNote, addr)
            };
            let open = || connect(addr);
            reconnecting("gpsd", f64::INFINITY, &tx, Msg::GnssNote, open, serve);
        } else if let Some(addr) = spec.strip_prefix("nmea-tcp:") {
            let serve = |s| nmea_source(BufReader::new(s), addr, &tx);
            reconnecting(
                "nmea",
                reconnect_for,
                &tx,
                Msg::GnssNote,
                || connect(addr),
                serve,
            );
        } else {
            let path = spec.strip_prefix("nmea:").unwrap_or("-");
            if path == "-" {
                nmea_source(io::stdin().lock(), "<stdin>", &tx);
            } else if is_char_device(path) {
                let open = || std::fs::File::open(path);
                let serve = |f| nmea_source(BufReader::new(f), path, &tx);
                reconnecting("nmea", reconnect_for, &tx, Msg::GnssNote, open, serve);
            } else {
                match std::fs::File::open(path) {
                    Ok(f) => {
                        nmea_source(BufReader::new(f), path, &tx);
                    }
                    Err(e) => {
                        let _ = tx.send(Msg::GnssNote(format!("{path}: cannot open: {e}")));
                    }
                }
            }
        }
        let _ = tx.send(Msg::GnssEnd);
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backoff_doubles_and_is_bounded() {
        let mut b = Backoff::new();
        let w: Vec<u64> = (0..8).map(|_| b.next_wait().as_millis() as u64).collect();
        assert_eq!(w, [100, 200, 400, 800, 1600, 3200, 5000, 5000]);
        b.reset();
        assert_eq!(b.next_wait(), Backoff::FIRST);
    }

    /// A TCP IMU source whose server closes the connection twice: every
    /// line arrives, two reconnects are reported, and the source ends once
    /// the server is gone for longer than `reconnect_for`.
    #[test]
    fn tcp_imu_source_reconnects() {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let server = std::thread::spawn(move || {
            for c in 0..3 {
                let (mut s, _) = l.accept().unwrap();
                for k in 0..5 {
                    writeln!(s, "line {c} {k}").unwrap();
                }
            }
        });
        let (tx, rx) = std::sync::mpsc::sync_channel(16);
        spawn_imu(&format!("tcp:{addr}"), 0.1, 0.5, tx);
        let (mut lines, mut reconnects) = (0, 0);
        loop {
            match rx
                .recv_timeout(Duration::from_secs(20))
                .expect("source hangs")
            {
                Msg::ImuLine(..) => lines += 1,
                Msg::Reconnect("imu") => reconnects += 1,
                Msg::ImuEnd => break,
                _ => {}
            }
        }
        server.join().unwrap();
        assert_eq!((lines, reconnects), (15, 2));
    }
}
