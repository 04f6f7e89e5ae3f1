//! SPP tests on synthetic geometry. The pseudoranges and Dopplers are made
//! with [`sat_at_receive`] (light-time iteration with a rotated frame), not
//! with the solver's own model (transmission time from the pseudorange,
//! linear Sagnac term), so the tests check the model, not only the algebra.

use super::*;
use crate::geodesy::{geodetic_to_ecef, Geodetic};
use crate::gnss::{sat_at_receive, SECONDS_PER_WEEK};

const T_OE: f64 = 1316.0 * SECONDS_PER_WEEK + 518_400.0;

/// 24 GPS-like orbits in 6 planes, with clocks and group delays.
fn constellation() -> [KeplerOrbit; 24] {
    let mut out = [KeplerOrbit::default(); 24];
    for (k, o) in out.iter_mut().enumerate() {
        let plane = (k / 4) as f64;
        let slot = (k % 4) as f64;
        *o = KeplerOrbit {
            prn: k as u8 + 1,
            sqrt_a: 5153.6 + k as f64 * 0.3,
            e: 0.002 + 0.0005 * k as f64,
            i0: 0.96,
            omega0: plane * 60f64.to_radians(),
            omega_dot: -8e-9,
            argp: 0.3 * plane,
            m0: slot * 90f64.to_radians() + plane * 15f64.to_radians(),
            t_oe: T_OE,
            t_oc: T_OE,
            af0: 1e-4 * ((k as f64) - 12.0) / 12.0,
            af1: 3e-12,
            tgd: -4e-9 + 3e-10 * k as f64,
            ..Default::default()
        };
    }
    out
}

fn receiver() -> Vec3 {
    geodetic_to_ecef(&Geodetic {
        lat: 36f64.to_radians(),
        lon: 139f64.to_radians(),
        h: 50.0,
    })
}

/// Observations of every satellite above 16° seen from `rx` (moving with
/// `v_e`) at true GPS time `t`, receiver clock `clk_m` [m] and drift
/// `drift_mps` per system, the system of PRN k being `sys_of(k)`.
fn observe(
    rx: &Vec3,
    v_e: &Vec3,
    t: f64,
    clk_m: &[f64; MAX_SYS],
    drift_mps: &[f64; MAX_SYS],
    sys_of: impl Fn(u8) -> u8,
    out: &mut [SppObs; MAX_SATS],
) -> usize {
    let g = ecef_to_geodetic(rx);
    let c = c_e_enu(g.lat, g.lon);
    let mut n = 0;
    for o in constellation().iter() {
        let s = sat_at_receive(o, rx, t);
        let el = (c * ((s.pos_e - rx) / s.range)).z.asin();
        if el < 16f64.to_radians() {
            continue;
        }
        let sys = sys_of(o.prn);
        let dts = o.clock_offset(s.t_tx);
        // Receiver clock: the time tag is t + clk/c.
        let pr = s.range + clk_m[sys as usize] - C_LIGHT * dts + C_LIGHT * o.tgd;
        // Range rate by central difference of the independent geometry.
        let h = 1.0; // long enough that the 0.1 µs resolution of absolute GPS time is negligible
        let r_p = sat_at_receive(o, &(rx + v_e * h), t + h);
        let r_m = sat_at_receive(o, &(rx - v_e * h), t - h);
        let ddts = (o.clock_offset(r_p.t_tx) - o.clock_offset(r_m.t_tx)) / (2.0 * h);
        let range_rate = (r_p.range - r_m.range) / (2.0 * h);
        let rr = range_rate + drift_mps[sys as usize] - C_LIGHT * ddts;
        out[n] = SppObs {
            sys,
            prn: o.prn,
            pr_m: pr,
            doppler_hz: -rr / GPS_L1_WAVELENGTH,
            lambda_m: GPS_L1_WAVELENGTH,
            orbit: *o,
            kind: OrbitKind::Gps,
            ura_m: 2.0,
            glo: None,
        };
        n += 1;
    }
    n
}

fn plain() -> SppConfig {
    SppConfig {
        iono: false,
        tropo: TropoModel::None,
        ..SppConfig::default()
    }
}

