//! A simulated multi-GNSS log as RINEX 3 files (issue 14, must-show 4):
//! GPS L1 C/A, Galileo E1 and BeiDou B1I code, carrier, Doppler and C/N0
//! of a rover driving a circle, 1 Hz, with the broadcast ephemerides that
//! generated them, written by [`navfuse_io::rinex_write`] so that other
//! programs (RTKLIB `rnx2rtkp`) read the same data as `navfuse spp`.
//! GLONASS (opt-in, [`MultiGnssConfig::glonass`]): the nominal 24-slot
//! constellation of [`navfuse_core::gnss::glonass::nominal_eph`] (3 planes
//! × 8, i = 64.8°, period 11 h 15 min 44 s), FDMA L1 C/A on each slot's
//! channel, a broadcast record every 30 min (t_b on UTC's :15/:45) chained
//! by the same RK4 integration (each record's state is the previous one
//! integrated 30 min; zero lunisolar terms), clocks τ_n uniform ±100 µs,
//! γ_n ±2e-12, continuous across records; the receiver's GLONASS
//! inter-system bias +60 m (200 ns). Truth evaluates the record nearest the
//! transmission time, as read back from the written text. No
//! inter-frequency code biases are simulated. Off by default, so the
//! three-system log is unchanged.
//!
//! Constellations (nominal geometry, [`constellations`]): GPS 24 satellites
//! (6 planes × 4, i = 55°, a = 26,560 km; the carrier-phase scene's
//! [`crate::carrier_phase::synthetic_constellation`] with small eccentricity,
//! clock and group-delay terms added); Galileo Walker 24/3/1 at i = 56°,
//! a = 29,600 km (Galileo OS SIS ICD §2.1 nominal constellation, E01–E24);
//! BeiDou MEO Walker 24/3/1 at i = 55°, a = 27,906 km (BDS-SIS-ICD-B1I
//! §3.1, C11–C34) and three GEOs at 80°, 110.5° and 140° E (C02, C03, C01).
//! Every record is one broadcast ephemeris per satellite with t_oe on the
//! 960 s grid just before the log starts; the simulator evaluates the records as read back from
//! the written navigation text, so the files and the truth agree to the
//! last written digit.
//!
//! Observables (everything in metres; `t` true GPS time, tag = t + δt_r):
//! `P = ρ + c δt_r + b_sys − c δt_s + c T_GD + T + I + e_sat + m + ε_P`,
//! with `ρ` the light-time range with earth rotation in each system's
//! frame constants, `δt_s` the broadcast clock with the relativistic term
//! ([`navfuse_core::gnss::orbit_gnss::clock_offset`]), `b_sys` the
//! receiver's inter-system bias (Galileo +25 m, BeiDou −40 m, 83 and
//! 133 ns: the values of the multi-GNSS SPP tests; both solvers estimate a
//! clock per system, so any constant is absorbed),
//! `T` Saastamoinen zenith delays with the Niell mapping
//! ([`navfuse_core::gnss::tropo::slant_delay`]), `I` the broadcast
//! Klobuchar delay scaled by (f_L1/f)² plus a per-satellite residual, and
//! the error models and values of [`crate::raw_gnss`] (C/N0 = 34 + 14 sin el,
//! DLL code noise 0.5 m at 45 dB-Hz, Gauss–Markov multipath 0.6 m / sin el ≤ 3 m
//! τ 10 s, ionosphere residual 1 m zenith τ 1800 s, satellite orbit/clock
//! error 1 m τ 3600 s, Doppler noise 0.05 m/s at 45 dB-Hz, carrier 3 mm).
//! Receiver clock: bias uniform ±0.5 ms and drift uniform ±0.5 ppm at the
//! start (TCXO tolerance; [`crate::raw_gnss`]), linear over the hour.
//! Satellites are tracked above 10° (a tracking mask below the solvers'
//! 15° so that the solvers, not the file, apply the mask), at most
//! [`MAX_CHANNELS`] per epoch, the highest first.

