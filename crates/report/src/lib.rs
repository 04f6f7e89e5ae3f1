//! navfuse-report: one self-contained HTML page (inline SVG, a few lines of
//! inline script, no network) plus the same plots as standalone SVG files,
//! from a run directory.
//!
//! # RUN_DIR layout
//!
//! Only the top level of the directory is read; names are case-insensitive.
//!
//! | file | meaning |
//! |---|---|
//! | `truth.{nav,csv,pos}`, `reference.*` | reference trajectory (or `--truth FILE`) |
//! | `gnss.{pos,txt,csv,nav}`, `fixes.*` | GNSS fixes the run used (KF-GINS GNSS `.txt`, RTKLIB `.pos`, navfuse CSV) |
//! | `summary.json` | run configuration and record counts, shown as they are; an `"outages"` key (`[[start, end], …]` or `[{"start":…, "end":…}, …]`, GPS s) gives the outage intervals |
//! | `innovations.csv`, `NAME.innovations.csv` | innovations: columns `t` (or `t_gps_s`), `kind`, `nis`, `dof`, `accepted` (1/0/true/false), optional `estimator` |
//! | `states.csv`, `NAME.states.csv` | estimated states vs time: `t` (or `t_gps_s`) and columns `QUANTITY_AXIS_UNIT` or `QUANTITY_UNIT` (e.g. `bg_x_dph`, `ba_z_mg`, `td_s`); one plot per quantity+unit |
//! | any other `*.nav`, `*.csv` (navfuse trajectory CSV), `*.pos` | one solution each, named by the file stem, its own colour |
//! | `STEM.pos` quality | the Q column of any `.pos` (also one set aside as the same solution as `STEM.nav`): the fix state along the track and its shares ([`fix_state`]) |
//! | `STEM.std` | navfuse σ file of the solution `STEM.*` (or `--std FILE`): ±3σ bands and the uncertainty section (error against ±2σ, horizontal NEES) |
//! | `KF_GINS_Navresult.nav` + `KF_GINS_STD.txt` + `KF_GINS_IMU_ERR.txt` | a KF-GINS output folder (KF-GINS's or `navfuse kf-gins`'s): the solution with its σ and IMU error states ([`read_kfgins_output`]) |
//!
//! Other files (and CSVs without a trajectory header, e.g. an `errors.csv`
//! from `navfuse eval`) are listed as ignored. Times of week only (KF-GINS
//! writes GPS week 0) are placed in the week of the inputs that carry one.
//! Every section of the page appears only when its data exists.
//!
//! Errors: [`load_run_dir`] compares at the truth epochs (solutions
//! interpolated, `navfuse_eval::Align::AtReference`), so every estimator is
//! scored at the same instants whatever its output rate, as the drive_0708
//! benchmark does; set [`Inputs::eval`] to change it.
//!
//! Outages, first found wins: [`Inputs::outages`] as given (CLI
//! `--outages`), the `outages` key of `summary.json`, else gaps in the GNSS
//! fixes longer than 5 median fix intervals (and ≥ 3 s).

pub mod build;
pub mod fix_state;
pub mod fixture;
mod page;
mod sigma_in;
pub mod svg;

use navfuse_core::NavSolution;
use navfuse_eval::{EvalConfig, Evaluation, Outage};
use serde::Serialize;
use std::path::{Path, PathBuf};

const WEEK_S: f64 = 604_800.0;

/// A trajectory read from a file (a solution, the truth or the GNSS fixes).
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Legend name (file stem for solutions).
    pub name: String,
    pub path: Option<PathBuf>,
    pub epochs: Vec<NavSolution>,
    /// Line accounting of the reader ("N lines: … used, …").
    pub records: Option<String>,
}

/// One filter update as logged by an estimator.
#[derive(Clone, Debug, PartialEq)]
pub struct Innovation {
    /// GPS time [s].
    pub t: f64,
    /// Measurement kind ("gnss_pos", "gnss_vel", "nhc", …).
    pub kind: String,
    /// Normalised innovation squared νᵀS⁻¹ν.
    pub nis: f64,
    /// Degrees of freedom (measurement dimension).
    pub dof: usize,
    /// Whether the update was applied (false: rejected by the gate).
    pub accepted: bool,
}

