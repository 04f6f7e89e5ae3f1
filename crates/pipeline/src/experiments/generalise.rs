//! The generalisation matrix: platforms car / robot / pedestrian / uav × IMU
//! grade consumer / industrial / tactical × GNSS rtk / consumer × true IMU
//! time offset 0 / 0.1 s, seeds 0…n−1 per cell (even seeds start with a
//! static hold, odd seeds start moving), each seed run in the three
//! [`Variant`]s on the same simulated data.
//!
//! Scores (all from motion start + 60 s, motion start = first truth epoch
//! faster than 0.2 m/s; pooled over the seeds of a cell):
//! - `h_rms_m`: horizontal RMS of the solutions against `traj.at(sol.t)`;
//! - `outage_rms_of_max_m`: per outage window the max horizontal error in
//!   it, RMS over all windows of all seeds;
//! - `nees_h`: mean horizontal NEES (2 dof, diagonal σ_N, σ_E);
//! - `coverage95_h`: share of epochs with NEES ≤ χ²₂(95 %) = 5.991.
//!
//! Targets (the issue's, fixed before any run): default ≤ 1.2 × oracle in
//! both h_rms and outage drift; default ≤ kfgins_model in both.
//!
//! Beside the strict pooled comparison each cell carries the paired
//! per-seed ratios ([`super::paired`]): default/oracle and default/kfgins of
//! the per-seed h_rms and outage drift with a 95 % interval, and whether the
//! default is *significantly* above 1.2 × oracle or above the KF-GINS model.
//! The strict targets stay the issue's; the paired ones say which misses are
//! larger than the seed scatter.

use super::paired::{paired_ratio, PairedRatio};
use super::score::{motion_start, score_run, RunDiag, RunScore};
use super::{run_variant, variant_config, ExperimentError, Variant};
use navfuse_sim::platform::{
    platform_run, GnssGrade, ImuGrade, Outages, Platform, PlatformOptions, PlatformRun,
};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Scores start this long after the motion start [s] (the issue's: the
/// alignment transient is judged separately by [`super::align_check`]).
pub const SCORE_AFTER_MOTION_S: f64 = 60.0;
/// Seeds per cell by default. The issue asks for ≥ 10; 10 cannot resolve
/// the σ band [0.90, 0.99] of `coverage95_h`: a consumer receiver's error
/// correlates over ~1 min, so a 600 s run holds ≈ 10 independent stretches
/// of it, 10 seeds ≈ 100, and a true coverage of 0.95 is read with a
/// standard error of √(0.95·0.05/100) ≈ 0.02 — the band's edges are 2 SE
/// away. The simulator's GNSS error depends on the seed only, so every IMU
/// grade and offset of a platform shares those draws and the cells move
/// together (10 consumer-GNSS cells read 0.990–0.996 on seeds 0–9, 0.95–0.98
/// on seeds 0–29). 30 seeds bring the SE to ≈ 0.013.
pub const DEFAULT_SEEDS: u64 = 30;
/// Target: default ≤ this × oracle (h_rms and outage drift).
pub const ORACLE_RATIO_TARGET: f64 = 1.2;
/// The true IMU time offsets of the matrix [s].
pub const OFFSETS_S: [f64; 2] = [0.0, 0.1];

/// One cell of the matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub platform: Platform,
    pub imu: ImuGrade,
    pub gnss: GnssGrade,
    /// True IMU time offset τ [s] (true time = IMU stamp + τ).
    pub offset_s: f64,
}

impl Cell {
    /// `platform:imu:gnss:offset`, e.g. `car:industrial:rtk:0.1`.
    pub fn name(&self) -> String {
        format!(
            "{}:{}:{}:{}",
            self.platform, self.imu, self.gnss, self.offset_s
        )
    }
}

/// The full matrix in its fixed order (platform, IMU, GNSS, offset).
pub fn matrix() -> Vec<Cell> {
    matrix_with(&OFFSETS_S)
}

/// The matrix with other true time offsets [s] (e.g. the ±50/±200 ms check).
pub fn matrix_with(offsets: &[f64]) -> Vec<Cell> {
    cells_of(&Platform::MATRIX, offsets)
}