use navfuse_core::geodesy::{c_e_enu, ecef_to_geodetic, geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::glonass::{self, GlonassEph};
use navfuse_core::gnss::iono::Klobuchar;
use navfuse_core::gnss::orbit_gnss::{clock_offset, position_ecef, OrbitKind};
use navfuse_core::gnss::tropo::{day_of_year, slant_delay};
use navfuse_core::gnss::{KeplerOrbit, C_LIGHT, SECONDS_PER_WEEK};
use navfuse_core::Vec3;
use navfuse_io::rinex::{GnssObs, NavData, ObsValue};
use navfuse_io::rinex_nav3::GnssEph;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Channels written per epoch (the highest satellites): `navfuse spp`'s
/// per-epoch capacity (`navfuse_core::gnss::spp::MAX_SATS`).
pub const MAX_CHANNELS: usize = 32;

/// Broadcast Klobuchar coefficients of the log's navigation header: a set
/// of the kind GPS broadcasts at moderate solar activity (amplitude α₀ ≈ 11 ns,
/// period β₀ ≈ 25 h; both solvers apply the same model, so the values only
/// set the size of the correction, not an error).
pub const KLOBUCHAR: Klobuchar = Klobuchar {
    alpha: [1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8],
    beta: [9.0112e4, 4.9152e4, -1.3107e5, -3.2768e5],
};

/// What to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct MultiGnssConfig {
    /// First epoch, true GPS seconds.
    pub t0: f64,
    pub n_epochs: usize,
    /// Epoch interval [s].
    pub dt: f64,
    /// Centre of the rover's circle.
    pub centre: Geodetic,
    /// Circle radius [m] and speed [m/s].
    pub radius_m: f64,
    pub speed_mps: f64,
    /// Tracking mask [rad].
    pub track_mask_rad: f64,
    pub seed: u64,
    /// Add the GLONASS constellation (module documentation).
    pub glonass: bool,
}

impl Default for MultiGnssConfig {
    /// One hour at 1 Hz from GPS week 2034 day 2 00:00 (2019-01-01), a
    /// 500 m circle at 10 m/s near Tokyo (the GEONET stations' area).
    fn default() -> Self {
        MultiGnssConfig {
            t0: 2034.0 * SECONDS_PER_WEEK + 2.0 * 86_400.0,
            n_epochs: 3600,
            dt: 1.0,
            centre: Geodetic {
                lat: 35.6f64.to_radians(),
                lon: 139.6f64.to_radians(),
                h: 40.0,
            },
            radius_m: 500.0,
            speed_mps: 10.0,
            track_mask_rad: 10f64.to_radians(),
            seed: 1,
            glonass: false,
        }
    }
}

/// The simulated log.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MultiGnssLog {
    /// Receiver time tags [GPS s], parallel to `gnss.epochs`.
    pub tags: Vec<f64>,
    /// Observations (`C1C L1C D1C S1C` for G and E, `C2I L2I D2I S2I` for C).
    pub gnss: GnssObs,
    /// GPS records with [`KLOBUCHAR`].
    pub nav_gps: NavData,
    /// Galileo and BeiDou records.
    pub nav_other: Vec<GnssEph>,
    /// GLONASS records (empty unless [`MultiGnssConfig::glonass`]).
    pub nav_glonass: Vec<GlonassEph>,
    /// True antenna position (ECEF [m]) at each epoch's true time.
    pub truth_e: Vec<Vec3>,
    /// Receiver clock bias [s] at each epoch.
    pub clock_bias_s: Vec<f64>,
}

impl MultiGnssLog {
    /// The RINEX 3.04 observation text.
    pub fn obs_text(&self) -> String {
        let p = self.truth_e.first().copied().unwrap_or_default();
        navfuse_io::rinex_write::obs3_text("SIMROVER", [p.x, p.y, p.z], &self.tags, &self.gnss)
    }

    /// The RINEX 3.04 navigation text.
    pub fn nav_text(&self) -> String {
        navfuse_io::rinex_write::nav3_text(&self.nav_gps, &self.nav_other)
            + &navfuse_io::rinex_write::glonass3_records(&self.nav_glonass)
    }
}

