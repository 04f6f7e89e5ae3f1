//! `navfuse kf-gins CONFIG.yaml` as a library call: run an unmodified
//! KF-GINS YAML configuration with navfuse's ESKF in the KF-GINS model (21
//! states, GNSS position, same timing of updates), writing KF-GINS's three
//! output files.
//!
//! `enhanced` adds navfuse's land-vehicle aiding (NHC, ZUPT/ZARU, χ² gating);
//! `smooth` adds an RTS smoother pass (`KF_GINS_Navresult_smoothed.nav`).

pub use crate::check;
use crate::error::{PipelineError, Result};
use crate::kf_gins_out::{write_err_line, write_nav_line, write_std_line, OutFile, OutRow};
use crate::kfgins_input::{read_kfgins, RunInput};
use crate::time_offset::TimeOffset;
use navfuse_core::estimators::eskf::{
    rts_smooth, Eskf, EskfConfig, EskfStats, NhcConfig, SmoothedEpoch, ZuptConfig,
};
use navfuse_core::types::{Estimator, Event, GnssFix, NavSolution};
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of a KF-GINS run (the CLI's `navfuse kf-gins` flags).
#[derive(Clone, Debug, Default)]
pub struct KfGinsOptions {
    /// navfuse's land-vehicle configuration ([`enhanced`]): NHC, ZUPT/ZARU, χ² gating.
    pub enhanced: bool,
    /// Also run the RTS smoother and write `KF_GINS_Navresult_smoothed.nav`.
    pub smooth: bool,
    /// χ² innovation gate probability for the KF-GINS model, in [0.9, 1).
    pub gate: Option<f64>,
    /// Use GNSS positions only until this many seconds after `starttime`;
    /// after that only GNSS velocity (needs `gnssvelpath`) and height.
    pub position_until: Option<f64>,
    /// Write the outputs here instead of the YAML's `outputpath`.
    pub output: Option<PathBuf>,
    /// IMU–GNSS time offset added to the IMU stamps: seconds, `auto` or
    /// `none`. Default: `auto` with `enhanced`, else `none`.
    pub time_offset: Option<String>,
    /// Print the applied time offset and timings to stderr.
    pub verbose: bool,
}

/// Everything a run produced (for the tests and the summary).
pub struct KfGinsRun {
    /// Forward solutions as written (from the second IMU sample on).
    pub solutions: Vec<NavSolution>,
    /// RTS-smoothed epochs in time order (empty unless `smooth`).
    pub smoothed: Vec<SmoothedEpoch>,
    /// Update counters.
    pub stats: EskfStats,
    /// Folder written.
    pub output_dir: PathBuf,
    /// Filter configuration used.
    pub config: EskfConfig,
    /// IMU–GNSS time offset applied [s] and how it was found.
    pub time_offset: Option<(f64, String)>,
}

/// navfuse's best land-vehicle configuration on top of a KF-GINS model.
///
/// - χ² gate at 0.9999 on every update; innovations up to 100× the gate
///   (Mahalanobis distance ≈ 46 for 3 dof) are de-weighted (R·NIS/gate), beyond
///   are rejected; after 5 consecutive rejected GNSS
///   positions the next is applied ungated (no lock-out after a divergence).
/// - NHC: lateral and vertical body velocity 0 ± 0.5 m/s at 10 Hz above
///   0.5 m/s. The σ covers the IMU's offset from the axles, mounting
///   misalignment and vibration; chosen from 0.05–1.0 m/s on drive_0708
///   (0.1 over-constrains: a false along-track correction in the first
///   outage; 1.0 under-uses the constraint).
/// - Standstill: 0.5-s window with std |f| < 0.1 m/s², gyro std < 2 °/s
///   (the engine idles at 1–1.5 °/s rms), mean f within 0.2 m/s² of gravity
///   at the current attitude and filter speed < 1 m/s; then ZUPT (σ 0.02 m/s)
///   at 10 Hz and ZARU (σ 0.1 °/s) once per window.
pub fn enhanced(mut c: EskfConfig) -> EskfConfig {
    c.gate_probability = Some(0.9999);
    c.gate_deweight_factor = 100.0;
    c.gnss_force_after = 5;
    c.nhc = Some(NhcConfig {
        std: 0.5,
        interval: 0.1,
        min_speed: 0.5,
    });
    c.zupt = Some(ZuptConfig {
        window: 50,
        max_accel_std: 0.1,
        max_gyro_std: 2.0f64.to_radians(),
        max_accel_dev: 0.2,
        max_speed: 1.0,
        vel_std: 0.02,
        zaru_std: Some(0.1f64.to_radians()),
        interval: 0.1,
    });
    c
}

/// Run the KF-GINS YAML `yaml` (paths inside relative to it): read, filter,
/// write the three KF-GINS files (and the smoothed `.nav`). Prints to stderr
/// a warning when `auto` finds no time offset (then none is applied, as
/// KF-GINS does), and with `verbose` the offset and timings.
pub fn run_kf_gins(yaml: &Path, args: &KfGinsOptions) -> Result<KfGinsRun> {
    let t_read = Instant::now();
    let cfg = KfGinsConfig::load(yaml).map_err(PipelineError::Input)?;
    let mut input = read_kfgins(&cfg)?;
    let mode = match &args.time_offset {
        Some(s) => TimeOffset::parse(s)
            .map_err(|e| PipelineError::Options(format!("--time-offset: {e}")))?,
        None if args.enhanced => TimeOffset::Auto,
        None => TimeOffset::None,
    };
    let applied = match mode.resolve(&input.imu, &input.gnss) {
        Ok(a) => a,
        // auto without an estimate: run without an offset, as KF-GINS does.
        Err(e) => {
            eprintln!("IMU–GNSS {e}; none applied");
            None
        }
    };
    if let Some((tau, how)) = &applied {
        for s in input.imu.iter_mut() {
            s.t += tau;
        }
        if args.verbose {
            eprintln!("IMU–GNSS time offset {tau:+.3} s added to the IMU stamps ({how})");
        }
    }
    if args.verbose {
        eprintln!("read inputs: {:.3} s", t_read.elapsed().as_secs_f64());
    }
    let mut ecfg = cfg.eskf_config();
    if args.enhanced {
        ecfg = enhanced(ecfg);
    }
    if args.smooth {
        ecfg.smoother_every = 10;
    }
    if let Some(g) = args.gate {
        if !(0.9..1.0).contains(&g) {
            return Err(PipelineError::Options(format!(
                "--gate {g}: expected a probability in [0.9, 1)"
            )));
        }
        ecfg.gate_probability = Some(g);
        ecfg.gate_deweight_factor = 100.0;
        ecfg.gnss_force_after = 5;
    }
    if let Some(p) = args.position_until {
        if cfg.gnssvelpath.is_none() {
            return Err(PipelineError::Options(format!(
                "--position-until needs GNSS velocity: add `gnssvelpath:` to {}",
                yaml.display()
            )));
        }
        ecfg.position_until = Some(cfg.starttime + p);
    }
    let out_dir = match &args.output {
        Some(d) => d.clone(),
        None => cfg.resolve(&cfg.outputpath),
    };
    std::fs::create_dir_all(&out_dir)
        .map_err(PipelineError::io(&out_dir, "cannot create output folder: "))?;
    let end = if cfg.endtime < 0.0 {
        f64::INFINITY
    } else {
        cfg.endtime
    };
    let mut eskf = Eskf::new(ecfg, cfg.init_nav(), cfg.init_errors(), &cfg.init_std());
    let t_filter = Instant::now();
    let r = filter(&mut eskf, &input, cfg.starttime, end, &out_dir, args.smooth)?;
    if args.verbose {
        eprintln!("filter + write: {:.3} s", t_filter.elapsed().as_secs_f64());
    }
    Ok(KfGinsRun {
        solutions: r.0,
        smoothed: r.1,
        stats: *eskf.stats(),
        output_dir: out_dir,
        config: ecfg,
        time_offset: applied,
    })
}

/// KF-GINS's event order: IMU from the first sample at/after `start`, GNSS
/// fixes after `start`; a fix is handed over before the IMU sample whose
/// interval contains it.
fn filter(
    eskf: &mut Eskf,
    input: &RunInput,
    start: f64,
    end: f64,
    out_dir: &Path,
    smooth: bool,
) -> Result<(Vec<NavSolution>, Vec<SmoothedEpoch>)> {
    let imu = &input.imu;
    let gnss: &[GnssFix] = &input.gnss;
    let i0 = imu.partition_point(|s| s.t < start);
    let mut g = gnss.partition_point(|f| f.t <= start);
    let n = imu.len() - i0;
    let mut sols = Vec::with_capacity(n);
    let mut records = Vec::new();
    // The three files are formatted and written on a second thread, fed in
    // batches, while the filter runs (output identical to a serial write).
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<OutRow>>(4);
    let filtered = std::thread::scope(|scope| -> Result<()> {
        let writer = scope.spawn(move || -> Result<()> {
            // Streamed through reused buffers (no file-sized allocations to fault in).
            let mut nav = OutFile::create(out_dir, "KF_GINS_Navresult.nav")?;
            let mut err = OutFile::create(out_dir, "KF_GINS_IMU_ERR.txt")?;
            let mut std = OutFile::create(out_dir, "KF_GINS_STD.txt")?;
            for batch in rx {
                for row in &batch {
                    write_nav_line(&mut nav.buf, &row.sol);
                    write_err_line(&mut err.buf, row.sol.t, &row.err);
                    write_std_line(&mut std.buf, row.sol.t, &row.p_diag);
                    nav.flush_if_full()?;
                    err.flush_if_full()?;
                    std.flush_if_full()?;
                }
            }
            nav.finish()?;
            err.finish()?;
            std.finish()
        });
        let mut batch = Vec::with_capacity(OutRow::BATCH);
        let mut result = Ok(());
        for (k, s) in imu[i0..].iter().enumerate() {
            if s.t > end {
                break;
            }
            while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
                eskf.push(&Event::Gnss(gnss[g]));
                g += 1;
            }
            let sol = eskf.push(&Event::Imu(*s));
            if let Some(r) = eskf.take_record() {
                records.push(r);
            }
            // KF-GINS writes from the second sample on (the first only initialises).
            if let (Some(sol), true) = (sol, k > 0) {
                if !(sol.lat.is_finite()
                    && sol.h.is_finite()
                    && sol.v_n.iter().all(|v| v.is_finite()))
                {
                    result = Err(PipelineError::Estimator(format!(
                        "filter diverged (non-finite state) at t = {:.3} s",
                        s.t
                    )));
                    break;
                }
                let p = eskf.covariance();
                batch.push(OutRow {
                    sol,
                    err: *eskf.imu_errors(),
                    p_diag: core::array::from_fn(|i| p[(i, i)]),
                });
                if batch.len() == OutRow::BATCH {
                    let full = std::mem::replace(&mut batch, Vec::with_capacity(OutRow::BATCH));
                    if tx.send(full).is_err() {
                        break; // the writer failed: its error is reported below
                    }
                }
                sols.push(sol);
            }
        }
        if result.is_ok() && !batch.is_empty() {
            let _ = tx.send(batch);
        }
        drop(tx);
        let written = writer.join().unwrap_or_else(|_| {
            Err(PipelineError::Output(
                "output writer thread panicked".into(),
            ))
        });
        result.and(written)
    });
    filtered?;
    let write = |name: &str, buf: &[u8]| {
        let p = out_dir.join(name);
        std::fs::write(&p, buf).map_err(PipelineError::io(&p, "cannot write: "))
    };
    let mut smoothed = Vec::new();
    if smooth {
        smoothed.reserve(records.len());
        rts_smooth(&records, |e| smoothed.push(*e));
        smoothed.reverse();
        let mut buf = Vec::with_capacity(smoothed.len() * 180);
        for e in &smoothed {
            write_nav_line(&mut buf, &check::smoothed_solution(e));
        }
        write("KF_GINS_Navresult_smoothed.nav", &buf)?;
    }
    Ok((sols, smoothed))
}
