//! Reports built from in-memory runs: `navfuse eval --report`, the demo's
//! output folder, and experiments' solution series (legend name, epochs).
//! Frames: positions geodetic (lat, lon radians; h metres), GPS time [s].

use crate::{load_run_dir, write_report, Inputs, LoadOptions, Trajectory};
use navfuse_core::NavSolution;
use navfuse_eval::{Align, EvalConfig, OutageSchedule};
use std::path::Path;

const WEEK_S: f64 = 604_800.0;

/// The report of one `navfuse eval` run (`navfuse eval --report DIR`):
/// the solution and truth as eval read them (weeks harmonised), the fixes
/// file when given, the outages of the schedule inside the solution's span.
pub fn from_eval(
    dir: &Path,
    solution: (&Path, Vec<NavSolution>),
    truth: (&Path, Vec<NavSolution>),
    fixes: Option<&Path>,
    cfg: EvalConfig,
    schedule: Option<&OutageSchedule>,
) -> Result<(), String> {
    let traj = |name: String, p: &Path, epochs: Vec<NavSolution>| Trajectory {
        name,
        path: Some(p.to_path_buf()),
        epochs,
        records: None,
    };
    let (lo, hi) = (
        solution.1.first().map_or(0.0, |e| e.t),
        solution.1.last().map_or(0.0, |e| e.t),
    );
    let fixes = match fixes {
        Some(p) => {
            let mut f = crate::read_trajectory(p, "GNSS fixes", true)?;
            if lo >= WEEK_S && f.epochs.iter().all(|e| e.t < WEEK_S) {
                let w = (lo / WEEK_S).floor() * WEEK_S;
                f.epochs.iter_mut().for_each(|e| e.t += w);
            }
            Some(f)
        }
        None => None,
    };
    let name = solution
        .0
        .file_stem()
        .map_or("solution".into(), |s| s.to_string_lossy().into_owned());
    let inputs = Inputs {
        title: format!("navfuse eval: {}", solution.0.display()),
        solutions: vec![traj(name, solution.0, solution.1)],
        truth: Some(traj("truth".into(), truth.0, truth.1)),
        fixes,
        outages: schedule.map_or(Vec::new(), |s| s.intervals(lo, hi)),
        eval: cfg,
        ..Default::default()
    };
    let sum = write_report(dir, &inputs)?;
    stdout(&format!("  report: {}\n", sum.html.display()))?;
    Ok(())
}

/// The report of a `navfuse demo` output folder (`navfuse demo --report`):
/// the folder read as a RUN_DIR, the scenario's outages `(start, end)` [GPS s].
pub fn from_demo(out: &Path, outages: Vec<(f64, f64)>) -> Result<(), String> {
    let mut inp = load_run_dir(out, &LoadOptions::default())?;
    inp.title = format!("navfuse demo — {}", out.display());
    inp.outages = outages
        .into_iter()
        .map(|(start, end)| navfuse_eval::Outage { start, end })
        .collect();
    let sum = write_report(&out.join("report"), &inp)?;
    stdout(&format!("report: {}\n", sum.html.display()))
}

/// The report of an experiment (`navfuse experiment … --report DIR`): solution
/// series kept in memory (legend name, epochs), the truth and, if given, the
/// GNSS fixes used, compared at the truth epochs (solutions interpolated). Each series is sorted by
/// time and repeated epochs dropped, as [`crate::read_trajectory`] does.
pub fn from_series(
    dir: &Path,
    title: String,
    solutions: Vec<(String, Vec<NavSolution>)>,
    truth: Vec<NavSolution>,
    fixes: Option<Vec<NavSolution>>,
) -> Result<(), String> {
    let traj = |name: String, mut epochs: Vec<NavSolution>| {
        epochs.sort_by(|a, b| a.t.total_cmp(&b.t));
        epochs.dedup_by(|b, a| a.t == b.t);
        Trajectory {
            name,
            path: None,
            epochs,
            records: None,
        }
    };
    let inputs = Inputs {
        title,
        solutions: solutions
            .into_iter()
            .map(|(n, e)| traj(n, e))
            .filter(|t| !t.epochs.is_empty())
            .collect(),
        truth: Some(traj("truth".into(), truth)),
        fixes: fixes.map(|f| traj("GNSS fixes".into(), f)),
        // Every series scored at the same instants, as `load_run_dir` does.
        eval: EvalConfig {
            align: Align::AtReference,
            ..Default::default()
        },
        ..Default::default()
    };
    let sum = write_report(dir, &inputs)?;
    stdout(&format!("report: {}\n", sum.html.display()))
}

/// A position-only epoch (velocity, attitude and σ unknown = NaN).
pub fn position_at(t: f64, lat: f64, lon: f64, h: f64) -> NavSolution {
    let mut s = NavSolution::unknown_at(t);
    (s.lat, s.lon, s.h) = (lat, lon, h);
    s.v_n = navfuse_core::Vec3::repeat(f64::NAN);
    s
}

/// Print to stdout; a closed pipe (`| head`) is not an error.
pub fn stdout(s: &str) -> Result<(), String> {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match o.write_all(s.as_bytes()).and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}