/// Every simulated platform's cells (the matrix's plus `marine`), for
/// `--cells` to choose from.
pub fn all_platforms_with(offsets: &[f64]) -> Vec<Cell> {
    cells_of(&Platform::ALL, offsets)
}

fn cells_of(platforms: &[Platform], offsets: &[f64]) -> Vec<Cell> {
    let mut v = Vec::new();
    for &platform in platforms {
        for imu in ImuGrade::ALL {
            for gnss in GnssGrade::ALL {
                for &offset_s in offsets {
                    v.push(Cell {
                        platform,
                        imu,
                        gnss,
                        offset_s,
                    });
                }
            }
        }
    }
    v
}

/// The cells of [`all_platforms_with`] (the matrix and `marine`) matching
/// any of the comma-separated patterns
/// `platform[:imu[:gnss[:offset]]]` (`*` or a missing part matches all), e.g.
/// `car,uav:tactical:*:0.1`. Error when a pattern matches no cell.
pub fn select_cells(patterns: &str) -> Result<Vec<Cell>, ExperimentError> {
    select_cells_in(all_platforms_with(&OFFSETS_S), patterns)
}

/// [`select_cells`] among `all`.
pub fn select_cells_in(all: Vec<Cell>, patterns: &str) -> Result<Vec<Cell>, ExperimentError> {
    let pats: Vec<Vec<String>> = patterns
        .split(',')
        .map(|p| {
            p.trim()
                .split(':')
                .map(|s| s.trim().to_ascii_lowercase())
                .collect()
        })
        .collect();
    let matches = |c: &Cell, p: &[String]| {
        let parts = [
            c.platform.to_string(),
            c.imu.to_string(),
            c.gnss.to_string(),
            c.offset_s.to_string(),
        ];
        p.iter().zip(&parts).all(|(want, have)| {
            want == "*"
                || want == have
                || matches!((want.parse::<f64>(), have.parse::<f64>()), (Ok(a), Ok(b)) if a == b)
        })
    };
    for p in &pats {
        if p.len() > 4 || !all.iter().any(|c| matches(c, p)) {
            return Err(ExperimentError::Options(format!(
                "--cells: pattern '{}' matches no cell (platform:imu:gnss:offset, e.g. car:industrial:rtk:0.1)",
                p.join(":")
            )));
        }
    }
    Ok(all
        .into_iter()
        .filter(|c| pats.iter().any(|p| matches(c, p)))
        .collect())
}

/// Options of [`run_generalise`].
#[derive(Clone, Debug, Serialize)]
pub struct GeneraliseOptions {
    /// Seeds per cell (seeds `seed0 … seed0 + seeds − 1`).
    pub seeds: u64,
    pub seed0: u64,
    /// Trajectory length [s].
    pub duration_s: f64,
    /// Also run [`Variant::DefaultKnownOffset`] (the time-offset check's
    /// reference): `default_known_offset` and the paired ratios to it.
    pub known_offset: bool,
    /// IMU output rate [Hz] (the matrix's: 100).
    pub imu_rate_hz: f64,
    /// GNSS output rate [Hz] instead of the grade's 1 Hz (`None`: 1 Hz).
    /// With the rates the sweep asks whether the defaults hold on sensor
    /// rates the matrix never had.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gnss_rate_hz: Option<f64>,
}

impl Default for GeneraliseOptions {
    fn default() -> Self {
        GeneraliseOptions {
            seeds: DEFAULT_SEEDS,
            seed0: 0,
            duration_s: 600.0,
            known_offset: false,
            imu_rate_hz: 100.0,
            gnss_rate_hz: None,
        }
    }
}

/// Pooled scores of one variant in one cell (NaN → `null` in JSON).
#[derive(Clone, Debug, Serialize)]
pub struct VariantScores {
    pub h_rms_m: f64,
    pub outage_rms_of_max_m: f64,
    pub nees_h: f64,
    pub coverage95_h: f64,
    /// Runs scored, outage windows scored.
    pub runs_ok: usize,
    pub outages: usize,
    /// `seed N: message` of every run that errored or could not be scored.
    pub failures: Vec<String>,
    /// IMU time offset each scored run applied [s] (0: none), seed order.
    pub time_offset_applied_s: Vec<f64>,
}

