//! `navfuse experiment seed003` (`SEEDS.md §3`): Table 1 of the paper, the
//! LAMBDA part and the GEONET real baseline, beside the paper's numbers.
//! Choices the paper leaves open, as parameters of
//! [`SceneConfig`]: master at Seoul (37.5665° N, 126.978° E, 50 m), the real
//! YUMA almanac (week 2035) from its t_oa, 10° mask, at most 14 satellites;
//! attitude `A·sin(0.02 t + phase)` with A = 10°/10°/30° (roll/pitch/yaw,
//! phases 0, 120°, 240°); undifferenced phase noise 2 mm / 0.5 mm (DD noise
//! 2σ as the paper's R); 500 epochs of 10 s; RMS over epochs after 150,
//! averaged over seeds 1000…. Angles are the paper's (eq. 1–2: pitch about
//! x, roll about y). The float filter is the paper's (q = 0.02, R = (2σ)² I);
//! "fixed" = integer fixing each epoch (LAMBDA on the float filter, else a
//! single-epoch length-constrained search; ratio ≥ 3; baseline length and
//! angle integrity), then the attitude from all fixed DDs of all baselines
//! jointly (exact correlated covariance) carried by a rigid-body attitude
//! filter (ENU rate + angular acceleration, white jerk with q from the
//! scene's angular-jerk bound, `Motion::dynamics_bounds`); reported beside
//! the earlier per-epoch per-baseline LS + weighted Wahba, the per-epoch
//! joint LS and a fixed-lag smoothed attitude (`--smoother-lag`).
//!
//! Measured (`navfuse experiment seed003 --json /tmp/s3.json`, LAMBDA part,
//! seeds 5000–5099, 2 mm), attitude RMS over fixed epochs, pitch/roll/yaw:
//! per-epoch Wahba 0.177/0.121/0.088°, per-epoch joint LS
//! 0.109/0.080/0.066°, attitude filter 0.103/0.076/0.064°, smoothed with a
//! lag of 3 fixes (30 s) 0.064/0.049/0.044°. The float yaw of eq. 4 is no
//! better than its pitch/roll (0.26° each at 2 mm, the paper has yaw 0.13°):
//! with orthonormal body baselines eq. 4 is `C_nb = R_n⁻¹`, whose rows are
//! cross products of the other two baselines, so each angle sees one
//! horizontal error component; equal-weight Wahba on the same float
//! baselines gives yaw 0.18° (and pitch/roll 0.35/0.33°), the paper's pattern
//! (table1 key `float_wahba_equal_weights`).

use std::path::PathBuf;

use super::attitude::{run_scene, wrap_deg, Method, SceneRun};
use crate::ToolError;
use navfuse_core::estimators::cp_attitude::{AttFilterConfig, CpAttConfig, FixConfig};
use navfuse_sim::carrier_phase::{simulate, SceneConfig};

mod lambda;
mod plots;
pub mod stream;
#[cfg(test)]
mod tests;

use lambda::lambda_part;
use plots::write_plots;

#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct Options {
    /// Seeds per noise level for Table 1.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 20))]
    pub seeds: u64,
    /// Epochs per run (10 s each).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 500))]
    pub epochs: usize,
    /// RMS is taken over epochs after this one (the paper: 150).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 150))]
    pub after: usize,
    /// Seeded runs for the LAMBDA experiment.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 100))]
    pub lambda_runs: u64,
    /// First seed of the LAMBDA runs (the reported numbers use 5000…; other
    /// values give an independent check).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 5000))]
    pub lambda_seed0: u64,
    /// Lag [fixed epochs] of the attitude smoother reported beside the
    /// real-time attitude filter in the LAMBDA part (3: where the gain levels
    /// off on the independent seeds 9000–9029 — lag 1/2/3/4 gave pitch
    /// 0.072/0.070/0.064/0.063°).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 3))]
    pub smoother_lag: usize,
    /// Kinematic order of the attitude filter (2: rate + angular
    /// acceleration, white jerk; 3: + jerk, white snap).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 2))]
    pub att_order: usize,
    /// YUMA almanac (default: gnss/almanac/yuma_week1011.alm under the data root).
    #[cfg_attr(feature = "clap", arg(long))]
    pub almanac: Option<PathBuf>,
    /// Folder of the GEONET RINEX files (default: gnss/rinex under the data root).
    #[cfg_attr(feature = "clap", arg(long))]
    pub rinex_dir: Option<PathBuf>,
    /// Skip the GEONET real-data part.
    #[cfg_attr(feature = "clap", arg(long))]
    pub skip_geonet: bool,
    /// Write the results as JSON here.
    #[cfg_attr(feature = "clap", arg(long))]
    pub json: Option<PathBuf>,
    /// Write per-epoch CSVs for the paper's figs. 4–6 into this folder.
    #[cfg_attr(feature = "clap", arg(long))]
    pub plots: Option<PathBuf>,
    /// Compute Table 1 through the streaming `cp-att` Estimator
    /// (per-satellite carrier-phase events → NED attitude solutions) instead
    /// of the batch loop; the numbers must be the same to the last digit.
    #[cfg_attr(feature = "clap", arg(long))]
    pub via_estimator: bool,
}

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
        let Some(est) = r.est(method) else { continue };
        for a in 0..3 {
            let d = wrap_deg((est[a] - r.rpy_true[a]).to_degrees());
            if d.is_finite() {
                e[a].push(d);
            }
        }
    }
    [rms(&e[0]), rms(&e[1]), rms(&e[2])]
}

