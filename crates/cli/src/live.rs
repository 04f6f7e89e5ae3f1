//! `navfuse live`: fuse a live GNSS stream (gpsd, NMEA on stdin/TCP/serial
//! device) with live IMU lines (stdin, a file being written, TCP, serial
//! device) and write solutions, with their σ, at the IMU rate as JSON lines
//! or NMEA (docs/live.md).
//!
//! The estimator (by default the self-aligning ESKF) runs through the
//! `Estimator` trait, driven by [`navfuse_pipeline::live::LiveDriver`] and
//! fed by [`navfuse_io::live::Sequencer`], which reproduces the event order
//! of a batch run (time order, IMU before GNSS at equal times), so live and
//! batch solutions agree whenever no event had to be released by timeout
//! (the summary counts those). Every input line is counted used, skipped or
//! rejected by reason ([`navfuse_pipeline::live_session::Inputs`]); the
//! summary is printed to stderr at the end of the IMU input or on
//! SIGINT/SIGTERM (exit 0; a second SIGINT exits at once) and, with
//! `--summary-json`, written as JSON.
//!
//! Threads: one per input source ([`navfuse_io::live_source`]: reading
//! lines, reconnecting with backoff), the main thread sequencing,
//! estimating and writing. Channels are bounded, so a slow consumer
//! back-pressures the readers instead of growing memory.

pub mod soak;

use crate::fail::Fail;
use clap::Args as ClapArgs;
use navfuse_io::live::Sequencer;
use navfuse_io::live_source::{spawn_gnss, spawn_imu, Msg};
use navfuse_io::live_ubx::spawn_ubx;
use navfuse_pipeline::live::{
    aligning_eskf, kfgins_eskf, make_estimator, Format, LiveDriver, LiveEst, Out,
};
use navfuse_pipeline::live_session::{End, Inputs};
use std::io::{self, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, RecvTimeoutError};
use std::sync::Arc;
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
    /// GPS week of the IMU time-of-week stamps (not needed with `--ubx`,
    /// whose data carry their date).
    #[arg(long, required_unless_present_any = ["ubx", "carrier_phase"])]
    pub gps_week: Option<u32>,
    /// A u-blox UBX stream carrying IMU (ESF-RAW/ESF-MEAS), GNSS (NAV-PVT),
    /// wheel ticks and dual-antenna heading (NAV-RELPOSNED) in place of
    /// `--imu` and `--gnss`: `-` (stdin), `tcp:HOST:PORT`, a serial device
    /// (configured beforehand, e.g. with stty) or a file / FIFO.
    #[arg(long, conflicts_with_all = ["imu", "gnss"])]
    pub ubx: Option<String>,
    /// With `--ubx`: distance per wheel tick [m] (without it tick data are
    /// rejected and counted).
    #[arg(long)]
    pub ubx_metres_per_tick: Option<f64>,
    /// With `--ubx`: the ESF sensor time tag unit [s].
    #[arg(long)]
    pub ubx_esf_tick_s: Option<f64>,
    /// Nominal IMU rate [Hz] (gives the first sample's interval).
    #[arg(long, default_value_t = 100.0)]
    pub imu_rate: f64,
    /// Estimator: `eskf` (default: aligns itself from the streams with the
    /// `--platform` profile, or starts from `--kfgins-config`), `cp-att`
    /// (seed 003 attitude on `--carrier-phase` with `--cp-config`) or `hold`
    /// (test estimator: last GNSS position at every IMU sample; not a
    /// navigation filter).
    #[arg(long, default_value = "eskf")]
    pub estimator: String,
    /// With `--estimator cp-att`: the carrier-phase CSV stream (`-`, a
    /// file / FIFO / serial device, `tcp:HOST:PORT`; format of `[input]
    /// carrier_phase`), in place of `--imu` and `--gnss`.
    #[arg(long, requires = "cp_config")]
    pub carrier_phase: Option<String>,
    /// With `--estimator cp-att`: a run configuration whose `[cp_att]` gives
    /// the antenna geometry and bounds (as `navfuse run --estimator cp-att`).
    #[arg(long)]
    pub cp_config: Option<PathBuf>,
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
    /// aligns itself from the streams (static levelling, GNSS course or yaw
    /// GSF). Default: `car`, as `navfuse run` (a note says so on stderr).
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
    /// Seconds to keep retrying a lost TCP or serial IMU/NMEA source (with
    /// backoff 0.1 s doubling to 5 s) before ending it; `inf` retries forever.
    #[arg(long, default_value_t = 60.0)]
    pub reconnect_for: f64,
    /// Write the run summary as JSON to this file too.
    #[arg(long)]
    pub summary_json: Option<PathBuf>,
}

