//! Round trips of the RINEX 3 writers through our readers.

use super::*;
use crate::rinex::{parse_nav_data, parse_obs_gnss};
use crate::rinex_nav3::parse_nav_gnss;
use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::orbit_gnss::OrbitKind;
use navfuse_core::gnss::KeplerOrbit;

fn orbit(prn: u8, t_oe: f64, k: f64) -> KeplerOrbit {
    KeplerOrbit {
        prn,
        health: 0,
        t_oe,
        t_oc: t_oe,
        sqrt_a: 5153.6 + 100.0 * k,
        e: 0.0031 + 1e-4 * k,
        i0: 0.96 - 0.01 * k,
        idot: -3.2e-10 * k,
        omega0: -2.1 + 0.3 * k,
        omega_dot: -8.2e-9,
        argp: 0.21 * k,
        m0: 1.3 - 0.2 * k,
        delta_n: 4.1e-9,
        cuc: 1.1e-6,
        cus: -2.3e-6 * k,
        crc: 201.5,
        crs: -12.375,
        cic: 3.7e-8,
        cis: -1.9e-8,
        af0: 1.7e-5 * (k - 3.0),
        af1: -2.2e-12,
        af2: 0.0,
        tgd: -4.7e-9 + 1e-10 * k,
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-11 * a.abs().max(b.abs()) + 1e-300
}

fn same_orbit(a: &KeplerOrbit, b: &KeplerOrbit) -> bool {
    let fa = [
        a.t_oe,
        a.t_oc,
        a.sqrt_a,
        a.e,
        a.i0,
        a.idot,
        a.omega0,
        a.omega_dot,
        a.argp,
        a.m0,
        a.delta_n,
        a.cuc,
        a.cus,
        a.crc,
        a.crs,
        a.cic,
        a.cis,
        a.af0,
        a.af1,
        a.af2,
        a.tgd,
    ];
    let fb = [
        b.t_oe,
        b.t_oc,
        b.sqrt_a,
        b.e,
        b.i0,
        b.idot,
        b.omega0,
        b.omega_dot,
        b.argp,
        b.m0,
        b.delta_n,
        b.cuc,
        b.cus,
        b.crc,
        b.crs,
        b.cic,
        b.cis,
        b.af0,
        b.af1,
        b.af2,
        b.tgd,
    ];
    a.prn == b.prn && a.health == b.health && fa.iter().zip(&fb).all(|(x, y)| close(*x, *y))
}

/// GPS, Galileo, BeiDou MEO and GEO records with a header ionosphere,
/// written and read back by both navigation readers: the same records (12
/// significant digits), systems, kinds, accuracies, BDT epochs converted
/// back to GPS time, and the same Klobuchar coefficients.
#[test]
fn mixed_navigation_round_trip() {
    let t0 = 2034.0 * SECONDS_PER_WEEK + 172_800.0;
    let gps = NavData {
        orbits: vec![orbit(3, t0, 0.0), orbit(17, t0 + 7200.0, 1.0)],
        ura_m: vec![2.0, 2.8],
        iono: Some(Klobuchar {
            alpha: [1.118e-8, 7.451e-9, -5.96e-8, -5.96e-8],
            beta: [90_110.0, 49_150.0, -131_100.0, -327_700.0],
        }),
    };
    let mut unhealthy = orbit(7, t0 + 600.0, 4.0);
    unhealthy.health = 1;
    let other = vec![
        GnssEph {
            sys: 'E',
            kind: OrbitKind::Galileo,
            orbit: orbit(11, t0 + 600.0, 2.0),
            accuracy_m: 3.12,
        },
        GnssEph {
            sys: 'E',
            kind: OrbitKind::Galileo,
            orbit: unhealthy,
            accuracy_m: 3.12,
        },
        GnssEph {
            sys: 'C',
            kind: OrbitKind::BeiDou,
            orbit: orbit(23, t0 + 14.0, 3.0),
            accuracy_m: 2.0,
        },
        GnssEph {
            sys: 'C',
            kind: OrbitKind::BeiDouGeo,
            // t_oe on a Sunday in BDT but Saturday in GPS time: the week rolls.
            orbit: orbit(1, 2035.0 * SECONDS_PER_WEEK + 6.0, 5.0),
            accuracy_m: 2.0,
        },
    ];
    let text = nav3_text(&gps, &other);
    let all = parse_nav_gnss(&text, "w.rnx").unwrap();
    assert_eq!(all.skipped, 0);
    assert_eq!(all.ephs.len(), 6);
    for (k, e) in all.ephs.iter().take(2).enumerate() {
        assert_eq!((e.sys, e.kind), ('G', OrbitKind::Gps));
        assert!(same_orbit(&e.orbit, &gps.orbits[k]), "{e:?}");
        assert_eq!(e.accuracy_m, gps.ura_m[k]);
    }
    for (e, w) in all.ephs[2..].iter().zip(&other) {
        assert_eq!((e.sys, e.kind), (w.sys, w.kind));
        assert!(same_orbit(&e.orbit, &w.orbit), "{e:?}\n{w:?}");
        assert_eq!(e.accuracy_m, w.accuracy_m);
    }
    let g = parse_nav_data(&text, "w.rnx").unwrap();
    assert_eq!(g.iono, gps.iono);
    assert_eq!(g.orbits.len(), 2);
    assert!(g
        .orbits
        .iter()
        .zip(&gps.orbits)
        .all(|(a, b)| same_orbit(a, b)));
    assert_eq!(g.ura_m, gps.ura_m);
}

/// Mixed observations (GPS with four codes, Galileo, BeiDou with a blank
/// and a loss-of-lock flag) written and read back: the same epochs, time
/// tags, systems, PRNs, values (mm) and flags, and the GPS part in the
/// reader's RINEX 2 names.
#[test]
fn mixed_observation_round_trip() {
    let t0 = 2034.0 * SECONDS_PER_WEEK + 172_800.0 + 0.000_123_4;
    let sys_codes = vec![
        (
            'G',
            vec!["C1C".into(), "L1C".into(), "D1C".into(), "S1C".into()],
        ),
        (
            'E',
            vec!["C1C".into(), "L1C".into(), "D1C".into(), "S1C".into()],
        ),
        (
            'C',
            vec!["C2I".into(), "L2I".into(), "D2I".into(), "S2I".into()],
        ),
    ];
    let v = |x: i64, lli: u8| {
        Some(ObsValue {
            value: x as f64 / 1000.0,
            lli,
        })
    };
    let mut epochs = Vec::new();
    let mut times = Vec::new();
    for k in 0..3i64 {
        times.push(t0 + k as f64);
        epochs.push(vec![
            (
                'G',
                5u8,
                vec![
                    v(21_234_567_891 + k, 0),
                    v(-111_588_123_456, 1),
                    v(-1_234_567 - k, 0),
                    v(45_125, 0),
                ],
            ),
            (
                'G',
                12,
                vec![
                    v(23_000_000_001, 0),
                    v(120_000_000_000, 0),
                    v(987_654, 0),
                    v(38_000, 0),
                ],
            ),
            (
                'E',
                11,
                vec![
                    v(24_111_222_333, 0),
                    v(126_000_111_222, 0),
                    v(-55_555, 0),
                    v(41_000, 0),
                ],
            ),
            (
                'C',
                23,
                vec![v(22_333_444_555, 0), None, v(2_000_001, 0), v(36_250, 0)],
            ),
            (
                'C',
                1,
                vec![
                    v(37_999_888_777, 0),
                    v(197_000_000_123, 1),
                    v(-12, 0),
                    v(33_000, 0),
                ],
            ),
        ]);
    }
    let gnss = GnssObs { sys_codes, epochs };
    let text = obs3_text(
        "SIM",
        [-3_947_762.0, 3_364_399.0, 3_699_428.0],
        &times,
        &gnss,
    );
    let (o, g) = parse_obs_gnss(&text, "w.obs").unwrap();
    assert_eq!(g, gnss);
    assert_eq!(o.version, 3.04);
    assert_eq!(o.marker, "SIM");
    assert_eq!(o.types, vec!["C1", "L1", "D1", "S1"]);
    assert_eq!(o.epochs.len(), 3);
    for (e, t) in o.epochs.iter().zip(&times) {
        assert!((e.t - t).abs() < 1e-9, "{} {t}", e.t);
        let prns: Vec<u8> = e.sats.iter().map(|s| s.0).collect();
        assert_eq!(prns, vec![5, 12]);
    }
    assert_eq!(o.epochs[1].sats[0].1, gnss.epochs[1][0].2);
    assert_eq!(o.other_count('E'), 3);
    assert_eq!(o.other_count('C'), 6);
}

/// Dual-frequency observations (GPS L1 C/A + L2C, Galileo E1 + E5b, BeiDou
/// B1I + B2I) with the codes of [`Signal::rinex3_codes`] written and read
/// back: the same values and flags, every code maps back to its signal,
/// and the GPS-only reader names L2C `C2 L2 D2 S2` (no `P2`).
#[test]
fn dual_frequency_observation_round_trip() {
    use navfuse_core::gnss::raw::{GnssSystem, Signal};
    let t0 = 2034.0 * SECONDS_PER_WEEK + 172_800.0;
    let mut sys_codes = Vec::new();
    for sys in [GnssSystem::Gps, GnssSystem::Galileo, GnssSystem::BeiDou] {
        let mut c: Vec<String> = Vec::new();
        for sig in [Signal::first_of(sys), Signal::second_of(sys).unwrap()] {
            c.extend(sig.rinex3_codes().iter().map(|x| x.to_string()));
        }
        sys_codes.push((sys.letter(), c));
    }
    let v = |x: i64, lli: u8| {
        Some(ObsValue {
            value: x as f64 / 1000.0,
            lli,
        })
    };
    let vals = |k: i64| {
        vec![
            v(21_234_567_891 + k, 0),
            v(-111_588_123_456, 1),
            v(-1_234_567, 0),
            v(45_125, 0),
            v(21_234_570_001 + k, 0),
            v(-86_951_000_111, 0),
            None,
            v(41_000, 0),
        ]
    };
    let times: Vec<f64> = (0..2).map(|k| t0 + k as f64).collect();
    let epochs = (0..2i64)
        .map(|k| vec![('G', 7u8, vals(k)), ('E', 19, vals(k)), ('C', 30, vals(k))])
        .collect();
    let gnss = GnssObs { sys_codes, epochs };
    let text = obs3_text(
        "DUAL",
        [-3_947_762.0, 3_364_399.0, 3_699_428.0],
        &times,
        &gnss,
    );
    let (o, g) = parse_obs_gnss(&text, "d.obs").unwrap();
    assert_eq!(g, gnss);
    for (sys, codes) in &g.sys_codes {
        let sigs: Vec<Signal> = codes
            .iter()
            .map(|c| Signal::from_rinex3(*sys, c).unwrap())
            .collect();
        assert!(sigs[..4].iter().all(|s| s.is_first()), "{sys}");
        assert!(sigs[4..].iter().all(|s| !s.is_first()), "{sys}");
    }
    assert_eq!(
        o.types,
        vec!["C1", "L1", "D1", "S1", "C2", "L2", "D2", "S2"]
    );
}

#[test]
fn fortran_fields() {
    assert_eq!(d19(-4.78835042158e-10), "-4.788350421580E-10");
    assert_eq!(d19(0.0), " 0.000000000000E+00");
    assert_eq!(d19(174_720.0), " 1.747200000000E+05");
    assert_eq!(d12(1.1176e-8), "  1.1176E-08");
    assert_eq!(d12(-327_680.0), " -3.2768E+05");
}
