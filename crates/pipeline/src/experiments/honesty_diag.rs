//! Diagnostics of σ honesty per cell and seed (an ignored test, printed
//! tables): horizontal NEES and 95 % coverage inside and outside the GNSS
//! outages, per seed, for configuration variants of the default run. Run
//! without `DIAG_*` variables (as CI's `--ignored` step does) it asserts
//! issue 20's band on the car RTK cells' and pedestrian:industrial:rtk:0's
//! default configuration, forward and smoothed.
//!
//! `DIAG_CELLS='*:*:rtk' DIAG_SEEDS=4 DIAG_VARIANTS=default,consider cargo
//! test --release -p navfuse-pipeline honesty_diag -- --ignored --nocapture`
//! (`DIAG_SEED0`: first seed, 0 by default; variants: `default`, `oracle`, `+`-joined tweaks `smooth` (score the
//! RTS-smoothed solutions), `consider`, `white`,
//! `nis`, `nonis`, `s01` = GNSS σ declared × 0.1, `nhc_off`, `nhc_adapt`,
//! `zupt_off`, `tauN` = `[filter.gnss_error] tau_s = N`).
//!
//! Findings at b37aa29 (8 seeds, 600 s, all 24 RTK cells):
//! - The white RTK model is what is overconfident: while GNSS is present
//!   coverage95_h is 0.77–0.90 (NEES 2.6–5.6), inside the outages 0.79–1.00; the truth-started oracle (also white) is the same, so it is
//!   not the alignment or the time offset. The simulator's RTK error is half
//!   Gauss–Markov (τ 30 s), which a white model averages away.
//! - `model = "consider"` (the consumer prior: √0.9 σ, τ 60 s) on RTK puts
//!   coverage95_h in [0.90, 0.99] in 20 of 24 cells (GNSS-present 0.93–0.97)
//!   but raises the pedestrian industrial/tactical h RMS by 27–38 %
//!   (0.266 → 0.367 m, 0.224 → 0.305 m), so RTK stays white by default.
//! - Sensitivity σ (`gnss_error::sensitivity_model`, white gain kept, σ under
//!   a Gauss–Markov part split from the fixes, τ 115 s), 10 seeds, all 24
//!   RTK cells: coverage95_h 0.82–0.92 → 0.90–0.93 (23/24 in [0.90, 0.99];
//!   car:tactical:rtk:0.1 0.898), NEES 2.1–3.4 → 2.1–3.0, every h RMS and
//!   outage drift bit-identical. Pedestrian cells unchanged: their
//!   fix-to-fix differences show no correlated part (white 0.020 ± 0.008 m
//!   of 0.020). τ 30 / 115 / 600 s (`tau30`, `tau600`): coverage 0.93–0.94
//!   on car:industrial and uav:tactical (4 seeds), NEES within ±0.1. On the
//!   matrix platforms the split reads σ_w 0.016–0.020 m against the
//!   simulator's 0.014 (on `scenarios/demo_drive.toml` with `--gnss
//!   rtk-1hz`: 0.014), so σ_b is under-read there. Traced: the trapezoid
//!   of the fix velocities misses the trajectory's own term (0.03–0.09 m
//!   RMS per axis at 1 Hz); on the IMU's quiet intervals
//!   (`crate::fix_dynamics`) the split reads 0.0135–0.0153. 20 seeds
//!   (10–29): car:industrial:rtk:0 coverage 0.92 → 0.96, robot:tactical
//!   0.91 → 0.96, car:tactical:rtk:0.1 0.91 → 0.95 (NEES 2.2–2.5 → 1.9–2.1).
//! - Consumer-GNSS cells at 0.990–0.996 (industrial/tactical IMUs, seeds
//!   0–9): the GNSS error stream depends on the seed only (sim stream 3),
//!   so all IMU grades and offsets of a platform share the same 10 error
//!   realisations, ≈ 90 independent τ-long stretches of b (coverage SE ≈
//!   0.02). On seeds 10–19 car/robot/pedestrian:tactical:consumer:0 give
//!   0.969 / 0.975 / 0.975 (NEES 1.73–1.76): sampling, not a model error.
//! - Smoothed σ (variant `smooth`, seeds 10–15, all 24 τ = 0 cells): with
//!   the forward `P − P_filter` of the sensitivity covariance added to the
//!   smoother's white covariance, the RTK cells with a correlated split
//!   covered 0.84–0.93 (GNSS present 0.84–0.93, NEES 2.0–3.4): the smoother
//!   averages the share of σ_fix² the white model calls white but that is
//!   `b`. With the part `b` drives (the white twin, core `eskf/sens.rs`):
//!   0.91–0.98, NEES 1.35–2.47. Consumer-GNSS cells (consider states, not
//!   the sensitivity covariance) unchanged: 0.87–1.00. Not solved then
//!   (next item): the pedestrian RTK cells, 0.69–0.71 (GNSS present 0.60–0.64, NEES ≈ 6),
//!   where the split finds no correlated part (every interval is used, the
//!   walker's steps raise σ_w to σ_fix, σ_b is only a lower bound) and the
//!   smoother averages fixes whose error is half Gauss–Markov; the forward
//!   σ there is in band.
//! - Walkers' smoothed σ (seeds 10–15): the split reads σ_w 0.020 ± 0.005–
//!   0.010 m of the reported 0.020 on every interval (the simulator's white
//!   part is 0.014, its Gauss–Markov part 0.014 with τ 30 s), so σ_b is
//!   only bounded from below. With the smoother's own model at the upper
//!   end, σ_b = σ_fix (`gnss_error::SigmaModels::smoothed`, core
//!   `Eskf::start_smoother_sensitivity`), pedestrian RTK smoothed coverage95_h
//!   0.69–0.71 → 0.98 (NEES 5.0–5.3 → 1.28–1.39; GNSS present 0.60–0.64 →
//!   0.97); forward unchanged (0.92–0.93). The consumer-IMU RTK cells, whose
//!   gyro bias leaves too few quiet intervals on 4 of 6 seeds, take it too:
//!   car / robot / uav 0.91 / 0.93 / 0.94 → 0.95 / 0.98 / 0.97. Every other
//!   cell identical. Fresh seeds 40–45 (not looked at while developing),
//!   smoothed: pedestrian RTK 0.63–0.66 → 0.97 (NEES 5.8–6.4 → 1.57–1.60),
//!   consumer-IMU RTK car / robot / uav 0.94 / 0.91 / 0.91 → 0.97 / 0.97 /
//!   0.94; the other six RTK cells and every forward σ identical.
//! - Mean NEES in the robot:consumer:rtk cells is heavy-tailed (5–8 with
//!   coverage 0.88–0.95): a few epochs with very large NEES.