/// The innovations of one estimator.
#[derive(Clone, Debug)]
pub struct InnovationSet {
    pub estimator: String,
    pub path: Option<PathBuf>,
    pub rows: Vec<Innovation>,
}

/// Estimated states (biases, time offset, …) of one estimator vs time.
#[derive(Clone, Debug)]
pub struct StateSet {
    pub estimator: String,
    pub path: Option<PathBuf>,
    /// Column names (without the time column), e.g. `bg_x_dph`.
    pub columns: Vec<String>,
    pub t: Vec<f64>,
    /// `values[i][k]`: epoch i, column k (NaN = unknown).
    pub values: Vec<Vec<f64>>,
}

/// Everything a report is drawn from. Build it with [`load_run_dir`] or by
/// hand (a command that has its solutions in memory), then [`write_report`].
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    pub title: String,
    pub run_dir: Option<PathBuf>,
    pub solutions: Vec<Trajectory>,
    pub truth: Option<Trajectory>,
    pub fixes: Option<Trajectory>,
    pub innovations: Vec<InnovationSet>,
    pub states: Vec<StateSet>,
    /// `summary.json` as it is.
    pub summary: Option<serde_json::Value>,
    /// Configuration files of the run (`*.toml`, `*.yaml` in RUN_DIR): (name, text).
    pub config_files: Vec<(String, String)>,
    /// GNSS outage intervals (GPS s); empty: from `summary.json` or fix gaps.
    pub outages: Vec<Outage>,
    /// Evaluation settings (lever arm solution → truth point, max gap).
    pub eval: EvalConfig,
    /// Files seen and not used, with the reason.
    pub ignored: Vec<String>,
    /// Per-epoch fix state (quality Q) of the solutions that have one
    /// (`STEM.pos`, also when the solution itself is read from `STEM.nav`).
    pub quality: Vec<fix_state::QualityTrack>,
}

/// Options of [`load_run_dir`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Truth file (overrides `truth.*` in the directory).
    pub truth: Option<PathBuf>,
    /// GNSS fixes file (overrides `gnss.*`).
    pub fixes: Option<PathBuf>,
    /// More solution files: (legend name, path).
    pub solutions: Vec<(String, PathBuf)>,
    /// KF-GINS output folders: (legend name, folder) — see [`read_kfgins_output`].
    pub kfgins_outputs: Vec<(String, PathBuf)>,
    /// GPS week for time-of-week-only inputs (default: from the inputs).
    pub week: Option<u32>,
    /// σ file ([`navfuse_io::stdfile`]) of the solution with the same file
    /// stem, else of the first solution (default: every `STEM.std` in the
    /// directory goes to the solution `STEM.*`).
    pub std: Option<PathBuf>,
}

/// Whitespace-separated numeric rows of a KF-GINS text output with at least
/// `min` columns; errors name file, line and column.
fn read_columns(path: &Path, min: usize) -> Result<Vec<Vec<f64>>, String> {
    let text = navfuse_io::text::read_text_capped(path, u64::MAX).map_err(|e| e.to_string())?;
    let mut rows = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let mut row = Vec::with_capacity(min);
        for (k, f) in t.split_whitespace().enumerate() {
            let v = f.parse::<f64>().map_err(|_| {
                format!(
                    "{}:{}: field `column {}`: not a number: {f:?}",
                    path.display(),
                    ln + 1,
                    k + 1
                )
            })?;
            row.push(v);
        }
        if row.len() < min {
            return Err(format!(
                "{}:{}: field `column {}`: line has {} columns, expected {min}",
                path.display(),
                ln + 1,
                row.len() + 1,
                row.len()
            ));
        }
        rows.push(row);
    }
    Ok(rows)
}

