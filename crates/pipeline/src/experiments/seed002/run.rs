//! The experiment: tables, JSON and the optional report.

use super::*;

// ---------------------------------------------------------------- report

pub(super) fn scores_json(s: &Scores) -> Value {
    json!({
        "raw_gps_m": s.raw,
        "compensated_gps_m": s.comp,
        "sir_pf_gps_m": s.sir,
        "lc_original_m": s.lc_orig,
        "lc_proposed_m": s.lc_prop,
        "eskf_m": s.eskf,
    })
}

pub(super) fn pct(a: f64, b: f64) -> String {
    format!("{:+.1} %", 100.0 * (b - a) / a)
}

/// Table row: name, value, per-run accessor, paper value.
pub(super) type Row = (&'static str, f64, fn(&Scores) -> f64, Option<f64>);

pub(super) fn print_table(title: &str, s: &Scores, runs: &[Scores], paper: bool) {
    println!("\n{title}");
    println!(
        "  {:<26} {:>9} {:>7}  {:>9}",
        "mean horizontal error",
        "ours [m]",
        "±sd",
        if paper { "paper [m]" } else { "" }
    );
    let rows: [Row; 6] = [
        ("raw GPS", s.raw, |r| r.raw, Some(PAPER_RAW)),
        (
            "compensated GPS (paper PF)",
            s.comp,
            |r| r.comp,
            Some(PAPER_COMP),
        ),
        ("SIR-PF GPS", s.sir, |r| r.sir, None),
        (
            "original LC (raw GPS)",
            s.lc_orig,
            |r| r.lc_orig,
            Some(PAPER_LC_ORIG),
        ),
        (
            "proposed LC (comp. GPS)",
            s.lc_prop,
            |r| r.lc_prop,
            Some(PAPER_LC_PROP),
        ),
        ("ESKF (navfuse, seed 001)", s.eskf, |r| r.eskf, None),
    ];
    for (name, v, f, p) in rows {
        let sd = spread(runs, f);
        let p = match (paper, p) {
            (true, Some(p)) => format!("{p:9.2}"),
            _ => String::new(),
        };
        if v.is_nan() {
            println!("  {name:<26} {:>9} {:>7}  {p}", "n/a", "");
        } else {
            println!("  {name:<26} {v:9.3} {sd:7.3}  {p}");
        }
    }
    println!(
        "  compensation vs raw: {} (paper −40.0 %); proposed vs original LC: {} (paper −12.0 %); SIR vs raw: {}",
        pct(s.raw, s.comp),
        pct(s.lc_orig, s.lc_prop),
        pct(s.raw, s.sir)
    );
}

pub(super) fn print_corners(title: &str, s: &Scores, paper: bool) {
    println!("\n{title}");
    if paper {
        println!(
            "  {:>6} {:>8} {:>8} {:>8} {:>8}   {:>8} {:>8} {:>8}",
            "corner", "A raw", "B orig", "C prop", "B−C", "paper A", "paper B", "paper C"
        );
    } else {
        println!(
            "  {:>6} {:>8} {:>8} {:>8} {:>8}",
            "corner", "A raw", "B orig", "C prop", "B−C"
        );
    }
    for (i, c) in s.corners.iter().enumerate() {
        let mut line = format!(
            "  {:>6} {:8.3} {:8.3} {:8.3} {:+8.3}",
            i + 1,
            c[0],
            c[1],
            c[2],
            c[1] - c[2]
        );
        if paper && i < 9 {
            line += &format!(
                "   {:8.4} {:8.4} {:8.4}",
                PAPER_A[i], PAPER_B[i], PAPER_C[i]
            );
        }
        println!("{line}");
    }
    let scored = s.corners.iter().filter(|c| c[1].is_finite()).count();
    let better = s.corners.iter().filter(|c| c[2] < c[1]).count();
    println!("  proposed better than original at {better} of {scored} scored corners");
}

pub(super) fn corners_json(set: &str, s: &Scores, paper: bool) -> Vec<Value> {
    s.corners
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut v = json!({
                "set": set,
                "corner": i + 1,
                "a_raw_gps_m": c[0],
                "b_lc_original_m": c[1],
                "c_lc_proposed_m": c[2],
            });
            if paper && i < 9 {
                v["paper_a_m"] = json!(PAPER_A[i]);
                v["paper_b_m"] = json!(PAPER_B[i]);
                v["paper_c_m"] = json!(PAPER_C[i]);
            }
            v
        })
        .collect()
}

pub(super) fn config_from(args: &Options) -> Result<PfLcConfig, String> {
    let mut cfg = PfLcConfig {
        compensation: crate::smooth_gps::compensation_config(args.span, args.w_min, args.w_max)?,
        ..PfLcConfig::default()
    };
    cfg.use_imu_accel = !args.no_imu_accel;
    Ok(cfg)
}