fn wrap(a: f64) -> f64 {
    a - (a / std::f64::consts::TAU + 0.5).floor() * std::f64::consts::TAU
}

/// The three constellations of the module documentation with t_oe = t_oc =
/// `t_oe` (BeiDou: `t_oe` + 14 s, a whole BDT second), as the navigation
/// file holds them (written and read back). Clock terms, eccentricities and
/// group delays are drawn from `seed`: a_f0 uniform ±0.5 ms, a_f1 ±5e-12,
/// e uniform 0–0.01, T_GD/BGD uniform ±10 ns (of the order the broadcast
/// values of the three systems take).
pub fn constellations(t_oe: f64, seed: u64) -> (NavData, Vec<GnssEph>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6e61_7666);
    let perturb = |o: &mut KeplerOrbit, rng: &mut ChaCha8Rng| {
        o.e = rng.gen_range(0.0..0.01);
        o.af0 = rng.gen_range(-5e-4..5e-4);
        o.af1 = rng.gen_range(-5e-12..5e-12);
        o.tgd = rng.gen_range(-1e-8..1e-8);
        o.delta_n = 4.5e-9;
        o.omega_dot = -8.0e-9;
    };
    let gps: Vec<KeplerOrbit> = crate::carrier_phase::synthetic_constellation(t_oe)
        .into_iter()
        .map(|mut o| {
            perturb(&mut o, &mut rng);
            o
        })
        .collect();
    let mut other = Vec::new();
    let walker = |sys: char, kind, a: f64, i_deg: f64, prn0: u8, toe: f64| {
        (0..24)
            .map(|k| {
                let (plane, slot) = ((k / 8) as f64, (k % 8) as f64);
                GnssEph {
                    sys,
                    kind,
                    orbit: KeplerOrbit {
                        prn: prn0 + k as u8,
                        t_oe: toe,
                        t_oc: toe,
                        sqrt_a: a.sqrt(),
                        i0: i_deg.to_radians(),
                        omega0: wrap(plane * 120f64.to_radians()),
                        // Walker 24/3/1: phasing 360°/24 between planes.
                        m0: wrap((slot * 45.0 + plane * 15.0).to_radians()),
                        ..Default::default()
                    },
                    accuracy_m: if sys == 'E' { 3.12 } else { 2.0 },
                }
            })
            .collect::<Vec<_>>()
    };
    other.extend(walker('E', OrbitKind::Galileo, 29_600e3, 56.0, 1, t_oe));
    other.extend(walker(
        'C',
        OrbitKind::BeiDou,
        27_906e3,
        55.0,
        11,
        t_oe + 14.0,
    ));
    // GEOs: elements in the ICD's 5°-tilted frame (Table 5-11), node set so
    // the satellite sits at its longitude at t_oe.
    let (mu, we) = OrbitKind::BeiDouGeo.constants();
    for (prn, lon) in [(1u8, 140.0f64), (2, 80.0), (3, 110.5)] {
        let toe = t_oe + 14.0;
        let mut geo = KeplerOrbit {
            prn,
            sqrt_a: (mu / (we * we)).powf(1.0 / 6.0),
            i0: 5f64.to_radians(),
            omega0: std::f64::consts::PI + we * (toe - 14.0).rem_euclid(SECONDS_PER_WEEK),
            t_oe: toe,
            t_oc: toe,
            ..Default::default()
        };
        let p = position_ecef(&geo, OrbitKind::BeiDouGeo, toe);
        geo.omega0 = wrap(geo.omega0 + lon.to_radians() - p.y.atan2(p.x));
        other.push(GnssEph {
            sys: 'C',
            kind: OrbitKind::BeiDouGeo,
            orbit: geo,
            accuracy_m: 2.0,
        });
    }
    for e in other.iter_mut() {
        let keep_e = e.kind == OrbitKind::BeiDouGeo;
        let e0 = e.orbit.e;
        perturb(&mut e.orbit, &mut rng);
        if keep_e {
            e.orbit.e = e0 + 2e-4;
            e.orbit.delta_n = 0.0;
            e.orbit.omega_dot = 0.0;
        }
    }
    let nav = NavData {
        ura_m: vec![2.0; gps.len()],
        orbits: gps,
        iono: Some(KLOBUCHAR),
    };
    // As broadcast: through the writer and both readers.
    let text = navfuse_io::rinex_write::nav3_text(&nav, &other);
    let gps = navfuse_io::rinex::parse_nav_data(&text, "sim").expect("own navigation text");
    let all = navfuse_io::rinex_nav3::parse_nav_gnss(&text, "sim").expect("own navigation text");
    let other = all.ephs.into_iter().filter(|e| e.sys != 'G').collect();
    (gps, other)
}