/// A KF-GINS output folder: `KF_GINS_Navresult.nav` (the solution),
/// `KF_GINS_STD.txt` (if present: 1-σ position NED [m], velocity [m/s],
/// attitude [deg], gyro bias [°/h], accelerometer bias [mGal], scale factors
/// [ppm], after the time column) attached to the solution epoch with the same
/// time (±1 ms), and `KF_GINS_IMU_ERR.txt` (if present: gyro bias [°/h],
/// accelerometer bias [mGal], gyro and accelerometer scale factors [ppm]) as
/// a [`StateSet`] with the σ from the STD file.
pub fn read_kfgins_output(
    dir: &Path,
    name: &str,
) -> Result<(Trajectory, Option<StateSet>), String> {
    let mut sol = read_trajectory(&dir.join("KF_GINS_Navresult.nav"), name, false)?;
    let std_p = dir.join("KF_GINS_STD.txt");
    let std_rows = if std_p.exists() {
        Some(read_columns(&std_p, 22)?)
    } else {
        None
    };
    // Times of the .nav are GPS seconds with week 0 → equal to the TOW here.
    let mut attached = 0usize;
    if let Some(rows) = &std_rows {
        let mut j = 0;
        for e in sol.epochs.iter_mut() {
            while j < rows.len() && rows[j][0] < e.t - 1e-3 {
                j += 1;
            }
            if j < rows.len() && (rows[j][0] - e.t).abs() <= 1e-3 {
                let r = &rows[j];
                let d = std::f64::consts::PI / 180.0;
                e.std_pos_ned = navfuse_core::Vec3::new(r[1], r[2], r[3]);
                e.std_v_n = navfuse_core::Vec3::new(r[4], r[5], r[6]);
                e.std_rpy = navfuse_core::Vec3::new(r[7] * d, r[8] * d, r[9] * d);
                attached += 1;
            }
        }
        if attached == 0 {
            return Err(format!(
                "{}: no line's time matches an epoch of KF_GINS_Navresult.nav",
                std_p.display()
            ));
        }
        if let Some(r) = sol.records.as_mut() {
            r.push_str(&format!("; σ from KF_GINS_STD.txt at {attached} epochs"));
        }
    }
    let err_p = dir.join("KF_GINS_IMU_ERR.txt");
    let states = if err_p.exists() {
        let rows = read_columns(&err_p, 13)?;
        let mut columns: Vec<String> = Vec::new();
        for (q, u) in [("bg", "dph"), ("ba", "mgal"), ("sg", "ppm"), ("sa", "ppm")] {
            for a in ["x", "y", "z"] {
                columns.push(format!("{q}_{a}_{u}"));
            }
        }
        let n_state = columns.len();
        if std_rows.is_some() {
            for k in 0..n_state {
                columns.push(format!("std_{}", columns[k]));
            }
        }
        let mut t = Vec::with_capacity(rows.len());
        let mut values = Vec::with_capacity(rows.len());
        let mut j = 0;
        for r in &rows {
            t.push(r[0]);
            let mut v: Vec<f64> = r[1..=n_state].to_vec();
            if let Some(sr) = &std_rows {
                while j < sr.len() && sr[j][0] < r[0] - 1e-3 {
                    j += 1;
                }
                if j < sr.len() && (sr[j][0] - r[0]).abs() <= 1e-3 {
                    v.extend_from_slice(&sr[j][10..10 + n_state]);
                } else {
                    v.extend(std::iter::repeat_n(f64::NAN, n_state));
                }
            }
            values.push(v);
        }
        Some(StateSet {
            estimator: name.to_string(),
            path: Some(err_p),
            columns,
            t,
            values,
        })
    } else {
        None
    };
    Ok((sol, states))
}

fn lower_name(p: &Path) -> String {
    p.file_name()
        .and_then(|s| s.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("solution")
        .to_string()
}

/// Read a trajectory: `.nav` KF-GINS, `.pos` RTKLIB, `.csv` navfuse
/// trajectory CSV, `.txt` KF-GINS GNSS (only when `txt_is_gnss`).
pub fn read_trajectory(path: &Path, name: &str, txt_is_gnss: bool) -> Result<Trajectory, String> {
    let (mut epochs, stats) =
        navfuse_eval::files::read_trajectory(path, 0, txt_is_gnss).map_err(|e| e.to_string())?;
    if epochs.is_empty() {
        return Err(format!("{}: no epochs", path.display()));
    }
    epochs.sort_by(|a, b| a.t.total_cmp(&b.t));
    epochs.dedup_by(|b, a| a.t == b.t);
    Ok(Trajectory {
        name: name.to_string(),
        path: Some(path.to_path_buf()),
        epochs,
        records: Some(stats.to_string()),
    })
}

/// First non-empty, non-comment line of a text file.
fn first_line(path: &Path) -> Result<String, String> {
    let f = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    for l in navfuse_io::text::capped_lines(std::io::BufReader::new(f)) {
        let l = l.map_err(|e| format!("{}: {e}", path.display()))?;
        let t = l.trim();
        if !t.is_empty() && !t.starts_with('#') {
            return Ok(t.to_string());
        }
    }
    Ok(String::new())
}

/// Header columns of a CSV line.
fn header_cols(line: &str) -> Vec<String> {
    line.split(',').map(|s| s.trim().to_string()).collect()
}

fn parse_bool(s: &str) -> Option<bool> {
    match s.trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" | "accepted" => Some(true),
        "0" | "false" | "no" | "rejected" => Some(false),
        _ => None,
    }
}

