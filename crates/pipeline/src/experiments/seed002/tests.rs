use super::*;

#[test]
fn simulated_loop_is_consistent() {
    let ds = simulate(1, GnssErrModel::lowcost_4hz());
    // Nine corners, fixes at 4 Hz with truth for each.
    assert_eq!(ds.corners.len(), 9);
    let nf = ds
        .events
        .iter()
        .filter(|e| matches!(e, Event::Gnss(_)))
        .count();
    assert_eq!(nf, ds.truth.len());
    // Time order.
    assert!(ds.events.windows(2).all(|w| w[0].t() <= w[1].t()));
    let gnss_err = GnssErrModel::lowcost_4hz();
    assert!((gnss_err.sigma_h * 1.1774 - 5.0).abs() < 1e-3);
}

#[test]
fn gnss_error_model_has_the_stated_cep_and_correlation() {
    let mut g = GnssErrGen::new(
        GnssErrModel {
            jump_prob: 0.0,
            ..GnssErrModel::lowcost_4hz()
        },
        3,
    );
    let mut r = Vec::new();
    let mut prev = [0.0; 2];
    let (mut c, mut v) = (0.0, 0.0);
    for _ in 0..400_000 {
        let e = g.next(0.25);
        r.push((e[0] * e[0] + e[1] * e[1]).sqrt());
        c += e[0] * prev[0];
        v += e[0] * e[0];
        prev = e;
    }
    r.sort_by(f64::total_cmp);
    let cep = r[r.len() / 2];
    assert!((cep / 5.0 - 1.0).abs() < 0.05, "CEP {cep}");
    // Lag-1 correlation ≈ 0.8 · exp(−0.25/60).
    let rho = c / v;
    assert!(
        (rho - 0.8 * (-0.25f64 / 60.0).exp()).abs() < 0.03,
        "rho {rho}"
    );
}

#[test]
fn sim_run_scores_are_sane() {
    let cfg = PfLcConfig::default();
    let s = run_methods(&simulate(5, GnssErrModel::lowcost_4hz()), &cfg, 5, None);
    // 5 m CEP: mean radial error ≈ 1.2533 σ = 5.3 m, one short run varies.
    assert!(s.raw > 2.5 && s.raw < 9.0, "{s:?}");
    for v in [s.comp, s.sir, s.lc_orig, s.lc_prop] {
        assert!(v.is_finite() && v < 1.5 * s.raw, "{s:?}");
    }
    assert_eq!(s.corners.len(), 9);
    // White-only GNSS noise is what the smoothers can remove.
    let w = run_methods(
        &simulate(5, GnssErrModel::lowcost_4hz_gm(0.0)),
        &cfg,
        5,
        None,
    );
    assert!(w.comp < 0.9 * w.raw && w.lc_orig < 0.7 * w.raw, "{w:?}");
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn real_drive_0708_seed002_table() {
    navfuse_io::data::require("drive_0708/kfgins/imu.txt");
    let inp = load_real().unwrap();
    assert!(inp.imu.len() > 50_000 && inp.truth.len() > 2000);
    let ds = real_dataset(&inp, 1, GnssErrModel::lowcost_4hz());
    assert!(ds.events.windows(2).all(|w| w[0].t() <= w[1].t()));
    assert!(ds.corners.len() >= 10, "{} corners", ds.corners.len());
    let s = run_methods(&ds, &PfLcConfig::default(), 1, None);
    println!("{s:?}");
    assert!(s.raw > 3.0 && s.raw < 9.0, "{s:?}");
    // Honest bounds, not the result: every method stays within 1.5× raw.
    for v in [s.comp, s.sir, s.lc_orig, s.lc_prop] {
        assert!(v.is_finite() && v < 1.5 * s.raw, "{s:?}");
    }
}

/// `--report` with `--no-real`: the first simulated seed's series, each
/// method scored against the simulated truth on the page.
#[test]
fn report_of_the_first_simulated_seed_names_every_method() {
    let dir = std::env::temp_dir().join(format!("navfuse-seed002-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // `seed002 --seeds 1 --no-real --report DIR`, the other options at their defaults.
    run(Options {
        seeds: 1,
        first_seed: 1,
        real_seeds: None,
        json: None,
        no_real: true,
        gm_fraction: 0.8,
        sim: SimSource::NavfuseSim,
        scenario: None,
        no_imu_accel: false,
        span: None,
        w_min: None,
        w_max: None,
        report: Some(dir.clone()),
    })
    .unwrap();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(html.contains("truth = simulated"));
    for n in SERIES_NAMES {
        // A column of the error summary: the method was scored against the truth.
        assert!(
            html.contains(&format!("<th colspan=\"3\">{n}</th>")),
            "{n} missing"
        );
    }
    assert!(dir.join("plots/track.svg").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn navfuse_sim_campus_loop_has_its_corners() {
    let sc = navfuse_sim::Scenario::from_file(&default_scenario()).unwrap();
    let ds = simulate_navfuse(&sc, 1, 0.8).unwrap();
    // Two laps of a rectangle: eight 90° corners.
    assert_eq!(ds.corners.len(), 8, "{:?}", ds.corners);
    assert!(ds.events.windows(2).all(|w| w[0].t() <= w[1].t()));
}

#[test]
fn corner_detector_finds_the_simulated_corners() {
    let ds = simulate(2, GnssErrModel::lowcost_4hz());
    assert!(ds.events.len() > 20_000);
    let d = real_corners(
        &ds.truth
            .iter()
            .enumerate()
            .map(|(i, g)| (i as f64 * 0.25, *g))
            .collect::<Vec<_>>(),
    );
    // The corner detector used on the real drive finds the simulated corners.
    assert!((7..=10).contains(&d.len()), "{} corners", d.len());
}
