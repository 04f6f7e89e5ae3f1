//! The default configuration on simulated car and uav runs (industrial IMU,
//! RTK): injected offsets recovered within 10 ms, none applied at 0.
//! Targets fixed before the runs (issue 13).
use crate::experiments::{run_variant, variant_config, Variant};
use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};

fn check(platform: Platform, seed: u64) {
    for tau in [0.0, 0.05, -0.05, 0.2, -0.2] {
        let opt = PlatformOptions {
            imu: ImuGrade::Industrial,
            gnss: GnssGrade::Rtk,
            imu_time_offset_s: tau,
            static_start: seed.is_multiple_of(2),
            ..Default::default()
        };
        let pr = platform_run(platform, seed, &opt).expect("simulation");
        let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
        let applied = r.time_offset_applied.as_ref().map(|a| a.0);
        let note = r.time_offset_passes.clone().unwrap_or_default();
        eprintln!("{platform} seed {seed} τ {tau:+}: applied {applied:?}; {note}");
        if tau == 0.0 {
            assert!(
                applied.is_none_or(|a| a.abs() < 0.005),
                "{platform} seed {seed}: τ = 0 but {applied:?} applied ({note})"
            );
        } else {
            let a = applied.unwrap_or_else(|| panic!("{platform} τ {tau}: none applied ({note})"));
            assert!(
                (a - tau).abs() < 0.010,
                "{platform} seed {seed} τ {tau}: {a} applied ({note})"
            );
        }
    }
}

#[test]
fn uav_offsets_recovered_within_10_ms() {
    check(Platform::Uav, 2);
}

/// Issue 13's must-show 2 on a car (seed chosen before the run, not one of
/// the experiment's seeds 0–9).
#[test]
fn car_offsets_recovered_within_10_ms() {
    check(Platform::Car, 11);
}

/// A receiver whose velocity lags its positions by 0.125 s (drive_0708's
/// RTKLIB `.pos`, README) on a simulated car drive with τ = 0.1 s: the
/// latency is measured from the GNSS alone and removed, so τ comes out
/// within 10 ms; compared as reported, the lag would add to τ.
#[test]
fn lagging_receiver_velocity_does_not_bias_the_offset() {
    const LAG_S: f64 = 0.125;
    let tau = 0.1;
    let mut pr = car_12(tau);
    let (traj, gnss) = (&pr.run.traj, &mut pr.run.gnss);
    for g in gnss.iter_mut() {
        if let Some(v) = g.v_n.as_mut() {
            *v += traj.at(g.t - LAG_S).v_n - traj.at(g.t).v_n;
        }
    }
    let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
    let note = r.time_offset_passes.clone().unwrap_or_default();
    eprintln!("lagging receiver: {note}");
    assert!(note.contains("removed"), "latency not removed: {note}");
    let a = r
        .time_offset_applied
        .as_ref()
        .map(|a| a.0)
        .unwrap_or_else(|| panic!("none applied ({note})"));
    assert!((a - tau).abs() < 0.010, "{a} applied for τ {tau} ({note})");
}

/// The 90 s car starts of `experiment align` (moving start, GNSS 0.5 s
/// before the IMU, true τ = 0), on seeds outside the experiment's: the
/// filter converges through part of the record, which the passes must not
/// read as an offset.
#[test]
fn short_in_motion_car_record_at_zero_offset_applies_nothing() {
    use crate::experiments::align_check::scenarios;
    for sc in scenarios()
        .into_iter()
        .filter(|s| s.platform == Platform::Car)
    {
        for seed in 100..104u64 {
            let pr = platform_run(sc.platform, seed, &sc.options()).expect("simulation");
            let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
            let applied = r.time_offset_applied.as_ref().map(|a| a.0);
            let note = r.time_offset_passes.clone().unwrap_or_default();
            assert!(
                applied.is_none_or(|a| a.abs() < 0.005),
                "{} seed {seed}: {applied:?} applied at τ = 0 ({note})",
                sc.name()
            );
        }
    }
}