/// Run the experiment: print the tables, write `--json` / `--plots`.
pub fn run(a: Options) -> Result<(), ToolError> {
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
        "\nTable 1 — attitude error RMS after epoch {} [deg], mean over {} seeds (float KF, paper's R and q){}",
        a.after,
        a.seeds,
        if a.via_estimator {
            ", through the cp-att Estimator"
        } else {
            ""
        }
    );
    println!(
        "{:>8} | {:>22} | {:>22} | {:>22} | {:>22} | {:>22}",
        "noise",
        "paper pitch/roll/yaw",
        "ours float (paper R)",
        "float, exact DD cov",
        "fixed + Wahba (epoch)",
        "fixed + att. filter"
    );
    let mut t1 = serde_json::Map::new();
    for &(sigma, pp, pr, py) in &PAPER_TABLE1 {
        let mut acc_f = [0.0; 3];
        let mut acc_x = [0.0; 3];
        let mut acc_xf = [0.0; 3];
        let mut acc_e = [0.0; 3];
        let mut acc_fw = [0.0; 3];
        let mut nx = 0usize;
        for s in 0..a.seeds {
            let cfg = SceneConfig {
                sigma_phase: sigma,
                seed: 1000 + s,
                ..base.clone()
            };
            let scene = simulate(&cfg, &orbits);
            let runner = if a.via_estimator {
                stream::run_scene_via_estimator
            } else {
                run_scene
            };
            let run = runner(
                &scene,
                &cfg,
                CpAttConfig::default(),
                Some(FixConfig::default()),
            );
            let f = rms_after(&run, a.after, Method::Float);
            let fw = rms_after(&run, a.after, Method::FloatWahba);
            let x = rms_after(&run, a.after, Method::FixedWahba);
            let xf = rms_after(&run, a.after, Method::Fixed);
            // The same float filter with the exact (correlated) DD covariance.
            let exact = CpAttConfig {
                dd_noise: navfuse_core::gnss::dd::DdNoise::Exact,
                ..Default::default()
            };
            let e = rms_after(&runner(&scene, &cfg, exact, None), a.after, Method::Float);
            for i in 0..3 {
                acc_f[i] += f[i] / a.seeds as f64;
                acc_e[i] += e[i] / a.seeds as f64;
                acc_fw[i] += fw[i] / a.seeds as f64;
            }
            if x.iter().chain(&xf).all(|v| v.is_finite()) {
                for i in 0..3 {
                    acc_x[i] += x[i];
                    acc_xf[i] += xf[i];
                }
                nx += 1;
            }
        }
        for v in acc_x.iter_mut().chain(acc_xf.iter_mut()) {
            *v /= nx.max(1) as f64;
        }
        let label = if sigma == 0.002 { "2mm" } else { "0.5mm" };
        println!(
            "{:>8} | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}    | {:>6.3} {:>6.3} {:>6.3}",
            label, pp, pr, py, acc_f[1], acc_f[0], acc_f[2], acc_e[1], acc_e[0], acc_e[2], acc_x[1], acc_x[0], acc_x[2], acc_xf[1], acc_xf[0], acc_xf[2]
        );
        t1.insert(
            label.into(),
            serde_json::json!({
                "pitch_deg": acc_f[1], "roll_deg": acc_f[0], "yaw_deg": acc_f[2],
                "paper": {"pitch_deg": pp, "roll_deg": pr, "yaw_deg": py},
                "fixed_wahba": {"pitch_deg": acc_x[1], "roll_deg": acc_x[0], "yaw_deg": acc_x[2]},
                "fixed_att_filter": {"pitch_deg": acc_xf[1], "roll_deg": acc_xf[0], "yaw_deg": acc_xf[2]},
                "float_wahba_equal_weights": {"pitch_deg": acc_fw[1], "roll_deg": acc_fw[0], "yaw_deg": acc_fw[2]},
                "float_exact_dd_cov": {"pitch_deg": acc_e[1], "roll_deg": acc_e[0], "yaw_deg": acc_e[2]},
                "seeds": a.seeds,
            }),
        );
    }
    json.insert("table1".into(), serde_json::Value::Object(t1));
    json.insert("via_estimator".into(), a.via_estimator.into());
    if a.lambda_runs > 0 {
        json.insert("lambda".into(), lambda_part(&a, &base, &orbits));
    }
    if let Some(dir) = &a.plots {
        write_plots(dir, &base, &orbits)?;
    }
    if !a.skip_geonet {
        let dir = a
            .rinex_dir
            .clone()
            .unwrap_or_else(|| navfuse_io::data::data_dir().join("gnss/rinex"));
        json.insert("geonet".into(), super::baseline::geonet_part(&dir)?);
    }
    if let Some(p) = &a.json {
        let s = serde_json::to_string_pretty(&serde_json::Value::Object(json))
            .map_err(|e| e.to_string())?;
        navfuse_io::atomic::write_atomic(p, s).map_err(|e| format!("{}: {e}", p.display()))?;
        println!("\nwrote {}", p.display());
    }
    Ok(())
}
