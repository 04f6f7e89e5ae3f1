//! `navfuse demo`: simulate a drive, run every estimator on it, write outputs and a report.
//!
//! Needs no files: the default scenario (`scenarios/demo_drive.toml`, a
//! ~10-minute car drive with an industrial MEMS IMU at 100 Hz and 1 Hz GNSS
//! with two outages) is embedded. Every estimator in [`estimators`] is fed
//! the same time-ordered events; each one's solutions are written
//! (`<name>.nav`, `<name>.csv`) beside the truth and sensor files and scored
//! against the exact truth: horizontal RMS and max over the run, and the
//! largest horizontal error inside each GNSS outage (the drift while coasting).

use clap::Args as ClapArgs;
use navfuse_core::Estimator;
use navfuse_core::{earth, Event, GnssFix, NavSolution, Vec3};
use navfuse_io::writers::{CsvWriter, KfGinsNavWriter, TrajectoryWriter};
use navfuse_sim::{output, simulate, Scenario, SimRun};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The embedded default scenario.
const DEMO_SCENARIO: &str = include_str!("../../../scenarios/demo_drive.toml");

/// Simulate a drive, run every estimator on it, write outputs and a report.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Seed of the simulated sensor errors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use this scenario instead of the embedded drive.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
}

/// Every estimator the demo runs, fed the same events. Add one line per
/// estimator as they land (`Box::new(Eskf::new(cfg, init))`, …).
fn estimators(_run: &SimRun) -> Vec<Box<dyn Estimator>> {
    vec![Box::new(GnssHold::default())]
}

/// Estimators of the project that do not exist yet (named in the report).
const NOT_YET: &[&str] = &["eskf (seed 001)", "pf-lc (seed 002)", "gps-acc (seed 004)"];

/// Baseline, not one of the four systems: holds the last GNSS fix (antenna
/// position, the receiver's velocity) at every IMU epoch — seed 004's
/// "GPS-only" comparison. No attitude (NaN).
#[derive(Default)]
struct GnssHold {
    last: Option<GnssFix>,
}

impl Estimator for GnssHold {
    fn name(&self) -> &'static str {
        "gnss-hold"
    }
    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        match ev {
            Event::Gnss(g) => {
                self.last = Some(*g);
                None
            }
            Event::Imu(s) => self.last.map(|g| NavSolution {
                lat: g.lat,
                lon: g.lon,
                h: g.h,
                v_n: g.v_n.unwrap_or(Vec3::repeat(f64::NAN)),
                std_pos_ned: g.std_ned,
                std_v_n: g.std_v_n.unwrap_or(Vec3::repeat(f64::NAN)),
                ..NavSolution::unknown_at(s.t)
            }),
        }
    }
}

/// Scores of one estimator against truth.
struct Score {
    name: &'static str,
    epochs: usize,
    h_rms: f64,
    h_max: f64,
    v_rms: f64,
    /// Largest horizontal error inside each outage [m] (NaN: no solution there).
    outage_max: Vec<f64>,
    secs: f64,
}

fn horizontal_vertical(run: &SimRun, s: &NavSolution) -> (f64, f64) {
    let t = run.traj.at(s.t);
    let (rm, rn) = earth::radii(t.lat);
    let dn = (s.lat - t.lat) * (rm + t.h);
    let de = (s.lon - t.lon) * (rn + t.h) * t.lat.cos();
    (dn.hypot(de), s.h - t.h)
}