/// One car seed (`SEED`, default 8) at ±50 ms and +200 ms: the passes
/// recover each offset within issue 13's 10 ms; each pass is printed
/// (`cargo test --release -- --ignored passes_of_one_seed --nocapture`).
#[test]
#[ignore = "one seed's passes, 3 × 600 s runs: cargo test --release -- --ignored passes_of_one_seed"]
fn passes_of_one_seed() {
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    for tau in [0.05, -0.05, 0.2] {
        let opt = PlatformOptions {
            imu: ImuGrade::Industrial,
            gnss: GnssGrade::Rtk,
            imu_time_offset_s: tau,
            static_start: seed.is_multiple_of(2),
            ..Default::default()
        };
        let pr = platform_run(Platform::Car, seed, &opt).expect("simulation");
        let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
        let note = r.time_offset_passes.clone().unwrap_or_default();
        eprintln!("car seed {seed} τ {tau:+}: {note}");
        let applied = r.time_offset_applied.as_ref().map(|a| a.0);
        assert!(
            applied.is_some_and(|a| (a - tau).abs() < 0.010),
            "seed {seed}, true τ {tau:+}: applied {applied:?} ({note})"
        );
    }
}

/// The likelihood refinement's parabola: vertex and curvature of an exact
/// quadratic NLL (σ = 0.5 ms around 12.3 ms) from three probes on one side.
#[test]
fn likelihood_parabola_recovers_vertex_and_curvature() {
    let s = 5e-4;
    let f = |t: f64| 0.5 * ((t - 0.0123) / s).powi(2) + 7.0;
    let p = [0.010, 0.012, 0.014].map(|t| (t, f(t)));
    let (v, c) = super::parabola(&p).expect("distinct probes");
    assert!((v - 0.0123).abs() < 1e-9, "vertex {v}");
    assert!((1.0 / c.sqrt() - s).abs() < 1e-9, "σ {}", 1.0 / c.sqrt());
    assert!(super::parabola(&[(0.0, 1.0), (0.0, 2.0), (1.0, 3.0)]).is_none_or(|x| !x.0.is_finite()));
}

/// The probes' NLL counts only the updates every probe has (a shifted span
/// gains or loses an edge fix), so an extra term cannot tilt the parabola.
#[test]
fn likelihood_terms_only_over_shared_updates() {
    let mut a = super::NllTerms::new();
    let mut b = super::NllTerms::new();
    a.insert((0, 0), (1.0, 3));
    a.insert((1, 0), (2.0, 3));
    b.insert((1, 0), (5.0, 3));
    b.insert((2, 1), (100.0, 3));
    let (nll, dof) = super::common_nll(&[a, b]);
    assert_eq!(nll, vec![2.0, 5.0]);
    assert_eq!(dof, 3.0);
}

/// A car (industrial IMU, RTK) at τ = 0.1 s, seed 13 (chosen before the
/// run, not one of the experiments' development seeds 0–9): the
/// likelihood refinement runs and brings τ̂ within 2 ms (the passes alone
/// scatter 2–4 ms; the refined σ is ≈ 0.5 ms on this scenario).
#[test]
fn car_offset_refined_by_the_likelihood_within_2_ms() {
    let opt = PlatformOptions {
        imu: ImuGrade::Industrial,
        gnss: GnssGrade::Rtk,
        imu_time_offset_s: 0.1,
        static_start: false,
        ..Default::default()
    };
    let pr = platform_run(Platform::Car, 13, &opt).expect("simulation");
    let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
    let note = r.time_offset_passes.clone().unwrap_or_default();
    let a = r.time_offset_applied.as_ref().map(|a| a.0);
    eprintln!("applied {a:?}; {note}");
    assert!(note.contains("likelihood refinement: "), "{note}");
    let a = a.expect("an offset applied");
    assert!((a - 0.1).abs() < 0.002, "{a} applied ({note})");
}