use super::generalise::{cell_options, select_cells};
use super::score::{h_error_ne, motion_start, CHI2_2_95};
use super::{run_variant, variant_config, Variant};
use crate::config::RunConfig;
use navfuse_sim::platform::platform_run;
use rayon::prelude::*;

pub(super) fn tweak(name: &str, cfg: &mut RunConfig) {
    for part in name.split('+') {
        match part {
            "default" | "" => {}
            "consider" => {
                cfg.filter.gnss_error = Some(crate::gnss_error::GnssErrorCfg {
                    model: Some("consider".into()),
                    ..Default::default()
                })
            }
            "nis" => cfg.filter.nis_adaptation = Some(true),
            "nonis" => cfg.filter.nis_adaptation = Some(false),
            "white" => {
                cfg.filter.gnss_error = Some(crate::gnss_error::GnssErrorCfg {
                    model: Some("white".into()),
                    ..Default::default()
                })
            }
            "s01" => {}
            "smooth" => cfg.filter.smooth = true,
            t if t.starts_with("tau") => {
                let g = cfg.filter.gnss_error.get_or_insert_with(Default::default);
                g.tau_s = Some(t[3..].parse().expect("tauN: N seconds"));
            }
            "nhc_off" => {
                cfg.filter.nhc = Some(crate::config::NhcCfg {
                    enabled: Some(false),
                    ..Default::default()
                })
            }
            "nhc_adapt" => {
                cfg.filter.nhc = Some(crate::config::NhcCfg {
                    adaptive: Some(true),
                    ..Default::default()
                })
            }
            "zupt_off" => {
                cfg.filter.zupt = Some(crate::config::ZuptCfg {
                    enabled: Some(false),
                    ..Default::default()
                })
            }
            p => panic!("unknown tweak {p}"),
        }
    }
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: usize,
    nees: f64,
    in95: usize,
    e2: f64,
}

impl Acc {
    fn add(&mut self, e2: f64, nees: f64) {
        self.n += 1;
        self.nees += nees;
        self.in95 += usize::from(nees <= CHI2_2_95);
        self.e2 += e2;
    }
    fn merge(&mut self, o: &Acc) {
        self.n += o.n;
        self.nees += o.nees;
        self.in95 += o.in95;
        self.e2 += o.e2;
    }
    fn fmt(&self) -> String {
        let n = self.n.max(1) as f64;
        format!(
            "{:7.2} {:5.2} {:6.3}",
            self.nees / n,
            self.in95 as f64 / n,
            (self.e2 / n).sqrt()
        )
    }
}

