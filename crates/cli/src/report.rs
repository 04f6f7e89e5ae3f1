//! `navfuse report`: one self-contained HTML page and standalone SVG plots
//! of a run directory (layout: `navfuse_report` crate doc).

use clap::Args as ClapArgs;
use navfuse_core::NavSolution;
use navfuse_eval::{Align, EvalConfig, OutageSchedule};
use navfuse_report::{
    load_run_dir, write_report_with, Inputs, LoadOptions, ReportSummary, Trajectory,
};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

const WEEK_S: f64 = 604_800.0;

/// Write RUN_DIR/report/index.html (self-contained) and RUN_DIR/report/plots/*.svg.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Run directory: solutions (*.nav, *.csv, *.pos), truth.*, gnss.*,
    /// summary.json, *innovations.csv, *states.csv (see `navfuse_report`).
    pub run_dir: PathBuf,
    /// Truth trajectory (.nav, .csv, .pos; overrides truth.* in RUN_DIR).
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// GNSS fixes used by the run (KF-GINS GNSS .txt, .pos, .csv; overrides gnss.*).
    #[arg(long, value_name = "FILE")]
    pub fixes: Option<PathBuf>,
    /// Another solution file, with its legend name (repeatable).
    #[arg(long = "solution", value_name = "NAME=FILE")]
    pub solutions: Vec<String>,
    /// A KF-GINS output folder (KF_GINS_Navresult.nav, KF_GINS_STD.txt,
    /// KF_GINS_IMU_ERR.txt — KF-GINS's or `navfuse kf-gins`'s) with its legend
    /// name: the solution with ±3σ and its IMU error states (repeatable).
    #[arg(long = "kfgins-output", value_name = "NAME=DIR")]
    pub kfgins_outputs: Vec<String>,
    /// Lever arm x,y,z [m], body FRD, from the solutions' point to the truth's
    /// point (drive_0708: 0,-0.05,0, IMU → antenna).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub lever_arm: Option<String>,
    /// Outage schedule S,P,L[,T0]: GNSS cut for L s every P s from S s after
    /// T0 (default T0: the first epoch). Default: summary.json's `outages`,
    /// else gaps in the GNSS fixes.
    #[arg(long, value_name = "S,P,L[,T0]")]
    pub outages: Option<String>,
    /// Maximum number of outages of the schedule.
    #[arg(long, value_name = "N")]
    pub outage_count: Option<usize>,
    /// Compare at the truth epochs (same instants for every estimator) or at
    /// each solution's epochs.
    #[arg(long, value_enum, default_value_t = At::Reference)]
    pub at: At,
    /// Largest gap [s] bridged by interpolation.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub max_gap: f64,
    /// GPS week for time-of-week-only inputs (default: from the other inputs).
    #[arg(long)]
    pub week: Option<u32>,
    /// Output directory (default RUN_DIR/report).
    #[arg(long, short, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Page title.
    #[arg(long)]
    pub title: Option<String>,
    /// Print nothing on success.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print what was written (files, plots, statistics) as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write a small synthetic run (navfuse_report::fixture) into RUN_DIR first
    /// (for tests and the browser check).
    #[arg(long, hide = true)]
    pub fixture: bool,
}

/// Where to compare.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    Reference,
    Solution,
}

fn parse_floats(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{what}: {p:?} is not a finite number"))
        })
        .collect()
}

