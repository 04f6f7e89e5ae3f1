//! `navfuse report`: one self-contained HTML page and standalone SVG plots
//! of a run directory (layout: `navfuse_report` crate doc).

use clap::Args as ClapArgs;
use navfuse_eval::{Align, OutageSchedule};
use navfuse_report::build::stdout;
use navfuse_report::{load_run_dir, write_report_with, LoadOptions, ReportSummary};
use std::io::IsTerminal;
use std::path::PathBuf;

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
    /// σ file (navfuse `.std`) of the solution with the same stem, else of
    /// the first solution (default: STEM.std beside STEM.nav is used).
    #[arg(long, value_name = "FILE")]
    pub std: Option<PathBuf>,
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
            std: args.std.clone(),
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
            std: None,
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
                std: None,
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
