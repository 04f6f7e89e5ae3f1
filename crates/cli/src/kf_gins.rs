//! `navfuse kf-gins CONFIG.yaml`: run an unmodified KF-GINS YAML configuration
//! with navfuse's ESKF in the KF-GINS model (21 states, GNSS position, same
//! timing of updates), writing KF-GINS's three output files.
//!
//! `--enhanced` adds navfuse's land-vehicle aiding (NHC, ZUPT/ZARU, χ² gating);
//! `--smooth` adds an RTS smoother pass (`KF_GINS_Navresult_smoothed.nav`).

use crate::run::{self as ingest, RunInput};
use clap::Args as ClapArgs;
use navfuse_core::estimators::eskf::{
    rts_smooth, Eskf, EskfConfig, EskfStats, ImuErrors, NhcConfig, SmoothedEpoch, ZuptConfig,
    I_ATT, I_BA, I_BG, I_POS, I_SA, I_SG, I_VEL, NX,
};
use navfuse_core::types::{Estimator, Event, GnssFix, NavSolution};
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Run a KF-GINS YAML configuration (drop-in replacement for KF-GINS).
#[derive(ClapArgs, Debug, Clone)]
pub struct Args {
    /// KF-GINS YAML configuration (paths inside are relative to it).
    pub config: PathBuf,
    /// navfuse's land-vehicle configuration: NHC, ZUPT/ZARU, χ² gating.
    #[arg(long)]
    pub enhanced: bool,
    /// Also run the RTS smoother and write `KF_GINS_Navresult_smoothed.nav`.
    #[arg(long)]
    pub smooth: bool,
    /// χ² innovation gate probability for the KF-GINS model (e.g. 0.9999);
    /// `--enhanced` always gates at 0.9999.
    #[arg(long)]
    pub gate: Option<f64>,
    /// Use GNSS positions only until this many seconds after `starttime`; after
    /// that only GNSS velocity (needs `gnssvelpath`) and height aid the INS
    /// (seed 001's after-370-s mode).
    #[arg(long)]
    pub position_until: Option<f64>,
    /// Write the outputs here instead of the YAML's `outputpath`.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Print a one-line summary with timing and update counts to stderr.
    #[arg(long, short)]
    pub verbose: bool,
    /// IMU–GNSS time offset added to the IMU stamps: seconds, `auto`
    /// (course-rate / yaw-rate cross-correlation) or `none`. Default: `auto`
    /// with `--enhanced`, else `none` (KF-GINS applies none).
    #[arg(long)]
    pub time_offset: Option<String>,
    /// Print accuracy against this reference (KF-GINS .nav layout of the
    /// antenna, e.g. `truth.nav`): horizontal/vertical RMS and, with
    /// `--outages`, the per-outage maximum horizontal drift and its RMS.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Print the horizontal/vertical RMS difference to another KF-GINS result
    /// (IMU positions, e.g. KF-GINS's own `KF_GINS_Navresult.nav`), at its epochs.
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Outage schedule for `--truth`: `START,LEN,PERIOD,COUNT` [s] (e.g. 243382,30,90,5).
    #[arg(long)]
    pub outages: Option<String>,
}