/// Pass/fail of the targets in one cell. A cell whose default runs failed
/// (any seed) fails both; a metric that is undefined on both sides (no
/// outage window in a short run) is not compared.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Targets {
    /// default ≤ 1.2 × oracle (h_rms and outage drift).
    pub default_vs_oracle: bool,
    /// default ≤ kfgins_model (h_rms and outage drift).
    pub default_vs_kfgins: bool,
    /// Paired: default not significantly above 1.2 × oracle (95 %, both metrics).
    pub default_vs_oracle_paired: bool,
    /// Paired: default not significantly above kfgins_model (95 %, both metrics).
    pub default_vs_kfgins_paired: bool,
}

/// Paired per-seed ratios of the default to the oracle and to the KF-GINS
/// model (h_rms and outage drift; see [`super::paired`]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PairedReport {
    pub h_rms_vs_oracle: PairedRatio,
    pub outage_vs_oracle: PairedRatio,
    pub h_rms_vs_kfgins: PairedRatio,
    pub outage_vs_kfgins: PairedRatio,
    /// Default over the default given the true offset (with `known_offset`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub h_rms_vs_known_offset: Option<PairedRatio>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outage_vs_known_offset: Option<PairedRatio>,
}

/// One cell's result.
#[derive(Clone, Debug, Serialize)]
pub struct CellReport {
    pub platform: String,
    pub imu: String,
    pub gnss: String,
    pub offset_s: f64,
    pub seeds: u64,
    pub default: VariantScores,
    pub oracle: VariantScores,
    pub kfgins_model: VariantScores,
    /// The default given the true offset (`known_offset` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub default_known_offset: Option<VariantScores>,
    pub paired: PairedReport,
    pub targets: Targets,
    /// One row per seed: what the pooled scores hide (a single seed that
    /// goes wrong) and why (the default's alignment, yaw error, warnings).
    pub per_seed: Vec<SeedRow>,
}

/// One seed of a cell: h_rms and outage drift of default / oracle /
/// kfgins_model (NaN → `null`: failed or no outage), and the default run's
/// diagnostics (`None`: it failed).
#[derive(Clone, Debug, Serialize)]
pub struct SeedRow {
    pub seed: u64,
    pub h_rms_m: [f64; 3],
    pub outage_rms_of_max_m: [f64; 3],
    pub default: Option<RunDiag>,
    /// h_rms and outage drift of the default given the true offset
    /// (`known_offset` only; NaN where it failed).
    pub known_offset: Option<[f64; 2]>,
}

/// The experiment's settings, written beside the cells.
#[derive(Clone, Debug, Serialize)]
pub struct GeneraliseConfig {
    pub options: GeneraliseOptions,
    pub score_after_motion_s: f64,
    pub motion_speed_m_s: f64,
    pub oracle_ratio_target: f64,
    pub outages: String,
    pub static_start: &'static str,
    pub variants: &'static str,
}

/// The whole result (`--json`).
#[derive(Clone, Debug, Serialize)]
pub struct GeneraliseReport {
    pub cells: Vec<CellReport>,
    pub config: GeneraliseConfig,
    /// Wall-clock seconds of the whole matrix.
    pub wall_seconds: f64,
}

/// The platform options of a cell and seed (even seeds: static start).
pub fn cell_options(cell: &Cell, seed: u64, duration_s: f64) -> PlatformOptions {
    PlatformOptions {
        duration_s,
        static_start: seed.is_multiple_of(2),
        imu: cell.imu,
        gnss: cell.gnss,
        imu_time_offset_s: cell.offset_s,
        outages: Outages::default(),
        ..Default::default()
    }
}

/// Scores of the variants of one seed (`Err`: the message): the three of
/// [`Variant::ALL`], then [`Variant::DefaultKnownOffset`] (`Err` "not run"
/// without `known_offset`).
type SeedScores = [Result<RunScore, String>; 4];