/// Read an innovations CSV (see the crate doc). Errors name file, line and field.
pub fn read_innovations(
    path: &Path,
    default_estimator: &str,
) -> Result<Vec<InnovationSet>, String> {
    let text = navfuse_io::text::read_text_capped(path, u64::MAX).map_err(|e| e.to_string())?;
    let name = path.display().to_string();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, head) = lines
        .next()
        .ok_or_else(|| format!("{name}: empty innovations file"))?;
    let cols = header_cols(head);
    let find = |names: &[&str]| cols.iter().position(|c| names.contains(&c.as_str()));
    let it = find(&["t", "t_gps_s", "time"])
        .ok_or_else(|| format!("{name}:1: field `t`: header needs a `t` or `t_gps_s` column"))?;
    let ik = find(&["kind"]);
    let inis = find(&["nis", "NIS"])
        .ok_or_else(|| format!("{name}:1: field `nis`: header needs a `nis` column"))?;
    let idof = find(&["dof"])
        .ok_or_else(|| format!("{name}:1: field `dof`: header needs a `dof` column"))?;
    let iacc = find(&["accepted"])
        .ok_or_else(|| format!("{name}:1: field `accepted`: header needs an `accepted` column"))?;
    let iest = find(&["estimator"]);
    let mut sets: Vec<InnovationSet> = Vec::new();
    for (ln, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |i: usize, field: &str| -> Result<&str, String> {
            f.get(i).copied().ok_or_else(|| {
                format!(
                    "{name}:{}: field `{field}`: missing (line has {} columns, header {})",
                    ln + 1,
                    f.len(),
                    cols.len()
                )
            })
        };
        let num = |i: usize, field: &str| -> Result<f64, String> {
            let s = get(i, field)?;
            s.parse::<f64>()
                .map_err(|_| format!("{name}:{}: field `{field}`: not a number: {s:?}", ln + 1))
        };
        // An RTK run's fix decisions (`rtk_fix`, navfuse run) share the
        // journal: not innovations (their `nis` is `nan`).
        if ik.and_then(|i| f.get(i)).is_some_and(|k| *k == "rtk_fix") {
            continue;
        }
        let t = num(it, "t")?;
        if !t.is_finite() {
            return Err(format!("{name}:{}: field `t`: not finite", ln + 1));
        }
        let nis = num(inis, "nis")?;
        let dof = num(idof, "dof")?;
        if !(dof >= 1.0 && dof.fract() == 0.0 && dof <= 1000.0) {
            return Err(format!(
                "{name}:{}: field `dof`: not a positive integer: {dof}",
                ln + 1
            ));
        }
        let acc_s = get(iacc, "accepted")?;
        let accepted = parse_bool(acc_s).ok_or_else(|| {
            format!(
                "{name}:{}: field `accepted`: expected 1/0/true/false, got {acc_s:?}",
                ln + 1
            )
        })?;
        let kind = match ik {
            Some(i) => get(i, "kind")?.to_string(),
            None => "update".to_string(),
        };
        let est = match iest {
            Some(i) => get(i, "estimator")?.to_string(),
            None => default_estimator.to_string(),
        };
        let row = Innovation {
            t,
            kind,
            nis,
            dof: dof as usize,
            accepted,
        };
        match sets.iter_mut().find(|s| s.estimator == est) {
            Some(s) => s.rows.push(row),
            None => sets.push(InnovationSet {
                estimator: est,
                path: Some(path.to_path_buf()),
                rows: vec![row],
            }),
        }
    }
    Ok(sets)
}

