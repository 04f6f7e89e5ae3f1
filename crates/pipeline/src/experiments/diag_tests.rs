//! Diagnostic (ignored): per-seed scores of configuration variants of one
//! generalise cell. `DIAG_CELL=uav:consumer:consumer:0 DIAG_SEEDS=0-3
//! DIAG_VARIANTS=D,DW,O,K cargo test --release -p navfuse-pipeline diag_cell
//! -- --ignored --nocapture`. Variants: D default, O oracle, K KF-GINS
//! model; suffixes W white GNSS, C consider (prior), N time offset none,
//! S σ_b from DIAG_SIGMA, T τ from DIAG_TAU.

use super::generalise::{cell_options, select_cells, SCORE_AFTER_MOTION_S};
use super::score::{h_error_ne, motion_start};
use super::{run_variant, variant_config, Variant};
use crate::time_offset::TimeOffsetCfg;
use navfuse_sim::platform::platform_run;
use rayon::prelude::*;

#[derive(Default, Clone, Copy)]
struct S {
    e2_in: f64,
    n_in: usize,
    e2_out: f64,
    n_out: usize,
    omax2: f64,
    no: usize,
    nees: f64,
    in95: usize,
    nn: usize,
    yaw2: f64,
}

#[test]
#[ignore]
fn diag_cell() {
    let cell_s = std::env::var("DIAG_CELL").unwrap_or("uav:consumer:consumer:0".into());
    let seeds = std::env::var("DIAG_SEEDS").unwrap_or("0-3".into());
    let (a, b) = seeds.split_once('-').unwrap();
    let (a, b): (u64, u64) = (a.parse().unwrap(), b.parse().unwrap());
    let dur: f64 = std::env::var("DIAG_DUR").map_or(600.0, |s| s.parse().unwrap());
    let vars: Vec<String> = std::env::var("DIAG_VARIANTS")
        .unwrap_or("D,DW,O,K".into())
        .split(',')
        .map(String::from)
        .collect();
    let sig: Option<f64> = std::env::var("DIAG_SIGMA").ok().map(|s| s.parse().unwrap());
    let tau: Option<f64> = std::env::var("DIAG_TAU").ok().map(|s| s.parse().unwrap());
    let cell = select_cells(&cell_s).unwrap()[0];
    let jobs: Vec<(u64, usize)> = (a..=b)
        .flat_map(|s| (0..vars.len()).map(move |v| (s, v)))
        .collect();
    let res: Vec<(u64, usize, S, f64, String)> = jobs
        .par_iter()
        .map(|&(seed, vi)| {
            let pr = platform_run(cell.platform, seed, &cell_options(&cell, seed, dur)).unwrap();
            let v = &vars[vi];
            let base = match &v[..1] {
                "D" => Variant::Default,
                "O" => Variant::Oracle,
                _ => Variant::KfginsModel,
            };
            let mut cfg = variant_config(base, &pr);
            let mut g = cfg.filter.gnss_error.clone().unwrap_or_default();
            if v.contains('W') {
                g.model = Some("white".into());
            }
            if v.contains('C') {
                g.model = Some("consider".into());
            }
            if v.contains('S') {
                g.sigma_m = sig;
                g.sigma_v_m = sig.map(|s| 1.5 * s);
            }
            if v.contains('T') {
                g.tau_s = tau;
            }
            cfg.filter.gnss_error = Some(g);
            if v.contains('N') {
                cfg.input.imu_time_offset = Some(TimeOffsetCfg::Named("none".into()));
            }
            let t0 = motion_start(&pr.run.traj).unwrap() + SCORE_AFTER_MOTION_S;
            let r = match run_variant(&cfg, &pr) {
                Ok(r) => r,
                Err(e) => return (seed, vi, S::default(), f64::NAN, e.to_string()),
            };
            let mut s = S::default();
            let mut omax = vec![0.0f64; pr.outages.len()];
            for sol in r.solutions.iter().filter(|x| x.t >= t0) {
                let (en, ee) = h_error_ne(sol.lat, sol.lon, &pr.run.traj.at(sol.t));
                let e2 = en * en + ee * ee;
                if let Some(k) = pr
                    .outages
                    .iter()
                    .position(|o| sol.t >= o[0] && sol.t < o[1])
                {
                    s.e2_out += e2;
                    s.n_out += 1;
                    omax[k] = omax[k].max(e2.sqrt());
                } else {
                    s.e2_in += e2;
                    s.n_in += 1;
                }
                let tr = pr.run.traj.at(sol.t);
                let dy = (sol.rpy.z - tr.rpy.z + std::f64::consts::PI)
                    .rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI;
                s.yaw2 += dy.to_degrees().powi(2);
                let (sn, se) = (sol.std_pos_ned.x, sol.std_pos_ned.y);
                let nees = en * en / (sn * sn) + ee * ee / (se * se);
                if nees.is_finite() {
                    s.nees += nees;
                    s.nn += 1;
                    s.in95 += usize::from(nees <= 5.991);
                }
            }
            for (k, o) in pr.outages.iter().enumerate() {
                if o[0] >= t0 && omax[k] > 0.0 {
                    s.omax2 += omax[k] * omax[k];
                    s.no += 1;
                }
            }
            let tau_app = r.time_offset_applied.as_ref().map_or(0.0, |a| a.0);
            let st = &r.stats;
            // Time of the largest error in the first 200 s after the start.
            let (mut tmax, mut emax) = (0.0, 0.0f64);
            for sol in r.solutions.iter().step_by(20) {
                let (en, ee) = h_error_ne(sol.lat, sol.lon, &pr.run.traj.at(sol.t));
                if en.hypot(ee) > emax {
                    (tmax, emax) = (sol.t - r.solutions[0].t, en.hypot(ee));
                }
            }
            let note = format!(
                "{} | pos used {} gated {} forced {} deweighted {} | align {} wait {:.1} s yaw σ {:.2}° | max err {:.1} m at +{:.0} s",
                r.augmented_states,
                st.gnss_pos_used,
                st.gnss_pos_rejected_gate,
                st.gnss_pos_forced,
                st.deweighted,
                r.align_method,
                r.align_wait_s,
                r.align_yaw_std_deg,
                emax,
                tmax
            );
            (seed, vi, s, tau_app, note)
        })
        .collect();
    let pr = |s: &S| {
        format!(
            "h {:5.2} in {:5.2} out {:5.2} omax {:5.2} nees {:5.2} cov {:4.2} yaw {:5.2}",
            ((s.e2_in + s.e2_out) / (s.n_in + s.n_out) as f64).sqrt(),
            (s.e2_in / s.n_in as f64).sqrt(),
            (s.e2_out / s.n_out as f64).sqrt(),
            (s.omax2 / s.no as f64).sqrt(),
            s.nees / s.nn as f64,
            s.in95 as f64 / s.nn as f64,
            (s.yaw2 / (s.n_in + s.n_out) as f64).sqrt()
        )
    };
    println!("cell {cell_s} seeds {seeds} dur {dur}");
    for (seed, vi, s, t, note) in &res {
        println!("seed {seed:2} {:5} {} tau {t:+.3}", vars[*vi], pr(s));
        if std::env::var("DIAG_NOTE").is_ok() {
            println!("     {note}");
        }
    }
    for (vi, v) in vars.iter().enumerate() {
        let mut p = S::default();
        for (_, _, s, _, _) in res.iter().filter(|r| r.1 == vi) {
            p.e2_in += s.e2_in;
            p.n_in += s.n_in;
            p.e2_out += s.e2_out;
            p.n_out += s.n_out;
            p.omax2 += s.omax2;
            p.no += s.no;
            p.nees += s.nees;
            p.nn += s.nn;
            p.in95 += s.in95;
            p.yaw2 += s.yaw2;
        }
        println!("POOL {v:5} {}", pr(&p));
    }
}