fn run_seed(cell: &Cell, seed: u64, opt: &GeneraliseOptions) -> SeedScores {
    let popt = PlatformOptions {
        imu_rate_hz: opt.imu_rate_hz,
        gnss_rate_hz: opt.gnss_rate_hz,
        ..cell_options(cell, seed, opt.duration_s)
    };
    let pr = match platform_run(cell.platform, seed, &popt) {
        Ok(pr) => pr,
        Err(e) => {
            let m = format!("simulation: {e}");
            return [Err(m.clone()), Err(m.clone()), Err(m.clone()), Err(m)];
        }
    };
    let [d, o, k] = Variant::ALL.map(|v| score_variant(v, &pr));
    let known = if opt.known_offset {
        score_variant(Variant::DefaultKnownOffset, &pr)
    } else {
        Err("not run".into())
    };
    [d, o, k, known]
}

fn score_variant(v: Variant, pr: &PlatformRun) -> Result<RunScore, String> {
    let t_move = motion_start(&pr.run.traj).ok_or("the platform never moves")?;
    let r = run_variant(&variant_config(v, pr), pr).map_err(|e| e.to_string())?;
    let mut s = score_run(
        &r.solutions,
        &pr.run.traj,
        t_move + SCORE_AFTER_MOTION_S,
        &pr.outages,
    );
    s.tau_applied = r.time_offset_applied.as_ref().map_or(0.0, |a| a.0);
    s.diag.align_method = r.align_method.to_string();
    s.diag.align_wait_s = r.align_wait_s;
    s.diag.align_yaw_std_deg = r.align_yaw_std_deg;
    s.diag.warnings = r.warnings.clone();
    s.diag.tau_applied_s = s.tau_applied;
    s.diag.time_offset_passes = r.time_offset_passes.clone().unwrap_or_default();
    if s.n == 0 {
        return Err("no solution after motion start + 60 s".into());
    }
    if !s.sum_e2.is_finite() {
        return Err("non-finite position error (diverged)".into());
    }
    Ok(s)
}

fn pool(cell_seeds: &[(u64, &SeedScores)], k: usize) -> VariantScores {
    let (mut sum_e2, mut n, mut omax, mut nees, mut nees_n, mut in95) =
        (0.0, 0usize, Vec::new(), 0.0, 0usize, 0usize);
    let mut failures = Vec::new();
    let mut runs_ok = 0;
    let mut taus = Vec::new();
    for (seed, s) in cell_seeds {
        match &s[k] {
            Ok(r) => {
                runs_ok += 1;
                taus.push(r.tau_applied);
                sum_e2 += r.sum_e2;
                n += r.n;
                omax.extend_from_slice(&r.outage_max);
                nees += r.nees_sum;
                nees_n += r.nees_n;
                in95 += r.nees_in95;
            }
            Err(m) => failures.push(format!("seed {seed}: {m}")),
        }
    }
    let ratio = |a: f64, b: usize| if b == 0 { f64::NAN } else { a / b as f64 };
    VariantScores {
        h_rms_m: ratio(sum_e2, n).sqrt(),
        outage_rms_of_max_m: super::rms(&omax),
        nees_h: ratio(nees, nees_n),
        coverage95_h: ratio(in95 as f64, nees_n),
        runs_ok,
        outages: omax.len(),
        failures,
        time_offset_applied_s: taus,
    }
}

/// Per-seed h_rms and outage drift (RMS of the outage maxima) of variant
/// `k` (NaN where the run failed or has no outage).
fn per_seed(cell_seeds: &[(u64, &SeedScores)], k: usize) -> (Vec<f64>, Vec<f64>) {
    cell_seeds
        .iter()
        .map(|(_, s)| match &s[k] {
            Ok(r) if r.n > 0 => ((r.sum_e2 / r.n as f64).sqrt(), super::rms(&r.outage_max)),
            _ => (f64::NAN, f64::NAN),
        })
        .unzip()
}

fn paired_report(rows: &[(u64, &SeedScores)], known_offset: bool) -> PairedReport {
    let [(dh, dout), (oh, oout), (kh, kout), (nh, nout)] = [0, 1, 2, 3].map(|k| per_seed(rows, k));
    PairedReport {
        h_rms_vs_oracle: paired_ratio(&dh, &oh),
        outage_vs_oracle: paired_ratio(&dout, &oout),
        h_rms_vs_kfgins: paired_ratio(&dh, &kh),
        outage_vs_kfgins: paired_ratio(&dout, &kout),
        h_rms_vs_known_offset: known_offset.then(|| paired_ratio(&dh, &nh)),
        outage_vs_known_offset: known_offset.then(|| paired_ratio(&dout, &nout)),
    }
}