/// Read a states CSV (see the crate doc).
pub fn read_states(path: &Path, estimator: &str) -> Result<StateSet, String> {
    let text = navfuse_io::text::read_text_capped(path, u64::MAX).map_err(|e| e.to_string())?;
    let name = path.display().to_string();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, head) = lines
        .next()
        .ok_or_else(|| format!("{name}: empty states file"))?;
    let cols = header_cols(head);
    let it = cols
        .iter()
        .position(|c| c == "t" || c == "t_gps_s")
        .ok_or_else(|| format!("{name}:1: field `t`: header needs a `t` or `t_gps_s` column"))?;
    let columns: Vec<String> = cols
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != it)
        .map(|(_, c)| c.clone())
        .collect();
    let mut t = Vec::new();
    let mut values = Vec::new();
    for (ln, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != cols.len() {
            return Err(format!(
                "{name}:{}: field `{}`: line has {} columns, the header has {}",
                ln + 1,
                cols.get(f.len()).map_or("<extra>", |s| s.as_str()),
                f.len(),
                cols.len()
            ));
        }
        let mut row = Vec::with_capacity(columns.len());
        for (i, s) in f.iter().enumerate() {
            let v = if s.eq_ignore_ascii_case("nan") || s.is_empty() {
                f64::NAN
            } else {
                s.parse::<f64>().map_err(|_| {
                    format!(
                        "{name}:{}: field `{}`: not a number: {s:?}",
                        ln + 1,
                        cols[i]
                    )
                })?
            };
            if i == it {
                if !v.is_finite() {
                    return Err(format!(
                        "{name}:{}: field `{}`: not finite",
                        ln + 1,
                        cols[i]
                    ));
                }
                t.push(v);
            } else {
                row.push(v);
            }
        }
        values.push(row);
    }
    Ok(StateSet {
        estimator: estimator.to_string(),
        path: Some(path.to_path_buf()),
        columns,
        t,
        values,
    })
}