#[test]
#[ignore]
fn honesty_diag() {
    let cells = select_cells(
        &std::env::var("DIAG_CELLS").unwrap_or("car:*:rtk:0,pedestrian:industrial:rtk:0".into()),
    )
    .unwrap();
    let seeds: u64 = std::env::var("DIAG_SEEDS").map_or(4, |s| s.parse().unwrap());
    let seed0: u64 = std::env::var("DIAG_SEED0").map_or(0, |s| s.parse().unwrap());
    let dur: f64 = std::env::var("DIAG_DURATION").map_or(600.0, |s| s.parse().unwrap());
    let variants: Vec<String> = std::env::var("DIAG_VARIANTS")
        .unwrap_or("default,smooth".into())
        .split(',')
        .map(String::from)
        .collect();
    let nv = variants.len();
    let mut all = Vec::new();
    let jobs: Vec<(usize, u64, usize)> = (0..cells.len())
        .flat_map(|c| (0..seeds).flat_map(move |s| (0..nv).map(move |v| (c, s, v))))
        .collect();
    let res: Vec<(Acc, Acc, String)> = super::on_worker_pool(|| {
        jobs.par_iter()
            .map(|&(c, s, v)| {
                let cell = &cells[c];
                let s = seed0 + s;
                let mut pr = platform_run(cell.platform, s, &cell_options(cell, s, dur)).unwrap();
                if variants[v].contains("s01") {
                    for g in &mut pr.run.gnss {
                        g.std_ned *= 0.1;
                        g.std_v_n = g.std_v_n.map(|x| x * 0.1);
                    }
                }
                let base = if variants[v].starts_with("oracle") {
                    Variant::Oracle
                } else {
                    Variant::Default
                };
                let mut cfg = variant_config(base, &pr);
                tweak(
                    variants[v]
                        .trim_start_matches("oracle+")
                        .trim_start_matches("oracle"),
                    &mut cfg,
                );
                let (mut inn, mut out) = (Acc::default(), Acc::default());
                let r = match run_variant(&cfg, &pr) {
                    Ok(r) => r,
                    Err(e) => return (inn, out, e.to_string()),
                };
                let t0 =
                    motion_start(&pr.run.traj).unwrap() + super::generalise::SCORE_AFTER_MOTION_S;
                // `smooth`: score the RTS-smoothed solutions and their σ.
                let sols = if variants[v].contains("smooth") {
                    &r.smoothed
                } else {
                    &r.solutions
                };
                for sol in sols.iter().filter(|x| x.t >= t0) {
                    let (en, ee) = h_error_ne(sol.lat, sol.lon, &pr.run.traj.at(sol.t));
                    let (sn, se) = (sol.std_pos_ned.x, sol.std_pos_ned.y);
                    let nees = en * en / (sn * sn) + ee * ee / (se * se);
                    if !nees.is_finite() {
                        continue;
                    }
                    let o = pr.outages.iter().any(|o| sol.t >= o[0] && sol.t < o[1]);
                    if o { &mut inn } else { &mut out }.add(en * en + ee * ee, nees);
                }
                (inn, out, r.augmented_states.clone())
            })
            .collect()
    });
    println!(
        "{:<28} {:<22} {:>4}  {:>20}  {:>20}  {:>20}",
        "cell", "variant", "seed", "all nees/cov/rms", "outage", "gnss"
    );
    for (c, cell) in cells.iter().enumerate() {
        for (v, vn) in variants.iter().enumerate() {
            let (mut ti, mut to) = (Acc::default(), Acc::default());
            for s in 0..seeds {
                let k = jobs.iter().position(|j| *j == (c, s, v)).unwrap();
                let (i, o, ref how) = res[k];
                let mut a = i;
                a.merge(&o);
                println!(
                    "{:<28} {:<22} {:>4}  {}  {}  {}  {}",
                    cell.name(),
                    vn,
                    s,
                    a.fmt(),
                    i.fmt(),
                    o.fmt(),
                    how
                );
                ti.merge(&i);
                to.merge(&o);
            }
            let mut a = ti;
            a.merge(&to);
            println!(
                "{:<28} {:<22} {:>4}  {}  {}  {}",
                cell.name(),
                vn,
                "ALL",
                a.fmt(),
                ti.fmt(),
                to.fmt()
            );
            all.push((cell.name(), vn.clone(), a));
        }
    }
    // Without DIAG_* overrides (as CI runs it): issue 20's band for the
    // default configuration on the car RTK cells, the cells whose σ the
    // sensitivity covariance made honest (coverage95_h 0.82–0.89 before),
    // and on pedestrian:industrial:rtk:0, whose smoothed σ the smoother's
    // upper-end model made honest (0.69 before on seeds 10–15; seeds 0–3
    // were not looked at before this assertion was written; measured there
    // 0.64 → 0.97, NEES 6.28 → 1.54, and car:consumer:rtk:0 0.93 → 0.97).
    if std::env::vars().all(|(k, _)| !k.starts_with("DIAG_")) {
        for (cell, v, a) in &all {
            let (cov, nees) = (a.in95 as f64 / a.n as f64, a.nees / a.n as f64);
            assert!(
                (0.90..=0.99).contains(&cov) && (0.7..=4.0).contains(&nees),
                "{cell} {v}: coverage95_h {cov:.3}, nees_h {nees:.2}"
            );
        }
    }
}
