//! Raw GNSS input: satellite states, the broadcast ionosphere and every
//! observation accounted for.

use super::*;
use navfuse_core::geodesy::{geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::raw::sat_state_from_kepler;
use navfuse_io::rinex::{NavData, ObsEpoch, ObsValue};
use navfuse_sim::carrier_phase::synthetic_constellation;
use navfuse_sim::raw_gnss::{simulate_raw, RawConfig};

/// The Kepler-system state equals core's GPS one for a GPS orbit.
#[test]
fn gps_sat_state_is_cores() {
    let mut o = synthetic_constellation(1.4e9)[5];
    o.af0 = 2.1e-4;
    o.af1 = -3e-12;
    o.tgd = -5e-9;
    o.e = 0.01;
    let t = 1.4e9 + 900.0;
    let a = sat_state(&o, OrbitKind::Gps, t, 2.2e7);
    let b = sat_state_from_kepler(&o, t, 2.2e7);
    assert!((a.pos_e - b.pos_e).norm() < 1e-6, "{a:?} {b:?}");
    assert!((a.vel_e - b.vel_e).norm() < 1e-6);
    assert!((a.clock_m - b.clock_m).abs() < 1e-6);
    assert!((a.clock_rate_mps - b.clock_rate_mps).abs() < 1e-6);
}

/// 30 epochs of a static receiver: one satellite without an ephemeris
/// (PRN 30), one unhealthy (PRN 2), one entry without code: each counted
/// by satellite and reason, everything else a record with the Klobuchar
/// delay and its variance; each epoch's last record flagged; an SPP fix per
/// epoch near the receiver.
#[test]
fn every_observation_is_a_record_or_counted() {
    let t0 = 1.4e9;
    let mut orbits = synthetic_constellation(t0);
    orbits[1].health = 1; // PRN 2
    let rx = geodetic_to_ecef(&Geodetic {
        lat: 0.6,
        lon: 2.4,
        h: 50.0,
    });
    let times: Vec<f64> = (0..30).map(|k| t0 + k as f64).collect();
    let healthy: Vec<_> = orbits
        .iter()
        .map(|o| navfuse_core::gnss::KeplerOrbit { health: 0, ..*o })
        .collect();
    let eps = simulate_raw(&RawConfig::default(), &healthy, &times, |_| {
        (rx, Vec3::zeros())
    });
    let mut obs = ObsFile {
        types: vec!["C1".into(), "D1".into()],
        ..Default::default()
    };
    for e in &eps {
        let mut sats: Vec<(u8, Vec<Option<ObsValue>>)> = e
            .epoch
            .sats()
            .iter()
            .map(|s| {
                let v = |value| Some(ObsValue { value, lli: 0 });
                (s.obs.prn, vec![v(s.obs.pseudorange_m), v(s.obs.doppler_hz)])
            })
            .collect();
        sats.push((30, sats[0].1.clone()));
        sats.push((3, vec![None, None]));
        obs.epochs.push(ObsEpoch {
            t: e.epoch.t,
            flag: 0,
            sats,
        });
    }
    let nav = SppNav {
        gps: NavData {
            ura_m: vec![2.0; orbits.len()],
            orbits,
            iono: Some(navfuse_core::gnss::iono::Klobuchar {
                alpha: [1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08],
                beta: [8.8060e+04, 1.6380e+04, -1.9660e+05, -1.3110e+05],
            }),
        },
        other: Vec::new(),
        glonass: Vec::new(),
    };
    let r = raw_from_obs(
        &obs,
        &GnssObs::default(),
        &nav,
        Path::new("mem"),
        "rinex-obs",
    )
    .unwrap();
    let read: u64 = obs.epochs.iter().map(|e| e.sats.len() as u64).sum();
    assert_eq!(r.observations, read);
    let rej: u64 = r.rejected.values().map(PreCounts::total).sum();
    assert_eq!(r.records.len() as u64 + rej, read);
    assert_eq!(r.rejected["G30"].no_ephemeris, 30);
    assert_eq!(r.rejected["G03"].no_code, 30);
    let n2 = eps[0]
        .epoch
        .sats()
        .iter()
        .filter(|s| s.obs.prn == 2)
        .count() as u64;
    if n2 > 0 {
        assert_eq!(r.rejected["G02"].unhealthy, 30 * n2);
    }
    assert_eq!(r.records.iter().filter(|x| x.obs.last_in_epoch).count(), 30);
    assert!(r.records.iter().all(|x| x.sat.iono_m > 0.0 && x.sat.valid));
    // var = scale · (nominal URA² + (½ I)²), URA 2.0 m (index 0, nominal
    // 2.0 m); 30 s of slow satellite
    // errors (τ 1800 s) are about one sample per residual dof: the
    // a-priori budget stands (scale 1).
    assert!(r.sat_var_dof_eff < crate::spp::MIN_POOLED_DOF as f64);
    assert_eq!(r.sat_var_scale, 1.0);
    let x = &r.records[0];
    let want = r.sat_var_scale * (2.0f64.powi(2) + (0.5 * x.sat.iono_m as f64).powi(2));
    assert!((x.sat.var_m2 as f64 - want).abs() < 1e-3 * want, "{x:?}");
    assert_eq!(r.fixes.len(), 30);
    for f in &r.fixes {
        let p = geodetic_to_ecef(&Geodetic {
            lat: f.lat,
            lon: f.lon,
            h: f.h,
        });
        // The simulated errors (≈ 2 m per range) and the Klobuchar model
        // the simulated ranges do not contain: tens of metres at most.
        assert!((p - rx).norm() < 60.0, "{}", (p - rx).norm());
    }
}

/// Real data (GEONET 0759, RINEX 2 obs + nav, 1 h): every observation a
/// record or counted; the records' satellite variance scale is the SPP's
/// pooled variance factor; the fixes are the SPP's.
#[test]
#[ignore = "real data: cargo test --release -p navfuse-pipeline -- --ignored"]
fn geonet_rinex_raw_input_accounts_for_every_observation() {
    let obs = navfuse_io::data::require("gnss/rinex/07590920.05o");
    let nav = navfuse_io::data::require("gnss/rinex/07590920.05n");
    let r = load_raw(&obs, &[nav]).unwrap();
    let rej: u64 = r.rejected.values().map(PreCounts::total).sum();
    eprintln!(
        "{} observations: {} records, {rej} rejected ({:?}); {} fixes; variance scale {:.3}",
        r.observations,
        r.records.len(),
        r.report.rejected,
        r.fixes.len(),
        r.var_scale
    );
    assert_eq!(r.records.len() as u64 + rej, r.observations);
    assert_eq!(r.fixes.len(), r.spp.solved);
    assert!(r.records.len() as u64 > r.observations / 2);
    assert_eq!(r.var_scale, r.spp.variance_factor);
    let want = if r.sat_var_dof_eff >= crate::spp::MIN_POOLED_DOF as f64 {
        r.spp.variance_factor
    } else {
        1.0
    };
    eprintln!(
        "satellite variance: dof_eff {:.1}, scale {:.3}",
        r.sat_var_dof_eff, r.sat_var_scale
    );
    assert_eq!(r.sat_var_scale, want);
    assert!(r.records.iter().all(|x| x.sat.iono_m > 0.0));
}

/// GLONASS records of the simulated multi-GNSS log: system R, signal G1
/// on the ephemeris' frequency channel (the Doppler's wavelength), a valid
/// satellite state whose range model (geometric range with Sagnac,
/// receiver clock, the simulated +60 m inter-system bias, satellite clock)
/// explains the pseudorange to the atmosphere and noise (< 40 m; a wrong
/// transmission time or frame would be km), and the GLONASS broadcast σ
/// (5 m) in the record's variance.
#[test]
fn glonass_records_from_the_simulated_log() {
    use navfuse_core::gnss::raw::geometric_range;
    use navfuse_core::gnss::C_LIGHT;
    use navfuse_sim::multi_gnss::{simulate_multi, MultiGnssConfig};
    let log = simulate_multi(&MultiGnssConfig {
        n_epochs: 60,
        glonass: true,
        ..Default::default()
    });
    let (o, g) = navfuse_io::rinex::parse_obs_gnss(&log.obs_text(), "sim.obs").unwrap();
    let nav = SppNav {
        gps: log.nav_gps.clone(),
        other: log.nav_other.clone(),
        glonass: log.nav_glonass.clone(),
    };
    let r = raw_from_obs(&o, &g, &nav, Path::new("mem"), "rinex-obs").unwrap();
    let glo: Vec<&RawSat> = r
        .records
        .iter()
        .filter(|x| x.obs.system == GnssSystem::Glonass)
        .collect();
    assert!(glo.len() >= 60 * 4, "{}", glo.len());
    assert!(
        r.rejected.keys().all(|k| !k.starts_with('R')),
        "{:?}",
        r.rejected
    );
    for x in glo {
        let e = nav.glonass_ephemeris(x.obs.prn, x.obs.t).unwrap();
        assert_eq!(x.obs.signal, Signal::GloG1);
        assert_eq!(x.obs.glo_fcn, e.freq_ch);
        let lam = C_LIGHT / navfuse_core::gnss::glonass::l1_frequency_hz(e.freq_ch);
        assert!((x.obs.wavelength_m() - lam).abs() < 1e-12);
        assert!(x.sat.valid && x.obs.doppler_hz.is_finite());
        assert!(f64::from(x.sat.var_m2) >= 25.0 * r.sat_var_scale * 0.999);
        let k = log.tags.iter().position(|t| *t == x.obs.t).unwrap();
        let (rho, _) = geometric_range(&x.sat.pos_e, &log.truth_e[k]);
        let model = rho + log.clock_bias_s[k] * C_LIGHT + 60.0 - x.sat.clock_m;
        let d = x.obs.pseudorange_m - model;
        assert!(d.abs() < 40.0, "R{:02}: {d} m", x.obs.prn);
    }
}

/// RTK input of a RINEX 3 G+E+C pair file (the simulated scene's own
/// codes): with `second_frequency` every Galileo and BeiDou satellite gets
/// its carrier on the first signal and an E5b / B2I record after it, equal
/// to the simulated records to the file's precision; without it the
/// Galileo/BeiDou records stay code-only and no second signal appears (the
/// SPP/tight input unchanged).
#[test]
fn rtk_input_reads_galileo_e5b_and_beidou_b2i() {
    use navfuse_sim::multi_gnss::{constellations, MultiGnssConfig};
    use navfuse_sim::rtk_scene::{offset_position, simulate_rtk, RtkSceneConfig, SceneSat};
    let dir = crate::test_dir("rtk-input-e5b-b2i");
    let m = MultiGnssConfig::default();
    let t_oe = ((m.t0 - 1.0) / 960.0).floor() * 960.0;
    let (nav_gps, nav_other) = constellations(t_oe, 4);
    let sats = SceneSat::from_broadcast(&nav_gps, &nav_other);
    let rx = geodetic_to_ecef(&m.centre);
    let base = offset_position(&rx, 5000.0, 2000.0, 20.0);
    let times: Vec<f64> = (0..5).map(|k| m.t0 + k as f64).collect();
    let sc = simulate_rtk(
        &RtkSceneConfig::default(),
        &sats,
        &times,
        |_| (rx, Vec3::zeros()),
        base,
    );
    let (rover_text, _) = sc.obs_texts();
    let obs = dir.join("rover.obs");
    let nav = dir.join("nav.rnx");
    std::fs::write(&obs, rover_text).unwrap();
    std::fs::write(
        &nav,
        navfuse_io::rinex_write::nav3_text(&nav_gps, &nav_other),
    )
    .unwrap();
    let dual = load_raw_with(&obs, std::slice::from_ref(&nav), true).unwrap();
    let single = load_raw_with(&obs, std::slice::from_ref(&nav), false).unwrap();
    let count = |r: &RawInput, s: Signal| r.records.iter().filter(|x| x.obs.signal == s).count();
    for s in [Signal::GalE5b, Signal::BdsB2I] {
        assert!(count(&dual, s) >= 5, "{s:?}: {}", count(&dual, s));
        assert_eq!(count(&single, s), 0, "{s:?}");
        let first = Signal::first_of(s.system());
        assert_eq!(count(&dual, s), count(&dual, first), "{s:?}");
    }
    let mut compared = 0;
    for r in dual
        .records
        .iter()
        .filter(|x| x.obs.system != GnssSystem::Gps)
    {
        let ep = sc
            .rover
            .iter()
            .find(|e| (e.epoch.t - r.obs.t).abs() < 1e-6)
            .expect("epoch");
        let o = ep
            .epoch
            .sats()
            .iter()
            .find(|s| {
                s.obs.system == r.obs.system
                    && s.obs.prn == r.obs.prn
                    && s.obs.signal == r.obs.signal
            })
            .expect("simulated record");
        // RINEX: 0.001 cycles and 0.001 m.
        assert!(
            (r.obs.carrier_m - o.obs.carrier_m).abs() < 2e-3,
            "{r:?} {o:?}"
        );
        assert!((r.obs.pseudorange_m - o.obs.pseudorange_m).abs() < 2e-3);
        assert_eq!(
            r.obs.flags & FLAG_LOSS_OF_LOCK,
            o.obs.flags & FLAG_LOSS_OF_LOCK
        );
        compared += 1;
    }
    assert!(compared >= 20, "{compared}");
    assert!(single
        .records
        .iter()
        .filter(|x| x.obs.system != GnssSystem::Gps)
        .all(|x| x.obs.carrier_m.is_nan()));
}