/// Read a run directory (layout in the crate doc).
pub fn load_run_dir(dir: &Path, opt: &LoadOptions) -> Result<Inputs, String> {
    let mut inp = Inputs {
        title: format!("navfuse report — {}", dir.display()),
        run_dir: Some(dir.to_path_buf()),
        eval: EvalConfig {
            align: navfuse_eval::Align::AtReference,
            ..EvalConfig::default()
        },
        ..Default::default()
    };
    let mut files: Vec<PathBuf> = Vec::new();
    if dir.as_os_str().is_empty() || dir.exists() {
        let rd = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for e in rd {
            let e = e.map_err(|e| format!("{}: {e}", dir.display()))?;
            if e.file_type().map(|t| t.is_file()).unwrap_or(false) {
                files.push(e.path());
            }
        }
    } else {
        return Err(format!("{}: no such directory", dir.display()));
    }
    files.sort();
    let mut truth_path = opt.truth.clone();
    let mut fixes_path = opt.fixes.clone();
    let mut sol_paths: Vec<(String, PathBuf)> = Vec::new();
    let mut kfgins_dirs: Vec<(String, PathBuf)> = Vec::new();
    let mut truth_cands: Vec<PathBuf> = Vec::new();
    let mut std_files: Vec<PathBuf> = Vec::new();
    for p in &files {
        let n = lower_name(p);
        let ext = n.rsplit('.').next().unwrap_or("").to_string();
        let st = n.split('.').next().unwrap_or("").to_string();
        if n == "summary.json" {
            let text =
                navfuse_io::text::read_text_capped(p, u64::MAX).map_err(|e| e.to_string())?;
            let v: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| format!("{}:{}: field `<json>`: {e}", p.display(), e.line()))?;
            inp.summary = Some(v);
        } else if n == "innovations.csv" || n.ends_with(".innovations.csv") {
            let est = if n == "innovations.csv" {
                "estimator".to_string()
            } else {
                p.file_name()
                    .and_then(|s| s.to_str())
                    .map(|s| s[..s.len() - ".innovations.csv".len()].to_string())
                    .unwrap_or_default()
            };
            inp.innovations.extend(read_innovations(p, &est)?);
        } else if n == "states.csv" || n.ends_with(".states.csv") {
            let est = if n == "states.csv" {
                "estimator".to_string()
            } else {
                p.file_name()
                    .and_then(|s| s.to_str())
                    .map(|s| s[..s.len() - ".states.csv".len()].to_string())
                    .unwrap_or_default()
            };
            inp.states.push(read_states(p, &est)?);
        } else if (st == "truth" || st == "reference")
            && ["nav", "csv", "pos"].contains(&ext.as_str())
        {
            truth_cands.push(p.clone());
        } else if (st == "gnss" || st == "fixes")
            && ["nav", "csv", "pos", "txt"].contains(&ext.as_str())
        {
            if fixes_path.is_none() {
                fixes_path = Some(p.clone());
            }
        } else if n == "kf_gins_std.txt" || n == "kf_gins_imu_err.txt" {
            // Read with KF_GINS_Navresult.nav.
        } else if n == "kf_gins_navresult.nav" {
            kfgins_dirs.push(("KF-GINS output".into(), dir.to_path_buf()));
        } else if ext == "nav" || ext == "pos" {
            sol_paths.push((stem(p), p.clone()));
        } else if ext == "std" {
            std_files.push(p.clone());
        } else if ext == "csv" {
            let head = first_line(p)?;
            if header_cols(&head).iter().any(|c| c == "lat_deg") {
                sol_paths.push((stem(p), p.clone()));
            } else {
                inp.ignored
                    .push(format!("{} (CSV without a trajectory header)", p.display()));
            }
        } else if ext == "toml" || ext == "yaml" || ext == "yml" {
            let text =
                navfuse_io::text::read_text_capped(p, u64::MAX).map_err(|e| e.to_string())?;
            let mut text: String = text.chars().take(20_000).collect();
            if text.len() >= 20_000 {
                text.push_str("\n…");
            }
            inp.config_files.push((
                p.file_name().unwrap_or_default().to_string_lossy().into(),
                text,
            ));
        } else {
            inp.ignored
                .push(format!("{} (not a report input)", p.display()));
        }
    }
    // Truth: KF-GINS .nav first (it carries velocity and attitude), then .csv, .pos.
    if truth_path.is_none() {
        for want in ["nav", "csv", "pos"] {
            if let Some(p) = truth_cands.iter().find(|p| lower_name(p).ends_with(want)) {
                truth_path = Some(p.clone());
                break;
            }
        }
    }
    for p in &truth_cands {
        if Some(p) != truth_path.as_ref() {
            inp.ignored
                .push(format!("{} (another truth file)", p.display()));
        }
    }
    // The same solution as .csv (with σ) and .nav: keep the .csv.
    let csv_stems: Vec<String> = sol_paths
        .iter()
        .filter(|(_, p)| lower_name(p).ends_with(".csv"))
        .map(|(n, _)| n.clone())
        .collect();
    sol_paths.retain(|(n, p)| {
        let dup = lower_name(p).ends_with(".nav") && csv_stems.contains(n);
        if dup {
            inp.ignored.push(format!(
                "{} (same solution as {n}.csv, which has σ)",
                p.display()
            ));
        }
        !dup
    });
    // `navfuse run` with formats = ["pos"]: STEM.pos is STEM.nav again.
    let nav_stems: Vec<String> = sol_paths
        .iter()
        .filter(|(_, p)| !lower_name(p).ends_with(".pos"))
        .map(|(n, _)| n.clone())
        .collect();
    sol_paths.retain(|(n, p)| {
        let dup = lower_name(p).ends_with(".pos") && nav_stems.contains(n);
        if dup {
            inp.ignored
                .push(format!("{} (same solution as {n}.nav/.csv)", p.display()));
        }
        !dup
    });
    // The fix state of every `.pos` (kept or set aside as a duplicate).
    for p in files.iter().filter(|p| lower_name(p).ends_with(".pos")) {
        let st = lower_name(p);
        if st.starts_with("truth.") || st.starts_with("reference.") {
            continue;
        }
        if st.starts_with("gnss.") || st.starts_with("fixes.") {
            continue;
        }
        if let Some(q) = fix_state::read_pos_quality(p, &stem(p))? {
            inp.quality.push(q);
        }
    }
    sol_paths.extend(opt.solutions.iter().cloned());
    for (name, p) in &sol_paths {
        inp.solutions.push(read_trajectory(p, name, false)?);
    }
    sigma_in::attach_std_files(
        &mut inp.solutions,
        &std_files,
        opt.std.as_deref(),
        &mut inp.ignored,
    )?;
    kfgins_dirs.extend(opt.kfgins_outputs.iter().cloned());
    for (name, d) in &kfgins_dirs {
        let (sol, states) = read_kfgins_output(d, name)?;
        inp.solutions.push(sol);
        inp.states.extend(states);
    }
    if let Some(p) = &truth_path {
        inp.truth = Some(read_trajectory(p, "truth", true)?);
    }
    if let Some(p) = &fixes_path {
        inp.fixes = Some(read_trajectory(p, "GNSS fixes", true)?);
    }
    if let Some(s) = &inp.summary {
        inp.outages = outages_from_json(s)?;
    }
    harmonise_weeks(&mut inp, opt.week);
    Ok(inp)
}

