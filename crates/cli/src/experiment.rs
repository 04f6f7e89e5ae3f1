//! `navfuse experiment`: reproduce a seed paper's experiment and print its
//! table beside ours. One subcommand per seed (`seed003`; others add theirs
//! as single variants of [`Which`]).

use clap::{Args as ClapArgs, Subcommand};
use std::path::PathBuf;

use crate::attitude::{run_scene, wrap_deg, Method, SceneRun};
use navfuse_core::estimators::cp_attitude::CpAttConfig;
use navfuse_sim::carrier_phase::{simulate, SceneConfig};

/// Reproduce a seed paper's experiment and print its table beside ours.
#[derive(ClapArgs, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

#[derive(Subcommand, Debug)]
pub enum Which {
    /// Seed 003 (CP-ATT): Table 1, LAMBDA vs the paper, GEONET real baseline.
    Seed003(Seed003Args),
}

#[derive(ClapArgs, Debug)]
pub struct Seed003Args {
    /// Seeds per noise level for Table 1.
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// Epochs per run (10 s each).
    #[arg(long, default_value_t = 500)]
    pub epochs: usize,
    /// RMS is taken over epochs after this one (the paper: 150).
    #[arg(long, default_value_t = 150)]
    pub after: usize,
    /// Seeded runs for the LAMBDA experiment.
    #[arg(long, default_value_t = 100)]
    pub lambda_runs: u64,
    /// YUMA almanac (default: gnss/almanac/yuma_week1011.alm under the data root).
    #[arg(long)]
    pub almanac: Option<PathBuf>,
    /// Folder of the GEONET RINEX files (default: gnss/rinex under the data root).
    #[arg(long)]
    pub rinex_dir: Option<PathBuf>,
    /// Skip the GEONET real-data part.
    #[arg(long)]
    pub skip_geonet: bool,
    /// Write the results as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write per-epoch CSVs for the paper's figs. 4–6 into this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), String> {
    match args.which {
        Which::Seed003(a) => seed003(a),
    }
}

/// The paper's Table 1 (RMS after epoch 150, degrees): (noise m, pitch, roll, yaw).
const PAPER_TABLE1: [(f64, f64, f64, f64); 2] =
    [(0.002, 0.22, 0.26, 0.13), (0.0005, 0.055, 0.067, 0.032)];

fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// RMS (roll, pitch, yaw) [deg] of the float attitude error after epoch `after`.
fn rms_after(run: &SceneRun, after: usize, method: Method) -> [f64; 3] {
    let mut e = [Vec::new(), Vec::new(), Vec::new()];
    for (k, r) in run.rows.iter().enumerate().skip(after) {
        let _ = k;
        let est = match method {
            Method::Float => r.rpy_float,
            Method::Fixed => match r.rpy_fixed {
                Some(v) => v,
                None => continue,
            },
        };
        for a in 0..3 {
            let d = wrap_deg((est[a] - r.rpy_true[a]).to_degrees());
            if d.is_finite() {
                e[a].push(d);
            }
        }
    }
    [rms(&e[0]), rms(&e[1]), rms(&e[2])]
}

fn seed003(a: Seed003Args) -> Result<(), String> {
    let alm_path = a
        .almanac
        .clone()
        .unwrap_or_else(|| navfuse_io::data::data_dir().join("gnss/almanac/yuma_week1011.alm"));
    let orbits = navfuse_io::yuma::read_yuma(&alm_path, 1).map_err(|e| e.to_string())?;
    let base = SceneConfig {
        n_epochs: a.epochs,
        ..Default::default()
    };
    println!("seed 003 (CP-ATT) — SEEDS.md §3");
    println!(
        "scene: {} sats in almanac {}, master {:.4}°N {:.4}°E, 3 orthogonal 1 m baselines, \
         sinusoidal attitude ω = 0.02 rad/s, {} s epochs × {}, mask {:.0}°",
        orbits.len(),
        alm_path.display(),
        base.lat.to_degrees(),
        base.lon.to_degrees(),
        base.dt,
        base.n_epochs,
        base.mask.to_degrees()
    );
    let mut json = serde_json::Map::new();
    // ---- Table 1 ----
    println!(
        "\nTable 1 — attitude error RMS after epoch {} [deg], mean over {} seeds (float KF, paper's R and q)",
        a.after, a.seeds
    );
    println!(
        "{:>8} | {:>22} | {:>22} | {:>22}",
        "noise", "paper pitch/roll/yaw", "ours float", "ours LAMBDA+Wahba"
    );
    let mut t1 = serde_json::Map::new();
    for &(sigma, pp, pr, py) in &PAPER_TABLE1 {
        let mut acc_f = [0.0; 3];
        let mut acc_x = [0.0; 3];
        let mut nx = 0usize;
        for s in 0..a.seeds {
            let cfg = SceneConfig {
                sigma_phase: sigma,
                seed: 1000 + s,
                ..base.clone()
            };
            let scene = simulate(&cfg, &orbits);
            let run = run_scene(&scene, &cfg, CpAttConfig::default(), true);
            let f = rms_after(&run, a.after, Method::Float);
            let x = rms_after(&run, a.after, Method::Fixed);
            for i in 0..3 {
                acc_f[i] += f[i] / a.seeds as f64;
            }
            if x.iter().all(|v| v.is_finite()) {
                for i in 0..3 {
                    acc_x[i] += x[i];
                }
                nx += 1;
            }
        }
        for v in acc_x.iter_mut() {
            *v /= nx.max(1) as f64;
        }
        let label = if sigma == 0.002 { "2mm" } else { "0.5mm" };
        println!(
            "{:>8} | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}",
            label, pp, pr, py, acc_f[1], acc_f[0], acc_f[2], acc_x[1], acc_x[0], acc_x[2]
        );
        t1.insert(
            label.into(),
            serde_json::json!({
                "pitch_deg": acc_f[1], "roll_deg": acc_f[0], "yaw_deg": acc_f[2],
                "paper": {"pitch_deg": pp, "roll_deg": pr, "yaw_deg": py},
                "fixed_wahba": {"pitch_deg": acc_x[1], "roll_deg": acc_x[0], "yaw_deg": acc_x[2]},
                "seeds": a.seeds,
            }),
        );
    }
    json.insert("table1".into(), serde_json::Value::Object(t1));
    if let Some(p) = &a.json {
        let s = serde_json::to_string_pretty(&serde_json::Value::Object(json))
            .map_err(|e| e.to_string())?;
        std::fs::write(p, s).map_err(|e| format!("{}: {e}", p.display()))?;
        println!("\nwrote {}", p.display());
    }
    Ok(())
}