#[test]
fn synthetic_geometry_recovers_position_clock_and_velocity() {
    let rx = receiver();
    let v_e = Vec3::new(12.0, -7.0, 3.0);
    let clk = [3.0e4, 0.0, 0.0, 0.0];
    let drift = [45.0, 0.0, 0.0, 0.0];
    let t = T_OE + 1500.0;
    let mut obs = [SppObs::default(); MAX_SATS];
    let n = observe(&rx, &v_e, t, &clk, &drift, |_| 0, &mut obs);
    assert!(n >= 6, "only {n} satellites visible");
    let mut spp = Spp::new(plain(), None);
    let sol = spp.solve(t + clk[0] / C_LIGHT, &obs[..n], None).unwrap();
    let err = (sol.pos_e - rx).norm();
    assert!(err < 5e-3, "position error {err} m");
    assert!(
        (sol.clk_m[0] - clk[0]).abs() < 5e-3,
        "clock {}",
        sol.clk_m[0]
    );
    assert!(sol.clk_m[1].is_nan());
    assert_eq!(sol.n_used as usize, n);
    assert_eq!(sol.used_mask, (1u64 << n) - 1);
    assert_eq!(sol.n_excluded, 0);
    assert!(sol.chi2 < 1e-6, "noise-free χ² {}", sol.chi2);
    let vel = sol.vel.expect("Doppler velocity");
    let dv = (vel.vel_e - v_e).norm();
    assert!(dv < 1e-3, "velocity {} error {dv}", vel.vel_e);
    assert!((vel.drift_mps[0] - drift[0]).abs() < 1e-3);
    // DOPs: GDOP² = PDOP² + TDOP², PDOP² = HDOP² + VDOP², all > 0.
    let d = sol.dop;
    assert!(d.hdop > 0.0 && d.vdop > 0.0 && d.gdop > d.pdop);
    assert!((d.pdop * d.pdop - d.hdop * d.hdop - d.vdop * d.vdop).abs() < 1e-9);
    // ENU and ECEF covariances are the same tensor (equal traces).
    assert!((sol.cov_pos_enu.trace() - sol.cov_pos_e.trace()).abs() < 1e-9);
    // A prior only changes the iteration count.
    let sol2 = spp
        .solve(t + clk[0] / C_LIGHT, &obs[..n], Some(rx))
        .unwrap();
    assert!((sol2.pos_e - sol.pos_e).norm() < 1e-3);
    assert!(sol2.iterations < sol.iterations);
}