/// `"outages"` of a summary: `[[start, end], …]` or `[{"start", "end"}, …]`.
fn outages_from_json(v: &serde_json::Value) -> Result<Vec<Outage>, String> {
    let Some(arr) = v.get("outages").and_then(|o| o.as_array()) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for (i, o) in arr.iter().enumerate() {
        let (s, e) = match o {
            serde_json::Value::Array(a) if a.len() == 2 => (a[0].as_f64(), a[1].as_f64()),
            serde_json::Value::Object(m) => (
                m.get("start").and_then(|x| x.as_f64()),
                m.get("end").and_then(|x| x.as_f64()),
            ),
            _ => (None, None),
        };
        match (s, e) {
            (Some(s), Some(e)) if s.is_finite() && e.is_finite() && s < e => {
                out.push(Outage { start: s, end: e })
            }
            _ => {
                return Err(format!(
                    "summary.json: field `outages[{i}]`: expected [start, end] with start < end, got {o}"
                ))
            }
        }
    }
    Ok(out)
}

fn tow_only(e: &[NavSolution]) -> bool {
    e.iter().all(|x| x.t < WEEK_S)
}

/// Place time-of-week-only series (and innovation/state/outage times) in the
/// week of the inputs that carry one (or `week`).
fn harmonise_weeks(inp: &mut Inputs, week: Option<u32>) {
    let mut trajs: Vec<&mut Trajectory> = inp.solutions.iter_mut().collect();
    if let Some(t) = inp.truth.as_mut() {
        trajs.push(t);
    }
    if let Some(t) = inp.fixes.as_mut() {
        trajs.push(t);
    }
    let w = match week {
        Some(w) => f64::from(w),
        None => match trajs
            .iter()
            .find(|t| !tow_only(&t.epochs))
            .and_then(|t| t.epochs.first())
        {
            Some(e) => (e.t / WEEK_S).floor(),
            None => return,
        },
    };
    if w <= 0.0 {
        return;
    }
    let shift = |t: &mut f64| {
        if *t < WEEK_S {
            *t += w * WEEK_S;
        }
    };
    for t in trajs {
        if tow_only(&t.epochs) {
            for e in t.epochs.iter_mut() {
                shift(&mut e.t);
            }
        }
    }
    for s in inp.innovations.iter_mut() {
        for r in s.rows.iter_mut() {
            shift(&mut r.t);
        }
    }
    for s in inp.states.iter_mut() {
        for t in s.t.iter_mut() {
            shift(t);
        }
    }
    for o in inp.outages.iter_mut() {
        shift(&mut o.start);
        shift(&mut o.end);
    }
}

