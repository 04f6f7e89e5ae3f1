//! `navfuse live`: fuse a live GNSS stream (gpsd, NMEA on stdin/TCP/serial
//! device) with live IMU lines (stdin, a file being written, TCP) and write
//! solutions at the IMU rate as JSON lines or NMEA.
//!
//! The estimator runs through the `Estimator` trait, driven by
//! [`navfuse_pipeline::live::LiveDriver`] and fed by
//! [`navfuse_io::live::Sequencer`], which reproduces the event order of a
//! batch run (time order, IMU before GNSS at equal times), so live and batch
//! solutions agree whenever no event had to be released by timeout (the
//! summary counts those). Every input line is counted used, skipped or
//! rejected by reason; the summary is printed to stderr on exit (end of the
//! IMU input) and, with `--summary-json`, written as JSON.
//!
//! Threads: one per input source reading lines (blocking I/O), the main
//! thread sequencing, estimating and writing. Channels are bounded, so a
//! slow consumer back-pressures the readers instead of growing memory.

use clap::Args as ClapArgs;
use navfuse_core::types::{GnssFix, NavSolution};
use navfuse_io::live::{FollowReader, GpsdAssembler, GpsdLine, ImuLineParser, Sequencer};
use navfuse_io::nmea::{NmeaOptions, NmeaReader};
use navfuse_io::RecordStats;
use navfuse_pipeline::live::{
    aligning_eskf, jnum, kfgins_eskf, make_estimator, stats_json, Format, LiveDriver, Out,
};
use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, RecvTimeoutError, SyncSender};
use std::time::{Duration, Instant};

/// Fuse live GNSS (gpsd / NMEA) and IMU streams; solutions at the IMU rate.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// GNSS source: `gpsd` or `gpsd:HOST:PORT` (gpsd JSON, default
    /// 127.0.0.1:2947); `nmea:-` (stdin); `nmea:PATH` (file or serial device,
    /// configured beforehand, e.g. with stty); `nmea-tcp:HOST:PORT`; `none`.
    #[arg(long, default_value = "gpsd")]
    pub gnss: String,
    /// IMU source, KF-GINS lines `tow Δθxyz[rad] Δvxyz[m/s]` (body FRD):
    /// `-` (stdin), a file path (followed while it is being written), or
    /// `tcp:HOST:PORT`.
    #[arg(long, default_value = "-")]
    pub imu: String,
    /// GPS week of the IMU time-of-week stamps.
    #[arg(long)]
    pub gps_week: u32,
    /// Nominal IMU rate [Hz] (gives the first sample's interval).
    #[arg(long, default_value_t = 100.0)]
    pub imu_rate: f64,
    /// Estimator: `hold` (test estimator: last GNSS position at every IMU
    /// sample; not a navigation filter) or `eskf` (`--kfgins-config` or `--platform`).
    #[arg(long, default_value = "hold")]
    pub estimator: String,
    /// KF-GINS YAML configuration for `--estimator eskf`: the ESKF is built
    /// exactly as `navfuse kf-gins` builds it (model, initial state, its
    /// start/end time window; times are handed to it as time of week, and the
    /// first solution is not written, as there) so both give the same
    /// solutions on the same data. The YAML's input paths are not read.
    #[arg(long)]
    pub kfgins_config: Option<PathBuf>,
    /// With `--kfgins-config`: navfuse's land-vehicle additions (as `kf-gins --enhanced`).
    #[arg(long)]
    pub enhanced: bool,
    /// `--estimator eskf` without a YAML: the platform profile; the filter
    /// aligns itself from the streams (static levelling, GNSS course or yaw GSF).
    #[arg(long)]
    pub platform: Option<navfuse_pipeline::profile::Platform>,
    /// With `--platform`: IMU noise preset (sensor model, docs/config.md).
    #[arg(long)]
    pub imu_preset: Option<String>,
    /// With `--platform`: GNSS antenna in the body frame FRD [m], `x,y,z`.
    #[arg(long, value_delimiter = ',', num_args = 3, default_values_t = [0.0, 0.0, 0.0])]
    pub lever_arm: Vec<f64>,
    /// Output file (default stdout).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
    /// Longest wall-clock wait [s] of an event for the other stream before it
    /// is released anyway (counted in the summary).
    #[arg(long, default_value_t = 1.0)]
    pub max_wait: f64,
    /// Seconds without new bytes after which a followed IMU file has ended.
    #[arg(long, default_value_t = 5.0)]
    pub idle: f64,
    /// Seconds to keep retrying a lost TCP IMU/NMEA connection before ending it.
    #[arg(long, default_value_t = 10.0)]
    pub reconnect_for: f64,
    /// Write the run summary as JSON to this file too.
    #[arg(long)]
    pub summary_json: Option<PathBuf>,
}

