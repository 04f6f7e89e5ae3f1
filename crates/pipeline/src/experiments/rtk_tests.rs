//! The RTK/INS experiment at CI size (2 seeds × 500 s, both IMU grades;
//! the YUMA almanac of the data folder). The assertions are the module's
//! targets, written before the runs: with the INS every seed fixes, no
//! wrong fix, fixed epochs ≤ 2 cm horizontal RMS, the injected slip caught
//! by the INS-predicted test, float ≤ 0.3 m in the 4-satellite window, and
//! a faster re-fix after the outage than without the INS.

use super::*;

/// The dual-frequency G+E+C scenario at CI size (1 seed × 500 s,
/// both IMU grades; synthetic constellations, no data files). Asserted
/// with the INS (targets of the module documentation that the 20-seed run
/// reached): a fix within 5 s, re-fix within 2 epochs after the 30 s
/// outage, no wrong fix, full-sky fixed epochs ≤ 2 cm horizontal RMS, the
/// injected slip caught by the INS-predicted test. GNSS-only (the
/// comparison mode): no wrong fix, the injected slip caught by the GF/MW
/// test, and no divergence (float horizontal RMS < 10 m; it was 10⁵ m on
/// 5 of 20 seeds before its constant-velocity model). The 4-satellite
/// window's comparison (the "where GNSS-only RTK loses the fix")
/// is not asserted on one seed: with a sound GNSS-only mode it was a tie on
/// seed 1 (0.715 m with the phone IMU, 0.713 m without); the 20-seed run
/// of the module documentation reports it.
#[test]
fn dual_frequency_rtk_ins_fixes_fast_and_right() {
    let o = Options {
        seeds: 1,
        seed0: 1,
        duration: 500.0,
        almanac: None,
        json: None,
        single_frequency: false,
        intra_system_only: false,
        success_min: None,
    };
    let r = run_rtk(&o).unwrap();
    assert!(r.failed.is_empty(), "{:?}", r.failed);
    for (g, gr) in &r.by_imu {
        let w = &gr.with_ins;
        assert_eq!(w.never_fixed, 0, "{g}: {w:?}");
        assert!(w.first_fix_s.unwrap() <= 5.0, "{g}: {w:?}");
        assert!(w.refix_epochs.unwrap() <= 2.0, "{g}: {w:?}");
        assert_eq!(w.refix_censored, 0, "{g}: {w:?}");
        assert_eq!(w.wrong_fixes, 0.0, "{g}: {w:?}");
        assert!(w.fixed_h_rms_full_sky_m.unwrap() <= 0.02, "{g}: {w:?}");
        assert_eq!(w.injected_slip_detected, 1, "{g}: {w:?}");
        let wo = &gr.without_ins;
        assert_eq!(wo.wrong_fixes, 0.0, "{g}: {wo:?}");
        assert_eq!(wo.injected_slip_dual, 1, "{g}: {wo:?}");
        assert!(wo.float_h_rms_m.unwrap() < 10.0, "{g}: {wo:?}");
    }
}

#[test]
#[ignore = "real data (YUMA almanac): run with `cargo test --release -- --ignored`"]
fn rtk_ins_fixes_right_and_refixes_faster_than_gnss_only() {
    navfuse_io::data::require("gnss/almanac/yuma_week1011.alm");
    let o = Options {
        seeds: 2,
        seed0: 1,
        duration: 500.0,
        almanac: None,
        json: None,
        single_frequency: true,
        intra_system_only: false,
        success_min: None,
    };
    let r = run_rtk(&o).unwrap();
    assert!(r.failed.is_empty(), "{:?}", r.failed);
    for (g, gr) in &r.by_imu {
        let w = &gr.with_ins;
        assert_eq!(w.never_fixed, 0, "{g}: {w:?}");
        assert_eq!(w.wrong_fixes, 0.0, "{g}: {w:?}");
        assert!(w.fixed_h_rms_m.unwrap() <= 0.02, "{g}: {w:?}");
        assert_eq!(w.injected_slip_detected, 2, "{g}: {w:?}");
        assert!(w.partial_sky_h_m.unwrap() <= 0.3, "{g}: {w:?}");
        let wo = &gr.without_ins;
        assert!(
            w.refix_epochs.unwrap() < wo.refix_epochs.unwrap(),
            "{g}: {w:?} {wo:?}"
        );
        // Epochs are applied at their estimated true time (IMU at 100 Hz).
        assert!(w.max_time_error_s < 1e-3, "{g}: {w:?}");
    }
}

/// The truth integers recovered from the simulated carrier stay constant
/// while a satellite is tracked (so the wrong-fix count compares with the
/// simulator's integers, not with noise).
#[test]
fn truth_integers_are_constant_while_tracked() {
    let (orbits, _) = super::super::tight::load_orbits(None);
    let t0 = 1.0e6;
    let off = orbits[0].t_oe - t0;
    let r0 = geodetic_to_ecef(&Geodetic {
        lat: 0.6,
        lon: 2.0,
        h: 40.0,
    });
    let cfg = RawConfig {
        iono_zenith_m: 0.0,
        tropo_zenith_m: 0.0,
        sat_sigma_m: 0.0,
        orbit_time_offset_s: off,
        ..Default::default()
    };
    let times: Vec<f64> = (0..120).map(|k| t0 + k as f64).collect();
    let v = Vec3::new(8.0, -3.0, 0.0);
    let eps = simulate_raw(&cfg, &orbits, &times, |t| (r0 + v * (t - t0), v));
    let first = truth_integers(&eps[0], &r0, &orbits, off);
    assert!(first.len() >= 4);
    for e in &eps[1..] {
        let n = truth_integers(e, &(r0 + v * (e.t - t0)), &orbits, off);
        for (p, a) in &n {
            if let Some(b) = first.get(p) {
                assert_eq!(a, b, "prn {p} at {}", e.t - t0);
            }
        }
    }
}