/// Everything a run produced (for the tests and the summary).
pub struct KfGinsRun {
    pub solutions: Vec<NavSolution>,
    pub smoothed: Vec<SmoothedEpoch>,
    pub stats: EskfStats,
    pub output_dir: PathBuf,
    pub config: EskfConfig,
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

pub fn run(args: Args) -> Result<(), String> {
    let t0 = Instant::now();
    let r = run_config(&args)?;
    if let Some(cp) = &args.compare {
        let other = check::read_nav(cp)?;
        let a = check::accuracy(&r.solutions, &other, &navfuse_core::Vec3::zeros());
        eprintln!(
            "vs {}: horizontal RMS {:.4} m, vertical RMS {:.4} m, max horizontal {:.4} m ({} epochs)",
            cp.display(), a.h_rms, a.v_rms, a.h_max, a.n
        );
    }
    if let Some(tp) = &args.truth {
        let truth = check::read_nav(tp)?;
        let lever = r.config.lever_arm_b;
        let outages = match &args.outages {
            Some(s) => Some(check::parse_outages(s)?),
            None => None,
        };
        let fixes = run_fix_times(&args)?;
        let print = |name: &str, sols: &[NavSolution]| {
            let a = check::accuracy(sols, &truth, &lever);
            eprintln!("{name}: horizontal RMS {:.4} m, vertical RMS {:.4} m, max horizontal {:.3} m ({} epochs)", a.h_rms, a.v_rms, a.h_max, a.n);
            if let Some(o) = &outages {
                let m = check::outage_drift(sols, &truth, &lever, o, &fixes);
                let rms = (m.iter().map(|x| x * x).sum::<f64>() / m.len().max(1) as f64).sqrt();
                eprintln!("{name}: per-outage max horizontal drift {m:.2?} m, RMS {rms:.2} m");
            }
        };
        print("forward", &r.solutions);
        if !r.smoothed.is_empty() {
            let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
            print("smoothed", &sm);
        }
    }
    if args.verbose {
        let s = &r.stats;
        eprintln!(
            "navfuse kf-gins: {} IMU samples, GNSS pos used {} (gated {}, forced {}), vel used {} (gated {}), height used {} (gated {}), NHC {}, ZUPT {}, ZARU {}, {:.3} s -> {}",
            s.imu_samples,
            s.gnss_pos_used,
            s.gnss_pos_rejected_gate,
            s.gnss_pos_forced,
            s.gnss_vel_used,
            s.gnss_vel_rejected_gate,
            s.height_used,
            s.height_rejected_gate,
            s.nhc_used,
            s.zupt_used,
            s.zaru_used,
            t0.elapsed().as_secs_f64(),
            r.output_dir.display()
        );
    }
    Ok(())
}

/// Read, filter, write. Returns the solutions too.
pub fn run_config(args: &Args) -> Result<KfGinsRun, String> {
    let t_read = Instant::now();
    let cfg = KfGinsConfig::load(&args.config)?;
    let mut input = ingest::read_kfgins(&cfg)?;
    let mode = match &args.time_offset {
        Some(s) => ingest::TimeOffset::parse(s).map_err(|e| format!("--time-offset: {e}"))?,
        None if args.enhanced => ingest::TimeOffset::Auto,
        None => ingest::TimeOffset::None,
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
            return Err(format!("--gate {g}: expected a probability in [0.9, 1)"));
        }
        ecfg.gate_probability = Some(g);
        ecfg.gate_deweight_factor = 100.0;
        ecfg.gnss_force_after = 5;
    }
    if let Some(p) = args.position_until {
        if cfg.gnssvelpath.is_none() {
            return Err(format!(
                "--position-until needs GNSS velocity: add `gnssvelpath:` to {}",
                args.config.display()
            ));
        }
        ecfg.position_until = Some(cfg.starttime + p);
    }
    let out_dir = match &args.output {
        Some(d) => d.clone(),
        None => cfg.resolve(&cfg.outputpath),
    };
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("{}: cannot create output folder: {e}", out_dir.display()))?;
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
    })
}

