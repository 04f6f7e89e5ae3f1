//! `navfuse experiment soak`: `navfuse live` (a child process, default
//! options: self-aligning ESKF, car profile) against the replay server
//! ([`navfuse_pipeline::live_replay`]) over loopback TCP for hours of
//! stream time. Samples the child's resident memory (`VmRSS` of
//! /proc/PID/status) and CPU time (/proc/PID/stat) every `--sample-every`
//! seconds, drops each connection `--drops` times, stops the child with
//! SIGTERM once everything is sent, and checks that every record sent is
//! accounted for in its summary (used + skipped + rejected = lines sent).

use clap::Args as ClapArgs;
use navfuse_pipeline::live_replay::{serve, Recording, ReplayOptions};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Soak `navfuse live` against a looping replay server (docs/live.md).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Stream time to replay [h] (whole passes).
    #[arg(long, default_value_t = 10.0)]
    pub hours: f64,
    /// Replay speed (stream seconds per wall-clock second).
    #[arg(long, default_value_t = 20.0)]
    pub speed: f64,
    /// Recordings played in turn: `drive_0708` (KF-GINS files under
    /// $NAVFUSE_DATA) and/or `demo` (the simulated demo drive).
    #[arg(long, value_delimiter = ',', default_value = "drive_0708,demo")]
    pub recordings: Vec<String>,
    /// Connection drops per stream (IMU and GNSS), spread over the run.
    #[arg(long, default_value_t = 2)]
    pub drops: u64,
    /// Seconds between memory/CPU samples.
    #[arg(long, default_value_t = 60.0)]
    pub sample_every: f64,
    /// Directory for summary.json, soak.json and live's stderr.
    #[arg(long, default_value = "soak_out")]
    pub out: PathBuf,
    /// Where live writes its solutions (default: discarded).
    #[arg(long, default_value = "/dev/null")]
    pub solutions: PathBuf,
}

/// GPS week of drive_0708 (2025-07-08, data README).
const DRIVE_0708_WEEK: u32 = 2374;

fn load(names: &[String]) -> Result<Vec<Recording>, String> {
    names
        .iter()
        .map(|n| match n.as_str() {
            "drive_0708" => {
                let d = navfuse_io::data::require("drive_0708/kfgins");
                Recording::kfgins(
                    n,
                    &d.join("imu.txt"),
                    &d.join("gnss_full.txt"),
                    DRIVE_0708_WEEK,
                )
                .map_err(|e| e.to_string())
            }
            "demo" => Recording::demo().map_err(|e| e.to_string()),
            o => Err(format!("--recordings: unknown {o:?} (drive_0708, demo)")),
        })
        .collect()
}

/// (VmRSS [KiB], utime + stime [s]) of process `pid`.
fn proc_sample(pid: u32) -> Option<(u64, f64)> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let rss = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name (which may hold spaces): utime is the 14th field.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    // USER_HZ is 100 on every Linux ABI navfuse runs on (sysconf(_SC_CLK_TCK)).
    Some((rss, ticks / 100.0))
}

/// Least-squares slope of y over x.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    if x.len() < 2 {
        return f64::NAN;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