/// Light-time solution at true receive time `t` for the antenna at `rx`:
/// (satellite position in the ECEF frame of `t`, range, transmit time).
pub(crate) fn light_time(o: &KeplerOrbit, kind: OrbitKind, rx: &Vec3, t: f64) -> (Vec3, f64, f64) {
    let (_, we) = kind.constants();
    let mut tau = 0.075;
    let (mut p, mut range) = (Vec3::zeros(), 0.0);
    for _ in 0..8 {
        let q = position_ecef(o, kind, t - tau);
        let th = we * tau;
        p = Vec3::new(
            th.cos() * q.x + th.sin() * q.y,
            -th.sin() * q.x + th.cos() * q.y,
            q.z,
        );
        let r = (p - rx).norm();
        let done = (r - range).abs() < 1e-6;
        range = r;
        tau = range / C_LIGHT;
        if done {
            break;
        }
    }
    (p, range, t - tau)
}

/// The GLONASS records of the module documentation for a log covering
/// true GPS times `t_first..=t_last`: per slot, t_b on UTC's :15/:45 grid
/// from at least 15 min before `t_first` to at least 15 min after `t_last`
/// (so every epoch has a record within ±15 min), as the navigation file
/// holds them (written and read back).
pub fn glonass_records(t_first: f64, t_last: f64, seed: u64) -> Vec<GlonassEph> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x676c_6f6e);
    let leap = navfuse_io::time::gps_minus_utc(t_first);
    // t_b (GPS s) with UTC at hh:15 / hh:45.
    let first_utc = ((t_first - leap - 900.0 - 900.0) / 1800.0).floor() * 1800.0 + 900.0;
    let mut out = Vec::new();
    for slot in 1..=24u8 {
        let mut e = glonass::nominal_eph(slot, first_utc + leap);
        e.tau_n = rng.gen_range(-1e-4..1e-4);
        e.gamma_n = rng.gen_range(-2e-12..2e-12);
        while e.t_b <= t_last + 900.0 + 1800.0 {
            out.push(e);
            let t_next = e.t_b + 1800.0;
            let (p, v) = e.state_at(t_next);
            e = GlonassEph {
                t_b: t_next,
                pos_m: p,
                vel_mps: v,
                tau_n: e.tau_n - e.gamma_n * 1800.0,
                ..e
            };
        }
    }
    let text = navfuse_io::rinex_write::nav3_text(&NavData::default(), &[])
        + &navfuse_io::rinex_write::glonass3_records(&out);
    navfuse_io::rinex_glonass::parse_nav_glonass(&text, "sim").expect("own GLONASS text")
}

/// [`light_time`] for a GLONASS satellite: the record of `slot` (indices
/// `recs` into `ephs`) nearest the transmission time.
fn light_time_glo(
    ephs: &[GlonassEph],
    recs: &[usize],
    rx: &Vec3,
    t: f64,
) -> (Vec3, f64, f64, usize) {
    let we = glonass::OMEGA_E_PZ90;
    let mut tau = 0.075;
    let (mut p, mut range, mut used) = (Vec3::zeros(), 0.0, recs[0]);
    for _ in 0..8 {
        let tt = t - tau;
        used = *recs
            .iter()
            .min_by(|&&a, &&b| {
                (ephs[a].t_b - tt)
                    .abs()
                    .total_cmp(&(ephs[b].t_b - tt).abs())
            })
            .expect("records");
        let q = ephs[used].position_ecef(tt);
        let th = we * tau;
        p = Vec3::new(
            th.cos() * q.x + th.sin() * q.y,
            -th.sin() * q.x + th.cos() * q.y,
            q.z,
        );
        let r = (p - rx).norm();
        let done = (r - range).abs() < 1e-6;
        range = r;
        tau = range / C_LIGHT;
        if done {
            break;
        }
    }
    (p, range, t - tau, used)
}