/// With the atmosphere modelled in the data by the same Klobuchar and
/// Saastamoinen formulas the solver removes it exactly; ignoring it costs
/// metres (so the corrections are really applied).
#[test]
fn atmosphere_corrections_are_applied() {
    let rx = receiver();
    let t = T_OE + 1500.0;
    let k = Klobuchar {
        alpha: [1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08],
        beta: [8.8060e+04, 1.6380e+04, -1.9660e+05, -1.3110e+05],
    };
    let mut obs = [SppObs::default(); MAX_SATS];
    let n = observe(
        &rx,
        &Vec3::zeros(),
        t,
        &[0.0; 4],
        &[0.0; 4],
        |_| 0,
        &mut obs,
    );
    let g = ecef_to_geodetic(&rx);
    let c = c_e_enu(g.lat, g.lon);
    let (zhd, zwd) = saastamoinen_zenith(g.lat, g.h, 0.7);
    let tow = t - (t / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
    for o in obs[..n].iter_mut() {
        let s = sat_at_receive(&o.orbit, &rx, t);
        let los = c * ((s.pos_e - rx) / s.range);
        let el = los.z.asin();
        let az = los.x.atan2(los.y);
        o.pr_m += k.delay_l1(g.lat, g.lon, az, el, tow) + (zhd + zwd) / el.sin();
    }
    let mut spp = Spp::new(SppConfig::default(), Some(k));
    let sol = spp.solve(t, &obs[..n], None).unwrap();
    assert!(
        (sol.pos_e - rx).norm() < 0.01,
        "{}",
        (sol.pos_e - rx).norm()
    );
    let mut bare = Spp::new(plain(), Some(k));
    let sol = bare.solve(t, &obs[..n], None).unwrap();
    assert!((sol.pos_e - rx).norm() > 1.0);
}

#[test]
fn raim_excludes_an_injected_50_m_fault() {
    let rx = receiver();
    let t = T_OE + 600.0;
    let mut obs = [SppObs::default(); MAX_SATS];
    let n = observe(
        &rx,
        &Vec3::zeros(),
        t,
        &[0.0; 4],
        &[0.0; 4],
        |_| 0,
        &mut obs,
    );
    assert!(n >= 6, "{n}");
    let bad = 2;
    obs[bad].pr_m += 50.0;
    let mut spp = Spp::new(plain(), None);
    let sol = spp.solve(t, &obs[..n], None).unwrap();
    assert_eq!(sol.n_excluded, 1);
    assert_eq!(sol.excluded_prn[0], obs[bad].prn);
    assert_eq!(sol.used_mask & (1 << bad), 0);
    assert_eq!(spp.skips().raim, 1);
    assert!((sol.pos_e - rx).norm() < 5e-3);
    // Without RAIM the same epoch fails the χ² test.
    let mut no_raim = Spp::new(
        SppConfig {
            raim: false,
            ..plain()
        },
        None,
    );
    match no_raim.solve(t, &obs[..n], None) {
        Err(SppReject::ChiSquare { chi2, dof }) => {
            assert_eq!(dof, n - 4);
            assert!(chi2 > chi2_999(dof));
        }
        other => panic!("expected a χ² rejection, got {other:?}"),
    }
}

/// Two clock groups: each system's receiver clock is its own unknown.
#[test]
fn two_systems_two_clocks() {
    let rx = receiver();
    let t = T_OE + 900.0;
    let clk = [150.0, 150.0 + 37.5, 0.0, 0.0];
    let mut obs = [SppObs::default(); MAX_SATS];
    let n = observe(&rx, &Vec3::zeros(), t, &clk, &[0.0; 4], |p| p % 2, &mut obs);
    assert!(n >= 7, "{n}");
    // The time tag follows the system-0 clock; the other group's offset is
    // an inter-system bias in its ranges only.
    let mut spp = Spp::new(plain(), None);
    let sol = spp.solve(t + clk[0] / C_LIGHT, &obs[..n], None).unwrap();
    assert!(
        (sol.pos_e - rx).norm() < 5e-3,
        "{}",
        (sol.pos_e - rx).norm()
    );
    assert!((sol.clk_m[1] - sol.clk_m[0] - 37.5).abs() < 5e-3);
    assert_eq!(sol.dof as usize, n - 5);
}

#[test]
fn rejections_and_skips_are_counted() {
    let rx = receiver();
    let t = T_OE + 600.0;
    let mut obs = [SppObs::default(); MAX_SATS];
    let n = observe(
        &rx,
        &Vec3::zeros(),
        t,
        &[0.0; 4],
        &[0.0; 4],
        |_| 0,
        &mut obs,
    );
    obs[0].orbit.health = 1;
    obs[1].pr_m = f64::NAN;
    obs[2].sys = MAX_SYS as u8;
    let mut spp = Spp::new(plain(), None);
    let r = spp.solve(t, &obs[..n], None);
    let s = spp.skips();
    assert_eq!((s.unhealthy, s.bad_range, s.over_capacity), (1, 1, 1));
    if n - 3 >= 4 {
        assert!(r.is_ok());
    }
    match spp.solve(t, &obs[3..6], None) {
        Err(SppReject::TooFewSatellites { have: 3, need: 4 }) => {}
        other => panic!("{other:?}"),
    }
    // A tight GDOP limit rejects.
    let mut strict = Spp::new(
        SppConfig {
            max_gdop: 0.5,
            ..plain()
        },
        None,
    );
    assert!(matches!(
        strict.solve(t, &obs[3..n], None),
        Err(SppReject::GdopTooHigh { .. })
    ));
}

/// Nominal URA values of IS-GPS-200 §20.3.3.3.1.3.1 by index.
#[test]
fn ura_nominal_values_by_index() {
    use super::ura_nominal_m;
    let cases = [
        (0.5, 2.0),
        (2.4, 2.0),
        (2.5, 2.0f64.powf(1.5)),
        (4.0, 4.0),
        (10.0, 2.0f64.powf(3.5)),
        (20.0, 16.0),
        (40.0, 32.0),
        (6000.0, 4096.0),
        (f64::NAN, 6144.0),
        (1e5, 6144.0),
    ];
    for (b, want) in cases {
        assert!(
            (ura_nominal_m(b) - want).abs() < 1e-9,
            "{b}: {}",
            ura_nominal_m(b)
        );
    }
}

/// GLONASS satellites (nominal constellation, RK4 orbits, clocks −τ_n +
/// γ_n (t − t_b)) next to GPS: observed by an independent light-time
/// solution (satellite at t − τ in the frame of t − τ, rotated into the
/// frame of t), with a GLONASS receiver clock 120 m off GPS's and the
/// Doppler on each satellite's FDMA wavelength. The solver recovers the
/// position, both clocks and the velocity (noise-free: to mm, mm/s); the
/// GLONASS ranges carry the larger noise variance (EFACT_GLO²).
#[test]
fn glonass_with_gps_two_clocks() {
    use crate::gnss::glonass::{l1_frequency_hz, nominal_eph};
    let rx = receiver();
    let v_e = Vec3::new(-6.0, 9.0, 1.0);
    let t = T_OE + 600.0;
    let clk = [2.0e3, 0.0, 0.0, 2.0e3 + 120.0];
    let drift = [30.0, 0.0, 0.0, 30.0];
    let mut obs = [SppObs::default(); MAX_SATS];
    let mut n = observe(&rx, &v_e, t, &clk, &drift, |_| 0, &mut obs);
    let n_gps = n;
    let g = ecef_to_geodetic(&rx);
    let c = c_e_enu(g.lat, g.lon);
    let receive = |e: &GlonassEph, rx: &Vec3, t: f64| -> (f64, f64) {
        let mut tau = 0.07;
        let mut range = 0.0;
        for _ in 0..10 {
            let q = e.position_ecef(t - tau);
            let th = OMEGA_E_DOT * tau;
            let p = Vec3::new(
                th.cos() * q.x + th.sin() * q.y,
                -th.sin() * q.x + th.cos() * q.y,
                q.z,
            );
            range = (p - rx).norm();
            tau = range / C_LIGHT;
        }
        (range, t - tau)
    };
    let mut n_glo = 0;
    for slot in 1..=24u8 {
        let mut e = nominal_eph(slot, T_OE + 900.0);
        e.tau_n = 1e-5 * (f64::from(slot) - 12.0) / 12.0;
        e.gamma_n = 1e-12 * (f64::from(slot % 5) - 2.0);
        let (range, t_tx) = receive(&e, &rx, t);
        let el = (c * ((e.position_ecef(t_tx) - rx) / range)).z.asin();
        if el < 16f64.to_radians() || n == MAX_SATS {
            continue;
        }
        let pr = range + clk[3] - C_LIGHT * e.clock_offset(t_tx);
        let h = 1.0;
        let (r_p, tp) = receive(&e, &(rx + v_e * h), t + h);
        let (r_m, tm) = receive(&e, &(rx - v_e * h), t - h);
        let rr = (r_p - r_m) / (2.0 * h) + drift[3]
            - C_LIGHT * (e.clock_offset(tp) - e.clock_offset(tm)) / (2.0 * h);
        let lambda = C_LIGHT / l1_frequency_hz(e.freq_ch);
        obs[n] = SppObs {
            sys: 3,
            prn: slot,
            pr_m: pr,
            doppler_hz: -rr / lambda,
            lambda_m: lambda,
            ura_m: 5.0,
            glo: Some(e),
            ..SppObs::default()
        };
        n += 1;
        n_glo += 1;
    }
    assert!(n_glo >= 4, "{n_glo} GLONASS satellites visible");
    let mut spp = Spp::new(plain(), None);
    let sol = spp.solve(t + clk[0] / C_LIGHT, &obs[..n], None).unwrap();
    let err = (sol.pos_e - rx).norm();
    assert!(
        err < 5e-3,
        "position error {err} m ({n_gps} GPS + {n_glo} GLONASS)"
    );
    assert!(
        (sol.clk_m[3] - sol.clk_m[0] - 120.0).abs() < 5e-3,
        "{:?}",
        sol.clk_m
    );
    assert_eq!(sol.n_used as usize, n);
    let vel = sol.vel.expect("Doppler velocity");
    assert!((vel.vel_e - v_e).norm() < 2e-3, "{}", vel.vel_e - v_e);
    assert!((vel.drift_mps[3] - drift[3]).abs() < 2e-3);
    // GLONASS only (4 unknowns: position and the GLONASS clock).
    let sol_r = spp
        .solve(t + clk[0] / C_LIGHT, &obs[n_gps..n], None)
        .unwrap();
    assert!((sol_r.pos_e - rx).norm() < 5e-3);
    assert!(sol_r.clk_m[0].is_nan());
    // An unhealthy GLONASS ephemeris is skipped and counted.
    let mut bad = obs;
    bad[n_gps].glo.as_mut().unwrap().health = 1;
    spp.solve(t + clk[0] / C_LIGHT, &bad[..n], None).unwrap();
    assert_eq!(spp.skips().unhealthy, 1);
}