/// The simulated car of these tests: industrial IMU, RTK, seed 12, static
/// start, IMU offset `tau`.
fn car_12(tau: f64) -> navfuse_sim::platform::PlatformRun {
    let opt = PlatformOptions {
        imu: ImuGrade::Industrial,
        gnss: GnssGrade::Rtk,
        imu_time_offset_s: tau,
        static_start: true,
        ..Default::default()
    };
    platform_run(Platform::Car, 12, &opt).expect("simulation")
}

/// [`car_12`] with its fixes' velocities removed (positions-only receiver).
fn positions_only_car(tau: f64) -> navfuse_sim::platform::PlatformRun {
    let mut pr = car_12(tau);
    for g in &mut pr.run.gnss {
        g.v_n = None;
        g.std_v_n = None;
    }
    pr
}

/// A receiver that reports positions only (no velocity, so no velocity
/// passes): the course estimate decides, and where its variants disagree
/// the filter's GNSS-position likelihood ([`super::likelihood_on_positions`]).
/// Car, industrial IMU, RTK, seed 12 (not used before). Targets fixed before
/// the run (issue 13 must-show 2): nothing applied (or < 5 ms) at τ = 0,
/// ±50 ms recovered within 10 ms.
#[test]
fn positions_only_offsets_recovered_within_10_ms() {
    for tau in [0.0, 0.05, -0.05] {
        let pr = positions_only_car(tau);
        let r = run_variant(&variant_config(Variant::Default, &pr), &pr).expect("run");
        let applied = r.time_offset_applied.as_ref().map(|a| a.0);
        let how = r.time_offset_applied.as_ref().map(|a| a.1.clone());
        eprintln!("positions only, τ {tau:+}: applied {applied:?} ({how:?})");
        if tau == 0.0 {
            assert!(
                applied.is_none_or(|a| a.abs() < 0.005),
                "{applied:?} {how:?}"
            );
        } else {
            let a = applied.unwrap_or_else(|| panic!("τ {tau}: none applied"));
            assert!((a - tau).abs() < 0.010, "τ {tau}: {a} applied ({how:?})");
        }
    }
}

/// [`super::likelihood_on_positions`] itself, on the positions-only car of
/// the test above given a course estimate whose two variants disagree in
/// sign (the case it exists for: the real one agreed there). Targets fixed
/// before the run: at τ = 0 nothing applied (or < 5 ms); at ±50 ms the
/// likelihood's τ within 10 ms.
#[test]
fn positions_likelihood_settles_disagreeing_course_variants() {
    use crate::time_offset::{auto_estimate, TimeOffsetCfg};
    for tau in [0.0, 0.05, -0.05] {
        let pr = positions_only_car(tau);
        let mut course = auto_estimate(&pr.run.imu, &pr.run.gnss);
        // Variants of opposite sign, both significant at 30 ms and 60 ms.
        course.apply = false;
        for (k, (_, e)) in course.variants.iter_mut().enumerate() {
            let t = if k % 2 == 0 { 0.03 } else { -0.06 };
            (e.tau_s, e.std_s, e.significant) = (Some(t), 0.005, true);
        }
        let cfg = variant_config(Variant::Default, &pr);
        let mut terms_at = |t: f64| {
            let mut c = cfg.clone();
            c.input.imu_time_offset = Some(TimeOffsetCfg::Seconds(t));
            let r = run_variant(&c, &pr)?;
            Ok(super::gnss_nll_terms(&r.updates, &pr.run.gnss))
        };
        let (applied, note) = super::likelihood_on_positions(&course, &mut terms_at).unwrap();
        eprintln!("positions likelihood, τ {tau:+}: {applied:?}; {note:?}");
        let applied = applied.map(|a| a.0);
        if tau == 0.0 {
            assert!(
                applied.is_none_or(|a| a.abs() < 0.005),
                "{applied:?} {note:?}"
            );
        } else {
            let a = applied.unwrap_or_else(|| panic!("τ {tau}: none applied ({note:?})"));
            assert!((a - tau).abs() < 0.010, "τ {tau}: {a} ({note:?})");
        }
    }
}