fn run_fix_times(args: &Args) -> Result<Vec<f64>, String> {
    let cfg = KfGinsConfig::load(&args.config)?;
    Ok(ingest::read_kfgins_gnss(&cfg.resolve(&cfg.gnsspath))?
        .iter()
        .map(|g| g.t)
        .collect())
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
) -> Result<(Vec<NavSolution>, Vec<SmoothedEpoch>), String> {
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
    let filtered = std::thread::scope(|scope| -> Result<(), String> {
        let writer = scope.spawn(move || -> Result<(), String> {
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
                    result = Err(format!(
                        "filter diverged (non-finite state) at t = {:.3} s",
                        s.t
                    ));
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
        let written = writer
            .join()
            .unwrap_or_else(|_| Err("output writer thread panicked".into()));
        result.and(written)
    });
    filtered?;
    let write = |name: &str, buf: &[u8]| {
        let p = out_dir.join(name);
        std::fs::write(&p, buf).map_err(|e| format!("{}: cannot write: {e}", p.display()))
    };
    let mut smoothed = Vec::new();
    if smooth {
        smoothed.reserve(records.len());
        rts_smooth(&records, |e| smoothed.push(*e));
        smoothed.reverse();
        let mut buf = Vec::with_capacity(smoothed.len() * 180);
        for e in &smoothed {
            let mut sol = NavSolution::unknown_at(e.t);
            sol.lat = e.nav.lat;
            sol.lon = e.nav.lon;
            sol.h = e.nav.h;
            sol.v_n = e.nav.v_n;
            sol.rpy = e.nav.rpy();
            write_nav_line(&mut buf, &sol);
        }
        write("KF_GINS_Navresult_smoothed.nav", &buf)?;
    }
    Ok((sols, smoothed))
}

/// What one output line of the three files needs.
struct OutRow {
    sol: NavSolution,
    err: ImuErrors,
    /// Diagonal of the error-state covariance.
    p_diag: [f64; NX],
}

impl OutRow {
    const BATCH: usize = 1024;
}

/// An output file written in chunks from a reused buffer.
struct OutFile {
    path: PathBuf,
    file: std::fs::File,
    buf: Vec<u8>,
}

impl OutFile {
    const CHUNK: usize = 1 << 18;

    fn create(dir: &Path, name: &str) -> Result<Self, String> {
        let path = dir.join(name);
        let file = std::fs::File::create(&path)
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        Ok(OutFile {
            path,
            file,
            buf: Vec::with_capacity(Self::CHUNK + 4096),
        })
    }

    fn write_out(&mut self) -> Result<(), String> {
        use std::io::Write as _;
        self.file
            .write_all(&self.buf)
            .map_err(|e| format!("{}: cannot write: {e}", self.path.display()))?;
        self.buf.clear();
        Ok(())
    }

    #[inline]
    fn flush_if_full(&mut self) -> Result<(), String> {
        if self.buf.len() >= Self::CHUNK {
            self.write_out()?;
        }
        Ok(())
    }

    fn finish(mut self) -> Result<(), String> {
        self.write_out()
    }
}

/// KF-GINS number layout: fixed 9 decimals, left-aligned in 15 columns, then a space.
#[inline]
pub(crate) fn put(buf: &mut Vec<u8>, x: f64) {
    let mut tmp = [b' '; 32];
    match fixed9_into(&mut tmp, x) {
        // Fixed-length copies (no memmove call for the common widths).
        Some(n) if n <= 15 => buf.extend_from_slice(&tmp[..16]),
        Some(n) if n <= 23 => buf.extend_from_slice(&tmp[..n + 1]),
        _ => {
            let start = buf.len();
            buf.extend_from_slice(format!("{x:.9}").as_bytes());
            while buf.len() - start < 15 {
                buf.push(b' ');
            }
            buf.push(b' ');
        }
    }
}

/// Fast `{:.9}` for |x| < 9e9 (falls back to `format!` beyond, and for NaN).
#[cfg(test)]
fn fixed9(buf: &mut Vec<u8>, x: f64) {
    let mut tmp = [b' '; 32];
    match fixed9_into(&mut tmp, x) {
        Some(n) => buf.extend_from_slice(&tmp[..n]),
        None => buf.extend_from_slice(format!("{x:.9}").as_bytes()),
    }
}

/// "00" … "99".
const PAIRS: [[u8; 2]; 100] = {
    let mut t = [[0u8; 2]; 100];
    let mut i = 0;
    while i < 100 {
        t[i] = [b'0' + (i / 10) as u8, b'0' + (i % 10) as u8];
        i += 1;
    }
    t
};

/// `{:.9}` of `x` (rounded half away from zero at 1e-9, i.e. as
/// `(|x|·1e9).round()`; `-0.000000000` printed without the sign) into `out`,
/// returning its length; `None` for NaN and |x| ≥ 9e9. Writes at most 21
/// bytes and leaves the rest of `out` untouched.
#[inline(always)]
fn fixed9_into(out: &mut [u8; 32], x: f64) -> Option<usize> {
    if x.is_nan() || x.abs() >= 9.0e9 {
        return None;
    }
    // round(|x|·1e9) half away from zero, exactly as f64::round (without the
    // libm call): y < 9e18 fits u64; below 2^52 `y − ⌊y⌋` is exact, above y
    // is an integer.
    let y = x.abs() * 1e9;
    let fl = y as u64;
    let scaled = if y - fl as f64 >= 0.5 { fl + 1 } else { fl };
    let mut n = 0;
    if x < 0.0 && scaled != 0 {
        out[0] = b'-';
        n = 1;
    }
    let int = scaled / 1_000_000_000;
    let frac = (scaled % 1_000_000_000) as u32;
    // Integer part (< 9e9, at most 10 digits), two digits at a time.
    let mut digits = [b'0'; 10];
    let mut i = digits.len();
    let mut v = int;
    while v >= 100 {
        i -= 2;
        digits[i..i + 2].copy_from_slice(&PAIRS[(v % 100) as usize]);
        v /= 100;
    }
    if v >= 10 {
        i -= 2;
        digits[i..i + 2].copy_from_slice(&PAIRS[v as usize]);
    } else {
        i -= 1;
        digits[i] = b'0' + v as u8;
    }
    let len = digits.len() - i;
    out[n..n + len].copy_from_slice(&digits[i..]);
    n += len;
    out[n] = b'.';
    n += 1;
    // Nine decimals as 4 + 5 digits (independent chains).
    let (hi, lo) = (frac / 100_000, frac % 100_000);
    let f: &mut [u8; 9] = (&mut out[n..n + 9])
        .try_into()
        .unwrap_or_else(|_| unreachable!());
    f[0..2].copy_from_slice(&PAIRS[(hi / 100) as usize]);
    f[2..4].copy_from_slice(&PAIRS[(hi % 100) as usize]);
    let (l1, l2) = (lo / 1000, lo % 1000);
    f[4..6].copy_from_slice(&PAIRS[l1 as usize]);
    f[6..8].copy_from_slice(&PAIRS[(l2 / 10) as usize]);
    f[8] = b'0' + (l2 % 10) as u8;
    Some(n + 9)
}

fn write_nav_line(buf: &mut Vec<u8>, s: &NavSolution) {
    let r2d = 180.0 / std::f64::consts::PI;
    let yaw = s.rpy.z * r2d;
    put(buf, 0.0);
    put(buf, s.t);
    put(buf, s.lat * r2d);
    put(buf, s.lon * r2d);
    put(buf, s.h);
    for v in s.v_n.iter() {
        put(buf, *v);
    }
    put(buf, s.rpy.x * r2d);
    put(buf, s.rpy.y * r2d);
    // KF-GINS writes yaw in [0, 360).
    put(buf, if yaw < 0.0 { yaw + 360.0 } else { yaw });
    buf.push(b'\n');
}

const DEG_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

fn write_err_line(buf: &mut Vec<u8>, t: f64, e: &ImuErrors) {
    put(buf, t);
    for v in e.bg.iter() {
        put(buf, v * DEG_H);
    }
    for v in e.ba.iter() {
        put(buf, v * 1e5);
    }
    for v in e.sg.iter() {
        put(buf, v * 1e6);
    }
    for v in e.sa.iter() {
        put(buf, v * 1e6);
    }
    buf.push(b'\n');
}

fn write_std_line(buf: &mut Vec<u8>, t: f64, p_diag: &[f64; NX]) {
    let sd = |i: usize| p_diag[i].max(0.0).sqrt();
    put(buf, t);
    for (i0, k) in [
        (I_POS, 1.0),
        (I_VEL, 1.0),
        (I_ATT, 180.0 / std::f64::consts::PI),
        (I_BG, DEG_H),
        (I_BA, 1e5),
        (I_SG, 1e6),
        (I_SA, 1e6),
    ] {
        for i in i0..i0 + 3 {
            put(buf, sd(i) * k);
        }
    }
    buf.push(b'\n');
}

/// A small accuracy check against a reference trajectory (the project's
/// evaluator lives in navfuse-eval; this keeps `kf-gins --truth` and the tests
/// self-contained).
pub mod check {
    use navfuse_core::earth;
    use navfuse_core::estimators::eskf::SmoothedEpoch;
    use navfuse_core::ins::mech::q_bn_from_rpy;
    use navfuse_core::types::NavSolution;
    use navfuse_core::Vec3;
    use std::path::Path;

    /// Solution of a smoothed epoch (no covariance).
    pub fn smoothed_solution(e: &SmoothedEpoch) -> NavSolution {
        let mut s = NavSolution::unknown_at(e.t);
        s.lat = e.nav.lat;
        s.lon = e.nav.lon;
        s.h = e.nav.h;
        s.v_n = e.nav.v_n;
        s.rpy = e.nav.rpy();
        s
    }

    /// Read a KF-GINS `.nav` (week tow lat lon h vN vE vD roll pitch yaw; attitude may be nan).
    pub fn read_nav(path: &Path) -> Result<Vec<NavSolution>, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let mut v = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<f64> = line
                .split_ascii_whitespace()
                .map(|s| s.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("{}:{}: {e}", path.display(), i + 1))?;
            if f.len() < 11 {
                return Err(format!(
                    "{}:{}: expected 11 fields, got {}",
                    path.display(),
                    i + 1,
                    f.len()
                ));
            }
            let mut s = NavSolution::unknown_at(f[1]);
            s.lat = f[2].to_radians();
            s.lon = f[3].to_radians();
            s.h = f[4];
            s.v_n = Vec3::new(f[5], f[6], f[7]);
            s.rpy = Vec3::new(f[8], f[9], f[10]).map(f64::to_radians);
            v.push(s);
        }
        Ok(v)
    }

    /// `START,LEN,PERIOD,COUNT` → outage intervals [start, end).
    pub fn parse_outages(s: &str) -> Result<Vec<(f64, f64)>, String> {
        let f: Vec<f64> = s
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("--outages {s:?}: {e}"))?;
        if f.len() != 4 || f[1] <= 0.0 || f[2] < f[1] || f[3] < 1.0 {
            return Err(format!("--outages {s:?}: expected START,LEN,PERIOD,COUNT"));
        }
        Ok((0..f[3] as usize)
            .map(|k| (f[0] + f[2] * k as f64, f[0] + f[2] * k as f64 + f[1]))
            .collect())
    }

    /// Antenna position of an IMU solution (lever arm in body FRD).
    pub fn antenna(s: &NavSolution, lever_b: &Vec3) -> (f64, f64, f64) {
        let l_n = q_bn_from_rpy(&s.rpy) * lever_b;
        let (rm, rn) = earth::radii(s.lat);
        (
            s.lat + l_n.x / (rm + s.h),
            s.lon + l_n.y / ((rn + s.h) * s.lat.cos()),
            s.h - l_n.z,
        )
    }

    /// NED error [m] of the solution's antenna (interpolated to `r.t`) against `r`.
    /// `None` outside the solution's time span.
    pub fn error_at(sols: &[NavSolution], r: &NavSolution, lever_b: &Vec3) -> Option<Vec3> {
        let k = sols.partition_point(|s| s.t < r.t);
        if k == 0 || k >= sols.len() {
            return (k < sols.len() && (sols[k].t - r.t).abs() < 1e-6).then(|| {
                let a = antenna(&sols[k], lever_b);
                ned(r, a)
            });
        }
        let (s0, s1) = (&sols[k - 1], &sols[k]);
        let w = (r.t - s0.t) / (s1.t - s0.t);
        let a0 = antenna(s0, lever_b);
        let a1 = antenna(s1, lever_b);
        let a = (
            a0.0 + w * (a1.0 - a0.0),
            a0.1 + w * (a1.1 - a0.1),
            a0.2 + w * (a1.2 - a0.2),
        );
        Some(ned(r, a))
    }

    fn ned(r: &NavSolution, a: (f64, f64, f64)) -> Vec3 {
        let (rm, rn) = earth::radii(r.lat);
        Vec3::new(
            (a.0 - r.lat) * (rm + r.h),
            (a.1 - r.lon) * (rn + r.h) * r.lat.cos(),
            -(a.2 - r.h),
        )
    }

    pub struct Accuracy {
        pub h_rms: f64,
        pub v_rms: f64,
        pub h_max: f64,
        pub n: usize,
    }

    /// Horizontal / vertical RMS of the antenna against every reference epoch in span.
    pub fn accuracy(sols: &[NavSolution], truth: &[NavSolution], lever_b: &Vec3) -> Accuracy {
        let (mut h2, mut v2, mut hm, mut n) = (0.0, 0.0, 0.0f64, 0usize);
        for r in truth {
            if let Some(e) = error_at(sols, r, lever_b) {
                let h = e.x.hypot(e.y);
                h2 += h * h;
                v2 += e.z * e.z;
                hm = hm.max(h);
                n += 1;
            }
        }
        let d = n.max(1) as f64;
        Accuracy {
            h_rms: (h2 / d).sqrt(),
            v_rms: (v2 / d).sqrt(),
            h_max: hm,
            n,
        }
    }

    /// Per outage [s, e): max horizontal error from `s` to the first fix at or after `e`.
    pub fn outage_drift(
        sols: &[NavSolution],
        truth: &[NavSolution],
        lever_b: &Vec3,
        outages: &[(f64, f64)],
        fix_times: &[f64],
    ) -> Vec<f64> {
        outages
            .iter()
            .map(|&(s, e)| {
                let k = fix_times.partition_point(|t| *t < e);
                let stop = fix_times.get(k).copied().unwrap_or(f64::INFINITY);
                truth
                    .iter()
                    .filter(|r| r.t >= s && r.t <= stop)
                    .filter_map(|r| error_at(sols, r, lever_b))
                    .map(|e| e.x.hypot(e.y))
                    .fold(0.0, f64::max)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed9_matches_std_formatting() {
        for x in [
            0.0,
            -0.0,
            1.5,
            -105.147447742,
            243262.014636,
            1e-10,
            -3.4e-9,
            357.9999999996,
        ] {
            let mut b = Vec::new();
            fixed9(&mut b, x);
            let mut want = format!("{x:.9}");
            if want == "-0.000000000" {
                want = "0.000000000".into();
            }
            assert_eq!(String::from_utf8(b).unwrap(), want, "x = {x}");
        }
        let mut b = Vec::new();
        put(&mut b, 1.0);
        assert_eq!(b.len(), 16);
        // Against the previous formatter's definition, `(|x|·1e9).round()`,
        // over many magnitudes and ties.
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for k in 0..200_000u32 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let mant = (s >> 11) as f64 / (1u64 << 53) as f64;
            let x = match k % 4 {
                0 => (mant - 0.5) * 10f64.powi((k % 19) as i32 - 9),
                1 => ((s % 2_000_000_001) as f64 - 1e9) * 1e-9 + 0.5e-9,
                2 => (mant - 0.5) * 1.7e10,
                _ => f64::from_bits(s) % 8.9e9,
            };
            if !x.is_finite() {
                continue;
            }
            let scaled = (x.abs() * 1e9).round() as u64;
            let mut want = String::new();
            if x < 0.0 && scaled != 0 {
                want.push('-');
            }
            want += &format!("{}.{:09}", scaled / 1_000_000_000, scaled % 1_000_000_000);
            if x.abs() >= 9.0e9 {
                want = format!("{x:.9}");
            }
            let mut b = Vec::new();
            fixed9(&mut b, x);
            assert_eq!(String::from_utf8(b).unwrap(), want, "x = {x:e}");
            let mut p = Vec::new();
            put(&mut p, x);
            assert!(p.len() >= 16 && p.starts_with(want.as_bytes()));
            assert!(p[want.len()..].iter().all(|&c| c == b' '));
        }
    }

    // ---- real-data checks (drive_0708) -----------------------------------

    use navfuse_io::data::require;
    use std::io::Write as _;

    const KFGINS_OUTAGE_RMS: f64 = 44.85;

    fn kfgins(rel: &str) -> PathBuf {
        require(&format!("drive_0708/kfgins/{rel}"))
    }

    fn temp_dir(name: &str) -> PathBuf {
        crate::test_dir(&format!("kfgins-{name}"))
    }

    fn args(config: PathBuf, out: &Path) -> Args {
        Args {
            config,
            enhanced: false,
            smooth: false,
            output: Some(out.to_path_buf()),
            verbose: false,
            time_offset: None,
            truth: None,
            outages: None,
            compare: None,
            position_until: None,
            gate: None,
        }
    }

    /// A copy of `kf-gins_full.yaml` in `dir` with absolute data paths, GNSS
    /// from `gnss` and optionally `gnssvelpath: vel`.
    fn yaml_copy(dir: &Path, gnss: &Path, vel: Option<&Path>) -> PathBuf {
        let src = kfgins("kf-gins_full.yaml");
        let text = std::fs::read_to_string(&src).unwrap();
        let imu = kfgins("imu.txt");
        let mut out = String::new();
        for line in text.lines() {
            if line.starts_with("imupath:") {
                out += &format!("imupath: \"{}\"\n", imu.display());
            } else if line.starts_with("gnsspath:") {
                out += &format!("gnsspath: \"{}\"\n", gnss.display());
                if let Some(v) = vel {
                    out += &format!("gnssvelpath: \"{}\"\n", v.display());
                }
            } else {
                out += line;
                out += "\n";
            }
        }
        let p = dir.join("config.yaml");
        std::fs::write(&p, out).unwrap();
        p
    }

    fn truth() -> Vec<NavSolution> {
        check::read_nav(&kfgins("truth.nav")).unwrap()
    }

    fn outage_rms(sols: &[NavSolution], lever: &navfuse_core::Vec3) -> (Vec<f64>, f64) {
        let outages = check::parse_outages("243382,30,90,5").unwrap();
        let fixes: Vec<f64> = crate::run::read_kfgins_gnss(&kfgins("gnss_outage.txt"))
            .unwrap()
            .iter()
            .map(|g| g.t)
            .collect();
        let m = check::outage_drift(sols, &truth(), lever, &outages, &fixes);
        let rms = (m.iter().map(|x| x * x).sum::<f64>() / m.len() as f64).sqrt();
        (m, rms)
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn parity_with_kfgins_full_run() {
        let out = temp_dir("parity-full");
        let r = run_config(&args(kfgins("kf-gins_full.yaml"), &out)).unwrap();
        let theirs = check::read_nav(&kfgins("kfgins_result_full_10hz.nav")).unwrap();
        let a = check::accuracy(&r.solutions, &theirs, &navfuse_core::Vec3::zeros());
        eprintln!(
            "vs KF-GINS: horizontal RMS {:.5} m over {} epochs",
            a.h_rms, a.n
        );
        assert!(a.n > 5000);
        assert!(a.h_rms < 0.05, "horizontal RMS vs KF-GINS {}", a.h_rms);
        // And its accuracy against the RTK truth (KF-GINS: 0.032 m).
        let t = check::accuracy(&r.solutions, &truth(), &r.config.lever_arm_b);
        eprintln!("vs truth: horizontal RMS {:.4} m", t.h_rms);
        assert!(t.h_rms < 0.05);
        // The three files exist with KF-GINS's column counts.
        for (f, cols) in [
            ("KF_GINS_Navresult.nav", 11),
            ("KF_GINS_IMU_ERR.txt", 13),
            ("KF_GINS_STD.txt", 22),
        ] {
            let text = std::fs::read_to_string(out.join(f)).unwrap();
            let first = text.lines().next().unwrap();
            assert_eq!(first.split_whitespace().count(), cols, "{f}");
            assert_eq!(text.lines().count(), r.solutions.len(), "{f}");
        }
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn parity_with_kfgins_outage_drift() {
        let out = temp_dir("parity-outage");
        let r = run_config(&args(kfgins("kf-gins_outage.yaml"), &out)).unwrap();
        let (m, rms) = outage_rms(&r.solutions, &r.config.lever_arm_b);
        eprintln!("outage maxima {m:.2?} m, RMS {rms:.2} m (KF-GINS {KFGINS_OUTAGE_RMS})");
        assert!((rms - KFGINS_OUTAGE_RMS).abs() < 0.15 * KFGINS_OUTAGE_RMS);
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn enhanced_and_smoothed_beat_kfgins_on_outages() {
        let out = temp_dir("enhanced-outage");
        let mut a = args(kfgins("kf-gins_outage.yaml"), &out);
        a.enhanced = true;
        a.smooth = true;
        let r = run_config(&a).unwrap();
        let lever = r.config.lever_arm_b;
        let (m, fwd) = outage_rms(&r.solutions, &lever);
        eprintln!("enhanced forward: maxima {m:.2?} m, RMS {fwd:.2} m");
        let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
        let (ms, smo) = outage_rms(&sm, &lever);
        eprintln!("enhanced smoothed: maxima {ms:.2?} m, RMS {smo:.2} m");
        assert!(fwd <= 10.0, "forward drift RMS {fwd}");
        assert!(smo <= 3.0, "smoothed drift RMS {smo}");
        assert!(out.join("KF_GINS_Navresult_smoothed.nav").exists());
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn enhanced_smoothed_full_run_tracks_rtk() {
        let out = temp_dir("enhanced-full");
        let mut a = args(kfgins("kf-gins_full.yaml"), &out);
        a.enhanced = true;
        a.smooth = true;
        let r = run_config(&a).unwrap();
        let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
        let acc = check::accuracy(&sm, &truth(), &r.config.lever_arm_b);
        eprintln!(
            "enhanced smoothed, 1 Hz GNSS: horizontal RMS {:.4} m",
            acc.h_rms
        );
        assert!(acc.n > 2000);
        assert!(acc.h_rms <= 0.03, "horizontal RMS {}", acc.h_rms);
    }

    /// GNSS velocity at the fix epochs from the RTKLIB .pos (its own vn/ve/vu
    /// and σ columns), in the `gnssvelpath` layout.
    fn write_velocity_file(path: &Path) {
        let fixes = crate::run::read_kfgins_gnss(&kfgins("gnss_full.txt")).unwrap();
        let pos = require("drive_0708/gnss_1934_sf.pos");
        let (rdr, name) = navfuse_io::open(&pos).unwrap();
        let mut f = std::fs::File::create(path).unwrap();
        let mut n = 0;
        for g in navfuse_io::pos::PosReader::new(rdr, &name) {
            let g = g.unwrap();
            let (_, tow) = navfuse_io::time::week_tow(g.t);
            let k = fixes.partition_point(|x| x.t < tow - 1e-3);
            if k < fixes.len() && (fixes[k].t - tow).abs() < 1e-3 {
                let (v, s) = (g.v_n.unwrap(), g.std_v_n.unwrap());
                writeln!(
                    f,
                    "{tow:.3} {} {} {} {} {} {}",
                    v.x, v.y, v.z, s.x, s.y, s.z
                )
                .unwrap();
                n += 1;
            }
        }
        assert!(n > 500, "only {n} velocity epochs matched");
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn paper_mode_velocity_and_height_after_300_s() {
        let dir = temp_dir("paper");
        let vel = dir.join("gnss_vel.txt");
        write_velocity_file(&vel);
        let cfg = yaml_copy(&dir, &kfgins("gnss_full.txt"), Some(&vel));
        let mut a = args(cfg, &dir.join("out"));
        a.position_until = Some(300.0);
        let r = run_config(&a).unwrap();
        assert!(r.stats.gnss_vel_used > 500 && r.stats.height_used > 200);
        assert!(r.stats.gnss_pos_used <= 301);
        let truth = truth();
        let last = truth
            .iter()
            .rev()
            .find(|t| t.t <= r.solutions.last().unwrap().t)
            .unwrap();
        let e = check::error_at(&r.solutions, last, &r.config.lever_arm_b).unwrap();
        let h = e.x.hypot(e.y);
        eprintln!(
            "paper mode: horizontal error at the end (t = {:.2}) {h:.2} m after {:.0} s without positions",
            last.t,
            last.t - 243262.0 - 300.0
        );
        assert!(h <= 3.0, "end error {h}");
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn injected_gnss_outliers_are_gated_and_counted() {
        use rand::{Rng, SeedableRng};
        let dir = temp_dir("outliers");
        let clean_cfg = yaml_copy(&dir, &kfgins("gnss_full.txt"), None);
        let mut a = args(clean_cfg, &dir.join("clean"));
        a.enhanced = true;
        let clean = run_config(&a).unwrap();
        // 50 fixes (after the first 60 s) moved 20–100 m in a random direction.
        let text = std::fs::read_to_string(kfgins("gnss_full.txt")).unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut picked = std::collections::BTreeSet::new();
        while picked.len() < 50 {
            picked.insert(rng.gen_range(60..lines.len() - 1));
        }
        for &k in &picked {
            let mut f: Vec<f64> = lines[k]
                .split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect();
            let d = rng.gen_range(20.0..100.0);
            let az: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let (rm, rn) = navfuse_core::earth::radii(f[1].to_radians());
            f[1] += (d * az.cos() / rm).to_degrees();
            f[2] += (d * az.sin() / (rn * f[1].to_radians().cos())).to_degrees();
            lines[k] = format!(
                "{:.3} {:.9} {:.9} {:.4} {} {} {}",
                f[0], f[1], f[2], f[3], f[4], f[5], f[6]
            );
        }
        let bad = dir.join("gnss_outliers.txt");
        std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
        let cfg = yaml_copy(&dir, &bad, None);
        let mut a = args(cfg, &dir.join("outliers"));
        a.enhanced = true;
        let r = run_config(&a).unwrap();
        let lever = r.config.lever_arm_b;
        let t = truth();
        let h0 = check::accuracy(&clean.solutions, &t, &lever).h_rms;
        let h1 = check::accuracy(&r.solutions, &t, &lever).h_rms;
        let extra = r.stats.gnss_pos_rejected_gate - clean.stats.gnss_pos_rejected_gate;
        eprintln!(
            "outliers: RMS clean {h0:.4} m, with 50 outliers {h1:.4} m; rejected {} (clean run {})",
            r.stats.gnss_pos_rejected_gate, clean.stats.gnss_pos_rejected_gate
        );
        assert!((h1 - h0).abs() < 0.02, "RMS changed by {}", h1 - h0);
        assert_eq!(extra, 50, "each injected outlier is rejected and counted");
        assert_eq!(r.stats.gnss_pos_forced, 0);
    }
}