/// Run the experiment: simulation seeds, then drive_0708 (unless
/// `no_real`); print the tables, write `json` and the `report` when asked.
pub fn run(args: Options) -> Result<(), ToolError> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    let cfg = config_from(&args)?;
    if !(0.0..=1.0).contains(&args.gm_fraction) {
        return Err(format!("--gm-fraction must be in 0..=1, got {}", args.gm_fraction).into());
    }
    let model = GnssErrModel::lowcost_4hz_gm(args.gm_fraction);
    println!("GNSS error model: {model:?}");
    // Load the real data first so a missing file fails before the long part.
    let real = if args.no_real {
        None
    } else {
        Some(load_real()?)
    };
    println!("seed 002 (PF-LC) experiment — SEEDS.md §2, issue 6");
    println!("config: {cfg:?}");
    println!(
        "scoring: mean horizontal error at the 4 Hz fix epochs after a {WARMUP_S} s warm-up; corners: turn start .. end + {CORNER_TAIL_S} s"
    );

    let seeds: Vec<u64> = (args.first_seed..args.first_seed + args.seeds as u64).collect();
    // --report: the first seed's series of the real run (of the simulation with --no-real).
    let mut sim_kept = (args.report.is_some() && args.no_real).then(Series::default);
    let mut real_kept = (args.report.is_some() && !args.no_real).then(Series::default);
    let (sim_runs, sim_title, paper_corners) = match args.sim {
        SimSource::Builtin => (
            seeds
                .iter()
                .map(|&s| {
                    let keep = if s == seeds[0] {
                        sim_kept.as_mut()
                    } else {
                        None
                    };
                    run_methods(&simulate(s, model), &cfg, s, keep)
                })
                .collect::<Vec<_>>(),
            "built-in campus loop, 20 km/h, 9 corners".to_string(),
            true,
        ),
        SimSource::NavfuseSim => {
            let path = args.scenario.clone().unwrap_or_else(default_scenario);
            let sc = navfuse_sim::Scenario::from_file(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            let mut runs = Vec::with_capacity(seeds.len());
            for &s in &seeds {
                let keep = if s == seeds[0] {
                    sim_kept.as_mut()
                } else {
                    None
                };
                runs.push(run_methods(
                    &simulate_navfuse(&sc, s, args.gm_fraction)?,
                    &cfg,
                    s,
                    keep,
                ));
            }
            (
                runs,
                format!("navfuse-sim {} ({})", path.display(), sc.description),
                false,
            )
        }
    };
    let sim = average(&sim_runs);
    print_table(
        &format!(
            "SIMULATION: {sim_title}; ADIS16365-grade IMU, 5 m CEP GNSS at 4 Hz (GM share {}, τ 60 s); {} seeds ({}..{})",
            args.gm_fraction,
            seeds.len(),
            seeds[0],
            seeds[seeds.len() - 1]
        ),
        &sim,
        &sim_runs,
        true,
    );
    print_corners(
        "SIMULATION cornering (mean error inside each corner, metres; paper Table 2 is of its own route, shown for scale)",
        &sim,
        true,
    );
    println!(
        "  (totals over the seeds: PV-KF fixes gated {}, compensation re-anchors {}, yaw resets to course {}, SIR re-inits {})",
        sim.pv_gated, sim.comp_reanchored, sim.course_resets, sim.sir_reinits
    );

    let mut real_json = Value::Null;
    let _ = paper_corners;
    let mut corners = corners_json("sim", &sim, true);
    if let Some(inp) = real {
        let n_real = args.real_seeds.unwrap_or(args.seeds).max(1);
        let rs: Vec<u64> = (args.first_seed..args.first_seed + n_real as u64).collect();
        let runs: Vec<Scores> = rs
            .iter()
            .map(|&s| {
                let keep = if s == rs[0] { real_kept.as_mut() } else { None };
                run_methods(&real_dataset(&inp, s, model), &cfg, s, keep)
            })
            .collect();
        let real_avg = average(&runs);
        print_table(
            &format!(
                "REAL drive_0708: KF-GINS imu.txt (100 Hz) + truth.nav RTK fixes degraded by 5 m CEP error at 4 Hz (GM share {}); {} noise seeds; truth = RTK",
                args.gm_fraction,
                rs.len()
            ),
            &real_avg,
            &runs,
            false,
        );
        print_corners(
            "REAL cornering (corners detected from the RTK course)",
            &real_avg,
            false,
        );
        println!(
            "  (totals over the seeds: PV-KF fixes gated {}, compensation re-anchors {}, yaw resets to course {}, SIR re-inits {})",
            real_avg.pv_gated, real_avg.comp_reanchored, real_avg.course_resets, real_avg.sir_reinits
        );
        real_json = scores_json(&real_avg);
        corners.extend(corners_json("real", &real_avg, false));
    }
    println!(
        "\nESKF: navfuse_core::estimators::eskf (15 states, ADIS16365 noise, NHC, no gate), started from the original LC's state after {ESKF_START_COURSES} course updates of its yaw; epochs before that are excluded for every method."
    );

    if let Some(path) = &args.json {
        let v = json!({
            "sim": scores_json(&sim),
            "real": real_json,
            "corners": corners,
            "paper": {
                "raw_gps_m": PAPER_RAW,
                "compensated_gps_m": PAPER_COMP,
                "lc_original_m": PAPER_LC_ORIG,
                "lc_proposed_m": PAPER_LC_PROP,
            },
            "seeds": seeds,
            "config": format!("{cfg:?}"),
        });
        let text = serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?;
        navfuse_io::atomic::write_atomic(path, text)
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    if let Some(dir) = &args.report {
        let (kept, what) = match (real_kept, sim_kept) {
            (Some(k), _) => (k, "drive_0708 (KF-GINS imu.txt, RTK truth.nav degraded to 5 m CEP fixes), truth = RTK"),
            (None, Some(k)) => (k, "simulation, truth = simulated"),
            (None, None) => return Err("--report: no run was kept".into()),
        };
        navfuse_report::build::from_series(
            dir,
            format!(
                "navfuse experiment seed002 — {what}; noise seed {}",
                args.first_seed
            ),
            SERIES_NAMES
                .iter()
                .zip(kept.sols)
                .map(|(n, s)| (n.to_string(), s))
                .collect(),
            kept.truth,
            None,
        )?;
    }
    Ok(())
}