pub fn run(a: Args) -> Result<(), String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let recs = load(&a.recordings)?;
    let (passes, _) =
        navfuse_pipeline::live_replay::schedule(&recs, a.hours * 3600.0, DRIVE_0708_WEEK)?;
    let imu_total: u64 = passes
        .iter()
        .map(|p| recs[p.recording].imu.len() as u64)
        .sum();
    let gnss_total: u64 = passes
        .iter()
        .map(|p| recs[p.recording].gnss.len() as u64)
        .sum();
    let spread =
        |total: u64| -> Vec<u64> { (1..=a.drops).map(|k| total * k / (a.drops + 1)).collect() };
    let opt = ReplayOptions {
        speed: a.speed,
        duration_s: a.hours * 3600.0,
        week: DRIVE_0708_WEEK,
        imu_drops: spread(imu_total),
        gnss_drops: spread(gnss_total),
    };
    let replay = serve(recs, opt)?;
    let (stream_s, n_passes) = (replay.duration_s, replay.passes);
    let summary = a.out.join("summary.json");
    let exe = std::env::current_exe().map_err(|e| format!("current exe: {e}"))?;
    let log = std::fs::File::create(a.out.join("live.stderr")).map_err(|e| e.to_string())?;
    let mut child = Command::new(exe)
        .args(["live", "--gps-week", &DRIVE_0708_WEEK.to_string()])
        .arg(format!("--imu=tcp:127.0.0.1:{}", replay.imu_port))
        .arg(format!("--gnss=nmea-tcp:127.0.0.1:{}", replay.gnss_port))
        .args(["--platform", "car", "--reconnect-for", "inf"])
        .arg("--out")
        .arg(&a.solutions)
        .arg("--summary-json")
        .arg(&summary)
        .stdin(Stdio::null())
        .stderr(log)
        .spawn()
        .map_err(|e| format!("cannot start navfuse live: {e}"))?;
    let pid = child.id();
    eprintln!(
        "soak: {n_passes} passes, {:.2} h of stream at {}× (≈ {:.1} min wall), live pid {pid}",
        stream_s / 3600.0,
        a.speed,
        stream_s / a.speed / 60.0
    );
    let t0 = Instant::now();
    let mut samples: Vec<(f64, u64, f64)> = Vec::new();
    // The first sample once the child has started (RSS of the exec'd image).
    let mut next = 1.0;
    let sent = replay.sent.clone();
    let done = std::thread::spawn(move || replay.join());
    while !done.is_finished() {
        let el = t0.elapsed().as_secs_f64();
        if el >= next {
            if let Some((rss, cpu)) = proc_sample(pid) {
                samples.push((el, rss, cpu));
                eprintln!(
                    "soak: {:.2} h stream, RSS {rss} KiB, CPU {cpu:.1} s, IMU lines sent {}",
                    el * a.speed / 3600.0,
                    sent.imu_lines.load(Ordering::Relaxed)
                );
            }
            next += a.sample_every;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    done.join().map_err(|_| "replay panicked")??;
    // Let live take in what is in flight (its sequencer waits ≤ --max-wait 1 s).
    std::thread::sleep(Duration::from_secs(3));
    if let Some((rss, cpu)) = proc_sample(pid) {
        samples.push((t0.elapsed().as_secs_f64(), rss, cpu));
    }
    let wall_s = t0.elapsed().as_secs_f64();
    let kill = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status();
    if !kill.is_ok_and(|s| s.success()) {
        let _ = child.kill();
        return Err("cannot send SIGTERM to navfuse live".into());
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    let s: Value = serde_json::from_str(
        &std::fs::read_to_string(&summary).map_err(|e| format!("{}: {e}", summary.display()))?,
    )
    .map_err(|e| e.to_string())?;

    // Accounting: every line sent was read and counted once.
    let n = |v: &Value| v.as_u64().unwrap_or(0);
    let rejected = |v: &Value| -> u64 { v.as_object().map_or(0, |o| o.values().map(n).sum()) };
    let (imu, gnss) = (&s["imu"], &s["gnss"]);
    let imu_sent = sent.imu_lines.load(Ordering::Relaxed);
    let gnss_lines = sent.gnss_lines.load(Ordering::Relaxed);
    let gnss_fixes = sent.gnss_fixes.load(Ordering::Relaxed);
    let imu_acc = n(&imu["used"]) + n(&imu["skipped"]) + rejected(&imu["rejected"]);
    let gnss_acc = n(&gnss["used"]) + n(&gnss["skipped"]) + rejected(&gnss["rejected"]);
    let accounted = n(&imu["lines"]) == imu_sent
        && imu_acc == imu_sent
        && n(&gnss["lines"]) == gnss_lines
        && gnss_acc == gnss_lines
        && n(&s["gnss_in"]) == gnss_fixes;

    // Memory: start = the first sample after the first pass has aligned
    // (10 % of the run, at least the second sample); growth = least-squares
    // slope of RSS over stream hours from there on.
    let k0 = (samples.len() / 10)
        .max(1)
        .min(samples.len().saturating_sub(1));
    let h: Vec<f64> = samples[k0..]
        .iter()
        .map(|x| x.0 * a.speed / 3600.0)
        .collect();
    let r: Vec<f64> = samples[k0..].iter().map(|x| x.1 as f64 / 1024.0).collect();
    let growth = slope(&h, &r);
    let cpu_s = samples.last().map_or(f64::NAN, |x| x.2);
    let self_cpu = proc_sample(std::process::id()).map_or(f64::NAN, |x| x.1);
    let report = json!({
        "stream_hours": stream_s / 3600.0,
        "passes": n_passes,
        "speed": a.speed,
        "wall_s": wall_s,
        "live_exit_ok": status.success(),
        "rss_first_mib": samples.first().map(|x| x.1 as f64 / 1024.0),
        "rss_start_mib": samples.get(k0).map(|x| x.1 as f64 / 1024.0),
        "rss_end_mib": samples.last().map(|x| x.1 as f64 / 1024.0),
        "rss_growth_mib_per_stream_hour": growth,
        "live_cpu_s": cpu_s,
        "live_cpu_fraction_of_a_core": cpu_s / wall_s,
        "replay_and_harness_cpu_s": self_cpu,
        "latency_p50_ms": s["latency_p50_ms"],
        "latency_p99_ms": s["latency_p99_ms"],
        "reconnects_sent": {"imu": sent.imu_reconnects.load(Ordering::Relaxed),
                            "gnss": sent.gnss_reconnects.load(Ordering::Relaxed)},
        "reconnects_seen": s["reconnects"],
        "realigns": s["realigns"],
        "imu_lines_sent": imu_sent, "imu_lines_accounted": imu_acc,
        "gnss_lines_sent": gnss_lines, "gnss_lines_accounted": gnss_acc,
        "gnss_fixes_sent": gnss_fixes, "gnss_fixes_in": s["gnss_in"],
        "accounted": accounted,
        "solutions": s["solutions"],
        "samples_wall_s_rss_kib_cpu_s": samples,
    });
    let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    navfuse_io::atomic::write_atomic(&a.out.join("soak.json"), &text).map_err(|e| e.to_string())?;
    println!(
        "soak: {:.2} h of stream in {:.0} s wall ({} passes); live exit {}",
        stream_s / 3600.0,
        wall_s,
        n_passes,
        status
    );
    println!(
        "  RSS {:.1} MiB (first) / {:.1} MiB (start, after warm-up) → {:.1} MiB (end); growth {growth:.3} MiB per stream hour",
        report["rss_first_mib"].as_f64().unwrap_or(f64::NAN),
        report["rss_start_mib"].as_f64().unwrap_or(f64::NAN),
        report["rss_end_mib"].as_f64().unwrap_or(f64::NAN),
    );
    println!(
        "  CPU: live {cpu_s:.1} s ({:.1} % of a core), replay + harness {self_cpu:.1} s",
        100.0 * cpu_s / wall_s
    );
    println!(
        "  latency p50 {} ms, p99 {} ms; reconnects {}; realigns {}; solutions {}",
        s["latency_p50_ms"], s["latency_p99_ms"], s["reconnects"], s["realigns"], s["solutions"]
    );
    println!(
        "  accounted: IMU {imu_acc}/{imu_sent} lines, GNSS {gnss_acc}/{gnss_lines} lines, {}/{gnss_fixes} fixes: {}",
        s["gnss_in"],
        if accounted { "all" } else { "MISMATCH" }
    );
    if !status.success() {
        return Err(format!("navfuse live exited with {status}"));
    }
    if !accounted {
        return Err("soak: records sent and accounted differ (soak.json)".into());
    }
    Ok(())
}