/// The signal that stopped the run (0: none).
fn signal_name(sig: usize) -> &'static str {
    match sig as i32 {
        signal_hook::consts::SIGINT => "SIGINT",
        signal_hook::consts::SIGTERM => "SIGTERM",
        _ => "a signal",
    }
}

/// SIGINT and SIGTERM store their number in the returned flag; a second
/// SIGINT/SIGTERM ends the process at once (exit 1).
fn stop_on_signals() -> Result<Arc<AtomicUsize>, String> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let stop = Arc::new(AtomicUsize::new(0));
    let armed = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        let err = |e: io::Error| format!("cannot handle signal {sig}: {e}");
        signal_hook::flag::register_conditional_shutdown(sig, 1, armed.clone()).map_err(err)?;
        signal_hook::flag::register(sig, armed.clone()).map_err(err)?;
        signal_hook::flag::register_usize(sig, stop.clone(), sig as usize).map_err(err)?;
    }
    Ok(stop)
}

/// The estimator the options ask for, and the kf-gins time window (YAML).
fn estimator(
    args: &Args,
) -> Result<(LiveEst, Option<navfuse_pipeline::live::KfGinsFrame>), String> {
    Ok(match (&args.kfgins_config, args.estimator.as_str()) {
        (Some(p), "eskf") => {
            let (e, f) = kfgins_eskf(p, args.enhanced, args.gps_week.unwrap_or(0))?;
            (LiveEst::Boxed(e), Some(f))
        }
        (Some(_), other) => {
            return Err(format!(
                "--kfgins-config goes with --estimator eskf, not {other:?}"
            ))
        }
        (None, "eskf") => {
            if args.platform.is_none() {
                eprintln!("live: no --platform: the car profile, as `navfuse run`");
            }
            let e = aligning_eskf(
                args.platform,
                args.imu_preset.as_deref(),
                &args.lever_arm,
                args.ubx.is_some(),
            )?;
            (e, None)
        }
        (None, name) => (LiveEst::Boxed(make_estimator(name)?), None),
    })
}

