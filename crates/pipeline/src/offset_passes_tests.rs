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
    let opt = PlatformOptions {
        imu: ImuGrade::Industrial,
        gnss: GnssGrade::Rtk,
        imu_time_offset_s: tau,
        static_start: true,
        ..Default::default()
    };
    let mut pr = platform_run(Platform::Car, 12, &opt).expect("simulation");
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
