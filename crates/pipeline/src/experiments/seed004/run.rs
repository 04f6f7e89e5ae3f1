//! The experiment: tables, JSON and the optional report.

use super::*;

pub(super) fn print_table(
    title: &str,
    rows: &[Row],
    paper: &[(u32, f64, f64, f64, f64)],
    spread: bool,
) {
    println!("{title}");
    let w = if spread { 29 } else { 17 };
    let eskf = if rows.iter().any(|r| r.eskf.is_some()) {
        format!(" | {:>w$} {:>w$}", "ESKF (gyro)", "ESKF+NHC/ZUPT")
    } else {
        String::new()
    };
    println!(
        "{:>5} | {:>w$} {:>15} | {:>w$} {:>w$} | {:>w$} {:>15}{eskf}",
        "GPS",
        "GPS+accel (main)",
        "paper",
        "(default cfg)",
        "(literal cfg)",
        "GPS-only (hold)",
        "paper"
    );
    let f = |c: &Cell| {
        if spread {
            format!(
                "{:6.2}±{:5.2} / {:6.2}±{:5.2}",
                c.lon_m, c.lon_sd_m, c.lat_m, c.lat_sd_m
            )
        } else {
            format!("{:7.2} / {:7.2}", c.lon_m, c.lat_m)
        }
    };
    for (r, p) in rows.iter().zip(paper) {
        let pp = |a: f64, b: f64| {
            if a.is_nan() {
                "      –".to_string()
            } else {
                format!("{a:7.3}/{b:7.3}")
            }
        };
        let e = match (&r.eskf, &r.eskf_nhc) {
            (Some(a), Some(b)) => format!(" | {:>w$} {:>w$}", f(a), f(b)),
            _ => String::new(),
        };
        println!(
            "{:>4}s | {:>w$} {:>15} | {:>w$} {:>w$} | {:>w$} {:>15}{e}",
            r.interval_s,
            f(&r.gps_acc),
            pp(p.1, p.2),
            f(&r.gps_acc_default),
            f(&r.gps_acc_literal),
            f(&r.gps_only),
            pp(p.3, p.4)
        );
    }
    println!();
}

pub(super) fn cell_json(c: &Cell) -> serde_json::Value {
    serde_json::json!({"lon_m": c.lon_m, "lat_m": c.lat_m, "lon_sd_m": c.lon_sd_m, "lat_sd_m": c.lat_sd_m})
}

pub(super) fn rows_json(rows: &[Row], paper: &[(u32, f64, f64, f64, f64)]) -> serde_json::Value {
    let num = |x: f64| {
        if x.is_nan() {
            serde_json::Value::Null
        } else {
            serde_json::json!(x)
        }
    };
    serde_json::Value::Array(
        rows.iter()
            .zip(paper)
            .map(|(r, p)| {
                serde_json::json!({
                    "interval_s": r.interval_s,
                    "gps_acc": cell_json(&r.gps_acc),
                    "gps_acc_default_cfg": cell_json(&r.gps_acc_default),
                    "gps_acc_paper_literal": cell_json(&r.gps_acc_literal),
                    "gps_only": cell_json(&r.gps_only),
                    "eskf": r.eskf.as_ref().map_or(serde_json::Value::Null, cell_json),
                    "eskf_nhc_zupt": r.eskf_nhc.as_ref().map_or(serde_json::Value::Null, cell_json),
                    "paper": {"gps_acc": {"lon_m": p.1, "lat_m": p.2},
                              "gps_only": {"lon_m": num(p.3), "lat_m": num(p.4)}},
                })
            })
            .collect(),
    )
}