pub fn run(args: Args) -> Result<(), String> {
    if args.fixture {
        navfuse_report::fixture::write_fixture(&args.run_dir)?;
    }
    let mut solutions = Vec::new();
    for s in &args.solutions {
        let (name, path) = s
            .split_once('=')
            .ok_or_else(|| format!("--solution: expected NAME=FILE, got {s:?}"))?;
        solutions.push((name.to_string(), PathBuf::from(path)));
    }
    let mut kfgins_outputs = Vec::new();
    for s in &args.kfgins_outputs {
        let (name, path) = s
            .split_once('=')
            .ok_or_else(|| format!("--kfgins-output: expected NAME=DIR, got {s:?}"))?;
        kfgins_outputs.push((name.to_string(), PathBuf::from(path)));
    }
    let show = !args.quiet && !args.json && std::io::stderr().is_terminal();
    let bar = show.then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.enable_steady_tick(std::time::Duration::from_millis(120));
        b
    });
    let mut progress = |stage: &str| {
        if let Some(b) = &bar {
            b.set_message(format!("report: {stage}"));
        }
    };
    progress("reading inputs");
    let mut inp = load_run_dir(
        &args.run_dir,
        &LoadOptions {
            truth: args.truth.clone(),
            fixes: args.fixes.clone(),
            solutions,
            kfgins_outputs,
            week: args.week,
        },
    )?;
    if let Some(t) = &args.title {
        inp.title = t.clone();
    }
    inp.eval.align = match args.at {
        At::Reference => Align::AtReference,
        At::Solution => Align::AtSolution,
    };
    inp.eval.max_gap = args.max_gap;
    if let Some(l) = &args.lever_arm {
        let v = parse_floats(l, "--lever-arm")?;
        if v.len() != 3 {
            return Err(format!("--lever-arm: expected X,Y,Z, got {l:?}"));
        }
        inp.eval.lever_arm_b = Some([v[0], v[1], v[2]]);
    }
    if let Some(o) = &args.outages {
        let v = parse_floats(o, "--outages")?;
        if v.len() != 3 && v.len() != 4 {
            return Err(format!("--outages: expected S,P,L or S,P,L,T0, got {o:?}"));
        }
        // The data span: truth if given, else all solutions.
        let epochs: Vec<f64> = match &inp.truth {
            Some(t) => t.epochs.iter().map(|e| e.t).collect(),
            None => inp
                .solutions
                .iter()
                .flat_map(|s| s.epochs.iter().map(|e| e.t))
                .collect(),
        };
        let lo = epochs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = epochs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            return Err("--outages: no epochs to place the schedule in".into());
        }
        let mut t0 = v.get(3).copied().unwrap_or(lo);
        if t0 < WEEK_S && lo >= WEEK_S {
            t0 += (lo / WEEK_S).floor() * WEEK_S; // T0 given as time of week
        }
        let sched = OutageSchedule::periodic(t0, v[0], v[1], v[2], args.outage_count)
            .map_err(|e| format!("--outages: {e}"))?;
        inp.outages = sched.intervals(lo, hi);
        if inp.outages.is_empty() {
            return Err(format!(
                "--outages {o}: no outage of the schedule lies inside the data ({lo:.3} – {hi:.3} s)"
            ));
        }
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.run_dir.join("report"));
    let sum = write_report_with(&out, &inp, &mut progress)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if args.json {
        let js = serde_json::to_string_pretty(&sum).map_err(|e| format!("JSON: {e}"))?;
        stdout(&format!("{js}\n"))?;
    } else if !args.quiet {
        stdout(&text_summary(&sum))?;
    }
    Ok(())
}

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
            let mut f = navfuse_report::read_trajectory(p, "GNSS fixes", true)?;
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
    let sum = navfuse_report::write_report(dir, &inputs)?;
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
    let sum = navfuse_report::write_report(&out.join("report"), &inp)?;
    stdout(&format!("report: {}\n", sum.html.display()))
}

/// The report of an experiment (`navfuse experiment … --report DIR`): solution
/// series kept in memory (legend name, epochs), the truth and, if given, the
/// GNSS fixes used, compared at the truth epochs (solutions interpolated). Each series is sorted by
/// time and repeated epochs dropped, as [`navfuse_report::read_trajectory`] does.
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
    let sum = navfuse_report::write_report(dir, &inputs)?;
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
fn stdout(s: &str) -> Result<(), String> {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match o.write_all(s.as_bytes()).and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}