/// A message from a source thread.
enum Msg {
    ImuLine(Vec<u8>, Instant),
    ImuEnd,
    ImuNote(String),
    GpsdLine(Vec<u8>, Instant),
    Fix(GnssFix, Instant),
    GnssStats(RecordStats),
    GnssNote(String),
    GnssEnd,
    Reconnect(&'static str),
}

fn connect(addr: &str) -> io::Result<TcpStream> {
    let s = TcpStream::connect(addr)?;
    s.set_nodelay(true).ok();
    Ok(s)
}

/// Read lines from `r`, sending each with its arrival time. Returns at EOF.
fn pump_lines(
    r: impl Read,
    tx: &SyncSender<Msg>,
    mk: impl Fn(Vec<u8>, Instant) -> Msg,
) -> io::Result<()> {
    let mut r = BufReader::with_capacity(1 << 16, r);
    let mut buf = Vec::with_capacity(256);
    loop {
        buf.clear();
        // Bound a line's length: a line longer than 64 KiB is cut (and will be rejected).
        let n = (&mut r).take(1 << 16).read_until(b'\n', &mut buf)?;
        if n == 0 {
            return Ok(());
        }
        let now = Instant::now();
        if tx.send(mk(buf.clone(), now)).is_err() {
            return Ok(());
        }
    }
}

fn spawn_imu(spec: &str, idle: f64, reconnect_for: f64, tx: SyncSender<Msg>) {
    let spec = spec.to_string();
    std::thread::spawn(move || {
        let mk = Msg::ImuLine;
        let res = if spec == "-" {
            pump_lines(io::stdin().lock(), &tx, mk)
        } else if let Some(addr) = spec.strip_prefix("tcp:") {
            let mut last_ok = Instant::now();
            loop {
                match connect(addr) {
                    Ok(s) => {
                        let r = pump_lines(s, &tx, mk);
                        let _ = tx.send(Msg::Reconnect("imu"));
                        if let Err(e) = r {
                            let _ = tx.send(Msg::ImuNote(format!("imu {addr}: {e}")));
                        }
                        last_ok = Instant::now();
                    }
                    Err(e) => {
                        if last_ok.elapsed().as_secs_f64() > reconnect_for {
                            let _ = tx.send(Msg::ImuNote(format!("imu {addr}: giving up: {e}")));
                            break Ok(());
                        }
                    }
                }
                std::thread::sleep(Duration::from_millis(200));
            }
        } else {
            match std::fs::File::open(&spec) {
                Ok(f) => pump_lines(FollowReader::new(f, Duration::from_secs_f64(idle)), &tx, mk),
                Err(e) => Err(io::Error::new(e.kind(), format!("{spec}: {e}"))),
            }
        };
        if let Err(e) = res {
            let _ = tx.send(Msg::ImuNote(format!("imu: {e}")));
        }
        let _ = tx.send(Msg::ImuEnd);
    });
}

fn nmea_source(r: impl BufRead, name: &str, tx: &SyncSender<Msg>) {
    let mut rd = NmeaReader::new(r, name, NmeaOptions::default());
    for f in rd.by_ref() {
        match f {
            Ok(f) => {
                if tx.send(Msg::Fix(f, Instant::now())).is_err() {
                    return;
                }
            }
            Err(e) => {
                let _ = tx.send(Msg::GnssNote(e.to_string()));
            }
        }
    }
    if let Some(e) = rd.last_rejection() {
        let _ = tx.send(Msg::GnssNote(format!("last rejected NMEA line: {e}")));
    }
    let _ = tx.send(Msg::GnssStats(rd.stats().clone()));
}

fn spawn_gnss(spec: &str, reconnect_for: f64, tx: SyncSender<Msg>) -> Result<(), String> {
    let spec = spec.to_string();
    if spec == "none" {
        let _ = tx.send(Msg::GnssEnd);
        return Ok(());
    }
    if !(spec == "gpsd"
        || spec.starts_with("gpsd:")
        || spec.starts_with("nmea:")
        || spec.starts_with("nmea-tcp:"))
    {
        return Err(format!(
            "--gnss {spec:?}: expected gpsd[:HOST:PORT], nmea:-, nmea:PATH, nmea-tcp:HOST:PORT or none"
        ));
    }
    std::thread::spawn(move || {
        if spec == "gpsd" || spec.starts_with("gpsd:") {
            let addr = spec
                .strip_prefix("gpsd:")
                .unwrap_or("127.0.0.1:2947")
                .to_string();
            // gpsd: reconnect for as long as the run lasts.
            loop {
                match connect(&addr) {
                    Ok(mut s) => {
                        let w = s.write_all(b"?WATCH={\"enable\":true,\"json\":true};\n");
                        if w.is_ok() {
                            let _ = pump_lines(s, &tx, Msg::GpsdLine);
                        }
                        if tx.send(Msg::Reconnect("gpsd")).is_err() {
                            return;
                        }
                    }
                    Err(e) => {
                        if tx
                            .send(Msg::GnssNote(format!("gpsd {addr}: {e}; retrying")))
                            .is_err()
                        {
                            return;
                        }
                    }
                }
                std::thread::sleep(Duration::from_millis(250));
            }
        } else if let Some(addr) = spec.strip_prefix("nmea-tcp:") {
            let mut last_ok = Instant::now();
            loop {
                match connect(addr) {
                    Ok(s) => {
                        nmea_source(BufReader::new(s), addr, &tx);
                        let _ = tx.send(Msg::Reconnect("nmea-tcp"));
                        last_ok = Instant::now();
                    }
                    Err(e) => {
                        if last_ok.elapsed().as_secs_f64() > reconnect_for {
                            let _ = tx.send(Msg::GnssNote(format!("{addr}: giving up: {e}")));
                            break;
                        }
                    }
                }
                std::thread::sleep(Duration::from_millis(200));
            }
        } else {
            let path = spec.strip_prefix("nmea:").unwrap_or("-");
            if path == "-" {
                nmea_source(io::stdin().lock(), "<stdin>", &tx);
            } else {
                match std::fs::File::open(path) {
                    Ok(f) => nmea_source(BufReader::new(f), path, &tx),
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

pub fn run(args: Args) -> Result<(), String> {
    if args.gnss == "nmea:-" && args.imu == "-" {
        return Err("--gnss nmea:- and --imu - cannot both read stdin".into());
    }
    if !(args.max_wait.is_finite() && args.max_wait >= 0.0) {
        return Err(format!("--max-wait {}: must be ≥ 0", args.max_wait));
    }
    let (est, frame) = match (&args.kfgins_config, args.estimator.as_str()) {
        (Some(p), "eskf") => {
            let (e, f) = kfgins_eskf(p, args.enhanced, args.gps_week)?;
            (e, Some(f))
        }
        (Some(_), other) => {
            return Err(format!(
                "--kfgins-config goes with --estimator eskf, not {other:?}"
            ))
        }
        (None, "eskf") if args.platform.is_some() => {
            let e = aligning_eskf(args.platform, args.imu_preset.as_deref(), &args.lever_arm)?;
            (e, None)
        }
        (None, name) => (make_estimator(name)?, None),
    };
    let sink: Box<dyn Write> = match &args.out {
        Some(p) => Box::new(io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: cannot create: {e}", p.display()))?,
        )),
        None => Box::new(io::BufWriter::new(io::stdout())),
    };
    let mut out = Out::new(args.format, sink);

    let mut drv = LiveDriver::new(est, frame);
    let (tx, rx) = sync_channel::<Msg>(4096);
    spawn_gnss(&args.gnss, args.reconnect_for, tx.clone())?;
    spawn_imu(&args.imu, args.idle, args.reconnect_for, tx);

    let t0 = Instant::now();
    let secs = |i: Instant| i.duration_since(t0).as_secs_f64();
    let mut seq = Sequencer::new(args.max_wait, 1 << 17);
    let mut imu = ImuLineParser::new(args.gps_week, Some(args.imu_rate));
    let mut gpsd = GpsdAssembler::new();
    let mut gpsd_stats = RecordStats::default();
    let mut nmea_stats = RecordStats::default();
    let mut notes: Vec<String> = Vec::new();
    let mut imu_notes = 0u64;
    let mut reconnects: Vec<(&'static str, u64)> = Vec::new();
    let mut samples = Vec::with_capacity(2);
    let mut gnss_ended = false;
    let note = |notes: &mut Vec<String>, s: String| {
        if notes.len() < 20 {
            notes.push(s);
        }
    };

    loop {
        let msg = rx.recv_timeout(Duration::from_millis(5));
        let now = Instant::now();
        match msg {
            Ok(Msg::ImuLine(b, at)) => {
                samples.clear();
                if let Err((_, m)) = imu.push_line(&b, &mut samples) {
                    imu_notes += 1;
                    note(&mut notes, format!("imu line {}: {m}", imu.stats.lines));
                }
                for s in &samples {
                    seq.push_imu(*s, secs(at));
                }
            }
            Ok(Msg::ImuEnd) => {
                imu.finish();
                seq.end_imu();
            }
            Ok(Msg::ImuNote(m)) => note(&mut notes, m),
            Ok(Msg::GpsdLine(b, at)) => {
                gpsd_stats.lines += 1;
                match gpsd.push_line(&b) {
                    GpsdLine::Ignored => gpsd_stats.skipped += 1,
                    GpsdLine::Held => gpsd_stats.used += 1,
                    GpsdLine::Rejected(r, m) => {
                        gpsd_stats.reject(r);
                        note(
                            &mut notes,
                            format!("gpsd line {}: {r}: {m}", gpsd_stats.lines),
                        );
                    }
                }
                while let Some(f) = gpsd.pop() {
                    seq.push_gnss(f, secs(at));
                }
                seq.gnss_time_seen(gpsd.horizon());
            }
            Ok(Msg::Fix(f, at)) => {
                seq.push_gnss(f, secs(at));
            }
            Ok(Msg::GnssStats(s)) => {
                nmea_stats.lines += s.lines;
                nmea_stats.used += s.used;
                nmea_stats.skipped += s.skipped;
                for (r, n) in s.rejected {
                    for _ in 0..n {
                        nmea_stats.reject(r);
                    }
                }
            }
            Ok(Msg::GnssNote(m)) => note(&mut notes, m),
            Ok(Msg::GnssEnd) => {
                gnss_ended = true;
                gpsd.flush();
                while let Some(f) = gpsd.pop() {
                    seq.push_gnss(f, secs(now));
                }
                seq.end_gnss();
            }
            Ok(Msg::Reconnect(what)) => {
                if what == "gpsd" {
                    // A held epoch will not be completed by the new connection.
                    gpsd.flush();
                    while let Some(f) = gpsd.pop() {
                        seq.push_gnss(f, secs(now));
                    }
                }
                match reconnects.iter_mut().find(|r| r.0 == what) {
                    Some(r) => r.1 += 1,
                    None => reconnects.push((what, 1)),
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                seq.end_imu();
                seq.end_gnss();
            }
        }
        // Release whatever may go now.
        let nows = secs(Instant::now());
        let mut write = |s: &NavSolution| out.write(s);
        drv.release(&mut seq, nows, &|| secs(Instant::now()), &mut write)?;
        if seq.imu_ended() && seq.queued().0 == 0 {
            // Remaining GNSS fixes (if any) go to the estimator too, then stop.
            drv.finish(&mut seq, &mut write)?;
            break;
        }
    }

    let LiveDriver {
        est,
        outside,
        n_sol,
        n_gnss_sol,
        n_imu_nosol,
        lat,
        ..
    } = drv;
    let q = &seq.stats;
    let gnss_stats = if nmea_stats.lines > 0 {
        &nmea_stats
    } else {
        &gpsd_stats
    };
    let gnss_label = if nmea_stats.lines > 0 { "NMEA" } else { "gpsd" };
    let mut e = io::stderr().lock();
    let _ = writeln!(
        e,
        "live: estimator {} ({:.1} s wall)",
        est.name(),
        t0.elapsed().as_secs_f64()
    );
    let _ = writeln!(e, "  IMU input: {}", imu.stats);
    let _ = writeln!(
        e,
        "  GNSS input ({gnss_label}): {gnss_stats}{}",
        if gnss_ended {
            ""
        } else {
            " (source still open)"
        }
    );
    let _ = writeln!(
        e,
        "  sequencer: IMU {} in / {} out / {} late, GNSS {} in / {} out / {} late; released by timeout: IMU {}, GNSS {}; by queue bound {}",
        q.imu_in, q.imu_out, q.imu_late, q.gnss_in, q.gnss_out, q.gnss_late,
        q.imu_released_by_timeout, q.gnss_released_by_timeout, q.released_by_bound
    );
    let _ = writeln!(
        e,
        "  solutions: {n_sol} written ({n_gnss_sol} at GNSS events); {n_imu_nosol} IMU samples without a solution (estimator not initialised)"
    );
    let _ = writeln!(
        e,
        "  latency (IMU line read → solution written): p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms over {} samples",
        lat.quantile(0.5) * 1e3,
        lat.quantile(0.99) * 1e3,
        lat.max() * 1e3,
        lat.count()
    );
    if !reconnects.is_empty() {
        let _ = writeln!(e, "  reconnects: {reconnects:?}");
    }
    if !outside.is_empty() {
        let _ = writeln!(
            e,
            "  not handed to the estimator (kf-gins time window): {outside:?}"
        );
    }
    for n in &notes {
        let _ = writeln!(e, "  note: {n}");
    }
    if imu_notes > notes.len() as u64 {
        let _ = writeln!(e, "  ({imu_notes} IMU rejections in total)");
    }
    if let Some(p) = &args.summary_json {
        let j = format!(
            "{{\"estimator\":\"{}\",\"imu\":{},\"gnss\":{},\"gnss_source\":\"{gnss_label}\",\"imu_in\":{},\"imu_out\":{},\"imu_late\":{},\"gnss_in\":{},\"gnss_out\":{},\"gnss_late\":{},\"imu_released_by_timeout\":{},\"gnss_released_by_timeout\":{},\"released_by_bound\":{},\"solutions\":{n_sol},\"imu_without_solution\":{n_imu_nosol},\"latency_p50_ms\":{},\"latency_p99_ms\":{},\"latency_max_ms\":{},\"latency_n\":{}}}\n",
            est.name(),
            stats_json(&imu.stats),
            stats_json(gnss_stats),
            q.imu_in, q.imu_out, q.imu_late, q.gnss_in, q.gnss_out, q.gnss_late,
            q.imu_released_by_timeout, q.gnss_released_by_timeout, q.released_by_bound,
            jnum(lat.quantile(0.5) * 1e3, 4),
            jnum(lat.quantile(0.99) * 1e3, 4),
            jnum(lat.max() * 1e3, 4),
            lat.count()
        );
        std::fs::write(p, j).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// File sources end to end: malformed lines and a gap survive, every
    /// line is accounted for, and the output is the batch-order result.
    #[test]
    fn live_over_files_with_bad_lines() {
        use navfuse_core::types::Vec3;
        let dir = std::env::temp_dir().join(format!("navfuse_live_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let week = 2374u32;
        let tow0 = 243_300.0;
        // IMU 100 Hz for 3 s with a 0.5 s gap and three bad lines.
        let mut imu = String::new();
        for k in 0..300 {
            let tow = tow0 + k as f64 * 0.01;
            if (100..150).contains(&k) {
                continue;
            }
            imu.push_str(&format!("{tow:.3} 0 0 0 0 0 -0.098\n"));
            if k == 20 {
                imu.push_str("garbage line\n");
                imu.push_str(&format!("{tow:.3} 0 0 0 0 0 -0.098\n")); // duplicate time
                imu.push_str("1 2 3\n");
            }
        }
        // GNSS 4 Hz as NMEA, plus a corrupted sentence.
        let mut nmea = Vec::new();
        {
            let mut w = navfuse_io::nmea::NmeaWriter::new(&mut nmea);
            for k in 0..12 {
                let f = GnssFix {
                    t: navfuse_io::time::gps_seconds(week, tow0 + 0.25 * k as f64 + 0.005),
                    lat: 0.7 + 1e-7 * k as f64,
                    lon: -1.8,
                    h: 1600.0 + k as f64,
                    std_ned: Vec3::new(0.01, 0.01, 0.02),
                    quality: 1,
                    num_sats: 9,
                    ..Default::default()
                };
                w.write_fix(&f).unwrap();
            }
        }
        nmea.extend_from_slice(b"$GNGGA,broken*00\r\n");
        std::fs::write(dir.join("imu.txt"), imu).unwrap();
        std::fs::write(dir.join("gnss.nmea"), nmea).unwrap();
        let args = Args {
            gnss: format!("nmea:{}", dir.join("gnss.nmea").display()),
            imu: dir.join("imu.txt").display().to_string(),
            gps_week: week,
            imu_rate: 100.0,
            estimator: "hold".into(),
            kfgins_config: None,
            enhanced: false,
            platform: None,
            imu_preset: None,
            lever_arm: vec![0.0; 3],
            out: Some(dir.join("out.jsonl")),
            format: Format::Json,
            max_wait: 1e9,
            idle: 0.1,
            reconnect_for: 0.0,
            summary_json: Some(dir.join("summary.json")),
        };
        run(args).unwrap();
        let out = std::fs::read_to_string(dir.join("out.jsonl")).unwrap();
        let sols: Vec<serde_json::Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        // 250 IMU samples; the first fix (tow0 + 0.005) precedes sample 1.
        assert_eq!(sols.len(), 249);
        // Each solution holds the last fix at or before its time (+1 ms lead).
        for s in &sols {
            let tow = s["tow"].as_f64().unwrap();
            let k = ((tow - tow0 - 0.005 + 1e-3) / 0.25).floor() as i64;
            let h = s["h"].as_f64().unwrap();
            assert!(
                (h - (1600.0 + k.min(11) as f64)).abs() < 1e-3,
                "tow {tow}: h {h}"
            );
        }
        let sum: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(sum["imu"]["lines"], 253);
        assert_eq!(sum["imu"]["used"], 250);
        assert_eq!(sum["imu"]["rejected"]["duplicate time"], 1);
        assert_eq!(sum["gnss"]["rejected"]["bad checksum"], 1);
        assert_eq!(sum["gnss_in"], 12);
        assert_eq!(sum["imu_released_by_timeout"], 0);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