pub fn run(args: Args) -> Result<(), Fail> {
    if args.gnss == "nmea:-" && args.imu == "-" {
        return Err(Fail::usage(
            "--gnss nmea:- and --imu - cannot both read stdin",
        ));
    }
    if !(args.max_wait.is_finite() && args.max_wait >= 0.0) {
        return Err(Fail::usage(format!(
            "--max-wait {}: must be ≥ 0",
            args.max_wait
        )));
    }
    if args.reconnect_for.is_nan() || args.reconnect_for < 0.0 {
        return Err(Fail::usage(format!(
            "--reconnect-for {}: must be ≥ 0",
            args.reconnect_for
        )));
    }
    if args.estimator == "cp-att" {
        return cp_att(&args);
    }
    let (est, frame) = estimator(&args)?;
    let sink = open_sink(&args)?;
    let mut out = Out::new(args.format, sink);
    let stop = stop_on_signals()?;

    let mut drv = LiveDriver::new(est, frame);
    let (tx, rx) = sync_channel::<Msg>(4096);
    if let Some(spec) = &args.ubx {
        let cfg = navfuse_pipeline::ubx_input::events_config(
            args.ubx_metres_per_tick,
            args.ubx_esf_tick_s,
            args.imu_rate,
        )
        .map_err(Fail::usage)?;
        spawn_ubx(spec, cfg, args.reconnect_for, tx)?;
    } else {
        spawn_gnss(&args.gnss, args.reconnect_for, tx.clone())?;
        spawn_imu(&args.imu, args.idle, args.reconnect_for, tx);
    }

    let t0 = Instant::now();
    let secs = |i: Instant| i.saturating_duration_since(t0).as_secs_f64();
    let mut seq = Sequencer::new(args.max_wait, 1 << 17);
    let mut inputs = Inputs::new(args.gps_week.unwrap_or(0), args.imu_rate);
    let mut end = End::default();
    loop {
        let msg = rx.recv_timeout(Duration::from_millis(5));
        let now = secs(Instant::now());
        match msg {
            Ok(m) => inputs.handle(m, &mut seq, &secs, now),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                seq.end_imu();
                seq.end_gnss();
            }
        }
        let sig = stop.load(Ordering::Relaxed);
        if sig != 0 && end.stopped_by.is_none() {
            // What has already arrived is used; the sources are not waited for.
            for _ in 0..(1 << 14) {
                let Ok(m) = rx.try_recv() else { break };
                inputs.handle(m, &mut seq, &secs, secs(Instant::now()));
            }
            seq.end_imu();
            seq.end_gnss();
            end.stopped_by = Some(signal_name(sig));
        }
        let mut write = |s: &navfuse_core::types::NavSolution| out.write(s);
        let nows = secs(Instant::now());
        drv.release(&mut seq, nows, &|| secs(Instant::now()), &mut write)
            .map_err(|e| Fail::from(e.to_string()))?;
        if seq.imu_ended() && seq.queued().0 == 0 {
            // Remaining GNSS fixes (if any) go to the estimator too, then stop.
            drv.finish(&mut seq, &mut write)
                .map_err(|e| Fail::from(e.to_string()))?;
            break;
        }
    }
    end.wall_s = t0.elapsed().as_secs_f64();
    eprint!("{}", inputs.summary_text(&drv, &seq, &end));
    // An empty or all-rejected IMU stream is an error, never a silent
    // success; the (empty) solution stream is removed and no summary file
    // claims a finished run.
    let st = inputs.imu_stats();
    if st.used == 0 {
        drop(out);
        if let Some(p) = &args.out {
            let _ = std::fs::remove_file(p);
        }
        return Err(Fail::input(format!(
            "live: no usable IMU records from {} ({} lines, {} rejected)",
            args.ubx.as_deref().unwrap_or(&args.imu),
            st.lines,
            st.rejected.iter().map(|r| r.1).sum::<u64>()
        )));
    }
    if let Some(p) = &args.summary_json {
        let j = inputs.summary_json(&drv, &seq, &end);
        navfuse_io::atomic::write_atomic(p, format!("{j}\n"))
            .map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(())
}

/// `--estimator cp-att`: CP-ATT on the `--carrier-phase` stream
/// ([`navfuse_pipeline::live_cp_att`]).
fn cp_att(args: &Args) -> Result<(), Fail> {
    let (Some(spec), Some(cfg)) = (&args.carrier_phase, &args.cp_config) else {
        return Err(Fail::usage(
            "--estimator cp-att needs --carrier-phase SPEC and --cp-config RUN.toml",
        ));
    };
    let cfg = navfuse_pipeline::config::RunConfig::from_toml_file(cfg)?;
    let (src, name) = navfuse_pipeline::live_cp_att::open_source(spec).map_err(|e| e.0)?;
    let sink = open_sink(args)?;
    let mut out = Out::new(args.format, sink);
    let stop = stop_on_signals()?;
    let s = navfuse_pipeline::live_cp_att::run_live_cp_att(&cfg, src, &name, &mut out, &|| {
        stop.load(Ordering::Relaxed) != 0
    })
    .map_err(|e| e.0)?;
    eprintln!(
        "live: estimator cp-att: {} solutions; epoch interval {} s\n  input: {}\n  estimator: {}",
        s.solutions, s.epoch_interval_s, s.input, s.estimator
    );
    Ok(())
}

/// The solution stream's sink: `--out FILE` (created) or standard output.
fn open_sink(args: &Args) -> Result<Box<dyn Write>, Fail> {
    Ok(match &args.out {
        Some(p) => Box::new(io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: cannot create: {e}", p.display()))?,
        )),
        None => Box::new(io::BufWriter::new(io::stdout())),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// File sources end to end: malformed lines and a gap survive, every
    /// line is accounted for, and the output is the batch-order result.
    #[test]
    fn live_over_files_with_bad_lines() {
        use navfuse_core::types::{GnssFix, Vec3};
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
            gps_week: Some(week),
            ubx: None,
            ubx_metres_per_tick: None,
            ubx_esf_tick_s: None,
            carrier_phase: None,
            cp_config: None,
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