fn run_estimator(
    est: &mut dyn Estimator,
    events: &[Event],
    run: &SimRun,
    out: &Path,
) -> Result<Score, String> {
    let t0 = Instant::now();
    let name = est.name();
    let mut sols = Vec::with_capacity(run.imu.len());
    for ev in events {
        if let Some(s) = est.push(ev) {
            sols.push(s);
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let open = |ext: &str| -> Result<BufWriter<File>, String> {
        let p = out.join(format!("{name}.{ext}"));
        File::create(&p)
            .map(BufWriter::new)
            .map_err(|e| format!("{}: {e}", p.display()))
    };
    let mut nav = KfGinsNavWriter::new(open("nav")?);
    let mut csv = CsvWriter::new(open("csv")?);
    let start = run.traj.truth[0].t;
    let outages = &run.scenario.gnss.outages;
    let mut outage_max = vec![f64::NAN; outages.len()];
    let (mut h2, mut v2, mut hmax) = (0.0, 0.0, 0.0f64);
    let mut n = 0usize;
    for s in &sols {
        nav.write(s).map_err(|e| format!("{name}.nav: {e}"))?;
        csv.write(s).map_err(|e| format!("{name}.csv: {e}"))?;
        let (h, v) = horizontal_vertical(run, s);
        if !(h.is_finite() && v.is_finite()) {
            return Err(format!("{name}: non-finite solution at t = {}", s.t));
        }
        h2 += h * h;
        v2 += v * v;
        hmax = hmax.max(h);
        n += 1;
        let rel = s.t - start;
        for (k, o) in outages.iter().enumerate() {
            if rel >= o[0] && rel < o[1] {
                outage_max[k] = if outage_max[k].is_nan() {
                    h
                } else {
                    outage_max[k].max(h)
                };
            }
        }
    }
    nav.finish().map_err(|e| format!("{name}.nav: {e}"))?;
    csv.finish().map_err(|e| format!("{name}.csv: {e}"))?;
    let nf = n.max(1) as f64;
    Ok(Score {
        name,
        epochs: n,
        h_rms: (h2 / nf).sqrt(),
        h_max: hmax,
        v_rms: (v2 / nf).sqrt(),
        outage_max,
        secs,
    })
}

pub fn run(args: Args) -> Result<(), String> {
    let t0 = Instant::now();
    let sc = match &args.scenario {
        Some(p) => Scenario::from_file(p).map_err(|e| e.to_string())?,
        None => Scenario::from_toml(DEMO_SCENARIO, "embedded demo_drive.toml")
            .map_err(|e| e.to_string())?,
    };
    let run = simulate(&sc, args.seed, None, None).map_err(|e| e.to_string())?;
    let t_sim = t0.elapsed().as_secs_f64();
    output::write_run(&run, &args.out).map_err(|e| e.to_string())?;
    let events = run.events();
    let mut scores = Vec::new();
    for mut est in estimators(&run) {
        scores.push(run_estimator(est.as_mut(), &events, &run, &args.out)?);
    }

    println!("navfuse demo — simulated drive (seed {})", args.seed);
    println!("{}", run.summary());
    let outs: Vec<String> = sc
        .gnss
        .outages
        .iter()
        .map(|o| format!("{:.0}–{:.0} s", o[0], o[1]))
        .collect();
    println!(
        "GNSS outages: {}",
        if outs.is_empty() {
            "none".into()
        } else {
            outs.join(", ")
        }
    );
    println!();
    println!(
        "estimators run: {}",
        scores.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
    );
    println!("not available yet: {}", NOT_YET.join(", "));
    println!(
        "{:<12} {:>8} {:>10} {:>10} {:>10}  max h error in each outage [m]",
        "estimator", "epochs", "h rms [m]", "h max [m]", "v rms [m]",
    );
    for s in &scores {
        let o: Vec<String> = s.outage_max.iter().map(|x| format!("{x:.2}")).collect();
        println!(
            "{:<12} {:>8} {:>10.2} {:>10.2} {:>10.2}  {}   ({:.3} s)",
            s.name,
            s.epochs,
            s.h_rms,
            s.h_max,
            s.v_rms,
            o.join(" / "),
            s.secs
        );
    }
    println!(
        "(errors of the IMU point vs exact truth; gnss-hold reports the antenna, {} m lever arm)",
        Vec3::from(sc.gnss.lever_arm_m).norm()
    );
    println!(
        "wrote {} (truth.nav/csv, imu*.txt/csv, gnss.txt/csv, <estimator>.nav/csv); simulation {:.2} s, total {:.2} s",
        args.out.display(),
        t_sim,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