/// Outages from gaps in the fix times longer than 5 median intervals and ≥ 3 s.
pub fn outages_from_fix_gaps(fix_t: &[f64]) -> Vec<Outage> {
    if fix_t.len() < 3 {
        return Vec::new();
    }
    let mut d: Vec<f64> = fix_t.windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_by(f64::total_cmp);
    let med = d[d.len() / 2];
    let thr = (5.0 * med).max(3.0);
    fix_t
        .windows(2)
        .filter(|w| w[1] - w[0] > thr)
        .map(|w| Outage {
            start: w[0] + med,
            end: w[1],
        })
        .collect()
}

/// Per-estimator results (for the page, the CLI's `--json`, and tests).
#[derive(Clone, Debug, Serialize)]
pub struct EstimatorResult {
    pub name: String,
    pub epochs: usize,
    /// Against the truth, when there is one.
    pub evaluation: Option<Evaluation>,
}

/// A plot of the page.
#[derive(Clone, Debug, Serialize)]
pub struct PlotInfo {
    /// Element id in the page and SVG file stem.
    pub id: String,
    /// Number of data series drawn (`data-series` of its `<svg>`).
    pub series: usize,
}

/// What [`write_report`] produced.
#[derive(Clone, Debug, Serialize)]
pub struct ReportSummary {
    pub html: PathBuf,
    pub svgs: Vec<PathBuf>,
    /// Each plot and the number of series it draws (what the browser check compares).
    pub plots: Vec<PlotInfo>,
    pub sections: Vec<String>,
    #[serde(serialize_with = "ser_results")]
    pub estimators: Vec<EstimatorResult>,
    pub outages: Vec<Outage>,
    pub notes: Vec<String>,
}

/// Results without the per-epoch error series (they stay out of JSON output).
fn ser_results<S: serde::Serializer>(v: &[EstimatorResult], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let mut seq = s.serialize_seq(Some(v.len()))?;
    for r in v {
        let mut val = serde_json::to_value(r).map_err(serde::ser::Error::custom)?;
        if let Some(ev) = val.get_mut("evaluation").and_then(|e| e.as_object_mut()) {
            ev.remove("errors");
        }
        seq.serialize_element(&val)?;
    }
    seq.end()
}

/// The rendered report in memory.
pub struct Rendered {
    pub html: String,
    /// (file name, SVG document) per plot.
    pub svgs: Vec<(String, String)>,
    pub plots: Vec<(String, usize)>,
    pub sections: Vec<String>,
    pub estimators: Vec<EstimatorResult>,
    pub outages: Vec<Outage>,
    pub notes: Vec<String>,
}

/// Evaluate and draw everything (no I/O). `progress` is called with a stage
/// name before each stage.
pub fn render(inputs: &Inputs, progress: &mut dyn FnMut(&str)) -> Result<Rendered, String> {
    page::render(inputs, progress)
}

/// Render `inputs` and write `out_dir/index.html` and `out_dir/plots/*.svg`
/// (creating the directories). The one-liner for any command that has
/// produced a run: `navfuse_report::write_report(&dir.join("report"), &inputs)`.
pub fn write_report(out_dir: &Path, inputs: &Inputs) -> Result<ReportSummary, String> {
    write_report_with(out_dir, inputs, &mut |_| {})
}

/// [`write_report`] with a progress callback.
pub fn write_report_with(
    out_dir: &Path,
    inputs: &Inputs,
    progress: &mut dyn FnMut(&str),
) -> Result<ReportSummary, String> {
    let r = render(inputs, progress)?;
    progress("writing files");
    let plots_dir = out_dir.join("plots");
    std::fs::create_dir_all(&plots_dir).map_err(|e| format!("{}: {e}", plots_dir.display()))?;
    let mut svgs = Vec::new();
    for (name, doc) in &r.svgs {
        let p = plots_dir.join(name);
        let text = format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{doc}\n");
        navfuse_io::atomic::write_atomic(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
        svgs.push(p);
    }
    let html = out_dir.join("index.html");
    navfuse_io::atomic::write_atomic(&html, &r.html)
        .map_err(|e| format!("{}: {e}", html.display()))?;
    Ok(ReportSummary {
        html,
        svgs,
        plots: r
            .plots
            .into_iter()
            .map(|(id, series)| PlotInfo { id, series })
            .collect(),
        sections: r.sections,
        estimators: r.estimators,
        outages: r.outages,
        notes: r.notes,
    })
}

#[cfg(test)]
mod tests;