/// `a ≤ k·b` for both metrics; a metric NaN on both sides is skipped, NaN on one fails.
fn within(a: &VariantScores, b: &VariantScores, k: f64) -> bool {
    let le = |x: f64, y: f64| (x.is_nan() && y.is_nan()) || x <= k * y;
    a.failures.is_empty()
        && a.h_rms_m.is_finite()
        && le(a.h_rms_m, b.h_rms_m)
        && le(a.outage_rms_of_max_m, b.outage_rms_of_max_m)
}

/// Run `cells` × seeds (rayon over the (cell, seed) pairs; the output
/// order is the cells' order, deterministic for given options).
pub fn run_generalise(
    cells: &[Cell],
    opt: &GeneraliseOptions,
) -> Result<GeneraliseReport, ExperimentError> {
    if opt.seeds == 0 || !(opt.duration_s.is_finite() && opt.duration_s > SCORE_AFTER_MOTION_S) {
        return Err(ExperimentError::Options(format!(
            "need seeds ≥ 1 and duration > {SCORE_AFTER_MOTION_S} s (got {} seeds, {} s)",
            opt.seeds, opt.duration_s
        )));
    }
    let t0 = Instant::now();
    let jobs: Vec<(usize, u64)> = (0..cells.len())
        .flat_map(|c| (opt.seed0..opt.seed0 + opt.seeds).map(move |s| (c, s)))
        .collect();
    let results: Vec<SeedScores> = super::on_worker_pool(|| {
        jobs.par_iter()
            .map(|&(c, s)| run_seed(&cells[c], s, opt))
            .collect()
    });
    let per = opt.seeds as usize;
    let reports = cells
        .iter()
        .enumerate()
        .map(|(c, cell)| {
            let rows: Vec<(u64, &SeedScores)> = (0..per)
                .map(|i| (opt.seed0 + i as u64, &results[c * per + i]))
                .collect();
            let [d, o, k] = [0, 1, 2].map(|k| pool(&rows, k));
            let paired = paired_report(&rows, opt.known_offset);
            let ps: [_; 3] = [0, 1, 2].map(|k| per_seed(&rows, k));
            let pk = per_seed(&rows, 3);
            let per_seed_rows = rows
                .iter()
                .enumerate()
                .map(|(i, (seed, s))| SeedRow {
                    seed: *seed,
                    h_rms_m: ps.each_ref().map(|p| p.0[i]),
                    outage_rms_of_max_m: ps.each_ref().map(|p| p.1[i]),
                    default: s[0].as_ref().ok().map(|r| r.diag.clone()),
                    known_offset: opt.known_offset.then(|| [pk.0[i], pk.1[i]]),
                })
                .collect();
            let targets = Targets {
                default_vs_oracle: within(&d, &o, ORACLE_RATIO_TARGET),
                default_vs_kfgins: within(&d, &k, 1.0),
                default_vs_oracle_paired: d.failures.is_empty()
                    && !paired
                        .h_rms_vs_oracle
                        .significantly_above(ORACLE_RATIO_TARGET)
                    && !paired
                        .outage_vs_oracle
                        .significantly_above(ORACLE_RATIO_TARGET),
                default_vs_kfgins_paired: d.failures.is_empty()
                    && !paired.h_rms_vs_kfgins.significantly_above(1.0)
                    && !paired.outage_vs_kfgins.significantly_above(1.0),
            };
            CellReport {
                platform: cell.platform.to_string(),
                imu: cell.imu.to_string(),
                gnss: cell.gnss.to_string(),
                offset_s: cell.offset_s,
                seeds: opt.seeds,
                default: d,
                oracle: o,
                kfgins_model: k,
                default_known_offset: opt.known_offset.then(|| pool(&rows, 3)),
                paired,
                targets,
                per_seed: per_seed_rows,
            }
        })
        .collect();
    let w = Outages::default().windows(opt.duration_s);
    Ok(GeneraliseReport {
        cells: reports,
        config: GeneraliseConfig {
            options: opt.clone(),
            score_after_motion_s: SCORE_AFTER_MOTION_S,
            motion_speed_m_s: super::score::MOTION_SPEED_M_S,
            oracle_ratio_target: ORACLE_RATIO_TARGET,
            outages: format!("{} windows [s after start]: {w:?}", w.len()),
            static_start: "even seeds (10–20 s hold); odd seeds start moving",
            variants: "default: platform + imu_preset; oracle: + imu_time_offset = τ, [init] = truth \
                       (σ 0.01 m, 0.01 m/s, 0.1°); kfgins_model: preset kf-gins, oracle init, offset none",
        },
        wall_seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The time-offset check's table (`known_offset`): per cell the applied
/// offsets' range, the default's h_rms and outage drift against the default
/// given the true offset and against the oracle, with the paired ratios.
pub fn format_known_offset(r: &GeneraliseReport) -> String {
    let mut s = format!(
        "{:<30} {:>17} {:>14} {:>14} {:>14} {:>22} {:>22}\n",
        "cell (known offset check)",
        "applied τ [ms]",
        "h d/known [m]",
        "out d/known",
        "h d/oracle",
        "paired h d/known",
        "paired out d/known"
    );
    let pr = |p: &Option<PairedRatio>| {
        p.map_or("-".into(), |p| {
            format!("{:.3} [{:.3}, {:.3}]", p.gmean, p.lo95, p.hi95)
        })
    };
    for c in &r.cells {
        let Some(k) = &c.default_known_offset else {
            continue;
        };
        let taus = &c.default.time_offset_applied_s;
        let (lo, hi) = taus
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
                (a.min(t), b.max(t))
            });
        let name = format!("{}:{}:{}:{}", c.platform, c.imu, c.gnss, c.offset_s);
        s += &format!(
            "{:<30} {:>17} {:>14} {:>14} {:>14} {:>22} {:>22}\n",
            name,
            format!("{:.1}…{:.1}", lo * 1e3, hi * 1e3),
            format!("{:.3}/{:.3}", c.default.h_rms_m, k.h_rms_m),
            format!(
                "{:.2}/{:.2}",
                c.default.outage_rms_of_max_m, k.outage_rms_of_max_m
            ),
            format!("{:.3}/{:.3}", c.default.h_rms_m, c.oracle.h_rms_m),
            pr(&c.paired.h_rms_vs_known_offset),
            pr(&c.paired.outage_vs_known_offset),
        );
    }
    s
}

/// One line per cell and seed: h_rms d/o/k, outage d/o/k, the default's
/// alignment method, wait, yaw σ, yaw error RMS/max and warning count.
pub fn format_per_seed(r: &GeneraliseReport) -> String {
    let mut s = String::new();
    let f = |x: f64| {
        if x.is_finite() {
            format!("{x:.2}")
        } else {
            "-".into()
        }
    };
    for c in &r.cells {
        for row in &c.per_seed {
            let d = row.default.as_ref().map_or("failed".into(), |d| {
                format!(
                    "{} wait {:.1} s yawσ {:.1}° yaw err rms/max {:.2}/{:.2}° warnings {}",
                    d.align_method,
                    d.align_wait_s,
                    d.align_yaw_std_deg,
                    d.yaw_err_rms_deg,
                    d.yaw_err_max_deg,
                    d.warnings.len()
                )
            });
            let known = match (&row.known_offset, &row.default) {
                (Some([h, o]), Some(d)) => format!(
                    "  known-τ h {} out {}  τ̂−τ {:+.1} ms",
                    f(*h),
                    f(*o),
                    1e3 * (d.tau_applied_s - c.offset_s)
                ),
                _ => String::new(),
            };
            s += &format!(
                "{}:{}:{}:{} seed {:>3}  h {}/{}/{}  out {}/{}/{}  {d}{known}\n",
                c.platform,
                c.imu,
                c.gnss,
                c.offset_s,
                row.seed,
                f(row.h_rms_m[0]),
                f(row.h_rms_m[1]),
                f(row.h_rms_m[2]),
                f(row.outage_rms_of_max_m[0]),
                f(row.outage_rms_of_max_m[1]),
                f(row.outage_rms_of_max_m[2]),
            );
        }
    }
    s
}

/// The compact table: one row per cell, h_rms and outage drift of default /
/// oracle / kfgins_model, default NEES and coverage, failures and the targets.
pub fn format_table(r: &GeneraliseReport) -> String {
    let mut s = format!(
        "{:<30} {:>20} {:>20} {:>8} {:>5} {:>12} {:>5} {:>5} {:>11}\n",
        "cell (platform:imu:gnss:τ)",
        "h_rms d/o/k [m]",
        "outage d/o/k [m]",
        "NEES",
        "cov",
        "fails d/o/k",
        "≤1.2o",
        "≤kf",
        "paired o/kf"
    );
    let f = |x: f64| {
        if x.is_finite() {
            format!("{x:.2}")
        } else {
            "-".into()
        }
    };
    let pf = |b: bool| if b { "pass" } else { "FAIL" };
    let (mut po, mut pk, mut qo, mut qk) = (0, 0, 0, 0);
    for c in &r.cells {
        s += &format!(
            "{:<30} {:>20} {:>20} {:>8} {:>5} {:>12} {:>5} {:>5} {:>11}\n",
            format!("{}:{}:{}:{}", c.platform, c.imu, c.gnss, c.offset_s),
            format!(
                "{}/{}/{}",
                f(c.default.h_rms_m),
                f(c.oracle.h_rms_m),
                f(c.kfgins_model.h_rms_m)
            ),
            format!(
                "{}/{}/{}",
                f(c.default.outage_rms_of_max_m),
                f(c.oracle.outage_rms_of_max_m),
                f(c.kfgins_model.outage_rms_of_max_m)
            ),
            f(c.default.nees_h),
            f(c.default.coverage95_h),
            format!(
                "{}/{}/{}",
                c.default.failures.len(),
                c.oracle.failures.len(),
                c.kfgins_model.failures.len()
            ),
            pf(c.targets.default_vs_oracle),
            pf(c.targets.default_vs_kfgins),
            format!(
                "{}/{}",
                pf(c.targets.default_vs_oracle_paired),
                pf(c.targets.default_vs_kfgins_paired)
            ),
        );
        po += usize::from(c.targets.default_vs_oracle);
        pk += usize::from(c.targets.default_vs_kfgins);
        qo += usize::from(c.targets.default_vs_oracle_paired);
        qk += usize::from(c.targets.default_vs_kfgins_paired);
    }
    s += &format!(
        "cells passing: default ≤ 1.2×oracle {po}/{n}, default ≤ kfgins_model {pk}/{n}; \
         paired (not significantly worse, 95 %): {qo}/{n}, {qk}/{n}; wall {:.0} s\n",
        r.wall_seconds,
        n = r.cells.len()
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CI-sized subset (1 seed, 180 s, one cell per platform plus a τ = 0.1 s
    /// cell): every run is either scored or listed as a failure; the oracle
    /// (started on the truth) completes with a finite horizontal RMS; the
    /// NEES coverage is a share. Accuracy and the targets are not asserted
    /// here: they are the experiment's output.
    #[test]
    fn ci_subset_completes_and_scores_are_sane() {
        let cells = select_cells(
            "car:industrial:rtk:0,robot:tactical:consumer:0,pedestrian:industrial:rtk:0.1,uav:consumer:rtk:0",
        )
        .unwrap();
        assert_eq!(cells.len(), 4);
        let opt = GeneraliseOptions {
            seeds: 1,
            seed0: 1,
            duration_s: 180.0,
            known_offset: false,
            ..GeneraliseOptions::default()
        };
        let r = run_generalise(&cells, &opt).unwrap();
        assert_eq!(r.cells.len(), 4);
        for c in &r.cells {
            for (name, v) in [
                ("default", &c.default),
                ("oracle", &c.oracle),
                ("kfgins", &c.kfgins_model),
            ] {
                assert_eq!(
                    v.runs_ok + v.failures.len(),
                    1,
                    "{} {name}: {v:?}",
                    c.platform
                );
                if v.runs_ok == 1 {
                    assert!(v.h_rms_m.is_finite(), "{} {name}: {v:?}", c.platform);
                    assert!((0.0..=1.0).contains(&v.coverage95_h) || v.coverage95_h.is_nan());
                }
            }
            assert!(
                c.oracle.failures.is_empty() && c.oracle.h_rms_m.is_finite(),
                "{}: oracle {:?}",
                c.platform,
                c.oracle
            );
        }
        let j = serde_json::to_value(&r).unwrap();
        assert!(j["cells"][0]["default"]["h_rms_m"].is_number());
        assert!(j["cells"][0]["kfgins_model"]["failures"].is_array());
        assert_eq!(j["cells"][0]["per_seed"][0]["seed"], 1);
        assert!(j["cells"][0]["per_seed"][0]["h_rms_m"][1].is_number());
        assert_eq!(format_per_seed(&r).lines().count(), 4);
        assert_eq!(j["cells"][0]["paired"]["h_rms_vs_kfgins"]["n"], 1);
        // The known-offset reference is absent unless asked for.
        assert!(j["cells"][0].get("default_known_offset").is_none());
        assert!(j["cells"][0]["paired"]
            .get("h_rms_vs_known_offset")
            .is_none());
        println!("{}", format_table(&r));
    }

    /// With `known_offset` the τ = 0.1 s cell also runs the default given
    /// the true offset: scored, paired with the default, in the JSON and the
    /// check's table.
    #[test]
    fn known_offset_reference_is_run_and_paired() {
        let cells = select_cells("car:industrial:rtk:0.1").unwrap();
        let opt = GeneraliseOptions {
            seeds: 1,
            seed0: 1,
            duration_s: 180.0,
            known_offset: true,
            ..GeneraliseOptions::default()
        };
        let r = run_generalise(&cells, &opt).unwrap();
        let c = &r.cells[0];
        let k = c.default_known_offset.as_ref().expect("reference run");
        assert_eq!(k.runs_ok, 1, "{k:?}");
        assert!(k.h_rms_m.is_finite() && k.h_rms_m > 0.0);
        assert_eq!(c.paired.h_rms_vs_known_offset.map(|p| p.n), Some(1));
        let j = serde_json::to_value(&r).unwrap();
        assert!(j["cells"][0]["default_known_offset"]["h_rms_m"].is_number());
        let t = format_known_offset(&r);
        assert!(
            t.lines()
                .nth(1)
                .is_some_and(|l| l.starts_with("car:industrial:rtk:0.1")),
            "{t}"
        );
    }

    #[test]
    fn cell_patterns_select_and_reject() {
        assert_eq!(matrix().len(), 48);
        assert_eq!(select_cells("car").unwrap().len(), 12);
        assert_eq!(
            select_cells_in(matrix(), "*:tactical:*:0.1").unwrap().len(),
            8
        );
        // `*` also reaches the platforms outside the matrix (marine).
        assert_eq!(select_cells("*:tactical:*:0.1").unwrap().len(), 10);
        assert_eq!(select_cells("uav:consumer:rtk:0.10").unwrap().len(), 1);
        assert!(select_cells("boat").is_err());
        // Outside the matrix, reached by name.
        assert_eq!(select_cells("marine").unwrap().len(), 12);
        assert!(matrix().iter().all(|c| c.platform != Platform::Marine));
    }

    /// A platform nobody tuned for: a small craft in waves with consumer
    /// GNSS, moving start, the seeds on which the yaw bank kept a member
    /// 180° off (seeds 1 and 3: h RMS 34 and 67 m against the oracle's 2.5
    /// and 2.0 m) before the GSF counted slow velocity changes as seen
    /// accelerations. A catastrophe bound, set by the failure's size (13–30×
    /// the oracle), not by the fixed runs (1.03–1.08× on the 600 s runs):
    /// the default within 1.5× the oracle on every seed.
    #[test]
    fn small_craft_with_consumer_gnss_aligns() {
        let cells = select_cells("marine:industrial:consumer:0").unwrap();
        let opt = GeneraliseOptions {
            seeds: 3,
            seed0: 1,
            duration_s: 300.0,
            known_offset: false,
            ..GeneraliseOptions::default()
        };
        let r = run_generalise(&cells, &opt).unwrap();
        for p in &r.cells[0].per_seed {
            let (d, o) = (p.h_rms_m[0], p.h_rms_m[1]);
            println!("marine seed {}: default {d:.2} m, oracle {o:.2} m", p.seed);
            assert!(d <= 1.5 * o, "seed {}: default {d} m, oracle {o} m", p.seed);
        }
    }
}