/// Simulate the log of `cfg` (deterministic from `cfg.seed`).
pub fn simulate_multi(cfg: &MultiGnssConfig) -> MultiGnssLog {
    // t_oe on the 16 s / 60 s grids of the three messages (BeiDou + 14 s),
    // before the first epoch: a broadcast record is received after its
    // reference time (RTKLIB 2.4.3 was seen to use Galileo records only
    // after their t_oe). The age stays below every system's fit interval
    // for a log of up to 2 h (GPS 4 h curve fit).
    let t_oe = ((cfg.t0 - 1.0) / 960.0).floor() * 960.0;
    let (nav_gps, nav_other) = constellations(t_oe, cfg.seed);
    let sats: Vec<(char, OrbitKind, KeplerOrbit)> = nav_gps
        .orbits
        .iter()
        .map(|o| ('G', OrbitKind::Gps, *o))
        .chain(nav_other.iter().map(|e| (e.sys, e.kind, e.orbit)))
        .collect();
    let nav_glonass = if cfg.glonass {
        let t_last = cfg.t0 + cfg.n_epochs as f64 * cfg.dt;
        glonass_records(cfg.t0, t_last, cfg.seed)
    } else {
        Vec::new()
    };
    // GLONASS satellites after the Kepler ones: (slot, record indices).
    let glo_sats: Vec<(u8, Vec<usize>)> = (1..=24u8)
        .map(|s| {
            let r: Vec<usize> = (0..nav_glonass.len())
                .filter(|&i| nav_glonass[i].slot == s)
                .collect();
            (s, r)
        })
        .filter(|(_, r)| !r.is_empty())
        .collect();
    let n_kepler = sats.len();
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let n01 = |r: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(r) };
    let b0 = rng.gen_range(-1.0..1.0) * 0.5e-3;
    let d0 = rng.gen_range(-1.0..1.0) * 0.5e-6;
    let ns = n_kepler + glo_sats.len();
    let mut mp: Vec<f64> = (0..ns).map(|_| n01(&mut rng)).collect();
    let mut iono: Vec<f64> = (0..ns).map(|_| n01(&mut rng)).collect();
    let mut sat_e: Vec<f64> = (0..ns).map(|_| n01(&mut rng)).collect();
    let mut amb = vec![0i64; ns];
    let mut locked = vec![false; ns];
    let gm = |x: f64, tau: f64, dt: f64, w: f64| {
        let phi = (-dt / tau).exp();
        phi * x + (1.0 - phi * phi).sqrt() * w
    };
    let centre = geodetic_to_ecef(&cfg.centre);
    let c_en = c_e_enu(cfg.centre.lat, cfg.centre.lon);
    let c_ne = c_en.transpose();
    let omega = cfg.speed_mps / cfg.radius_m;
    let antenna = |t: f64| {
        let a = omega * (t - cfg.t0);
        let p_n = Vec3::new(a.cos(), a.sin(), 0.0) * cfg.radius_m;
        let v_n = Vec3::new(-a.sin(), a.cos(), 0.0) * cfg.speed_mps;
        (centre + c_ne * p_n, c_ne * v_n)
    };
    let isb = |sys: char| match sys {
        'E' => 25.0,
        'C' => -40.0,
        'R' => 60.0,
        _ => 0.0,
    };
    let lambda = |sys: char| match sys {
        'C' => C_LIGHT / 1561.098e6,
        _ => C_LIGHT / 1575.42e6,
    };
    let lambda_l1 = C_LIGHT / 1575.42e6;
    let codes = |s: &[&str]| s.iter().map(|c| c.to_string()).collect::<Vec<_>>();
    let mut log = MultiGnssLog {
        gnss: GnssObs {
            sys_codes: vec![
                ('G', codes(&["C1C", "L1C", "D1C", "S1C"])),
                ('E', codes(&["C1C", "L1C", "D1C", "S1C"])),
                ('C', codes(&["C2I", "L2I", "D2I", "S2I"])),
            ]
            .into_iter()
            .chain(
                cfg.glonass
                    .then(|| ('R', codes(&["C1C", "L1C", "D1C", "S1C"]))),
            )
            .collect(),
            epochs: Vec::with_capacity(cfg.n_epochs),
        },
        nav_gps,
        nav_other,
        nav_glonass: nav_glonass.clone(),
        ..Default::default()
    };
    // Division by the exact power of ten: the double nearest the decimal,
    // as a reader parsing the written text gets it.
    let round = |x: f64, per_unit: f64| (x * per_unit).round() / per_unit;
    for k in 0..cfg.n_epochs {
        let t_nom = cfg.t0 + k as f64 * cfg.dt;
        let b = b0 + d0 * (t_nom - cfg.t0);
        // The tag on the file's 0.1 µs grid; the true time follows from it.
        let tag = round(t_nom + b, 1e7);
        let t = tag - b;
        if k > 0 {
            for i in 0..ns {
                mp[i] = gm(mp[i], 10.0, cfg.dt, n01(&mut rng));
                iono[i] = gm(iono[i], 1800.0, cfg.dt, n01(&mut rng));
                sat_e[i] = gm(sat_e[i], 3600.0, cfg.dt, n01(&mut rng));
            }
        }
        let (r_e, v_e) = antenna(t);
        let g = ecef_to_geodetic(&r_e);
        let c_n = c_e_enu(g.lat, g.lon);
        let doy = day_of_year(t);
        let tow = t.rem_euclid(SECONDS_PER_WEEK);
        let mut vis: Vec<(f64, f64, usize, f64, f64)> = Vec::new();
        for i in 0..ns {
            let (p, range, t_tx) = if i < n_kepler {
                let (_, kind, o) = &sats[i];
                light_time(o, *kind, &r_e, t)
            } else {
                let (p, r, tt, _) =
                    light_time_glo(&nav_glonass, &glo_sats[i - n_kepler].1, &r_e, t);
                (p, r, tt)
            };
            let u = c_n * ((p - r_e) / range);
            let el = u.z.clamp(-1.0, 1.0).asin();
            if el >= cfg.track_mask_rad {
                vis.push((el, u.x.atan2(u.y), i, range, t_tx));
            }
        }
        vis.sort_by(|a, b| b.0.total_cmp(&a.0));
        vis.truncate(MAX_CHANNELS);
        let mut present = vec![false; ns];
        let mut ep = Vec::with_capacity(vis.len());
        for &(el, az, i, range, t_tx) in &vis {
            present[i] = true;
            let h = 0.05;
            let (sys, prn, lam, rr, dts, dts_rate, tgd) = if i < n_kepler {
                let (sys, kind, o) = &sats[i];
                let rr = (light_time(o, *kind, &(r_e + v_e * h), t + h).1
                    - light_time(o, *kind, &(r_e - v_e * h), t - h).1)
                    / (2.0 * h);
                let dts = clock_offset(o, *kind, t_tx) * C_LIGHT;
                let dts_rate = (clock_offset(o, *kind, t_tx + 0.5)
                    - clock_offset(o, *kind, t_tx - 0.5))
                    * C_LIGHT;
                (*sys, o.prn, lambda(*sys), rr, dts, dts_rate, o.tgd)
            } else {
                let (slot, recs) = &glo_sats[i - n_kepler];
                let lt = |rx: &Vec3, t: f64| light_time_glo(&nav_glonass, recs, rx, t);
                let rr =
                    (lt(&(r_e + v_e * h), t + h).1 - lt(&(r_e - v_e * h), t - h).1) / (2.0 * h);
                let e = &nav_glonass[lt(&r_e, t).3];
                let lam = C_LIGHT / glonass::l1_frequency_hz(e.freq_ch);
                let dts = e.clock_offset(t_tx) * C_LIGHT;
                let dts_rate = e.gamma_n * C_LIGHT;
                ('R', *slot, lam, rr, dts, dts_rate, 0.0)
            };
            let se = el.sin().max(0.05);
            let cn0 = 34.0 + 14.0 * se + n01(&mut rng);
            let kf = 10f64.powf(((45.0 - cn0) / 20.0).max(0.0));
            let mp_sigma = (0.6 / se).min(3.0);
            let scale = (lam / lambda_l1).powi(2);
            let i_delay = scale
                * (KLOBUCHAR.delay_l1(g.lat, g.lon, az, el, tow)
                    + 1.0 * crate::raw_gnss::obliquity(el) * iono[i]);
            let t_delay = slant_delay(el, g.lat, g.h, doy, 0.7);
            let common = range + b * C_LIGHT + isb(sys) - dts + t_delay + 1.0 * sat_e[i];
            let pr = common + C_LIGHT * tgd + i_delay + mp_sigma * mp[i] + 0.5 * kf * n01(&mut rng);
            let rr_meas = rr + d0 * C_LIGHT - dts_rate + 0.05 * kf / se.sqrt() * n01(&mut rng);
            let mut lli = 0;
            if !locked[i] {
                amb[i] = rng.gen_range(-1_000_000..1_000_000);
                locked[i] = true;
                lli = 1;
            }
            let cp = (common - i_delay + 0.003 * n01(&mut rng)) / lam + amb[i] as f64;
            let v = |x: f64, lli: u8| {
                Some(ObsValue {
                    value: round(x, 1e3),
                    lli,
                })
            };
            ep.push((
                sys,
                prn,
                vec![v(pr, 0), v(cp, lli), v(-rr_meas / lam, 0), v(cn0, 0)],
            ));
        }
        for i in 0..ns {
            locked[i] &= present[i];
        }
        let order = |s: char| match s {
            'G' => 0,
            'E' => 1,
            'C' => 2,
            _ => 3,
        };
        ep.sort_by(|a, b| order(a.0).cmp(&order(b.0)).then(a.1.cmp(&b.1)));
        log.tags.push(tag);
        log.gnss.epochs.push(ep);
        log.truth_e.push(r_e);
        log.clock_bias_s.push(b);
    }
    log
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every system is observed at every epoch (≥ 4 satellites each),
    /// within the channel limit, a BeiDou GEO among them, and the files
    /// written from the log read back to the same observations and records.
    #[test]
    fn ten_minutes_of_three_systems() {
        let cfg = MultiGnssConfig {
            n_epochs: 600,
            ..Default::default()
        };
        let log = simulate_multi(&cfg);
        assert_eq!(log.gnss.epochs.len(), 600);
        let mut max_n = 0;
        for ep in &log.gnss.epochs {
            for s in ['G', 'E', 'C'] {
                let n = ep.iter().filter(|x| x.0 == s).count();
                assert!(n >= 4, "{s}: {n}");
            }
            max_n = max_n.max(ep.len());
        }
        assert!(max_n <= MAX_CHANNELS);
        let (o, g) = navfuse_io::rinex::parse_obs_gnss(&log.obs_text(), "sim.obs").unwrap();
        assert!(g == log.gnss, "observations differ after the round trip");
        assert_eq!(o.epochs.len(), 600);
        let nav = navfuse_io::rinex_nav3::parse_nav_gnss(&log.nav_text(), "sim.nav").unwrap();
        assert_eq!(nav.ephs.len(), 24 + 24 + 27);
        // A BeiDou GEO is in view from Tokyo.
        assert!(log.gnss.epochs[0].iter().any(|x| x.0 == 'C' && x.1 <= 3));
    }
}
