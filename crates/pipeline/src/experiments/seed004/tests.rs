use super::*;

fn builtin() -> navfuse_sim::Scenario {
    navfuse_sim::Scenario::from_toml(SCENARIO_TOML, "builtin").unwrap()
}

#[test]
fn simulated_profile_is_consistent() {
    let run = simulate(&builtin(), 1, Some(0.0)).unwrap();
    // 5 + 10 + 25 + 10 + 20 + 6 + 15 + 6 + 25 + 10 + 20 + 11.25 + 5 s, fixes at 1 Hz.
    assert_eq!(run.truth.len(), 169);
    // Ends at rest: the last two truth positions coincide.
    let n = run.truth.len();
    assert!((run.truth[n - 1].1 - run.truth[n - 2].1).abs() < 1e-12);
    // GPS-only hold with fixes every second has zero error.
    let sols = run_with_interval(&mut GpsHold::new(), &run.events, 1);
    let (lo, la) = mean_errors(&sols, &run.truth[1..]);
    assert!(lo < 1e-9 && la < 1e-9);
}

/// `--report` with `--no-real`: the first seed's "every 10 s" row, each
/// column scored against the simulated truth, the fixes used marked.
#[test]
fn report_of_the_first_simulated_seed_names_every_column() {
    let dir = std::env::temp_dir().join(format!("navfuse-seed004-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // `seed004 --seeds 1 --no-real --report DIR`, the other options at their defaults.
    run(Options {
        seeds: 1,
        seed0: 1,
        json: None,
        no_real: true,
        data: None,
        kf_q: None,
        accel_noise: None,
        mount_rpy_deg: vec![180.0, 0.0, 180.0],
        lateral_offset: false,
        scenario: None,
        chord: "displacement".into(),
        report: Some(dir.clone()),
    })
    .unwrap();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(html.contains("truth = simulated"));
    for n in ACC_NAMES.iter().chain([&HOLD_NAME]) {
        assert!(
            html.contains(&format!("<th colspan=\"3\">{n}</th>")),
            "{n} missing"
        );
    }
    // The fixes used every 10 s of the 169 s run: t0, t0 + 10, …, t0 + 160.
    assert!(
        html.contains("<td>GNSS fixes</td><td>(in memory)</td><td>17 epochs</td>"),
        "fixes used"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn noise_free_gps_acc_beats_hold_at_every_interval() {
    let run = simulate(&builtin(), 1, Some(0.0)).unwrap();
    let err = |cfg: Option<AccelDrConfig>, every: u32| {
        let sols = match cfg {
            Some(c) => run_with_interval(&mut AccelDr::new(c), &run.events, every),
            None => run_with_interval(&mut GpsHold::new(), &run.events, every),
        };
        let e = mean_errors(&sols, &run.truth[1..]);
        e.0 + e.1
    };
    for every in [2, 4, 10] {
        let h = err(None, every);
        let main = err(Some(AccelDrConfig::rate_scaled()), every);
        let def = err(Some(AccelDrConfig::default()), every);
        let lit = err(Some(AccelDrConfig::paper_literal()), every);
        assert!(main < 0.2 * h, "{every} s: main {main} vs hold {h}");
        assert!(def < h && lit < h, "{every} s: {def} {lit} vs hold {h}");
    }
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_0708_table4_gps_acc_beats_hold() {
    let root = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
    let root = root.parent().and_then(|p| p.parent()).expect("data root");
    let run = load_drive_0708(root, [180.0, 0.0, 180.0]).expect("drive_0708");
    let cfgs = Configs {
        main: AccelDrConfig::rate_scaled(),
        default: AccelDrConfig::default(),
        literal: AccelDrConfig::paper_literal(),
    };
    let rows = table4(&cfgs, &run, None);
    for r in &rows[1..] {
        let a = r.gps_acc.lon_m + r.gps_acc.lat_m;
        let h = r.gps_only.lon_m + r.gps_only.lat_m;
        assert!(a < h, "{} s: gps+acc {a} vs hold {h}", r.interval_s);
    }
    // With every fix used the error is of the order of 1 s of prediction.
    assert!(rows[0].gps_acc.lon_m < 1.5 && rows[0].gps_acc.lat_m < 1.5);
}

#[cfg(test)]
mod real_axes {
    use super::*;

    /// The FRD mapping on real data: the mean lateral specific force f_y over
    /// 2 s must follow v·(course rate) from the RTK velocities (right turn ⇒
    /// f_y > 0, the sign eq. 5–8 rely on). Prints the residual that limits
    /// accelerometer-only heading.
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn drive_0708_lateral_force_follows_course_rate() {
        let pos = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
        let root = pos.parent().and_then(|p| p.parent()).expect("data root");
        let run = load_drive_0708(root, [180.0, 0.0, 180.0]).unwrap();
        let fixes: Vec<_> = run
            .events
            .iter()
            .filter_map(|e| {
                if let Event::Gnss(f) = e {
                    Some(*f)
                } else {
                    None
                }
            })
            .collect();
        let imu: Vec<_> = run
            .events
            .iter()
            .filter_map(|e| {
                if let Event::Imu(s) = e {
                    Some(*s)
                } else {
                    None
                }
            })
            .collect();
        let (mut sx, mut sy, mut sxx, mut syy, mut sxy, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut fx_sum, mut ax_sum) = (0.0, 0.0);
        for w in fixes.windows(3) {
            let (a, b, c) = (w[0], w[1], w[2]);
            let (Some(va), Some(vc)) = (a.v_n, c.v_n) else {
                continue;
            };
            let v = b.v_n.unwrap().xy().norm();
            if v < 3.0 {
                continue;
            }
            let pa = va.y.atan2(va.x);
            let pc = vc.y.atan2(vc.x);
            let om = navfuse_core::estimators::accel_dr::wrap_pi(pc - pa) / (c.t - a.t);
            let expect = v * om;
            let acc_f = (vc.xy().norm() - va.xy().norm()) / (c.t - a.t);
            let sel: Vec<_> = imu.iter().filter(|s| s.t > a.t && s.t <= c.t).collect();
            if sel.is_empty() {
                continue;
            }
            let fy = sel.iter().map(|s| s.dvel_b.y / s.dt).sum::<f64>() / sel.len() as f64;
            let fx = sel.iter().map(|s| s.dvel_b.x / s.dt).sum::<f64>() / sel.len() as f64;
            fx_sum += fx - acc_f;
            ax_sum += 1.0;
            sx += expect;
            sy += fy;
            sxx += expect * expect;
            syy += fy * fy;
            sxy += expect * fy;
            n += 1.0;
        }
        let cov = sxy / n - sx / n * sy / n;
        let corr =
            cov / ((sxx / n - (sx / n).powi(2)).sqrt() * (syy / n - (sy / n).powi(2)).sqrt());
        let slope = cov / (sxx / n - (sx / n).powi(2));
        eprintln!("moving 2-s windows {n}: corr {corr:.3} slope {slope:.3}; mean v·ω {:.3} mean fy {:.3} rms resid {:.3}; mean fx - dv/dt {:.3}",
            sx / n, sy / n, ((syy - 2.0 * sxy + sxx) / n).sqrt(), fx_sum / ax_sum);
        assert!(n > 300.0, "too few moving epochs: {n}");
        assert!(corr > 0.95, "f_y vs v·ω correlation {corr}");
        assert!((slope - 1.0).abs() < 0.15, "f_y vs v·ω slope {slope}");
    }
}
