//! `navfuse kf-gins CONFIG.yaml` as a library call: run an unmodified
//! KF-GINS YAML configuration with navfuse's ESKF in the KF-GINS model (21
//! states, GNSS position, same timing of updates), writing KF-GINS's three
//! output files.
//!
//! `enhanced` adds navfuse's land-vehicle aiding (NHC, ZUPT/ZARU, χ² gating);
//! `smooth` adds an RTS smoother pass (`KF_GINS_Navresult_smoothed.nav` and
//! its σ, `KF_GINS_STD_smoothed.txt`).

pub use crate::check;
use crate::error::{PipelineError, Result};
use crate::kf_gins_align::{self, AlignDecision, AlignSource};
use crate::kf_gins_out::{write_err_line, write_nav_line, write_std_line, OutFile, OutRow};
use crate::kfgins_input::{read_kfgins, RunInput};
use crate::profile::Platform;
use crate::time_offset::{auto_estimate, describe, TimeOffset};
use navfuse_core::estimators::eskf::{rts_smooth, Eskf, EskfConfig, EskfStats, SmoothedEpoch};
use navfuse_core::types::{Estimator, Event, GnssFix, NavSolution};
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of a KF-GINS run (the CLI's `navfuse kf-gins` flags).
#[derive(Clone, Debug, Default)]
pub struct KfGinsOptions {
    /// navfuse's land-vehicle configuration ([`enhanced`]): NHC, ZUPT/ZARU, χ² gating.
    pub enhanced: bool,
    /// A platform profile's constraints and gating ([`crate::profile`]);
    /// `enhanced` is `Some(Platform::Car)`.
    pub platform: Option<Platform>,
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
    /// `none`. Default: `auto` (applied only when significant) with
    /// `enhanced` or a platform, else `none` (KF-GINS applies none).
    pub time_offset: Option<String>,
    /// Print the applied time offset and timings to stderr.
    pub verbose: bool,
    /// Initial state source ([`AlignSource`]); default `Auto` with
    /// `enhanced` or a platform, else `Yaml` (KF-GINS's behaviour).
    pub align: Option<AlignSource>,
    /// Also write `KF_GINS_Navresult.parquet` (and `_smoothed.parquet`):
    /// [`navfuse_io::parquet_out::solutions_table`], with the real GPS week
    /// and yaw in (−180°, 180°] where the `.nav` has week 0 and yaw in [0°, 360°).
    pub parquet: bool,
    /// Report the filter's own white-model σ even with a platform profile
    /// (KF-GINS's σ; the solutions are the same either way, only
    /// `KF_GINS_STD*.txt` and the solutions' σ differ).
    pub white_sigma: bool,
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
    /// Where the initial state came from, and why ([`kf_gins_align`]).
    pub align: AlignDecision,
    /// IMU–GNSS time offset applied [s] and how it was found.
    pub time_offset: Option<(f64, String)>,
    /// The correlated GNSS error model the σ is reported under (a platform
    /// profile only; `None`: the filter's own white-model σ, as KF-GINS)
    /// and how it was chosen ([`crate::gnss_error::white_gain_sigma_model`]).
    pub sigma_model: crate::gnss_error::SigmaModels,
}

/// navfuse's land-vehicle configuration on top of a KF-GINS model: the `car`
/// platform profile ([`crate::profile`], where every value has its physical
/// reason) — χ² gate 0.9999 with de-weighting, NHC σ 0.5 m/s at 10 Hz above
/// 0.5 m/s, standstill detection with ZUPT (0.02 m/s) and ZARU (0.1 °/s).
pub fn enhanced(c: EskfConfig) -> EskfConfig {
    Platform::Car.profile().apply(c)
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
        None if args.enhanced || args.platform.is_some() => TimeOffset::Auto,
        None => TimeOffset::None,
    };
    let mut applied = mode.resolve(&input.imu, &input.gnss)?;
    if mode == TimeOffset::Auto && applied.is_none() && args.verbose {
        // Not significant (or not estimable): none applied, as KF-GINS does.
        let e = auto_estimate(&input.imu, &input.gnss);
        eprintln!("IMU–GNSS time offset not applied: {}", describe(&e));
    }
    let platform = args.platform.or(args.enhanced.then_some(Platform::Car));
    let source = args.align.unwrap_or(if platform.is_some() {
        AlignSource::Auto
    } else {
        AlignSource::Yaml
    });
    let end = if cfg.endtime < 0.0 {
        f64::INFINITY
    } else {
        cfg.endtime
    };
    let mut ecfg = cfg.eskf_config();
    if let Some(p) = platform {
        ecfg = p.profile().apply(ecfg);
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
    if mode == TimeOffset::Auto && applied.is_none() {
        // The course variants may disagree: the filter's likelihood decides.
        let profile = platform.map(|p| p.profile());
        let (a, note) = crate::kf_gins_offset::likelihood_offset(
            yaml,
            &cfg,
            &ecfg,
            &input,
            profile.as_ref(),
            source,
            end,
        )?;
        if let (Some(n), true) = (note, args.verbose) {
            eprintln!("{n}");
        }
        applied = a;
    }
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
    let out_dir = match &args.output {
        Some(d) => d.clone(),
        None => cfg.resolve(&cfg.outputpath),
    };
    std::fs::create_dir_all(&out_dir)
        .map_err(PipelineError::io(&out_dir, "cannot create output folder: "))?;
    let i0 = input.imu.partition_point(|s| s.t < cfg.starttime);
    let profile = platform.map(|p| p.profile());
    let decision = kf_gins_align::decide(
        yaml,
        &cfg,
        &ecfg,
        &input.imu[i0..],
        &input.gnss,
        profile.as_ref(),
        source,
    )?;
    if source == AlignSource::Auto && decision.alignment.is_some() {
        eprintln!("warning: {}", decision.note);
    }
    let (mut eskf, start) = decision.start_filter(&cfg, &ecfg, &input.imu, i0);
    if args.verbose && !(source == AlignSource::Auto && decision.alignment.is_some()) {
        eprintln!("{}", decision.note);
    }
    // With a platform profile the σ is reported under the correlated fix
    // error `navfuse run` models on the same fixes (sensitivity covariance:
    // the gain, hence every solution, is unchanged). The plain KF-GINS model
    // keeps KF-GINS's own white-model σ.
    let sigma_model = if platform.is_some() && !args.white_sigma {
        let lo = input.gnss.partition_point(|f| f.t <= start);
        let hi = input.gnss.partition_point(|f| f.t <= end);
        crate::gnss_error::white_gain_sigma_model(&input.gnss[lo..hi.max(lo)], Some(&input.imu[..]))
    } else {
        crate::gnss_error::SigmaModels::default()
    };
    if let Some(m) = sigma_model.forward {
        eskf.start_sensitivity(m)
            .map_err(|e| PipelineError::Estimator(format!("sensitivity covariance: {e}")))?;
    }
    if let Some(m) = sigma_model.smoothed {
        eskf.start_smoother_sensitivity(m)
            .map_err(|e| PipelineError::Estimator(format!("smoothed sensitivity: {e}")))?;
    }
    if args.verbose && !sigma_model.how.is_empty() {
        eprintln!("{}", sigma_model.how);
    }

    let t_filter = Instant::now();
    let r = filter(&mut eskf, &input, start, end, &out_dir, args.smooth)?;
    if args.verbose {
        eprintln!("filter + write: {:.3} s", t_filter.elapsed().as_secs_f64());
    }
    if args.parquet {
        write_parquet(&out_dir, &r.0, &r.1)?;
    }
    Ok(KfGinsRun {
        solutions: r.0,
        smoothed: r.1,
        stats: *eskf.stats(),
        output_dir: out_dir,
        config: ecfg,
        time_offset: applied,
        align: decision,
        sigma_model,
    })
}

fn write_parquet(dir: &Path, sols: &[NavSolution], smoothed: &[SmoothedEpoch]) -> Result<()> {
    let write = |name: &str, s: &[NavSolution]| {
        navfuse_io::parquet_out::write_solutions(&dir.join(name), s)
            .map_err(|e| PipelineError::Output(e.to_string()))
    };
    write("KF_GINS_Navresult.parquet", sols)?;
    if !smoothed.is_empty() {
        let sm: Vec<NavSolution> = smoothed.iter().map(check::smoothed_solution).collect();
        write("KF_GINS_Navresult_smoothed.parquet", &sm)?;
    }
    Ok(())
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
        // The files are committed only once the filter has finished without
        // error: a failed run leaves no output (or the previous one).
        let writer = scope.spawn(move || -> Result<[OutFile; 3]> {
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
            nav.write_out()?;
            err.write_out()?;
            std.write_out()?;
            Ok([nav, err, std])
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
                // The σ reported: the sensitivity covariance when started.
                let p = eskf.reported_covariance();
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
        result?;
        written?.into_iter().try_for_each(OutFile::finish)
    });
    filtered?;
    let write = |name: &str, buf: &[u8]| {
        let p = out_dir.join(name);
        navfuse_io::atomic::write_atomic(&p, buf).map_err(PipelineError::io(&p, "cannot write: "))
    };
    let mut smoothed = Vec::new();
    if smooth {
        smoothed.reserve(records.len());
        rts_smooth(&records, eskf.last_record_covariance(), |e| {
            smoothed.push(*e)
        });
        smoothed.reverse();
        let mut buf = Vec::with_capacity(smoothed.len() * 180);
        for e in &smoothed {
            write_nav_line(&mut buf, &check::smoothed_solution(e));
        }
        write("KF_GINS_Navresult_smoothed.nav", &buf)?;
        // The smoothed covariance in KF-GINS's STD layout.
        buf.clear();
        for e in &smoothed {
            let mut d = [0.0; navfuse_core::estimators::eskf::NX];
            d.copy_from_slice(e.p_diag.as_slice());
            write_std_line(&mut buf, e.t, &d);
        }
        write("KF_GINS_STD_smoothed.txt", &buf)?;
    }
    Ok((sols, smoothed))
}