fn text_summary(sum: &ReportSummary) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "navfuse report: wrote {} ({} plots; sections: {}) and {} SVG files in {}",
        sum.html.display(),
        sum.plots.len(),
        sum.sections.join(", "),
        sum.svgs.len(),
        sum.svgs
            .first()
            .and_then(|p| p.parent())
            .map_or(String::new(), |p| p.display().to_string())
    );
    for n in &sum.notes {
        let _ = writeln!(s, "  note: {n}");
    }
    for r in &sum.estimators {
        let _ = write!(s, "  {:<16} {:>8} epochs", r.name, r.epochs);
        if let Some(ev) = &r.evaluation {
            if let Some(h) = ev.summary.horizontal {
                let _ = write!(
                    s,
                    "  horizontal RMS {:.3} m, max {:.3} m, p95 {:.3} m",
                    h.rms, h.max_abs, h.p95_abs
                );
            }
            if let Some(o) = ev.outages.as_ref().and_then(|o| o.rms_of_max) {
                let _ = write!(s, "  outage drift RMS-of-max {o:.2} m");
            }
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(dir: &std::path::Path) -> Args {
        Args {
            run_dir: dir.to_path_buf(),
            truth: None,
            fixes: None,
            solutions: vec![],
            kfgins_outputs: vec![],
            lever_arm: None,
            outages: None,
            outage_count: None,
            at: At::Reference,
            max_gap: 1.0,
            week: None,
            out: None,
            title: None,
            quiet: true,
            json: false,
            fixture: true,
        }
    }

    #[test]
    fn report_command_on_the_fixture() {
        let dir = std::env::temp_dir().join(format!("navfuse-cli-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut a = args(&dir);
        // An explicit schedule overrides summary.json: 10 s cuts every 100 s from 50 s.
        a.outages = Some("50,100,10".into());
        run(a).unwrap();
        let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
        assert!(html.contains("3 GNSS outages (t − t₀ [s]): 50.0–60.0, 150.0–160.0, 250.0–260.0."));
        assert!(dir.join("report/plots/track.svg").exists());

        let mut a = args(&dir);
        a.fixture = false;
        a.lever_arm = Some("1,2".into());
        assert!(run(a).unwrap_err().contains("--lever-arm"));
        let mut a = args(&dir);
        a.fixture = false;
        a.solutions = vec!["nofile".into()];
        assert!(run(a).unwrap_err().contains("NAME=FILE"));
        let mut a = args(&dir);
        a.fixture = false;
        a.outages = Some("5000,100,10".into());
        assert!(run(a).unwrap_err().contains("no outage"));
    }

    /// The drive_0708 outage run: navfuse's ESKF (`navfuse kf-gins` on the
    /// KF-GINS outage configuration) and KF-GINS's own result side by side
    /// against the RTK truth.
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn drive_0708_eskf_and_kfgins_side_by_side() {
        use navfuse_io::data::require;
        let yaml = require("drive_0708/kfgins/kf-gins_outage.yaml");
        let d = require("drive_0708/kfgins");
        let dir = std::env::temp_dir().join(format!("navfuse-drive-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let eskf = dir.join("eskf");
        std::fs::create_dir_all(&eskf).unwrap();
        let opts = navfuse_pipeline::kf_gins::KfGinsOptions {
            output: Some(eskf.clone()),
            ..Default::default()
        };
        navfuse_pipeline::kf_gins::run_kf_gins(&yaml, &opts).unwrap();

        let mut inp = load_run_dir(
            &dir,
            &LoadOptions {
                truth: Some(d.join("truth.nav")),
                fixes: Some(d.join("gnss_outage.txt")),
                solutions: vec![("KF-GINS".into(), d.join("kfgins_result_outage_10hz.nav"))],
                kfgins_outputs: vec![("navfuse ESKF".into(), eskf)],
                week: None,
            },
        )
        .unwrap();
        inp.eval.lever_arm_b = Some([0.0, -0.05, 0.0]);
        let t0 = (inp.truth.as_ref().unwrap().epochs[0].t / WEEK_S).floor() * WEEK_S + 243_262.0;
        inp.outages = (0..5)
            .map(|k| navfuse_eval::Outage {
                start: t0 + 120.0 + 90.0 * f64::from(k),
                end: t0 + 150.0 + 90.0 * f64::from(k),
            })
            .collect();
        let sum = navfuse_report::write_report(&dir.join("report"), &inp).unwrap();
        assert_eq!(sum.estimators.len(), 2);
        for r in &sum.estimators {
            let ev = r.evaluation.as_ref().unwrap();
            let o = ev.outages.as_ref().unwrap();
            assert_eq!(o.outages.len(), 5, "{}", r.name);
            let rms = o.rms_of_max.unwrap();
            eprintln!(
                "{}: outage drift RMS of maxima {rms:.2} m, horizontal RMS {:.3} m",
                r.name,
                ev.summary.horizontal.unwrap().rms
            );
            assert!(
                rms.is_finite() && rms > 0.0 && rms < 200.0,
                "{}: {rms}",
                r.name
            );
        }
        // KF-GINS's own result: the README's 44.85 m.
        let kf = sum.estimators.iter().find(|r| r.name == "KF-GINS").unwrap();
        let rms = kf
            .evaluation
            .as_ref()
            .unwrap()
            .outages
            .as_ref()
            .unwrap()
            .rms_of_max
            .unwrap();
        assert!((rms - 44.85).abs() <= 0.01, "{rms}");
        // The ESKF brings its σ (bands) and IMU error states.
        assert!(sum.sections.iter().any(|s| s == "states"));
        let html = std::fs::read_to_string(&sum.html).unwrap();
        assert!(html.contains("class=\"band\" data-name=\"navfuse ESKF ±3σ\""));
        assert!(html.contains("<th colspan=\"3\">KF-GINS</th><th colspan=\"3\">navfuse ESKF</th>"));
    }
}