/// Run the experiment: Table 3 over the seeds, Table 4 on drive_0708 (unless
/// `no_real`); print them beside the paper, write `json` and the `report`.
pub fn run(args: Options) -> Result<(), ToolError> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    let mut cfg = AccelDrConfig::rate_scaled();
    let mut def = AccelDrConfig::default();
    let mut lit = AccelDrConfig::paper_literal();
    cfg.chord = match args.chord.as_str() {
        "literal" => ChordMode::Literal,
        "midpoint" => ChordMode::Midpoint,
        "displacement" => ChordMode::Displacement,
        c => {
            return Err(
                format!("--chord: unknown mode `{c}` (literal, midpoint, displacement)").into(),
            )
        }
    };
    if let Some(q) = args.kf_q {
        if !(q > 0.0 && q.is_finite()) {
            return Err(format!("--kf-q must be a positive number, got {q}").into());
        }
        cfg.kf_q = q;
        cfg.kf_q_psd = None;
        def.kf_q = q;
        lit.kf_q = q;
    }
    if args.lateral_offset {
        cfg.learn_lateral_offset = true;
        def.learn_lateral_offset = true;
        lit.learn_lateral_offset = true;
    }
    println!("seed 004 GPS-ACC (SEEDS.md §4)\n main config:    {cfg:?}\n default config: {def:?}\n literal config: {lit:?}\n");
    let cfgs = Configs {
        main: cfg,
        default: def,
        literal: lit,
    };
    // Load the real data first so a missing file fails before the long part.
    let real = if args.no_real {
        None
    } else {
        let root = args.data.clone().unwrap_or_else(navfuse_io::data::data_dir);
        let m = &args.mount_rpy_deg;
        if m.len() != 3 || m.iter().any(|x| !x.is_finite()) {
            return Err(format!("--mount-rpy-deg needs three numbers r,p,y, got {m:?}").into());
        }
        Some(load_drive_0708(&root, [m[0], m[1], m[2]])?)
    };
    if let Some(n) = args.accel_noise {
        if !(n >= 0.0 && n.is_finite()) {
            return Err(format!("--accel-noise must be ≥ 0, got {n}").into());
        }
    }
    let sc = match &args.scenario {
        Some(p) => navfuse_sim::Scenario::from_file(p).map_err(|e| e.to_string())?,
        None => navfuse_sim::Scenario::from_toml(SCENARIO_TOML, "<built-in seed004_table3>")
            .map_err(|e| e.to_string())?,
    };
    println!(
        "scenario: {} ({})\n",
        sc.name,
        args.scenario
            .as_ref()
            .map_or("built-in".to_string(), |p| p.display().to_string())
    );
    let mut kept = args.report.as_ref().map(|_| Kept::default());
    let t3 = table3(
        &cfgs,
        &sc,
        args.seed0,
        args.seeds,
        args.accel_noise,
        if args.no_real { kept.as_mut() } else { None },
    )?;
    print_table(
        &format!(
            "Table 3 (simulation, accel noise {}, GPS {}; mean ± sd over {} seeds {}..{}): mean position error [m]",
            args.accel_noise
                .map_or("of the preset".to_string(), |n| format!("σ² = {n} G²")),
            sc.gnss.preset,
            args.seeds,
            args.seed0,
            args.seed0 + args.seeds - 1
        ),
        &t3,
        &PAPER_T3,
        true,
    );
    let t4 = match &real {
        Some(run) => {
            println!("drive_0708: {}", run.summary);
            let mut t4 = table4(&cfgs, run, kept.as_mut());
            let root = args.data.clone().unwrap_or_else(navfuse_io::data::data_dir);
            for (r, (a, b)) in t4
                .iter_mut()
                .zip(eskf_rows(&root, &run.truth, kept.as_mut())?)
            {
                r.eskf = Some(cell(&[a]));
                r.eskf_nhc = Some(cell(&[b]));
            }
            print_table(
                "Table 4 (drive_0708, accelerometer only, RTK decimated to 1 Hz; error vs 4 Hz RTK) — paper: its own car",
                &t4,
                &PAPER_T4,
                false,
            );
            println!("ESKF: navfuse ESKF with gyro on kfgins/imu.txt + the same 1 Hz fixes used every N s (kf-gins_full.yaml; +NHC/ZUPT = kf_gins::enhanced); antenna position\n");
            Some(t4)
        }
        None => {
            println!("real-data table skipped (--no-real)\n");
            None
        }
    };
    if let Some(path) = &args.json {
        let doc = serde_json::json!({
            "config": format!("{cfg:?}"),
            "config_default": format!("{def:?}"),
            "config_paper_literal": format!("{lit:?}"),
            "seeds": args.seeds,
            "seed0": args.seed0,
            "rows": rows_json(&t3, &PAPER_T3),
            "real": t4.as_deref().map_or(serde_json::Value::Null, |t| rows_json(t, &PAPER_T4)),
        });
        navfuse_io::atomic::write_atomic(path, serde_json::to_string_pretty(&doc).expect("json"))
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    if let (Some(dir), Some(k)) = (&args.report, kept) {
        // A horizontal method scored in longitude/latitude: positions only, h = 0.
        let pos = |s: Vec<NavSolution>| -> Vec<NavSolution> {
            s.iter()
                .map(|e| navfuse_report::build::position_at(e.t, e.lat, e.lon, 0.0))
                .collect()
        };
        let what = if real.is_some() {
            "drive_0708, truth = 4 Hz RTK (gnss_1934_sf.pos); fixes: the 1 Hz RTK epochs GPS+accel and the hold use"
        } else {
            "simulation (first seed), truth = simulated"
        };
        navfuse_report::build::from_series(
            dir,
            format!("navfuse experiment seed004 — GPS every {REPORT_EVERY} s; {what}; horizontal only (h = 0)"),
            k.series.into_iter().map(|(n, s)| (n, pos(s))).collect(),
            k.truth
                .iter()
                .map(|&(t, lat, lon)| navfuse_report::build::position_at(t, lat, lon, 0.0))
                .collect(),
            Some(pos(k.fixes)),
        )?;
    }
    Ok(())
}
